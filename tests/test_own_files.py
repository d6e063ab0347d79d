"""A user's geometry lives in the user's project: a scene names any .geo file (relative to the scene
file's folder), gmsh reads every .geo in a sandbox (gmsh's language runs programs and reads and
writes files; where the kernel has no Landlock only trusted files are meshed), and a run folder
holds what reruns it: `bin/ff edp/main.edp -DSCENE=<run>/scene.idp -out DIR` from the repository
root gives the run's history again."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from orchestrate import Scene
from orchestrate.freefem import SolverError
from orchestrate import mesh as meshing
from orchestrate.freefem import REPO, run_script
from orchestrate.geo import GeoError, read_sources
from orchestrate.mesh import MeshError, MeshLimits, body_mesh
from orchestrate.runner import run
from orchestrate.scene import SceneError

pytestmark = pytest.mark.runs

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


PROBING = RECTANGLE + 'found = FileExists("/etc/passwd");\n'  # what the sandbox cannot hide


def history_rows(folder: Path) -> list[str]:
    """history.csv without its last column, stepSeconds (a measured time)."""
    return [line.rsplit(",", 1)[0] for line in (folder / "history.csv").read_text().splitlines()]


# --- where a scene's .geo is ------------------------------------------------------------------

@pytest.mark.unit
def test_a_relative_geo_is_taken_beside_the_scene_file_from_any_working_folder(tmp_path, monkeypatch):
    scene = project(tmp_path / "proj")
    monkeypatch.chdir(tmp_path)
    assert Scene.load(scene).body1.mesh.source() == tmp_path / "proj" / "shapes" / "block.geo"
    (tmp_path / "shapes").mkdir()
    (tmp_path / "shapes" / "block.geo").write_text(RECTANGLE)  # the working folder's is not the scene's
    assert Scene.load(scene).body2.mesh.source() == tmp_path / "proj" / "shapes" / "block.geo"


@pytest.mark.unit
def test_the_project_meshes_path_is_found_in_the_repository_unless_the_scene_has_its_own(tmp_path):
    scene = project(tmp_path, "meshes/rectangle.geo")
    assert Scene.load(scene).body1.mesh.source() == tmp_path / "meshes" / "rectangle.geo"
    (tmp_path / "meshes" / "rectangle.geo").unlink()
    assert Scene.load(scene).body1.mesh.source() == REPO / "meshes" / "rectangle.geo"


@pytest.mark.unit
def test_a_scene_as_data_names_the_same_file_wherever_it_is_validated(tmp_path, monkeypatch):
    """A sweep sends its worker the scene as data (model_dump): the path was resolved on loading."""
    data = Scene.load(project(tmp_path / "proj")).model_dump(mode="json")
    monkeypatch.chdir(tmp_path)
    assert Scene.model_validate(data).body1.mesh.source() == tmp_path / "proj" / "shapes" / "block.geo"


@pytest.mark.unit
def test_a_missing_geo_names_where_it_was_looked_for(tmp_path):
    scene = project(tmp_path)
    scene.write_text(scene.read_text().replace("shapes/block.geo", "meshes/nowhere.geo"))
    with pytest.raises(SceneError) as error:
        Scene.load(scene)
    assert "body1.mesh.geo" in str(error.value) and str(tmp_path / "meshes" / "nowhere.geo") in str(error.value)
    assert str(REPO / "meshes" / "nowhere.geo") in str(error.value)


# --- what a .geo may not do ---------------------------------------------------------------------

@pytest.mark.unit
def test_every_project_geo_is_read_with_its_includes():
    sources = sorted((REPO / "meshes").glob("*.geo"))
    assert len(sources) >= 10
    for source in sources:
        read_sources(source)
    graded = read_sources(REPO / "meshes" / "paper_body1_graded.geo")
    assert [file.path.name for file in graded] == ["paper_body1_graded.geo", "graded_size.geo"]


def test_gmsh_itself_runs_a_system_command_which_the_mesher_s_sandbox_stops(tmp_path):
    """The hazard is real: gmsh's own reader runs the line. Meshed for a scene, nothing runs."""
    marker = tmp_path / "x"
    scene = project(tmp_path, text=evil(marker))
    subprocess.run([sys.executable, "-c", "import gmsh, sys; gmsh.initialize(); gmsh.option.setNumber("
                    "'General.Terminal', 0); gmsh.open(sys.argv[1])", str(tmp_path / "shapes" / "block.geo")],
                   check=True, capture_output=True)
    assert marker.exists()
    marker.unlink()
    with pytest.raises(MeshError, match="/bin/sh"):
        run(Scene.load(scene), tmp_path / "run")
    assert not marker.exists()


