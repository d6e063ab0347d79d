"""Sweeps on dask.distributed: four coarse runs on a LocalCluster, one failing on purpose; then
the same sweep again runs only what did not complete. The grid's syntax: TOML lists of any value,
boundary conditions by label, grid files."""
import csv
import re
import shutil
import subprocess
import sys

import pytest

from orchestrate import SceneError, sweep
from orchestrate.cli import main
from orchestrate.freefem import REPO
from orchestrate.freefem import InputError
from orchestrate.plot import history_runs, plot_columns
from orchestrate.results import load_result
from orchestrate.sweep import grid_of, parse_grid, plan

pytestmark = pytest.mark.runs

SCENE = REPO / "scenes" / "paper.toml"
BASE = {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.N": 20, "output.images": False}
GRID = {"glue.gammaNu": [0.0, 1.0, 2.0, 1e7]}  # a glue of 1e7 is far too stiff for the explicit scheme


@pytest.fixture(scope="module")
def first(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep")
    return out, sweep(SCENE, GRID, out, BASE, workers=2)


def test_each_run_has_its_folder_and_one_failure_does_not_stop_the_others(first):
    out, rows = first
    status = {row["glue.gammaNu"]: row["status"] for row in rows}
    assert status == {0.0: "completed", 1.0: "completed", 2.0: "completed", 1e7: "failed"}
    failed = next(row for row in rows if row["status"] == "failed")
    assert "SolverError" in failed["error"] and "exit 3" in failed["error"] and "normal glue bound" in failed["error"]
    for row in rows:
        assert (out / row["folder"] / "history.csv").exists() == (row["status"] == "completed")
    assert (out / (failed["folder"] + ".failed") / "run.log").exists()


def test_sweep_table_has_a_row_per_run_with_final_figures(first):
    out, _ = first
    with open(out / "sweep.csv") as handle:
        table = list(csv.DictReader(handle))
    assert len(table) == 4
    assert {"glue.gammaNu", "folder", "status", "error", "wallSeconds", "normV", "contactForce"} <= set(table[0])
    completed = [row for row in table if row["status"] == "completed"]
    assert all(float(row["normV"]) > 0 and float(row["wallSeconds"]) > 0 for row in completed)
    # glue pulls the open part of Γ_C back: more glue, less separation, more contact force
    forces = [float(row["contactForce"]) for row in completed]
    assert forces == sorted(forces)


def test_a_second_sweep_runs_only_what_did_not_complete(first):
    out, _ = first
    def stamps():
        return {p.parent.name: p.stat().st_mtime_ns for p in out.glob("glue.gammaNu=[012].0-*/history.csv")}

    before = stamps()
    rows = sweep(SCENE, {"glue.gammaNu": [0.0, 1.0, 2.0, 1e7, 3.0]}, out, BASE, workers=2)
    status = {row["glue.gammaNu"]: row["status"] for row in rows}
    assert status == {0.0: "skipped (complete)", 1.0: "skipped (complete)", 2.0: "skipped (complete)",
                      1e7: "failed", 3.0: "completed"}
    assert len(before) == 3 and stamps() == before


def test_changed_inputs_are_run_again(first):
    out, _ = first
    rows = sweep(SCENE, {"glue.gammaNu": [1.0]}, out, {**BASE, "time.N": 24}, workers=1)
    assert rows[0]["status"] == "completed"


def test_an_invalid_combination_is_recorded_without_running(tmp_path):
    rows = sweep(SCENE, {"time.N": [0, 20]}, tmp_path, {k: v for k, v in BASE.items() if k != "time.N"}, workers=1)
    assert rows[0]["status"] == "invalid" and "--grid time.N = 0" in rows[0]["error"]  # named as the user gave it
    assert rows[1]["status"] == "completed"


def test_a_sweep_runs_on_an_existing_cluster_given_its_address(tmp_path):
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=None) as cluster:
        rows = sweep(SCENE, {"glue.gammaNu": [0.5]}, tmp_path, BASE, scheduler=cluster.scheduler_address)
        assert rows[0]["status"] == "completed"
        assert "run_one" in cluster.scheduler.task_prefixes  # the run went through that scheduler


@pytest.mark.parametrize("images", [False, True])
def test_a_sweep_draws_images_only_when_asked(tmp_path, images):
    """A sweep's figures are its table: `sweep` runs skip the images unless --images."""
    settings = [f"--set={key}={value}" for key, value in BASE.items() if key != "output.images"]
    done = subprocess.run([sys.executable, "-m", "orchestrate", "sweep", str(SCENE), "--grid", "glue.gammaNu=0",
                           *settings, "--out", str(tmp_path / "sweep"), "--workers", "1", *(["--images"] if images else [])],
                          cwd=REPO, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    pictures = list((tmp_path / "sweep").rglob("*.png"))
    assert bool(pictures) == images and (not images or {p.name for p in pictures} >= {"fields.png", "history.png"})


# --- the grid's syntax ---------------------------------------------------------------------

@pytest.mark.unit
def test_a_toml_list_sweeps_expressions_whole_commas_and_all():
    grid = parse_grid(['body1.boundary[label=4].fy=["-10*min(t, 1)", \'atan2(y, x)\', "pow(x, 2)*max(t, 0.5)", -3]',
                       "time.N=20, 40", "solver.contactSolver=pdas,bm", "glue.gammaNu=[0, 1.5]"])
    assert grid == {"body1.boundary[label=4].fy": ["-10*min(t, 1)", "atan2(y, x)", "pow(x, 2)*max(t, 0.5)", -3],
                    "time.N": [20, 40], "solver.contactSolver": ["pdas", "bm"], "glue.gammaNu": [0, 1.5]}


@pytest.mark.parametrize("item, words", [
    ("body1.boundary[label=4].fy=-10*min(t, 1),-20*t", ["--grid body1.boundary[label=4].fy=", "'-10*min(t' is part of "
                                                        "a value cut at a comma", "body1.boundary[label=4].fy=[V1, V2"]),
    ("body1.boundary.1.fy=atan2(y, x)", ["--grid body1.boundary.1.fy=", "'atan2(y' is part", "a TOML list"]),
    ("time.N=20,,40", ["--grid time.N=20,,40", "an empty value"]),
    ("body1.boundary[label=4].fy=[-10*t, -20*t]", ["--grid body1.boundary[label=4].fy=[-10*t", "not a TOML list",
                                                   "strings in quotes", "KEY=V1,V2"]),
    ('time.N=[20, 40', ["--grid time.N=[20, 40", "not a TOML list", "Unclosed array"]),
    ("time.N", ["--grid 'time.N'", "expected key=value1,value2,... or key=[value1, value2, ...]"]),
])
@pytest.mark.unit
def test_a_grid_that_would_cut_or_misread_a_value_is_refused_showing_the_list_form(item, words):
    with pytest.raises(SceneError) as error:
        parse_grid([item])
    for word in words:
        assert word in str(error.value), (word, str(error.value))


@pytest.mark.unit
def test_grid_keys_are_checked_against_the_scene_before_anything_runs(tmp_path):
    with pytest.raises(SceneError, match=r"--grid body1.boundary\[label=9\].fy: no condition .* on label 9 \(its "
                                         r"conditions: 0 clamped on label 5, 1 traction on label 4, 2 traction on label 2"):
        sweep(SCENE, {"body1.boundary[label=9].fy": ["-10*t"]}, tmp_path / "a", BASE)
    with pytest.raises(SceneError, match=r"--grid body1.boundary.1.fy and body1.boundary\[label=4\].fy name the same"):
        sweep(SCENE, {"body1.boundary.1.fy": ["-10*t"], "body1.boundary[label=4].fy": ["-20*t"]}, tmp_path / "b", BASE)
    assert not list(tmp_path.iterdir())


@pytest.mark.unit
def test_a_grid_file_gives_the_plan_of_the_same_grid_on_the_command_line(tmp_path):
    loads = '["-10*min(t, 1)", "-10*atan2(t, 1)"]'
    path = tmp_path / "grid.toml"
    path.write_text(f'"body1.boundary[label=4].fy" = {loads}\n[glue]\ngammaNu = [0.5, 1]\n')
    written = [f"body1.boundary[label=4].fy={loads}", "glue.gammaNu=0.5,1"]
    partial = tmp_path / "loads.toml"
    partial.write_text(f'"body1.boundary[label=4].fy" = {loads}\n')
    from_file, from_options, both = grid_of([], path), grid_of(written, None), grid_of(written[1:], partial)
    assert from_file == from_options == both
    assert from_file["body1.boundary[label=4].fy"] == ["-10*min(t, 1)", "-10*atan2(t, 1)"]

    def folders(grid):
        return [row["folder"] for row in plan(SCENE, grid, tmp_path / "out", BASE)[0]]

    assert folders(from_file) == folders(from_options) and len(set(folders(from_file))) == 4
    example = plan(SCENE, grid_of([], REPO / "docs" / "examples" / "grid.toml"), tmp_path / "out", BASE)[0]
    assert len(example) == 6 and not any(row.get("status") == "invalid" for row in example)  # README's example
    with pytest.raises(SceneError, match=r"--grid glue.gammaNu is also in --grid-file .*grid.toml"):
        grid_of(["glue.gammaNu=2"], path)
    path.write_text('"time.N" = [20]\n[time]\nN = [40]\n')
    with pytest.raises(SceneError, match="grid file .*: time.N is given twice"):
        grid_of([], path)
    with pytest.raises(SceneError, match=r"nothing to sweep: give --grid KEY=\[V1, V2, ...\] .* or --grid-file FILE"):
        grid_of([], None)
    path.write_text('"time.N" = 20\n')
    with pytest.raises(SceneError, match=r"time.N = 20 is not a list: give its values as one, e.g. time.N = \[20, ...\]"):
        grid_of([], path)


def test_a_sweep_of_two_loads_with_commas_scales_the_contact_force_as_the_loads_do(tmp_path):
    """Without damage (lambdaU = 0 keeps zeta at 1) and without glue (gammaNu = 0), the problem is
    linear viscoelasticity under frictionless contact with no gap, whose constraint is a cone: from
    rest, twice the load gives twice the solution and twice the contact force, whatever the
    active set. The two loads, -10*min(t, 1) and -10*min(2*t, 2), are -10t and -20t on [0, 1];
    the label-2 traction is set to 0 (by label) so that the load is the swept one alone."""
    key = "body1.boundary[label=4].fy"
    settings = {**{k: v for k, v in BASE.items() if k != "output.images"}, "glue.gammaNu": 0,
                "body1.damage.lambdaU": 0, "body2.damage.lambdaU": 0, "body1.boundary[label=2].fx": '"0"'}
    done = subprocess.run([sys.executable, "-m", "orchestrate", "sweep", str(SCENE),
                           "--grid", f'{key}=["-10*min(t, 1)", "-10*min(2*t, 2)"]',
                           *[f"--set={k}={v}" for k, v in settings.items()], "--out", str(tmp_path), "--workers", "1"],
                          cwd=REPO, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    with open(tmp_path / "sweep.csv") as handle:
        single, double = csv.DictReader(handle)
    assert (single[key], double[key]) == ("-10*min(t, 1)", "-10*min(2*t, 2)")  # the column is the key as written
    assert all(row["folder"].startswith("body1.boundary_label=4_.fy=-10_min_") for row in (single, double))
    assert min(float(row[z]) for row in (single, double) for z in ("zetaMin1", "zetaMin2")) > 1 - 1e-12
    assert float(single["contactForce"]) > 1  # in contact
    assert float(double["contactForce"]) / float(single["contactForce"]) == pytest.approx(2, rel=1e-9)
    assert float(double["normV"]) / float(single["normV"]) == pytest.approx(2, rel=1e-9)


@pytest.mark.unit
def test_a_grid_key_that_names_a_set_value_is_refused_before_anything_runs(tmp_path):
    """However each is spelt, --set and --grid naming one value would either let the grid overrule
    the --set value silently or make every run invalid."""
    for set_key, grid_key in (("time.N", "time.N"), ("body1.boundary.1.fy", "body1.boundary[label=4].fy")):
        with pytest.raises(SceneError, match=rf"--grid .* and --set {re.escape(set_key)} name the same value"):
            plan(SCENE, {grid_key: ["-10*t", "-20*t"] if "fy" in grid_key else [20, 40]}, tmp_path / "out",
                 {**BASE, set_key: "-5*t" if "fy" in set_key else 80})
    assert not (tmp_path / "out").exists()


def test_a_grid_above_the_cap_asks_for_yes_before_building_a_scene(tmp_path):
    """1025 combinations: refused at once, saying the count and the cap (planning them takes a
    few ms each, a million of them hours), and planned with yes."""
    grid = {"glue.gammaNu": [float(value) for value in range(41)], "glue.gammaR": [float(value) for value in range(25)]}
    with pytest.raises(SceneError, match=r"--grid: 1025 combinations \(41 \(glue.gammaNu\) × 25 \(glue.gammaR\)\), "
                                         r"above the 1000 a sweep runs unasked: pass --yes"):
        plan(SCENE, grid, tmp_path, BASE)
    assert len(plan(SCENE, {**grid, "glue.gammaNu": [0.0, 1.0]}, tmp_path, BASE)[0]) == 50
    done = subprocess.run([sys.executable, "-m", "orchestrate", "sweep", str(SCENE), "--grid", "glue.gammaNu=[" +
                           ",".join(map(str, grid["glue.gammaNu"])) + "]", "--grid", "glue.gammaR=[" +
                           ",".join(map(str, grid["glue.gammaR"])) + "]", "--out", str(tmp_path / "s")],
                          capture_output=True, text=True, cwd=REPO, timeout=60)
    assert done.returncode == 2 and "pass --yes (yes=True)" in done.stderr and "--yes" in subprocess.run(
        [sys.executable, "-m", "orchestrate", "sweep", "--help"], capture_output=True, text=True, cwd=REPO).stdout


@pytest.mark.unit
def test_expressions_that_differ_in_surrounding_spaces_are_one_value(tmp_path):
    grid = {"body1.boundary[label=4].fy": ["-10*t", "-10*t "]}
    with pytest.raises(SceneError, match=r"'-10\*t'} and .*'-10\*t '} are the same run: list each value once"):
        plan(SCENE, grid, tmp_path, BASE)
    spaced, plain = (plan(SCENE, {"body1.boundary[label=4].fy": [value]}, tmp_path, BASE)[0][0]
                     for value in (" -10*t", "-10*t"))
    assert spaced["folder"] == plain["folder"]  # one run, one folder


def test_a_sweep_from_a_script_on_standard_input_says_to_save_it_to_a_file(tmp_path):
    """Dask's spawned workers run the main script again from its file: `python - < script.py`
    has none (Dask says only "Nanny failed to start")."""
    script = (f"from orchestrate import sweep\nsweep({str(SCENE)!r}, {{'glue.gammaNu': [0, 1]}}, {str(tmp_path)!r}, "
              f"{BASE!r}, workers=1, progress=False)\n")
    done = subprocess.run([sys.executable, "-"], input=script, capture_output=True, text=True, cwd=REPO, timeout=120)
    assert done.returncode == 1 and "Nanny" not in done.stderr
    assert "<stdin> is no file (a script read from standard input, `python - < script.py`). Save the script to a " \
           "file and run `python script.py`" in done.stderr.splitlines()[-1]


@pytest.mark.unit
def test_a_grid_nested_too_deeply_names_its_file(tmp_path):
    path = tmp_path / "grid.toml"
    for depth in (18, 3000):  # past the grid's limit; past what the TOML reader can follow
        path.write_text("x = " + "[" * depth + "1" + "]" * depth + "\n")
        with pytest.raises(SceneError, match=re.escape(str(path))):
            grid_of([], path)
    path.write_text(".".join(["a"] * 3000) + " = [1]\n")
    with pytest.raises(SceneError, match=re.escape(f"grid file {path}: a.a.a") + ".* nests tables more than 16 deep"):
        grid_of([], path)
    path.write_text('"output.times" = [[0.5, 1.0], [1.0]]\n')  # a list of lists sweeps a list
    assert grid_of([], path) == {"output.times": [[0.5, 1.0], [1.0]]}
    with pytest.raises(SceneError, match="--grid time.N: its values nest lists or tables more than 16 deep"):
        grid_of(["time.N=" + "[" * 3000 + "]" * 3000], None)


def table_of(out):
    """sweep.csv's swept keys (its columns before folder) and each row's values of them and status."""
    with open(out / "sweep.csv", newline="") as handle:
        reader = csv.DictReader(handle)
        rows, columns = list(reader), reader.fieldnames
    keys = columns[:columns.index("folder")]
    return keys, [{key: row[key] for key in (*keys, "status")} for row in rows]


@pytest.mark.unit
def test_a_second_sweep_into_a_folder_adds_its_rows_to_the_table_and_keeps_the_first_s(tmp_path, capsys):
    """Sweeps whose runs are all refused by the scene's checks (nothing runs): the second one's table
    held its own rows alone, and the first's were lost. Now one table: the first's rows, then the
    second's, under the union of their keys; a run of neither sweep's other key has no value there
    (it never started)."""
    sweep(SCENE, {"glue.gammaNu": [-1.0, -2.0]}, tmp_path, BASE, progress=False)
    assert main(["sweep", str(SCENE), "--grid", "body1.material.E=-5.0", "--out", str(tmp_path),
                 *(f"--set={key}={value}" for key, value in BASE.items() if key != "output.images")]) == 1
    assert f"table: {tmp_path / 'sweep.csv'} (with the 2 rows of earlier sweeps" in capsys.readouterr().out
    assert table_of(tmp_path) == (["glue.gammaNu", "body1.material.E"],
                                  [{"glue.gammaNu": "-1.0", "body1.material.E": "", "status": "invalid"},
                                   {"glue.gammaNu": "-2.0", "body1.material.E": "", "status": "invalid"},
                                   {"glue.gammaNu": "", "body1.material.E": "-5.0", "status": "invalid"}])
    sweep(SCENE, {"glue.gammaNu": [-2.0, -3.0]}, tmp_path, BASE, progress=False)  # -2.0 again: its row, once
    assert [row["glue.gammaNu"] for row in table_of(tmp_path)[1]] == ["-1.0", "-2.0", "", "-3.0"]
    (tmp_path / "sweep.csv").write_bytes(b"\xff\xfe not a table")
    with pytest.raises(InputError, match=r"sweep.csv is not a sweep's table .* move it away to start a new table"):
        sweep(SCENE, {"glue.gammaNu": [-4.0]}, tmp_path, BASE, progress=False)
    assert (tmp_path / "sweep.csv").read_bytes() == b"\xff\xfe not a table"


def test_a_second_sweep_s_rows_give_the_first_s_key_the_value_their_runs_ran_with(tmp_path):
    """One table of both sweeps: each run's value of the key its sweep did not sweep is the one it
    ran with (the first sweep's time.N is BASE's 20; the second's γ_ν is the scene file's), and the
    merged table draws as any sweep's, a curve per γ_ν against N."""
    import tomllib

    from orchestrate.plot import read_sweep, series

    sweep(SCENE, {"glue.gammaNu": [0.5]}, tmp_path, BASE, workers=1, progress=False)
    fewer = {key: value for key, value in BASE.items() if key != "time.N"}
    sweep(SCENE, {"time.N": [20, 30]}, tmp_path, fewer, workers=1, progress=False)
    scene_gamma = tomllib.loads(SCENE.read_text())["glue"]["gammaNu"]
    assert table_of(tmp_path) == (["glue.gammaNu", "time.N"],
                                  [{"glue.gammaNu": "0.5", "time.N": "20", "status": "completed"},
                                   {"glue.gammaNu": str(float(scene_gamma)), "time.N": "20", "status": "completed"},
                                   {"glue.gammaNu": str(float(scene_gamma)), "time.N": "30", "status": "completed"}])
    curves, ticks, left_out = series(*read_sweep(tmp_path), "time.N", "normV")
    assert ticks is None and not left_out
    assert {label: [n for n, _ in points] for label, points in curves.items()} == \
        {"glue.gammaNu = 0.5": [20.0], f"glue.gammaNu = {float(scene_gamma)}": [20.0, 30.0]}


@pytest.fixture(scope="module")
def glued(tmp_path_factory):
    """A sweep of its own (the other tests change theirs): two runs that complete, one that fails."""
    out = tmp_path_factory.mktemp("glued")
    sweep(SCENE, {"glue.gammaNu": [0.0, 1.0, 1e7]}, out, BASE, workers=2)
    return out


def test_history_columns_of_each_run_of_a_sweep_and_of_one_run_are_drawn(glued, tmp_path, monkeypatch):
    """`plot SOURCE --y COLUMN --x COLUMN`: a curve per completed run (labelled by its swept values,
    the failed one left out), or one run's alone; the columns must be the history's."""
    out = glued
    runs = history_runs(out)
    assert [label for label, _ in runs] == ["glue.gammaNu = 0.0", "glue.gammaNu = 1.0"]
    assert all(len(load_result(folder).history["forceY1"]) == 20 for _, folder in runs)
    target = plot_columns(out, "forceY1", "t", tmp_path / "force.png")
    assert target.read_bytes().startswith(b"\x89PNG") and target.stat().st_size > 5000
    single = plot_columns(runs[0][1], "contactForce", "normV", tmp_path / "one.svg")
    assert single.read_text().startswith("<?xml")
    beside = plot_columns(runs[0][1], "betaMean")  # beside the run folder, which holds its manifest's files alone
    assert beside == runs[0][1].parent / f"{runs[0][1].name}-betaMean-vs-t.png"
    load_result(runs[0][1])
    monkeypatch.chdir(runs[0][1])  # the run folder as ".": still beside it
    assert plot_columns(".", "betaMin") == runs[0][1].parent / f"{runs[0][1].name}-betaMin-vs-t.png"
    load_result(runs[0][1])
    with pytest.raises(InputError, match=r"--y forceZ1: not a column of history.csv \(columns: n, t, normV"):
        plot_columns(out, "forceZ1", "t", tmp_path / "x.png")
    with pytest.raises(InputError, match=r"--x time: not a column of history.csv"):
        plot_columns(runs[0][1], "normV", "time", tmp_path / "x.png")


def test_a_sweep_row_naming_a_folder_its_record_does_not_list_is_not_read(glued, tmp_path):
    out = glued
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    text = (copy / "sweep.csv").read_text()
    first_folder = history_runs(copy)[0][1].name
    (copy / "sweep.csv").write_text(text.replace(first_folder, "../elsewhere", 1))
    assert [folder.name for _, folder in history_runs(copy)] == [folder.name for _, folder in history_runs(out)][1:]


def test_a_second_sweep_into_a_folder_a_sweep_is_running_in_is_refused_and_the_table_kept(tmp_path):
    """Found by an adversarial pass: two sweeps at once into one folder each wrote sweep.csv from
    what it read before the other wrote, and one table was lost. The folder is held by one sweep
    at a time; workers are bounded (100 000 took minutes to start)."""
    from orchestrate.runner import RunError
    from orchestrate.sweep import sweep_lock

    out = tmp_path / "sweep"
    sweep(SCENE, {"glue.gammaNu": [1.0]}, out, BASE, workers=1)
    table = (out / "sweep.csv").read_text()
    with sweep_lock(out):  # as a sweep holds it while it runs
        with pytest.raises(RunError, match="another sweep is running in .*: wait for it to end"):
            sweep(SCENE, {"glue.gammaNu": [0.5]}, out, BASE, workers=1)
    assert (out / "sweep.csv").read_text() == table
    with pytest.raises(InputError, match="workers = 100000: give 1 to 256"):
        sweep(SCENE, {"glue.gammaNu": [0.5]}, out, BASE, workers=100_000)
