"""Sweeps on dask.distributed: four coarse runs on a LocalCluster, one failing on purpose; then
the same sweep again runs only what did not complete."""
import csv

import pytest

from orchestrate import sweep
from orchestrate.freefem import REPO

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
    assert "SolverError" in failed["error"] and "exit 5" in failed["error"]
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
    assert rows[0]["status"] == "invalid" and "time.N = 0" in rows[0]["error"]
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
    import subprocess
    import sys

    settings = [f"--set={key}={value}" for key, value in BASE.items() if key != "output.images"]
    done = subprocess.run([sys.executable, "-m", "orchestrate", "sweep", str(SCENE), "--grid", "glue.gammaNu=0",
                           *settings, "--out", str(tmp_path / "sweep"), "--workers", "1", *(["--images"] if images else [])],
                          cwd=REPO, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    pictures = list((tmp_path / "sweep").rglob("*.png"))
    assert bool(pictures) == images and (not images or {p.name for p in pictures} >= {"fields.png", "history.png"})