SECRET = "secret.geo"  # a file beside the .geo, outside the copies the mesher may read
SANDBOXED = [
    'System "touch {marker}";',
    'SystemCall "touch {marker}";',
    'NonBlockingSystemCall "touch {marker}";',
    'OnelabRun("x", "touch {marker}");',
    'Printf("%g", n) > "{marker}";',
    'Save "{marker}.msh";',
    'CreateDir "{marker}";',
    'Merge "{folder}/' + SECRET + '";',
    'l() = ListFromFile("{folder}/' + SECRET + '");',
    'S2N[StrCat("Sys", "tem")] "touch {marker}";',
    'f = StrCat("{folder}/", "' + SECRET + '");\nInclude f;',
    'Error(StrCat("HOME is ", GetEnv("HOME"), ";"));',
    'If (0)\n E" EndIf\nSystem "touch {marker}";\ns = ";\nEndIf\n// ";',
]


@pytest.mark.parametrize("code", SANDBOXED, ids=[code.split("\n")[-1][:30] for code in SANDBOXED])
def test_what_a_geo_does_stays_in_the_mesher_s_sandbox(tmp_path, code):
    """Programs, files written, files read but the copies, the environment: each either fails in
    gmsh or does nothing, and no file appears or is read outside the cache."""
    marker = tmp_path / "x"
    (tmp_path / SECRET).write_text("Point(99) = {7, 7, 0, 1};\nPhysical Point(99) = {99};\n")
    source = tmp_path / "block.geo"
    source.write_text(RECTANGLE + code.format(marker=marker, folder=tmp_path) + "\n")
    before = sorted(tmp_path.iterdir())
    try:
        path = body_mesh(source, {"n": 4.0}, cache=tmp_path / "cache")
        assert "7 7 0" not in path.read_text()
    except MeshError as error:
        assert "HOME is ;" in str(error) or "GetEnv" not in code
    assert sorted(path for path in tmp_path.iterdir() if path.name != "cache") == before


@pytest.mark.unit
def test_file_exists_which_the_sandbox_cannot_hide_is_refused_naming_file_line_and_includer(tmp_path):
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "size.geo").write_text('found = FileExists("/etc/passwd");\n')
    scene = project(tmp_path, text=RECTANGLE + 'Include "../parts/size.geo";\n')
    with pytest.raises(SceneError) as error:
        Scene.load(scene)
    assert (f"{tmp_path / 'parts' / 'size.geo'}, line 1 (included by {tmp_path / 'shapes' / 'block.geo'}, line "
            f"{RECTANGLE.count(chr(10)) + 1}): FileExists looks for a file, which the mesher's sandbox cannot hide"
            ) in str(error.value)


@pytest.mark.unit
def test_what_comments_and_strings_hold_is_not_code(tmp_path):
    source = tmp_path / "block.geo"
    source.write_text(RECTANGLE + '// FileExists("x");\n/* Include "y.geo";\nExit; */\nPrintf("FileExists %g", n);\n')
    assert [file.path for file in read_sources(source)] == [source]


@pytest.mark.unit
def test_symbolic_links_are_resolved_and_their_targets_read(tmp_path):
    (tmp_path / "hidden").mkdir()
    bad = tmp_path / "hidden" / "bad.geo"
    bad.write_text(PROBING)
    (tmp_path / "nice.geo").symlink_to(bad)
    (tmp_path / "plain").symlink_to(tmp_path / "hidden")
    (tmp_path / "hidden" / "notes.txt").write_text(RECTANGLE)
    (tmp_path / "disguised.geo").symlink_to(tmp_path / "hidden" / "notes.txt")
    for name in ("nice.geo", "plain/bad.geo"):
        with pytest.raises(GeoError, match=f"{bad}, line {RECTANGLE.count(chr(10)) + 1}: FileExists"):
            read_sources(tmp_path / name)
    with pytest.raises(GeoError, match="a link to .*notes.txt.* is not a gmsh .geo file"):
        read_sources(tmp_path / "disguised.geo")
    scene = tmp_path / "scene.toml"
    for name in ("nice.geo", "plain/bad.geo", "disguised.geo"):
        scene.write_text(SCENE.format(geo=name))
        with pytest.raises(SceneError, match="body1.mesh.geo"):
            Scene.load(scene)


