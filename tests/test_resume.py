"""A resume that always works or says why, and never deletes (issue 47, item 1).

Runs of every kind a user starts (each output mode, each scheme, degree 2, a size-field mesh, the
rate-independent glue, a start in substeps) are killed at a step drawn at random and resumed with
`orchestrate run --resume`: their files are those of the same run uninterrupted, to the bit. A
folder that cannot be continued keeps every file it holds and the refusal says what to do; a
failed run beside the output folder is kept unless --force; by default a run that lasts more than
a few seconds has checkpoints (a twentieth of its steps apart)."""
import json
import random
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import cli_args, resealed, rows, same_results
from orchestrate import run
from orchestrate.freefem import FILE_PROBLEM, REPO, FileProblem, SolverError
from orchestrate.runner import CHECKPOINTS, RunError, checkpoint_step, sealed_checkpoint, sealed_checkpoints

pytestmark = pytest.mark.runs

PAPER = REPO / "scenes" / "paper.toml"
STEPS = 500
BASE = {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.N": STEPS, "output.images": False,
        "output.checkpointEvery": 25}


def size_view(path: Path) -> Path:
    """A gmsh view of element sizes over the paper's body 1, (0, 6)² (0.6 at every corner of a square around it)."""
    path.write_text('View "sizes" {\nST(-1,-1,0,7,-1,0,7,7,0){0.6,0.6,0.6};\nST(-1,-1,0,7,7,0,-1,7,0){0.6,0.6,0.6};\n};\n')
    return path


KINDS = {
    "final": {},
    "all": {"output.times": "all", "output.fields": ["bodies", "contact"], "time.N": 150},  # 3 .pvd entries a step
    "none": {"output.times": "none"},
    "list": {"output.times": [0.25, 0.5, 0.75, 1.0], "output.fields": ["bodies", "stress", "contact", "state"]},
    "euler": {"time.scheme": "euler"},
    "bdf2 rate-independent": {"time.scheme": "bdf2", "glue.debondMobility": "inf"},
    "substeps": {"time.scheme": "bdf2", "time.startSteps": 2, "time.startSubsteps": 4},
    "degree 2": {"space.order": 2, "time.scheme": "semi-implicit", "time.N": 300},
    "size field": {"body1.mesh.sizes": "SIZES", "time.scheme": "semi-implicit"},
}


def command(out: Path, overrides: dict) -> list[str]:
    return [sys.executable, "-m", "orchestrate", "run", str(PAPER), *cli_args(overrides), "--out", str(out)]


def killed(out: Path, overrides: dict, at: int) -> None:
    """`orchestrate run` into `out`, stopped (SIGSTOP, then SIGKILL to its group) once its history
    has at least `at` rows."""
    process = subprocess.Popen(command(out, overrides), cwd=REPO, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL, start_new_session=True)
    partial = out.with_name(out.name + ".partial")
    deadline = time.time() + 120
    while process.poll() is None and rows(partial) < at and time.time() < deadline:
        time.sleep(0.002)
    subprocess.run(["pkill", "-KILL", "-g", str(process.pid)], check=False)
    process.wait()


