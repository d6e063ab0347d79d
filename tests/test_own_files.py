"""A user's geometry lives in the user's project: a scene names any .geo file (relative to the scene
file's folder), every .geo is checked before gmsh reads it (gmsh's language runs programs and
writes files), and a run folder holds what reruns it: `bin/ff edp/main.edp -DSCENE=<run>/scene.idp
-out DIR` from the repository root gives the run's history again."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from orchestrate import Scene
from orchestrate.freefem import REPO
from orchestrate.geo import GeoError, read_sources
from orchestrate.mesh import body_mesh
from orchestrate.runner import run
from orchestrate.scene import SceneError

SCENE = '''title = "two blocks of the user's own .geo"

[time]
T = 1.0
N = 20

[body1.mesh]
geo = "{geo}"
n = 4
parameters = {{ x0 = 0.0, x1 = 2.0, y0 = 0.0, y1 = 1.0 }}
contactLabel = 1

[[body1.boundary]]
type = "displacement"
label = 3
component = "y"
value = "-0.01*t"

[[body1.boundary]]
type = "roller"
label = 4
component = "x"

[body2.mesh]
geo = "{geo}"
n = 5
parameters = {{ x0 = 0.0, x1 = 2.0, y0 = -1.0, y1 = 0.0 }}
contactLabel = 3

[[body2.boundary]]
type = "clamped"
label = 1

[output]
images = false
'''
RECTANGLE = (REPO / "meshes" / "rectangle.geo").read_text()


def project(folder: Path, geo: str = "shapes/block.geo", text: str = RECTANGLE) -> Path:
    """A user's project: scene.toml and its .geo at `geo` from the scene's folder."""
    (folder / geo).parent.mkdir(parents=True, exist_ok=True)
    (folder / geo).write_text(text)
    (folder / "scene.toml").write_text(SCENE.format(geo=geo))
    return folder / "scene.toml"


def evil(marker: Path) -> str:
    """The rectangle with one more line, which makes gmsh create `marker`."""
    return RECTANGLE + f'System "touch {marker}";\n'


def history_rows(folder: Path) -> list[str]:
    """history.csv without its last column, stepSeconds (a measured time)."""
    return [line.rsplit(",", 1)[0] for line in (folder / "history.csv").read_text().splitlines()]


# --- where a scene's .geo is ------------------------------------------------------------------

def test_a_relative_geo_is_taken_beside_the_scene_file_from_any_working_folder(tmp_path, monkeypatch):
    scene = project(tmp_path / "proj")
    monkeypatch.chdir(tmp_path)
    assert Scene.load(scene).body1.mesh.source() == tmp_path / "proj" / "shapes" / "block.geo"
    (tmp_path / "shapes").mkdir()
    (tmp_path / "shapes" / "block.geo").write_text(RECTANGLE)  # the working folder's is not the scene's
    assert Scene.load(scene).body2.mesh.source() == tmp_path / "proj" / "shapes" / "block.geo"


def test_the_project_meshes_path_is_found_in_the_repository_unless_the_scene_has_its_own(tmp_path):
    scene = project(tmp_path, "meshes/rectangle.geo")
    assert Scene.load(scene).body1.mesh.source() == tmp_path / "meshes" / "rectangle.geo"
    (tmp_path / "meshes" / "rectangle.geo").unlink()
    assert Scene.load(scene).body1.mesh.source() == REPO / "meshes" / "rectangle.geo"


def test_a_scene_as_data_names_the_same_file_wherever_it_is_validated(tmp_path, monkeypatch):
    """A sweep sends its worker the scene as data (model_dump): the path was resolved on loading."""
    data = Scene.load(project(tmp_path / "proj")).model_dump(mode="json")
    monkeypatch.chdir(tmp_path)
    assert Scene.model_validate(data).body1.mesh.source() == tmp_path / "proj" / "shapes" / "block.geo"


def test_a_missing_geo_names_where_it_was_looked_for(tmp_path):
    scene = project(tmp_path)
    scene.write_text(scene.read_text().replace("shapes/block.geo", "meshes/nowhere.geo"))
    with pytest.raises(SceneError) as error:
        Scene.load(scene)
    assert "body1.mesh.geo" in str(error.value) and str(tmp_path / "meshes" / "nowhere.geo") in str(error.value)
    assert str(REPO / "meshes" / "nowhere.geo") in str(error.value)


# --- what a .geo may not do ---------------------------------------------------------------------

def test_every_project_geo_passes_the_check():
    sources = sorted((REPO / "meshes").glob("*.geo"))
    assert len(sources) >= 10
    for source in sources:
        read_sources(source)
    graded = read_sources(REPO / "meshes" / "paper_body1_graded.geo")
    assert [file.path.name for file in graded] == ["paper_body1_graded.geo", "graded_size.geo"]


def test_gmsh_itself_runs_a_system_command_which_a_scene_is_refused(tmp_path):
    """The hazard is real: gmsh's own reader runs the line. A scene naming the file is refused with
    the file, the line and the command, and nothing runs."""
    marker = tmp_path / "x"
    scene = project(tmp_path, text=evil(marker))
    subprocess.run([sys.executable, "-c", "import gmsh, sys; gmsh.initialize(); gmsh.option.setNumber("
                    "'General.Terminal', 0); gmsh.open(sys.argv[1])", str(tmp_path / "shapes" / "block.geo")],
                   check=True, capture_output=True)
    assert marker.exists()
    marker.unlink()
    with pytest.raises(SceneError) as error:
        Scene.load(scene)
    line = RECTANGLE.count("\n") + 1
    assert f"body1.mesh.geo = 'shapes/block.geo': {tmp_path / 'shapes' / 'block.geo'}, line {line}: System runs a " \
           "program" in str(error.value)
    with pytest.raises(GeoError, match="System runs a program"):
        body_mesh(tmp_path / "shapes" / "block.geo", {"n": 4.0}, cache=tmp_path / "cache")
    assert not marker.exists()


REFUSED = [
    ('SystemCall "touch {marker}";', "SystemCall runs a program"),
    ('NonBlockingSystemCall "touch {marker}";', "NonBlockingSystemCall runs a program"),
    ('OnelabRun("x", "touch {marker}");', "OnelabRun runs a program"),
    ('Printf("%g", n) > "{marker}";', "Printf(...) > file writes a file"),
    ('Printf("n") >> "{marker}";', "Printf(...) > file writes a file"),
    ('Save "{marker}.msh";', "Save writes a file"),
    ('Print "{marker}.png";', "Print writes an image file"),
    ('CreateDir "{marker}";', "CreateDir makes a folder"),
    ('Merge "{marker}.msh";', "Merge reads another file"),
    ('v() = ShapeFromFile("{marker}.step");', "ShapeFromFile reads a CAD file"),
    ('l() = ListFromFile("{marker}");', "ListFromFile reads numbers from a file"),
    ('s = GetEnv("HOME");', "GetEnv reads the environment"),
    ("Exit;", "Exit ends the mesher's process"),
    ("Plugin(Smooth).Run;", "Plugin runs a post-processing plugin"),
    ('S2N[StrCat("Sys", "tem")] "touch {marker}";', "S2N makes a command name from a string"),
    ('f = "x.geo";\nInclude f;', "Include with a computed file name"),
    ('Solver.Executable0 = "/bin/sh";', "Solver options name files and programs"),
    ("General.Terminal = 1;", "General options name files and programs"),
    ('Geometry.DoubleClickedPointCommand = "x";', "Geometry.DoubleClickedPointCommand holds gmsh code"),
    ("Field[3] = ExternalProcess;", "the ExternalProcess size field runs a program"),
    ("Field[3] = Structured;", "the Structured size field reads a file"),
    ('s = "never closed;', "a comment or string that is never closed"),
    ('s = "' + "a" * 1100 + '";', "a string of 1100 characters"),
    ('s = "a\0b";', "a NUL byte"),
]


@pytest.mark.parametrize("code, words", REFUSED, ids=[code.split("\n")[-1][:30] for code, _ in REFUSED])
def test_commands_that_run_programs_or_touch_files_are_refused_naming_file_line_and_command(tmp_path, code, words):
    marker = tmp_path / "x"
    source = tmp_path / "block.geo"
    source.write_text(RECTANGLE + code.format(marker=marker) + "\n")
    with pytest.raises(GeoError) as error:
        read_sources(source)
    assert f"{source}, line {RECTANGLE.count(chr(10)) + code.count(chr(10)) + 1}: {words}" in str(error.value)


def test_what_comments_and_strings_hold_is_not_code(tmp_path):
    source = tmp_path / "block.geo"
    source.write_text(RECTANGLE + '// System "touch x";\n/* Merge "y";\nExit; */\nPrintf("System %g", n);\n'
                      'Mesh.Algorithm = 6;\nGeometry.Tolerance = 1e-8;\n')
    assert read_sources(source)[0].text == source.read_text()


def test_an_included_file_is_checked_and_named_with_its_includer(tmp_path):
    marker = tmp_path / "x"
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "size.geo").write_text(f'System "touch {marker}";\n')
    scene = project(tmp_path, text=RECTANGLE + 'Include "../parts/size.geo";\n')
    with pytest.raises(SceneError) as error:
        Scene.load(scene)
    assert (f"{tmp_path / 'parts' / 'size.geo'}, line 1 (included by {tmp_path / 'shapes' / 'block.geo'}, line "
            f"{RECTANGLE.count(chr(10)) + 1}): System runs a program") in str(error.value)
    assert not marker.exists()


def test_symbolic_links_are_resolved_and_their_targets_checked(tmp_path):
    marker = tmp_path / "x"
    (tmp_path / "hidden").mkdir()
    bad = tmp_path / "hidden" / "bad.geo"
    bad.write_text(evil(marker))
    (tmp_path / "nice.geo").symlink_to(bad)
    (tmp_path / "plain").symlink_to(tmp_path / "hidden")
    (tmp_path / "hidden" / "notes.txt").write_text(RECTANGLE)
    (tmp_path / "disguised.geo").symlink_to(tmp_path / "hidden" / "notes.txt")
    for name in ("nice.geo", "plain/bad.geo"):
        with pytest.raises(GeoError, match=f"{bad}, line {RECTANGLE.count(chr(10)) + 1}: System runs a program"):
            read_sources(tmp_path / name)
    with pytest.raises(GeoError, match="a link to .*notes.txt.* is not a gmsh .geo file"):
        read_sources(tmp_path / "disguised.geo")
    scene = tmp_path / "scene.toml"
    for name in ("nice.geo", "plain/bad.geo", "disguised.geo"):
        scene.write_text(SCENE.format(geo=name))
        with pytest.raises(SceneError, match="body1.mesh.geo"):
            Scene.load(scene)
    assert not marker.exists()


def test_a_geo_edited_after_the_scene_was_read_is_checked_again_before_gmsh(tmp_path):
    """By the run (which validates its scene again) and by the mesher, which meshes a copy of the
    text it checked."""
    marker = tmp_path / "x"
    scene = Scene.load(project(tmp_path / "proj"))
    (tmp_path / "proj" / "shapes" / "block.geo").write_text(evil(marker))
    with pytest.raises(SceneError, match="System runs a program"):
        run(scene, tmp_path / "run")
    with pytest.raises(GeoError, match="System runs a program"):
        body_mesh(scene.body1.mesh.source(), scene.body1.mesh.numbers(), cache=tmp_path / "cache")
    assert not marker.exists()


# --- a run of a user's scene, and its rerun from the run folder -----------------------------------

def test_a_user_s_scene_runs_and_its_run_folder_reruns_from_the_repository_root(tmp_path, monkeypatch):
    scene = project(tmp_path / "proj")
    monkeypatch.chdir(tmp_path / "proj")
    result = run(scene)  # into results/scene of the working folder
    original = tmp_path / "proj" / "results" / "scene"
    assert result.folder == original and len(result.history["t"]) == 20
    env = {key: value for key, value in os.environ.items() if key != "FF_LOADPATH"}
    for name, command in (("ff", ["bin/ff"]), ("plain", ["FreeFem++", "-nw"])):  # plain: freefem++.pref
        rerun = tmp_path / f"rerun-{name}"
        done = subprocess.run([*command, "edp/main.edp", f"-DSCENE={original}/scene.idp", "-out", str(rerun)],
                              cwd=REPO, env=env, capture_output=True, text=True)
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr
        assert history_rows(rerun) == history_rows(original)
        assert (rerun / "params_used.json").read_text().count(str(original / "body1.msh")) == 1


def test_a_rerun_never_writes_into_its_run_folder_unless_told_and_a_cut_scene_path_is_refused(tmp_path):
    scene = project(tmp_path)
    original = tmp_path / "results" / "run"
    run(scene, original)
    before = {path.name: path.stat().st_mtime_ns for path in original.iterdir()}
    ff = str(REPO / "bin" / "ff")
    done = subprocess.run([ff, str(REPO / "edp" / "main.edp"), "-DSCENE=results/run/scene.idp"], cwd=tmp_path,
                          capture_output=True, text=True)
    message = "'results/run' (the default of -out) is the scene file's own folder"
    assert done.returncode == 3 and message in done.stdout + done.stderr
    assert {path.name: path.stat().st_mtime_ns for path in original.iterdir()} == before
    shutil.copytree(original, tmp_path / "other")  # another run's scene, rerun into the default folder
    done = subprocess.run([ff, str(REPO / "edp" / "main.edp"), "-DSCENE=other/scene.idp"], cwd=tmp_path,
                          capture_output=True, text=True)
    assert done.returncode == 3 and "'results/run' (the default of -out) holds a run" in done.stdout + done.stderr
    assert {path.name: path.stat().st_mtime_ns for path in original.iterdir()} == before
    cut = tmp_path / "a#b"
    cut.mkdir()
    (cut / "scene.idp").write_text((original / "scene.idp").read_text())  # there, as bin/ff checks first
    (tmp_path / "a").write_text((original / "scene.idp").read_text())  # what FreeFEM's macro reader would take
    done = subprocess.run([ff, str(REPO / "edp" / "main.edp"), "-DSCENE=a#b/scene.idp", "-out", "x"], cwd=tmp_path,
                          capture_output=True, text=True)
    assert done.returncode == 3 and "-DSCENE='a#b/scene.idp' reached FreeFEM as 'a'" in done.stdout + done.stderr
    assert not (tmp_path / "x").exists()


# Blocks that gmsh skips by reading raw characters (Gmsh.y's skip and skipTest): it loses the
# character after an R, E, I or F, keeps unread a few after a nested If or For, takes a digit for
# the end of a keyword, and starts each turn of a For or call of a Macro on the line after its
# header. In each, the System line runs although a reader that takes the file token by token sees
# it inside a string or comment (found by two reviews).
SKIPPED = {
    "macro": ("Macro Mhide\n R\" Return\nSystem 'touch {marker}';\ns = \";\nReturn\n// \";\n", "in a block gmsh may skip"),
    "if": ("If (0)\n E\" EndIf\nSystem 'touch {marker}';\ns = \";\nEndIf\n// \";\n", "in a block gmsh may skip"),
    "for": ("For i In {{1:0}}\n E\" EndFor\nSystem 'touch {marker}';\ns = \";\nEndFor\n// \";\n",
            "in a block gmsh may skip"),
    "function": ("Function F\n R/* Return\nSystem 'touch {marker}';\n/* */\nReturn\n", "in a block gmsh may skip"),
    "digit": ("If (0)\nIf2\nEndIf\nE\" EndIf\nSystem 'touch {marker}';\ns = \";\nEndIf\n// \";\n", "the name If2"),
    "over-read": ("If (0)\n  If(1)EndIf\nEndIf\nE\" EndIf\nSystem 'touch {marker}';\ns = \";\nEndIf\n// \";\n",
                  "in a block gmsh may skip"),
    "for-line": ("For i In {{1:2}}  s = \"\nSystem 'touch {marker}';\nt = 1; // \";\nEndFor\n",
                 "code on the line of a For header"),
    "macro-line": ("Macro m s = \"\nSystem 'touch {marker}';\nt = 1; // \";\nReturn\nCall m;\n",
                   "code on the line of a Macro header"),
    "carriage-return": ("For (1:2) s = \"\rSystem 'touch {marker}';\rt = 1; // \";\nEndFor\n",
                        "code on the line of a For header"),
}


def hidden(tmp_path, form) -> tuple[Path, Path]:
    marker = tmp_path / "x"
    source = tmp_path / "block.geo"
    source.write_bytes((SKIPPED[form][0].format(marker=marker) + RECTANGLE).encode())
    return source, marker


@pytest.mark.parametrize("form", SKIPPED)
def test_code_hidden_from_the_check_by_gmsh_s_skipping_is_refused(tmp_path, form):
    source, marker = hidden(tmp_path, form)
    subprocess.run([sys.executable, "-c", "import gmsh, sys; gmsh.initialize(); gmsh.option.setNumber("
                    "'General.Terminal', 0); gmsh.open(sys.argv[1])", str(source)], capture_output=True)
    assert marker.exists(), "gmsh should run the hidden line (the hazard this test guards against)"
    with pytest.raises(GeoError, match=rf"block.geo, line [0-9]+: .*{SKIPPED[form][1]}"):
        read_sources(source)


@pytest.mark.parametrize("form", SKIPPED)
def test_the_mesher_starts_no_program_whatever_the_check_misses(tmp_path, form):
    """The mesher given such a file without the check: Landlock stops gmsh's System."""
    from orchestrate.gmsh_mesher import landlock_abi

    if landlock_abi() < 1:
        pytest.skip("this kernel has no Landlock: the .geo check is the only guard")
    source, marker = hidden(tmp_path, form)
    (tmp_path / "out").mkdir()
    mesher = subprocess.run([sys.executable, str(REPO / "orchestrate" / "gmsh_mesher.py"), str(source), '{"n": 4}', "0",
                             str(tmp_path / "out" / "block.msh")], capture_output=True, text=True)
    assert not marker.exists() and mesher.returncode != 0 and "/bin/sh" in mesher.stderr