@pytest.mark.unit
def test_a_geo_edited_after_the_scene_was_read_is_read_again_before_gmsh(tmp_path):
    """By the run (which validates its scene again) and by the mesher, which meshes a copy of the
    text it read."""
    scene = Scene.load(project(tmp_path / "proj"))
    (tmp_path / "proj" / "shapes" / "block.geo").write_text(PROBING)
    with pytest.raises(SceneError, match="FileExists"):
        run(scene, tmp_path / "run")
    with pytest.raises(GeoError, match="FileExists"):
        body_mesh(scene.body1.mesh.source(), scene.body1.mesh.numbers(), cache=tmp_path / "cache")


def test_without_landlock_only_the_project_s_geo_or_a_trusted_one_is_meshed(tmp_path, monkeypatch):
    """There gmsh would run a .geo unconfined: a user's is refused naming the field, the reason and
    --trust-geo, on both commands that mesh; the project's own meshes/ and a trusted one are meshed."""
    monkeypatch.setattr(meshing, "landlock_abi", lambda: 0)
    scene = project(tmp_path)
    with pytest.raises(GeoError) as error:  # a cache of its own: a mesh made before would be data, not code
        run(scene, tmp_path / "run", mesh_cache=tmp_path / "cache")
    for words in ("body1.mesh.geo: ", str(tmp_path / "shapes" / "block.geo"), "this kernel has no Landlock",
                  "may run programs and read or write any of your files", "--trust-geo"):
        assert words in str(error.value), str(error.value)
    assert len(run(scene, tmp_path / "trusted", trust_geo=True).history["t"]) == 20
    body_mesh(REPO / "meshes" / "rectangle.geo", {"n": 7.0}, cache=tmp_path / "cache")
    for command in ("run", "sweep"):
        shown = subprocess.run([sys.executable, "-m", "orchestrate", command, "--help"], capture_output=True, text=True,
                               cwd=REPO).stdout
        assert "--trust-geo" in shown and "without Landlock" in shown, command


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
    assert done.returncode == 3 and "the -DSCENE path 'a#b/scene.idp' holds a '#'" in done.stderr  # bin/ff's check
    done = run_script(REPO / "edp" / "main.edp", ["-out", "x"], defines={"SCENE": "a#b/scene.idp"}, cwd=tmp_path)
    assert done.returncode == 3 and "-DSCENE='a#b/scene.idp' reached FreeFEM as 'a'" in done.error_line  # the driver's
    assert not (tmp_path / "x").exists()


# Code that gmsh's block skipping hides from any reader of the text but gmsh's (Gmsh.y's skip and
# skipTest lose the character after an R, E, I or F, and the like; found by two reviews of the
# former lexical check): gmsh runs the System line; the sandbox stops it.
HIDDEN = {
    "if": "If (0)\n E\" EndIf\nSystem 'touch {marker}';\ns = \";\nEndIf\n// \";\n",
    "macro": "Macro Mhide\n R\" Return\nSystem 'touch {marker}';\ns = \";\nReturn\n// \";\n",
    "for-line": "For i In {{1:2}}  s = \"\nSystem 'touch {marker}';\nt = 1; // \";\nEndFor\n",
}


@pytest.mark.parametrize("form", HIDDEN)
def test_code_hidden_by_gmsh_s_skipping_starts_no_program(tmp_path, form):
    marker = tmp_path / "x"
    source = tmp_path / "block.geo"
    source.write_text(HIDDEN[form].format(marker=marker) + RECTANGLE)
    subprocess.run([sys.executable, "-c", "import gmsh, sys; gmsh.initialize(); gmsh.option.setNumber("
                    "'General.Terminal', 0); gmsh.open(sys.argv[1])", str(source)], capture_output=True)
    assert marker.exists(), "gmsh should run the hidden line (the hazard this test guards against)"
    marker.unlink()
    with pytest.raises(MeshError, match="/bin/sh"):
        body_mesh(source, {"n": 4.0}, cache=tmp_path / "cache")
    assert not marker.exists()


