"""A run produces exactly what its inputs say or stops with a clear message; nothing it reports as
complete is wrong, cut short or mixed with another run; nothing a user puts in a path, a scene or
a flag changes the program (issue "Trustworthy under hostile paths ...", items 1-12)."""
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import meshio
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import solve
from orchestrate import Scene, SceneError, load_result, run, sweep
from orchestrate.freefem import FILE_PROBLEM, MAIN, REPO, InputError, SolverError, run_script
from orchestrate.manifest import IncompleteRun
from orchestrate.mesh import CACHE, MeshError, body_mesh, read_msh
from orchestrate.runner import SUFFIXES, RunError, TooLarge

pytestmark = pytest.mark.runs

PAPER = REPO / "scenes" / "paper.toml"
COARSE = {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.N": 20, "output.images": False}


def cli(*args, cwd=REPO, env=None, **kwargs):
    return subprocess.run([sys.executable, "-m", "orchestrate", *map(os.fsdecode, args)], capture_output=True,
                          text=True, cwd=cwd, env=env, **kwargs)


def checkout_copy(parent: Path) -> Path:
    """The parts of the repository a run needs, copied under `parent`."""
    copy = parent / "repo"
    for name in ("edp", "meshes", "orchestrate", "scenes", "bin"):
        shutil.copytree(REPO / name, copy / name, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(REPO / "freefem++.pref", copy)
    return copy


def in_copy(copy: Path, *args):
    """python -m orchestrate from a copied checkout (its own package, REPO and mesh cache)."""
    return cli(*args, cwd=copy, env={**os.environ, "PYTHONPATH": str(copy)})


# --- 1. no path changes the program -------------------------------------------------------------

def test_a_hash_in_the_output_folder_runs_no_code(tmp_path):
    (tmp_path / "o2").mkdir()
    (tmp_path / "o2" / "a").write_text('exec("touch pwned");\n')
    done = cli("run", PAPER, *sum((["--set", f"{k}={str(v).lower()}"] for k, v in COARSE.items()), []),
               "--out", "o2/a#q", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert not (tmp_path / "pwned").exists() and not (REPO / "pwned").exists()
    result = load_result(tmp_path / "o2" / "a#q")
    assert result.params["out"] == "." and len(result.history["t"]) == 20


FOLDER_NAMES = st.text(st.characters(blacklist_categories=("Cc", "Cs"), blacklist_characters="/\0"),
                       min_size=1, max_size=24).filter(lambda name: name not in (".", "..") and not name.endswith(SUFFIXES))


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(name=FOLDER_NAMES)
def test_any_folder_name_a_file_system_allows_holds_a_run(name):
    with tempfile.TemporaryDirectory() as parent:
        out = Path(parent) / name
        result = run(PAPER, out, COARSE)
        assert result.folder == out and load_result(out).history["t"][-1] == 1.0
        assert sorted(p.name for p in Path(parent).iterdir()) == [name]  # nothing beside it, nothing left


@pytest.mark.parametrize("name, words", [
    ("tab\there", ["control character", "'\\t'"]),
    ("new\nline", ["control character", "'\\n'"]),
    ("x" * 250, ["250 bytes long", "at most 246"]),
    ("/", ["names no folder"]),
])
@pytest.mark.unit
def test_folder_names_that_cannot_hold_a_run_are_refused_before_anything_starts(tmp_path, name, words):
    with pytest.raises(InputError) as error:
        run(PAPER, name if name == "/" else tmp_path / name, COARSE)
    for word in words:
        assert word in str(error.value)
    assert not any(tmp_path.iterdir())


def test_a_folder_name_that_is_not_utf8_is_refused_on_the_command_line(tmp_path):
    done = subprocess.run([sys.executable, "-m", "orchestrate", "run", str(PAPER), "--out",
                           os.fsencode(tmp_path) + b"/bad\xff"], capture_output=True, text=True, cwd=REPO)
    assert done.returncode == 2 and "is not valid UTF-8" in done.stderr and "Traceback" not in done.stderr
    assert not any(tmp_path.iterdir())


def test_a_checkout_whose_path_has_hash_semicolon_backslash_quotes_and_spaces_runs(tmp_path):
    copy = checkout_copy(tmp_path / "a#b;c\\g 'd\" e$(id)")
    sets = sum((["--set", f"{k}={str(v).lower()}"] for k, v in COARSE.items()), [])
    done = in_copy(copy, "run", "scenes/paper.toml", *sets, "--out", tmp_path / "out")
    assert done.returncode == 0, done.stderr
    ours = run(PAPER, tmp_path / "here", COARSE)
    np.testing.assert_array_equal(load_result(tmp_path / "out").history["normV"], ours.history["normV"])


# --- 2. every label a scene names is in its mesh ------------------------------------------------

@pytest.mark.parametrize("key, value, words", [
    ("body1.boundary.1.label", 99, ["body1.boundary.1.label = 99", "no boundary label 99", "1, 2, 3, 4, 5"]),
    ("body1.boundary.0.label", 42, ["body1.boundary.0.label = 42", "1, 2, 3, 4, 5"]),
    ("body2.boundary.0.label", 7, ["body2.boundary.0.label = 7", "1, 2, 3, 4"]),
    ("body2.mesh.contactLabel", 9, ["body2.mesh.contactLabel = 9"]),
    ("body2.mesh.contactLabel", [3, 9], ["body2.mesh.contactLabel = [3, 9]", "no boundary label 9"]),
])
def test_a_label_not_in_the_mesh_is_refused_naming_the_key_and_the_mesh_labels(tmp_path, key, value, words):
    """The driver's rule (edp/lib/meshes.idp), named by the scene's key (scene.idp's sceneLabels)."""
    with pytest.raises(SolverError) as error:
        run(PAPER, tmp_path / "run", {**COARSE, key: value})
    assert error.value.returncode == 3
    for word in words:
        assert word in str(error.value)
    assert not (tmp_path / "run").exists() and "no boundary label" in (tmp_path / "run.failed" / "run.log").read_text()


def test_the_driver_checks_a_hand_written_scene_s_labels(tmp_path):
    scene = tmp_path / "scene.idp"
    scene.write_text((REPO / "edp" / "scenes" / "paper.idp").read_text().replace("boundaryLabels1 5, 4, 2",
                                                                                   "boundaryLabels1 5, 99, 2"))
    done, _ = solve(tmp_path / "run", scene=scene)
    assert done.returncode == 3 and "boundary label 99" in done.error_line and "1, 2, 3, 4, 5" in done.error_line
    scene.write_text("macro dirichlet1(ux, uy) on(5, ux = 0, uy = 0) //\nmacro dirichlet2(ux, uy) on(3, ux = 0, uy = 0) //\n")
    done, _ = solve(tmp_path / "run2", scene=scene)
    assert done.returncode == 3 and "boundaryLabels1" in done.error_line


# --- 3. sweep folders never collide -------------------------------------------------------------

def test_combinations_that_sanitize_alike_get_their_own_folders_and_a_swap_is_noticed(tmp_path):
    grid = {"body1.boundary.1.fy": ["(x<=3)*(-10*t)", "(x>=3)*(-10*t)"]}
    rows = sweep(PAPER, grid, tmp_path, COARSE, workers=1)
    assert [row["status"] for row in rows] == ["completed", "completed"]
    first, second = (tmp_path / row["folder"] for row in rows)
    assert first != second and rows[0]["normV"] != rows[1]["normV"]
    for row in rows:
        assert Scene.load(tmp_path / row["folder"] / "scene.toml").body1.boundary[1].fy == row["body1.boundary.1.fy"]
    first.rename(tmp_path / "swap")
    second.rename(first)
    (tmp_path / "swap").rename(second)
    again = sweep(PAPER, grid, tmp_path, COARSE, workers=1)
    assert [row["status"] for row in again] == ["completed", "completed"]  # neither folder holds its row's inputs
    assert [row["normV"] for row in again] == [row["normV"] for row in rows]


def test_a_value_listed_twice_is_refused(tmp_path):
    done = cli("sweep", PAPER, "--grid", "time.N=400,400", "--out", tmp_path / "sweep")
    assert done.returncode == 2 and "400 is listed twice" in done.stderr and "Traceback" not in done.stderr
    done = cli("sweep", PAPER, "--grid", "time.N=40", "--grid", "time.N=80", "--out", tmp_path / "sweep")
    assert done.returncode == 2 and "given twice" in done.stderr
    done = cli("sweep", PAPER, "--grid", "glue.gammaR=1,1.0", "--out", tmp_path / "sweep")  # one real, written twice
    assert done.returncode == 2 and "are the same run" in done.stderr


# --- 5. a mesh cut short never enters the cache; a bad entry is rebuilt -------------------------

def test_a_damaged_cache_entry_is_rebuilt(tmp_path):
    source, numbers = REPO / "meshes" / "rectangle.geo", {"n": 5.0}
    good = body_mesh(source, numbers, cache=tmp_path)
    whole = good.read_bytes()
    good.write_bytes(whole[: len(whole) // 2])
    again = body_mesh(source, numbers, cache=tmp_path)
    assert again == good and again.read_bytes() == whole


def test_a_cache_entry_swapped_for_another_whole_mesh_is_made_again(tmp_path):
    """A valid mesh put in another entry's place (a copy over it, an editor, a bad sync) is no mesh
    of that entry's sources: its record (its SHA-256, written when it was made) refuses it, and
    the entry is made again, never used; so is one edited where its record was edited with it."""
    source = REPO / "meshes" / "rectangle.geo"
    entry = body_mesh(source, {"n": 5.0}, cache=tmp_path)
    made = entry.read_bytes()
    other = body_mesh(source, {"n": 7.0}, cache=tmp_path)
    shutil.copyfile(other, entry)
    assert body_mesh(source, {"n": 5.0}, cache=tmp_path) == entry and entry.read_bytes() == made
    assert meshio.read(entry).points.shape[0] < meshio.read(other).points.shape[0]  # n = 5's, not n = 7's
    (entry.parent / f"{entry.name}.sha256").unlink()  # an entry without its record is not taken either
    before = entry.stat().st_mtime_ns
    time.sleep(0.05)
    body_mesh(source, {"n": 5.0}, cache=tmp_path)
    assert entry.stat().st_mtime_ns != before and entry.read_bytes() == made


@pytest.mark.unit
def test_a_mesh_file_changed_in_place_is_read_again(tmp_path):
    """What a mesh file holds is known by its bytes, not by its stamp: rewritten in place with the
    same size and its modification time put back, it is read again (the process once kept what it
    had read against device, inode, size and modification time, and took the new file for whole)."""
    path = tmp_path / "body.msh"
    whole = (REPO / "meshes" / "paper_body1-n24.msh").read_bytes()
    path.write_bytes(whole)
    assert read_msh(path).nodes == 625  # (24 + 1)² nodes of the structured mesh
    before = path.stat()
    path.write_bytes(whole.replace(b"$EndElements", b"$EndElementZ"))  # same size, no longer whole
    os.utime(path, ns=(before.st_atime_ns, before.st_mtime_ns))
    with pytest.raises(MeshError, match="not a whole gmsh 2.2 mesh"):
        read_msh(path)


@pytest.mark.unit
def test_a_mesh_changed_after_it_was_read_is_not_handed_to_the_driver(tmp_path):
    """The driver gets the bytes that were checked (labels, curves, size): a mesh swapped between
    its reading and its copy into the run folder is refused, not copied."""
    from orchestrate.mesh import hand_over

    path = tmp_path / "body.msh"
    path.write_bytes((REPO / "meshes" / "paper_body1-n24.msh").read_bytes())
    info = read_msh(path)
    path.write_bytes((REPO / "meshes" / "paper_body2-n32.msh").read_bytes())
    with pytest.raises(MeshError, match="changed after it was read"):
        hand_over(path, info, tmp_path / "body1.msh")
    assert not (tmp_path / "body1.msh").exists()


@pytest.mark.unit
def test_a_size_field_changed_in_place_is_checked_again(tmp_path):
    """A size field is checked by its bytes too: one given a negative size in place, with its size
    and modification time kept, is refused (it was taken as the field checked before)."""
    from orchestrate.mesh import read_sizes

    view = tmp_path / "sizes.pos"
    view.write_text('View "sizes" {\nST(0,0,0,1,0,0,1,1,0){0.25,0.25,0.25};\nST(0,0,0,1,1,0,0,1,0){0.25,0.25,0.25};\n};\n')
    read_sizes(view, "body1.mesh.sizes")
    before = view.stat()
    view.write_text(view.read_text().replace("{0.25,", "{-.25,", 1))
    os.utime(view, ns=(before.st_atime_ns, before.st_mtime_ns))
    with pytest.raises(MeshError, match="body1.mesh.sizes: .* holds a size that is not a positive number"):
        read_sizes(view, "body1.mesh.sizes")


def test_gmsh_under_a_file_size_limit_leaves_no_cache_entry(tmp_path):
    code = ("import resource, signal, sys; from pathlib import Path; from orchestrate.mesh import body_mesh;"
            "signal.signal(signal.SIGXFSZ, signal.SIG_IGN); resource.setrlimit(resource.RLIMIT_FSIZE, (20000, 20000));"
            f"body_mesh(Path({str(REPO / 'meshes' / 'rectangle.geo')!r}), {{'n': 40.0}}, cache=Path({str(tmp_path)!r}))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO)
    assert done.returncode != 0 and "MeshError" in done.stderr
    assert list(tmp_path.iterdir()) == []
    body_mesh(REPO / "meshes" / "rectangle.geo", {"n": 40.0}, cache=tmp_path)  # and later runs mesh it whole


@pytest.mark.parametrize("damage", ["truncated", "nan"])
def test_a_damaged_mesh_file_is_named_by_the_driver_and_by_python(tmp_path, damage):
    text = (REPO / "meshes" / "paper_body1-n24.msh").read_text()
    if damage == "truncated":
        text = text[: len(text) // 2]
    else:
        lines = text.splitlines()
        node = lines.index("$Nodes") + 5
        lines[node] = " ".join(lines[node].split()[:1] + ["nan"] + lines[node].split()[2:])
        text = "\n".join(lines) + "\n"
    damaged = tmp_path / "damaged.msh"
    damaged.write_text(text)
    done, _ = solve(tmp_path / "run", "-mesh1", damaged)
    assert done.returncode == 3 and str(damaged) in done.error_line
    assert ("cut short" if damage == "truncated" else "not a finite number") in done.error_line
    with pytest.raises(MeshError, match="not a whole gmsh 2.2 mesh"):
        read_msh(damaged)


# --- 6. every input file belongs to the completion key ------------------------------------------

def test_a_committed_mesh_whose_geo_or_itself_changed_is_refused_until_made_again(tmp_path):
    """A body given only by n ran the committed mesh whatever its .geo had become. An edited .geo
    (here the top's split moved) or an edited mesh is refused, naming the command that makes the
    mesh again; made again, the run is a new one (its mesh is another), not a skipped one."""
    copy = checkout_copy(tmp_path)
    command = ["sweep", "scenes/paper.toml", "--grid", "glue.gammaNu=1", "--set", "time.N=20", "--set",
               "output.images=false", "--workers", "1", "--out", tmp_path / "sweep"]
    assert in_copy(copy, *command).returncode == 0
    geo = copy / "meshes" / "paper_body1.geo"
    geo.write_text(geo.read_text().replace("Point(4) = {3, 6, 0, h};", "Point(4) = {3.5, 6, 0, h};"))
    refused = in_copy(copy, *command)
    assert refused.returncode == 2, refused.stdout + refused.stderr
    assert "paper_body1.geo changed since its record paper_body1-n24.msh.sha256 was written" in refused.stderr
    assert f"python -m orchestrate commit-mesh {geo} --n 24" in refused.stderr
    assert in_copy(copy, "commit-mesh", "meshes/paper_body1.geo", "--n", "24").returncode == 0
    again = in_copy(copy, *command)
    assert again.returncode == 0 and "skipped" not in again.stdout and "completed" in again.stdout
    mesh = copy / "meshes" / "paper_body1-n24.msh"
    mesh.write_text(mesh.read_text().replace("\n2 6 0 0\n", "\n2 6.05 0 0\n"))  # a corner moved by hand
    refused = in_copy(copy, *command)
    assert refused.returncode == 2 and "paper_body1-n24.msh changed since its record" in refused.stderr


# --- 7, 8. nothing a user has is lost -----------------------------------------------------------

def test_a_second_run_into_a_folder_being_written_is_refused(tmp_path):
    out = tmp_path / "run"
    first = subprocess.Popen([sys.executable, "-m", "orchestrate", "run", str(PAPER), "--set", "time.N=4000",
                              "--set", "time.T=100", "--set", "output.images=false", "--out", str(out)],
                             cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    log = tmp_path / "run.partial" / "run.log"
    deadline = time.time() + 60
    while time.time() < deadline and not (log.exists() and "step 1/" in log.read_text()):
        time.sleep(0.05)
    second = cli("run", PAPER, "--out", out, "--force")
    assert second.returncode == 1 and "another run is writing" in second.stderr
    assert first.wait(timeout=120) == 0, first.stderr.read()
    assert len(load_result(out).history["t"]) == 4000  # whole, and the first run's alone


@pytest.mark.unit
def test_force_through_a_symbolic_link_deletes_nothing(tmp_path):
    target = tmp_path / "precious"
    target.mkdir()
    (target / "thesis.tex").write_text("years of work")
    (tmp_path / "link").symlink_to(target)
    for force in (False, True):
        with pytest.raises(RunError, match="symbolic link"):
            run(PAPER, tmp_path / "link", COARSE, force=force)
    assert (target / "thesis.tex").read_text() == "years of work"


def test_force_replaces_only_run_folders(tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    (tmp_path / "file").write_text("keep")
    for out in (mine, tmp_path / "file"):
        with pytest.raises(RunError, match="not a run folder"):
            run(PAPER, out, COARSE, force=True)
    assert (mine / "notes.txt").read_text() == "keep" and (tmp_path / "file").read_text() == "keep"
    first = run(PAPER, tmp_path / "run", COARSE)
    second = run(PAPER, first.folder, {**COARSE, "time.N": 24}, force=True)
    assert len(second.history["t"]) == 24


@pytest.mark.parametrize("kind", ["file", "link"])
@pytest.mark.unit
def test_a_partial_that_is_not_a_run_s_folder_is_refused(tmp_path, kind):
    partial = tmp_path / "run.partial"
    if kind == "file":
        partial.write_text("mine")
    else:
        (tmp_path / "elsewhere").mkdir()
        partial.symlink_to(tmp_path / "elsewhere")
    with pytest.raises(RunError, match="not a run's folder"):
        run(PAPER, tmp_path / "run", COARSE)
    assert partial.is_symlink() or partial.read_text() == "mine"


# --- 9-11. bad input: a clear message, never a traceback ---------------------------------------

@pytest.mark.parametrize("overrides, words", [
    ({"solver.contactMaxIt": 1e29}, ["solver.contactMaxIt", "valid integer"]),
    ({"solver.contactMaxIt": 10 ** 29}, ["solver.contactMaxIt", "less than or equal to 1000000"]),
    ({"time.N": True}, ["time.N = True", "an integer in [1, 10000000]"]),
    ({"output.times": []}, ["output.times"]),
    ({"body1.mesh.parameters": {"n": 1e5}}, ["parameters.n", "its own key"]),
    ({"body1.mesh.parameters": {"nn": 3}}, ["parameters.nn", "not a constant of paper_body1.geo", "n, structured"]),
    ({"body1.mesh.parameters": {"n": 1e308}}, ["parameters.n"]),
    ({"body1.mesh.n": 0}, ["body1.mesh.n = 0"]),
    ({"body1.mesh.n": -3}, ["body1.mesh.n = -3"]),
    ({"body1.boundary.1.fy": "2" + "^2" * 900}, ["body1.boundary.1.fy", "nested deeper than 64"]),
    ({"title": "x" * 501}, ["title", "at most 500"]),
    ({"body1.boundary.1.fy": "+".join(["x"] * 1000)}, ["deeper than 200 operations"]),
    ({"body1.boundary.1.fy": 10 ** 400}, ["not a finite double"]),
    ({"output.times": [10 ** 400]}, ["output.times", "is not a time"]),
    ({"glue.debondMobility": 10 ** 400}, ["glue.debondMobility", 'or "inf"']),
    ({"body1.mesh.parameters": {"nn": True}}, ["parameters.nn", "valid number"]),
    ({"body2.mesh.structured": True, "body2.mesh.geo": "meshes/base.geo"}, ["structured", "base.geo has no structured"]),
    ({"output.times": [True]}, ["output.times"]),
    ({"output.times": ["0.5"]}, ["output.times"]),
    ({"body1.mesh.timeLimit": 0}, ["body1.mesh.timeLimit = 0", "greater than 0"]),
    ({"body2.mesh.timeLimit": 1e6}, ["body2.mesh.timeLimit", "less than or equal to 86400"]),
    ({"body1.mesh.timeLimit": float("nan")}, ["body1.mesh.timeLimit", "finite"]),
    ({"body1.mesh.timeLimit": True}, ["body1.mesh.timeLimit", "valid number"]),
])
@pytest.mark.unit
def test_bad_scene_values_are_refused_naming_the_key(tmp_path, overrides, words):
    with pytest.raises(SceneError) as error:
        run(PAPER, tmp_path / "run", {**COARSE, **overrides})
    for word in words:
        assert word in str(error.value), (word, str(error.value))
    assert not any(tmp_path.iterdir())


def test_mesh_values_gmsh_refuses_leave_a_failed_folder_with_the_reason(tmp_path):
    scene = tmp_path / "blocks.toml"
    scene.write_text(PAPER.read_text().replace('geo = "meshes/paper_body2.geo"\nn = 32',
                                               'geo = "meshes/rectangle.geo"\nn = 32\nparameters = { x0 = 6, x1 = 0 }'))
    with pytest.raises(MeshError, match="x1 = 0 must exceed x0 = 6"):
        run(scene, tmp_path / "run")
    assert "must exceed" in (tmp_path / "run.failed" / "run.log").read_text()


def test_a_run_that_does_not_fit_the_memory_it_may_take_is_refused_before_its_set_up(tmp_path):
    """The driver's estimate (edp/lib/contact.idp, requireMemory: the one check of it) against
    -memoryLimitMB: the paper's scene (24 + 32, 1 714 nodes) needs about 15 MB; 10 MB is refused
    before a matrix is assembled, naming what to change, and 40 MB runs."""
    done = run_script(MAIN, ["-N", "20", "-memoryLimitMB", "10", "-out", tmp_path / "small"])
    assert done.returncode == 3 and "this run needs about" in done.error_line and "1714 nodes" in done.error_line
    assert "lower mesh.n or mesh.refine" in done.error_line and not (tmp_path / "small" / "params_used.json").exists()
    assert run_script(MAIN, ["-N", "20", "-memoryLimitMB", "40", "-out", tmp_path / "fits"]).returncode == 0


def test_a_mesh_too_large_for_this_machine_is_refused_with_the_estimate(tmp_path):
    with pytest.raises(TooLarge, match=r"about [0-9,]+ nodes.*GiB"):
        run(PAPER, tmp_path / "run", {"body1.mesh.refine": 6, "body2.mesh.refine": 6})


@settings(max_examples=300, deadline=None)
@given(key=st.sampled_from(["time.T", "body1.material.E", "body2.material.eta", "glue.gammaNu", "glue.L",
                            "damage.zetaMin", "solver.contactTol", "body1.damage.zeta0", "solver.divergenceFactor"]),
       value=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-2 ** 70, 2 ** 70),
                       st.sampled_from([0.0, -0.0, 5e-324, 1e-320, 1e308, -1e308, True, False, "1", None])))
@pytest.mark.unit
def test_numeric_edge_values_are_valid_or_refused_never_an_error_of_another_kind(key, value):
    from orchestrate.scene import to_freefem_scene

    try:
        scene = Scene.load(PAPER, {key: value})
    except SceneError as error:
        assert key in str(error)
        return
    text = to_freefem_scene(scene)
    assert "inf" not in text and "nan" not in text


FLAGS = ["-T", "-E1", "-eta2", "-gammaNu", "-N", "-contactMaxIt", "-divergenceFactor", "-zeta01", "-L"]
EDGES = ["inf", "-inf", "nan", "1e999", "-1e999", "1e-320", "0", "-0", "1e308", "9223372036854775808", "1e30"]


@settings(max_examples=25, deadline=None)
@given(flag=st.sampled_from(FLAGS), value=st.sampled_from(EDGES))
def test_the_driver_refuses_edge_values_with_exit_3_or_runs(flag, value):
    with tempfile.TemporaryDirectory() as folder:
        done = run_script(MAIN, [flag, value, "-N" if flag != "-N" else "-T", "20" if flag != "-N" else "1",
                                 "-outTimes", "none", "-out", folder])
    assert done.returncode in (0, 3, 5), (flag, value, done.returncode, done.stdout[-500:])
    if done.returncode == 3:
        assert flag[1:] in done.error_line or "bound" in done.error_line or "matrix" in done.error_line, done.error_line


def test_a_title_with_any_characters_round_trips_through_the_run_folder(tmp_path):
    title = 'line one\nline "two"\ttab \x7f del \\ back é ✓ \x00'
    result = run(PAPER, tmp_path / "run", {**COARSE, "title": title})
    assert Scene.load(result.folder / "scene.toml").title == title


@settings(max_examples=200, deadline=None)
@given(title=st.text(st.characters(blacklist_categories=("Cs",)), max_size=60))
@pytest.mark.unit
def test_every_title_survives_the_scene_file(title):
    scene = Scene.load(PAPER, {"title": title})
    import tomllib

    assert Scene.from_dict(tomllib.loads(scene.to_toml())) == scene


def hand_run(folder: Path) -> Path:
    done = run_script(MAIN, ["-out", folder])
    assert done.returncode == 0
    return folder


def redigested(path: Path) -> None:
    """run.json's SHA-256 of an edited file made anew: what a careful forger writes, left to the
    checks behind the digests."""
    from orchestrate.manifest import digest

    facts = json.loads((path.parent / "run.json").read_text())
    facts["fileDigests"][path.name] = digest(path)
    (path.parent / "run.json").write_text(json.dumps(facts))


def test_a_crafted_collection_or_a_missing_field_is_refused_by_render(tmp_path):
    crafted = hand_run(tmp_path / "crafted")
    pvd = crafted / "solution.pvd"
    pvd.write_text(pvd.read_text().replace('part="0"', 'part="7"', 1))
    missing = hand_run(tmp_path / "missing")
    vtu = missing / "body1_0040.vtu"
    vtu.write_text(vtu.read_text().replace('Name="u"', 'Name="v"'))
    for folder, name in ((crafted, "solution.pvd"), (missing, "body1_0040.vtu")):
        done = cli("render", folder)
        assert done.returncode == 1 and f"{name}: changed since the run finished" in done.stderr, done.stderr
    redigested(pvd)
    redigested(vtu)
    for folder, words in ((crafted, "not the run's collection"), (missing, "no u")):
        done = cli("render", folder)
        assert done.returncode == 1 and words in done.stderr and "Traceback" not in done.stderr, done.stderr


def test_a_run_folder_changed_after_the_run_is_not_trusted(tmp_path):
    result = run(PAPER, tmp_path / "run", COARSE)
    (result.folder / "history.csv").write_text((result.folder / "history.csv").read_text().replace("0.", "1.", 1))
    with pytest.raises(IncompleteRun, match="history.csv: changed since the run finished"):
        load_result(result.folder)


def test_a_sweep_with_an_invalid_row_runs_the_others(tmp_path):
    rows = sweep(PAPER, {"body1.boundary.1.fy": ["2" + "^2" * 900, "-10*t"]}, tmp_path, COARSE, workers=1)
    assert rows[0]["status"] == "invalid" and "nested deeper" in rows[0]["error"]
    assert rows[1]["status"] == "completed" and (tmp_path / "sweep.csv").exists()


# --- 12. interruptions end every child and leave a marker ---------------------------------------

def wait_for(condition, seconds=60):
    deadline = time.time() + seconds
    while time.time() < deadline and not condition():
        time.sleep(0.05)
    return condition()


def processes(pattern: str) -> list[str]:
    listing = subprocess.run(["pgrep", "-af", pattern], capture_output=True, text=True).stdout
    return [line for line in listing.splitlines() if "pgrep" not in line]


def test_sighup_marks_the_partial_folder(tmp_path):
    out = tmp_path / "run"
    process = subprocess.Popen([sys.executable, "-m", "orchestrate", "run", str(PAPER), "--set", "time.N=100000",
                                "--set", "time.T=2500", "--set", "output.images=false", "--out", str(out)], cwd=REPO,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert wait_for(lambda: (tmp_path / "run.partial" / "history.csv").exists())
    process.send_signal(signal.SIGHUP)
    _, stderr = process.communicate(timeout=30)
    assert process.returncode != 0 and "SIGHUP" in stderr
    assert "SIGHUP" in (tmp_path / "run.partial" / "INTERRUPTED").read_text()
    assert wait_for(lambda: not processes(str(tmp_path)), 10)


BIG_MESH = ["--set", "body1.mesh.n=600", "--set", "body1.mesh.structured=false"]  # gmsh takes ~20 s


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


@pytest.mark.parametrize("signal_number", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_an_interruption_while_meshing_ends_gmsh_at_once(tmp_path, signal_number):
    out = tmp_path / "run"
    process = subprocess.Popen([sys.executable, "-m", "orchestrate", "run", str(PAPER), *BIG_MESH, "--out", str(out)],
                               cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    mesher = '0-paper_body1.geo {"n": 600'  # gmsh meshes the checked copy of meshes/paper_body1.geo
    assert wait_for(lambda: any(mesher in line for line in processes("gmsh_mesher")), 30)
    started = time.time()
    process.send_signal(signal_number)
    process.communicate(timeout=30)
    assert wait_for(lambda: not any(mesher in line for line in processes("gmsh_mesher")), 10)
    assert time.time() - started < 10
    if signal_number == signal.SIGTERM:
        assert (tmp_path / "run.partial" / "INTERRUPTED").exists()
    else:  # what the killed mesher left (its sources' copies) is removed by the next use of that cache
        body_mesh(REPO / "meshes" / "rectangle.geo", {"n": 3.0})
        # meshes and source copies of dead meshers (a test running beside this one may be meshing)
        assert not [path for path in CACHE.glob("*.partial.*") if not alive(int(path.name.split(".")[-4]))]


def test_an_interrupted_sweep_writes_its_table_and_marks_what_it_stopped(tmp_path):
    out = tmp_path / "sweep"
    process = subprocess.Popen([sys.executable, "-m", "orchestrate", "sweep", str(PAPER), "--grid",
                                "glue.gammaNu=0.5,1", "--set", "time.N=100000", "--set", "time.T=2500", "--set",
                                "output.images=false", "--workers", "2", "--out", str(out)],
                               cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert wait_for(lambda: len(list(out.glob("*.partial/history.csv"))) == 2)
    process.send_signal(signal.SIGINT)
    process.communicate(timeout=60)
    table = (out / "sweep.csv").read_text()
    assert table.count(",interrupted,") == 2
    for partial in out.glob("*.partial"):
        assert (partial / "INTERRUPTED").exists()


# --- found by review: names the runner keeps for itself, and more bad input ----------------------

@pytest.mark.unit
def test_names_of_the_runner_s_own_folders_are_refused_and_a_user_s_folder_by_such_a_name_is_kept(tmp_path):
    for suffix in (".partial", ".failed", ".replaced"):
        with pytest.raises(InputError, match="the runner's own"):
            run(PAPER, tmp_path / f"mine{suffix}", COARSE)
    mine = tmp_path / "run.partial"
    mine.mkdir()
    (mine / "results.dat").write_text("keep")
    with pytest.raises(RunError, match="files no run wrote"):
        run(PAPER, tmp_path / "run", COARSE)
    assert (mine / "results.dat").read_text() == "keep"


def test_a_failed_folder_that_is_a_link_is_replaced_as_a_link(tmp_path):
    target = tmp_path / "elsewhere"
    target.mkdir()
    (target / "keep.txt").write_text("keep")
    (tmp_path / "run.failed").symlink_to(target)
    with pytest.raises(Exception, match="contactMaxIt"):
        run(PAPER, tmp_path / "run", {**COARSE, "solver.contactMaxIt": 1})
    assert (target / "keep.txt").read_text() == "keep" and (tmp_path / "run.failed" / "run.log").is_file()
    assert not (tmp_path / "run.failed").is_symlink()


@pytest.mark.unit
def test_a_rectangle_of_booleans_or_texts_is_refused():
    scene = (REPO / "scenes" / "shear.toml")
    with pytest.raises(SceneError, match="body1.mesh.rectangle"):
        Scene.load(scene, {"body1.mesh.rectangle": [True, "2", 0.0, 1.0]})


@pytest.mark.parametrize("make, words", [
    (lambda p: p.write_bytes(b'title = "\xff"\n'), ["not UTF-8"]),
    (lambda p: p.mkdir(), ["is a folder"]),
])
def test_a_scene_file_that_cannot_be_read_is_named(tmp_path, make, words):
    scene = tmp_path / "scene.toml"
    make(scene)
    done = cli("run", scene, "--out", tmp_path / "out")
    assert done.returncode == 2 and all(word in done.stderr for word in words) and "Traceback" not in done.stderr


def test_an_output_folder_under_a_file_or_too_long_is_refused_with_the_reason(tmp_path):
    (tmp_path / "afile").write_text("")
    done = cli("run", PAPER, "--out", tmp_path / "afile" / "x")
    assert done.returncode == FILE_PROBLEM and "Not a directory" in done.stderr and "Traceback" not in done.stderr
    deep = tmp_path.joinpath(*["d" * 200] * 21)
    done = cli("run", PAPER, "--out", deep)
    assert done.returncode == 2 and "the path is" in done.stderr and "Traceback" not in done.stderr


def test_an_override_given_twice_is_refused(tmp_path):
    done = cli("run", PAPER, "--set", "time.N=20", "--set", "time.N=40", "--out", tmp_path / "out")
    assert done.returncode == 2 and "--set time.N is given twice" in done.stderr


def test_a_fault_of_the_program_still_leaves_a_failed_folder_with_the_reason(tmp_path, monkeypatch):
    from orchestrate import runner as runner_module

    def broken(*args, **kwargs):
        raise ZeroDivisionError("a bug")
    monkeypatch.setattr(runner_module, "check_files", broken)
    with pytest.raises(ZeroDivisionError):
        run(PAPER, tmp_path / "run", COARSE)
    assert "ZeroDivisionError: a bug" in (tmp_path / "run.failed" / "run.log").read_text()


def test_an_edited_parameter_table_runs_again(tmp_path):
    copy = checkout_copy(tmp_path)
    command = ["sweep", "scenes/paper.toml", "--grid", "glue.gammaNu=1", "--set", "time.N=20", "--set",
               "output.images=false", "--workers", "1", "--out", tmp_path / "sweep"]
    assert in_copy(copy, *command).returncode == 0
    table = copy / "edp" / "lib" / "parameters.toml"
    reworded = table.read_text().replace('meaning = "slack of the invariants', 'meaning = "the slack of the invariants')
    table.write_text(reworded)
    (copy / "docs").mkdir()
    assert in_copy(copy, "reference", "--force").returncode == 0
    unchanged = in_copy(copy, *command)  # a meaning is prose: no generated include holds it
    assert unchanged.returncode == 0 and "skipped" in unchanged.stdout
    table.write_text(reworded.replace('name = "boundTol"\nscope = "run"\ntype = "real"\ndefault = "1e-10"',
                                      'name = "boundTol"\nscope = "run"\ntype = "real"\ndefault = "1e-9"'))
    assert in_copy(copy, "reference", "--force").returncode == 0
    again = in_copy(copy, *command)
    assert again.returncode == 0 and "skipped" not in again.stdout and "completed" in again.stdout