@pytest.mark.parametrize("kind", KINDS)
def test_a_run_killed_at_a_random_step_and_resumed_is_the_uninterrupted_run(tmp_path, kind):
    overrides = {**BASE, **KINDS[kind]}
    if "body1.mesh.sizes" in overrides:
        overrides["body1.mesh.sizes"] = str(size_view(tmp_path / "sizes.pos"))
    steps = overrides["time.N"]
    at = random.Random(kind).randint(steps // 3 + 10, steps * 8 // 10)  # "all": its .pvd entries then exceed N
    fresh = run(PAPER, tmp_path / "fresh", overrides)
    out = tmp_path / "run"
    killed(out, overrides, at)
    partial = tmp_path / "run.partial"
    checkpoint = checkpoint_step(partial)
    assert 0 < rows(partial) < steps and checkpoint > 0, f"killed at {rows(partial)} of {steps}"
    resumed = subprocess.run([*command(out, overrides), "--resume"], cwd=REPO, capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    assert json.loads((out / "run.json").read_text())["restartedFrom"] == checkpoint
    same_results(fresh.folder, out)
    assert rows(out) == steps


def kill_without_checkpoint(out: Path, at: int = 200) -> Path:
    killed(out, {**BASE, "output.checkpointEvery": STEPS}, at)
    partial = out.with_name(out.name + ".partial")
    assert rows(partial) >= at and not sealed_checkpoints(partial)
    return partial


def listing(folder: Path) -> dict[str, bytes]:
    return {path.name: path.read_bytes() for path in folder.iterdir()}


def test_an_interrupted_run_without_a_checkpoint_is_kept_and_the_refusal_says_what_to_do(tmp_path):
    out = tmp_path / "run"
    partial = kill_without_checkpoint(out)
    before = listing(partial)
    for resume in (True, False):
        with pytest.raises(RunError, match=r"holds an interrupted run of \d+ computed steps and no checkpoint.*--force to "
                                            r"start over.*move run.partial away"):
            run(PAPER, out, {**BASE, "output.checkpointEvery": STEPS}, resume=resume)
        assert listing(partial) == before
    assert rows(run(PAPER, out, BASE, force=True).folder) == STEPS  # only an explicit --force starts over


def test_a_resume_the_driver_refuses_leaves_the_interrupted_run_where_it_was(tmp_path):
    out = tmp_path / "run"
    killed(out, BASE, 400)
    partial = tmp_path / "run.partial"
    for name in ("checkpoint-a.txt", "checkpoint-b.txt"):  # a layout this driver does not know, sealed again
        resealed(partial / name, lambda lines: [line.replace("state-", "state-x") for line in lines])
    # the driver's records of this attempt (params_used.json, run.json), its scratch files and the log aside
    before = {name: data for name, data in listing(partial).items()
              if name not in ("run.log", "params_used.json", "run.json") and not name.endswith(".tmp")}
    with pytest.raises(RunError, match="could not be continued from its checkpoint at step .*kept another state.*"
                                       "--resume again once that is mended, --force to start over"):
        run(PAPER, out, BASE, resume=True)
    after = listing(partial)
    assert not (tmp_path / "run.failed").exists() and not out.exists()
    for name, data in before.items():  # the runner's own set-up files are written again, the same
        assert after[name] == data, name
    assert "resuming it failed" in after["INTERRUPTED"].decode() and b"resuming failed" in after["run.log"]


def test_a_failed_run_is_kept_unless_force_replaces_it(tmp_path):
    """A run that computed steps before it failed (euler above its elastic bound, let run: it
    diverges) is kept; one refused before its first step leaves nothing to keep and is replaced."""
    out = tmp_path / "run"
    with pytest.raises(SolverError, match="grew from"):
        run(PAPER, out, {**BASE, "time.N": 8, "time.T": 2.0, "solver.allowUnstable": True, "solver.divergenceFactor": 2.0})
    failed = tmp_path / "run.failed"
    before = listing(failed)
    assert rows(failed) > 0
    for resume in (False, True):
        with pytest.raises(RunError, match="run.failed holds a run that failed .*grew from.*move it away to keep it, "
                                           "or pass --force"):
            run(PAPER, out, BASE, resume=resume)
        assert listing(failed) == before
    run(PAPER, out, BASE, force=True)
    assert not failed.exists()
    with pytest.raises(SolverError, match="contactMaxIt"):  # fails in its first step: nothing computed
        run(PAPER, tmp_path / "other", {**BASE, "solver.contactMaxIt": 1})
    assert rows(tmp_path / "other.failed") == 0 and run(PAPER, tmp_path / "other", BASE).folder.is_dir()


def test_by_default_a_run_of_several_seconds_has_checkpoints_a_twentieth_of_its_steps_apart(tmp_path):
    """The default (output.checkpointEvery = 0): checkpoints at least 2 s apart and after every
    N/20 steps; a run killed after more than 2 s of steps has one, at a multiple of N/20 at most."""
    overrides = {**BASE, "body1.mesh.n": 24, "body2.mesh.n": 32, "time.N": 2000, "output.checkpointEvery": 0}
    out = tmp_path / "run"
    process = subprocess.Popen(command(out, overrides), cwd=REPO, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL, start_new_session=True)
    partial = tmp_path / "run.partial"
    started = None
    while process.poll() is None:
        if rows(partial) > 0 and started is None:
            started = time.monotonic()
        if started is not None and time.monotonic() - started > 3 and sealed_checkpoints(partial):
            break
        time.sleep(0.01)
    subprocess.run(["pkill", "-KILL", "-g", str(process.pid)], check=False)
    process.wait()
    steps = [step for step, _ in sealed_checkpoints(partial)]
    assert steps and rows(partial) < 2000, "no checkpoint within the run's first seconds"
    assert all(step >= 100 for step in steps)  # at least N/20 steps after the loop's start and apart
    if len(steps) == 2:
        assert abs(steps[0] - steps[1]) >= 100
    assert run(PAPER, out, overrides, resume=True).folder == out


# --- found by an adversarial pass ----------------------------------------------------------------

def test_a_run_whose_solver_finished_but_whose_files_were_not_published_is_published_by_resume(tmp_path, monkeypatch):
    """The disk fills while the manifest is written, after the driver's last step (it removes its
    checkpoints then): the folder stays <out>.partial, and --resume publishes it without solving
    again; the files are those of the same run done at once."""
    from orchestrate import runner as runner_module

    real = runner_module.write_manifest

    def full_disk(*args, **kwargs):
        raise OSError(28, "No space left on device", str(args[0] / "manifest.json"))
    monkeypatch.setattr(runner_module, "write_manifest", full_disk)
    out = tmp_path / "run"
    with pytest.raises(FileProblem, match="manifest.json: No space left on device.*--resume"):
        run(PAPER, out, BASE)
    partial = tmp_path / "run.partial"
    assert rows(partial) == STEPS and not sealed_checkpoints(partial) and not out.exists()
    monkeypatch.setattr(runner_module, "write_manifest", real)
    with pytest.raises(RunError, match="solver finished and whose files were not published: --resume"):
        run(PAPER, out, BASE)
    log = (partial / "run.log").read_text()
    resumed = run(PAPER, out, BASE, resume=True)
    assert (out / "run.log").read_text().startswith(log)  # no second solve appended to the log
    same_results(run(PAPER, tmp_path / "fresh", BASE).folder, resumed.folder)


def test_a_file_dropped_into_a_running_folder_leaves_it_resumable_once_it_is_moved(tmp_path):
    out = tmp_path / "run"
    process = subprocess.Popen(command(out, BASE), cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               text=True, start_new_session=True)
    partial = tmp_path / "run.partial"
    while process.poll() is None and rows(partial) < 10:
        time.sleep(0.002)
    (partial / "notes.txt").write_text("the user's")
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 1 and "notes.txt, which no run writes" in stderr and "--resume" in stderr
    assert rows(partial) == STEPS and not (tmp_path / "run.failed").exists()
    with pytest.raises(RunError, match="holds notes.txt, which no run writes: move it away"):
        run(PAPER, out, BASE, resume=True)
    (partial / "notes.txt").rename(tmp_path / "notes.txt")
    same_results(run(PAPER, tmp_path / "fresh", BASE).folder, run(PAPER, out, BASE, resume=True).folder)


def test_a_run_stopped_by_a_full_disk_stays_resumable_and_continues_once_there_is_space(tmp_path):
    """A file-size limit stands for the full disk: the driver stops naming the file (exit 74);
    the folder stays <out>.partial with its checkpoints, and --resume without the limit gives the
    run done at once."""
    overrides = {**BASE, "output.checkpointEvery": 50, "time.N": 2000}
    out = tmp_path / "run"

    def limited():
        resource.setrlimit(resource.RLIMIT_FSIZE, (400_000, 400_000))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    done = subprocess.run(command(out, overrides), cwd=REPO, capture_output=True, text=True, preexec_fn=limited)
    assert done.returncode == FILE_PROBLEM and "--resume" in done.stderr, done.stderr
    partial = tmp_path / "run.partial"
    assert not (tmp_path / "run.failed").exists() and checkpoint_step(partial) > 0
    resumed = subprocess.run([*command(out, overrides), "--resume"], cwd=REPO, capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    same_results(run(PAPER, tmp_path / "fresh", overrides).folder, out)


def test_a_link_planted_by_a_checkpoint_s_name_is_never_written_through(tmp_path):
    out = tmp_path / "run"
    killed(out, BASE, 300)
    partial = tmp_path / "run.partial"
    victim = tmp_path / "victim.txt"
    victim.write_text("the user's")
    steps = {name: (sealed_checkpoint(partial / name) or (-1,))[0] for name in CHECKPOINTS}
    written_next = min(steps, key=steps.get)  # the resumed run writes its next checkpoint over the older name
    (partial / written_next).unlink(missing_ok=True)
    (partial / written_next).symlink_to(victim)
    run(PAPER, out, BASE, resume=True)
    assert victim.read_text() == "the user's"
