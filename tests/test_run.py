"""`python -m orchestrate run`: a scene runs into a folder that appears complete or not at all,
with the solver's files, the scene as run, the log, summary.json and the images."""
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from conftest import solve_ok
from orchestrate import Scene, SolverError, load_result, run
from orchestrate.freefem import REPO
from orchestrate.runner import RunError

pytestmark = pytest.mark.runs

PAPER = REPO / "scenes" / "paper.toml"
COARSE = {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.N": 20, "output.images": False}


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory):
    return run(PAPER, tmp_path_factory.mktemp("toml") / "paper")


def test_the_paper_scene_file_gives_the_history_of_the_driver_run_by_hand(paper_run, tmp_path):
    direct = solve_ok(tmp_path / "direct")
    for column, values in direct.history.items():
        if column != "stepSeconds":
            np.testing.assert_array_equal(paper_run.history[column], values, err_msg=column)


def test_a_run_folder_holds_the_scene_as_run_the_log_and_a_summary(paper_run):
    names = {path.name for path in paper_run.folder.iterdir()}
    assert {"scene.toml", "scene.idp", "run.log", "summary.json", "history.csv", "params_used.json",
            "fields.png", "contact_line.png", "history.png"} <= names
    assert Scene.load(paper_run.folder / "scene.toml") == Scene.load(PAPER)
    summary = json.loads((paper_run.folder / "summary.json").read_text())
    assert summary["final"]["normV"] == paper_run.history["normV"][-1]
    assert summary["contactItersPerStep"] == pytest.approx(paper_run.history["contactIters"].mean())
    assert set(summary["timing"]) >= {"meshing", "solver", "images", "solverSetupCpu", "solverLoopCpu"}
    assert summary["versions"]["freefem"] == 4.9 and summary["versions"]["numpy"]
    assert "step 40/40" in (paper_run.folder / "run.log").read_text()
    assert not list(paper_run.folder.parent.glob("*.partial"))


def test_an_existing_folder_is_kept_unless_forced(tmp_path):
    out = tmp_path / "run"
    first_steps = len(run(PAPER, out, COARSE).history["t"])
    stamp = (out / "history.csv").stat().st_mtime_ns
    with pytest.raises(RunError, match="--force"):
        run(PAPER, out, COARSE)
    assert (out / "history.csv").stat().st_mtime_ns == stamp
    second = run(PAPER, out, {**COARSE, "time.N": 24}, force=True)
    assert first_steps == 20 and len(second.history["t"]) == 24


def test_a_failed_run_leaves_a_marked_folder_with_its_log(tmp_path):
    out = tmp_path / "run"
    with pytest.raises(SolverError, match="contactMaxIt"):
        run(PAPER, out, {**COARSE, "solver.contactMaxIt": 2})
    assert not out.exists()
    assert "ERROR: step 1/20" in (tmp_path / "run.failed" / "run.log").read_text()


def test_the_command_line_runs_a_scene_with_overrides(tmp_path):
    sets = [item for key, value in COARSE.items() for item in ("--set", f"{key}={str(value).lower()}")]
    done = subprocess.run([sys.executable, "-m", "orchestrate", "run", str(PAPER), *sets, "--out", str(tmp_path / "r")],
                          capture_output=True, text=True, cwd=REPO)
    assert done.returncode == 0, done.stderr
    assert "20 steps" in done.stdout
    assert load_result(tmp_path / "r").params["N"] == 20


def test_a_run_without_out_goes_to_results_in_the_current_folder(tmp_path):
    """A user's runs go to the user's project, not into this repository."""
    sets = [item for key, value in COARSE.items() for item in ("--set", f"{key}={str(value).lower()}")]
    done = subprocess.run([sys.executable, "-m", "orchestrate", "run", str(PAPER), *sets], capture_output=True,
                          text=True, cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert done.returncode == 0, done.stderr
    assert load_result(tmp_path / "results" / "paper").params["N"] == 20


def test_a_bad_override_is_refused_before_anything_runs(tmp_path):
    done = subprocess.run([sys.executable, "-m", "orchestrate", "run", str(PAPER), "--set", "body1.material.nu=0.6",
                           "--out", str(tmp_path / "r")], capture_output=True, text=True, cwd=REPO)
    assert done.returncode == 2 and "body1.material.nu = 0.6" in done.stderr
    assert not any(tmp_path.iterdir())


def test_an_interrupted_run_ends_freefem_and_leaves_a_marked_partial_folder(tmp_path):
    out = tmp_path / "long"
    command = [sys.executable, "-m", "orchestrate", "run", str(PAPER), "--set", "time.N=100000", "--set",
               "output.images=false", "--out", str(out)]
    process = subprocess.Popen(command, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    log = tmp_path / "long.partial" / "run.log"
    deadline = time.time() + 60
    while time.time() < deadline and not (log.exists() and "step 5/" in log.read_text()):
        time.sleep(0.1)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=30)
    assert process.returncode != 0 and "interrupted" in stderr
    assert (tmp_path / "long.partial" / "INTERRUPTED").exists() and not out.exists()
    time.sleep(0.5)
    leftovers = subprocess.run(["pgrep", "-f", str(tmp_path)], capture_output=True, text=True).stdout.split()
    assert [pid for pid in leftovers if int(pid) != os.getpid()] == []