def test_the_mesher_writes_its_one_target_whatever_the_geo_sets(tmp_path):
    """A .geo may set mesh options, but the file written is one gmsh 2.2 text file, the target (beside
    it in the cache, its record)."""
    source = tmp_path / "block.geo"
    source.write_text(RECTANGLE + "Mesh 2; Mesh.PartitionSplitMeshFiles = 1; Mesh.Binary = 1; PartitionMesh 3;\n")
    target = body_mesh(source, {"n": 4.0}, cache=tmp_path / "cache")
    assert sorted(path.name for path in target.parent.iterdir()) == [target.name, f"{target.name}.sha256"]
    assert target.read_text().startswith("$MeshFormat\n2.2 0 8\n")


def test_ordinary_loops_and_tests_are_meshed(tmp_path):
    source = tmp_path / "block.geo"
    source.write_text(RECTANGLE + 'For i In {1:3}\n  Point(10 + i) = {0.25*i, 0.5, 0, 0.1};\nEndFor\n'
                      'If (n < 1)\n  Error("n = %g must be at least 1", n);\nEndIf\nR = 2;\nIf (n > 1)\n  r = R/2;\nEndIf\n')
    body_mesh(source, {"n": 4.0}, cache=tmp_path / "cache", limits=MeshLimits("body1", 30))


# --- labels the solver cannot use (issue 32, messages) ---------------------------------------------

SPLIT_BOTTOM = RECTANGLE.replace("Line(1) = {1, 2};", "Point(5) = {x0 + (x1 - x0)/3, y0, 0, h};\n"
                                 "Point(6) = {x0 + 2*(x1 - x0)/3, y0, 0, h};\nLine(1) = {1, 5};\nLine(5) = {5, 6};\n"
                                 "Line(6) = {6, 2};").replace("Curve Loop(1) = {1, 2, 3, 4};",
                                                              "Curve Loop(1) = {1, 5, 6, 2, 3, 4};")
LOOSE_LINE = RECTANGLE.replace("Physical Curve(1) = {1};", "Point(10) = {x0, y0 - 0.5, 0, h};\n"
                               "Point(11) = {x1, y0 - 0.5, 0, h};\nLine(10) = {10, 11};\nPhysical Curve(1) = {1, 10};")


def test_a_contact_label_on_two_separate_curves_is_refused_naming_the_field(tmp_path):
    """Label 1 on the outer thirds of the bottom, the middle third labelled 6: Γ_C would be two
    pieces, which neither the mortar side (a segment) nor body 2's side (a curve facing it) can be."""
    scene = project(tmp_path, text=SPLIT_BOTTOM.replace("Physical Curve(1) = {1};",
                                                        "Physical Curve(1) = {1, 6};\nPhysical Curve(6) = {5};"))
    with pytest.raises(SolverError) as error:  # the driver's check of Γ_C (edp/lib/mortar.idp), by the scene's key
        run(scene, tmp_path / "run")
    message = str(error.value)
    assert "body 1's potential contact boundary (label 1, body1.mesh.contactLabel) is not one segment" in message \
        and "several labels must meet end to end" in message
    (tmp_path / "shapes" / "block.geo").write_text(SPLIT_BOTTOM.replace("Physical Curve(1) = {1};",
                                                                        "Physical Curve(1) = {1, 5, 6};"))
    assert len(run(scene, tmp_path / "joined").history["t"]) == 20  # the same side in three pieces that meet


def test_a_label_on_a_curve_outside_the_meshed_surface_is_refused_naming_it(tmp_path):
    """A line below the rectangle in label 1: its nodes are in no triangle (FreeFEM's matrices
    would be singular there, "the matrix K of body 1 is not finite and positive")."""
    with pytest.raises(SceneError) as error:
        run(project(tmp_path, text=LOOSE_LINE), tmp_path / "run")
    assert str(error.value).startswith("body1.mesh.geo: label 1 of body 1's mesh is on a curve that bounds none of "
                                       "its triangles (at (0, -0.5))")