def test_the_mesher_writes_its_one_target_whatever_the_geo_sets(tmp_path):
    """A .geo may set mesh options, but the file written is one gmsh 2.2 text file, the target."""
    source = tmp_path / "block.geo"
    source.write_text(RECTANGLE + "Mesh 2; Mesh.PartitionSplitMeshFiles = 1; Mesh.Binary = 1; PartitionMesh 3;\n")
    read_sources(source)  # nothing refused: these are mesh options
    target = tmp_path / "out" / "block.msh"
    target.parent.mkdir()
    subprocess.run([sys.executable, str(REPO / "orchestrate" / "gmsh_mesher.py"), str(source), '{"n": 4}', "0",
                    str(target)], check=True, capture_output=True)
    assert [path.name for path in target.parent.iterdir()] == ["block.msh"]
    assert target.read_text().startswith("$MeshFormat\n2.2 0 8\n")


def test_ordinary_loops_and_tests_pass_and_a_slash_right_after_a_name_s_first_letter_in_one_is_refused(tmp_path):
    source = tmp_path / "block.geo"
    source.write_text(RECTANGLE + 'For i In {1:3}\n  Point(10 + i) = {0.25*i, 0.5, 0, 0.1};\nEndFor\n'
                      'If (n < 1)\n  Error("n = %g must be at least 1", n);\nEndIf\n')
    read_sources(source)
    source.write_text(RECTANGLE + "R = 2;\nIf (n > 1)\n  r = R/2;\nEndIf\n")
    with pytest.raises(GeoError, match=r"'R/' in a block gmsh may skip.*e\.g\. 0\.5\*R for R/2"):
        read_sources(source)


def test_without_landlock_a_user_s_geo_may_hold_no_block_gmsh_could_skip(tmp_path, monkeypatch):
    """There the check alone stands between a scene and gmsh: a block (where gmsh's skipping reads
    otherwise) in a user's file is refused outright; the project's own files still pass."""
    import orchestrate.geo as geo

    monkeypatch.setattr(geo, "landlock_abi", lambda: 0)
    plain = "DefineConstant[ n = 4 ];\nPoint(1) = {0, 0, 0, 1/n}; Point(2) = {1, 0, 0, 1/n};\nLine(1) = {1, 2};\n"
    source = tmp_path / "block.geo"
    source.write_text(plain + "For i In {1:3}\n  Point(10 + i) = {0.25*i, 0.5, 0, 0.1};\nEndFor\n")
    with pytest.raises(GeoError, match=r"line 4: an If, For, Macro or Function block, on a kernel without Landlock"):
        read_sources(source)
    source.write_text(plain)
    read_sources(source)
    read_sources(REPO / "meshes" / "paper_body1_graded.geo")  # If blocks, in meshes/
