"""Restart from a checkpoint (issue "Trustworthy ...", item 13): a run killed at any step and
continued from its last checkpoint writes history.csv (its stepSeconds timing aside), .vtu, state
and .pvd files identical to the bit to those of the same run uninterrupted; a checkpoint of other
inputs is refused; `orchestrate run --resume` and sweeps continue by themselves."""
import json
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from conftest import cli_args, resealed, rows, same_results
from orchestrate import run, sweep
from orchestrate.freefem import MAIN, REPO, freefem_command, freefem_env, run_script
from orchestrate.runner import RunError

pytestmark = pytest.mark.runs

PAPER = REPO / "scenes" / "paper.toml"
# The paper's scene over 15 s: damage keeps growing, the contact set and the glue change.
DRIVER = ["-N", "600", "-T", "15", "-outTimes", "3,6,9,12,15", "-outFields", "bodies,stress,contact,state",
          "-checkpointEvery", "13"]


def killed_driver(folder: Path, at_rows: int, extra: tuple = (), scene: Path | None = None, driver=DRIVER,
                  defines: dict | None = None) -> None:
    """The driver run into `folder` (with the scene file `scene`, from its folder, and the macros
    `defines`), killed (SIGKILL) once its history has `at_rows` rows."""
    defines = ({"SCENE": scene.name} if scene else {}) | (defines or {}) or None
    process = subprocess.Popen(freefem_command(MAIN, [*driver, *extra, "-out", str(folder)], defines),
                               cwd=scene.parent if scene else REPO, env=freefem_env(),
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while process.poll() is None and rows(folder) < at_rows and time.time() < deadline:
        time.sleep(0.005)
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert 0 < rows(folder) < 600, "the run was to be killed before its end"


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    folder = tmp_path_factory.mktemp("full") / "run"
    done = run_script(MAIN, [*DRIVER, "-out", folder])
    assert done.returncode == 0, done.error_line
    return folder


@pytest.mark.parametrize("kill_at", [20, 140, 333, 545])
def test_a_killed_run_continued_from_its_checkpoint_is_the_uninterrupted_run(tmp_path, uninterrupted, kill_at):
    folder = tmp_path / "run"
    killed_driver(folder, kill_at)
    done = run_script(MAIN, [*DRIVER, "-out", folder, "-restart", folder])
    assert done.returncode == 0, done.error_line
    restarted = json.loads((folder / "run.json").read_text())
    assert 0 < restarted["restartedFrom"] <= kill_at
    same_results(uninterrupted, folder)
    assert restarted["files"] == json.loads((uninterrupted / "run.json").read_text())["files"]
    assert not list(folder.glob("checkpoint-*"))  # a finished run keeps none


# The implicit schemes read two steps back (u, strains, jumps, zeta, beta and the bonding rate):
# a restart must bring back both, also with the lazily made contact columns of the active set; and
# after a start in substeps (lib/start.idp), the levels and operators of steps of k it left.
@pytest.mark.parametrize("scheme, kill_at, start", [("semi-implicit", 140, ()), ("bdf2", 20, ()), ("bdf2", 333, ()),
                                                    ("bdf2", 20, ("-startSteps", "3"))])
def test_a_killed_run_of_an_implicit_scheme_continues_to_the_bit(tmp_path, scheme, kill_at, start):
    extra = ("-scheme", scheme, *start)
    whole = tmp_path / "whole"
    done = run_script(MAIN, [*DRIVER, *extra, "-out", whole])
    assert done.returncode == 0, done.error_line
    folder = tmp_path / "run"
    killed_driver(folder, kill_at, extra)
    done = run_script(MAIN, [*DRIVER, *extra, "-out", folder, "-restart", folder])
    assert done.returncode == 0, done.error_line
    assert 0 < json.loads((folder / "run.json").read_text())["restartedFrom"] <= kill_at
    same_results(whole, folder)


def test_a_killed_run_of_degree_two_continues_to_the_bit_and_not_at_another_degree(tmp_path):
    """Displacements of degree 2 (the P2 state, its contact columns, the glue's band matrices): a
    restart gives the uninterrupted run to the bit; a checkpoint of degree 1 is refused by a run of
    degree 2, naming the parameter."""
    extra, two = ("-scheme", "bdf2", "-order", "2"), {"ORDER": "2"}
    whole = tmp_path / "whole"
    done = run_script(MAIN, [*DRIVER, *extra, "-out", whole], defines=two)
    assert done.returncode == 0, done.error_line
    folder = tmp_path / "run"
    killed_driver(folder, 140, extra, defines=two)
    done = run_script(MAIN, [*DRIVER, *extra, "-out", folder, "-restart", folder], defines=two)
    assert done.returncode == 0, done.error_line
    assert 0 < json.loads((folder / "run.json").read_text())["restartedFrom"] <= 140
    same_results(whole, folder)
    other = tmp_path / "other"
    killed_driver(other, 140, ("-scheme", "bdf2"))
    done = run_script(MAIN, [*DRIVER, *extra, "-out", other, "-restart", other], defines=two)
    assert done.returncode == 3 and "was made with order = 1, this run has order = 2" in done.error_line, done.error_line


def test_a_run_killed_after_files_before_its_first_checkpoint_continues(tmp_path):
    """Files written before the first checkpoint (every step's state here; a start in substeps'
    steps) are sealed by it: the restart from the second takes them, and the result is the
    uninterrupted run's."""
    driver = ["-N", "600", "-T", "15", "-outTimes", "all", "-outFields", "state", "-checkpointEvery", "2",
              "-scheme", "bdf2", "-startSteps", "2"]
    whole = tmp_path / "whole"
    done = run_script(MAIN, [*driver, "-out", whole])
    assert done.returncode == 0, done.error_line
    folder = tmp_path / "run"
    killed_driver(folder, 7, driver=driver)
    done = run_script(MAIN, [*driver, "-out", folder, "-restart", folder])
    assert done.returncode == 0, done.error_line
    assert 2 <= json.loads((folder / "run.json").read_text())["restartedFrom"] <= 7
    same_results(whole, folder)


@pytest.mark.parametrize("flags, words", [
    (["-E1", "2000"], ["E1 = 1000", "this run has E1 = 2000"]),
    (["-contactSolver", "bm"], ["contactSolver = 'pdas'"]),
    (["-n1", "12", "-n2", "16"], ["n1 = 24", "n1 = 12"]),
])
def test_a_checkpoint_of_other_inputs_is_refused(tmp_path, flags, words):
    folder = tmp_path / "run"
    killed_driver(folder, 100)
    done = run_script(MAIN, [*DRIVER, *flags, "-out", tmp_path / "other", "-restart", folder])
    assert done.returncode == 3
    for word in words:
        assert word in done.error_line


@pytest.mark.parametrize("change, words", [
    (lambda text: text.replace("(-10*t)", "(-11*t)"), "other loads, boundary conditions or initial data"),
    (lambda text: text + "macro initialBonding(x, y) ((x < 3.) ? 1. : 0.) //\n", "beta0 = 'expression:initialBonding'"),
    (lambda text: text + "macro initialDamage2(x, y) (1. - 0.1*(y > -1.)) //\n", "zeta02 = 'expression:initialDamage2'"),
], ids=["load", "beta0", "zeta0"])
def test_other_loads_or_initial_data_are_refused(tmp_path, change, words):
    folder = tmp_path / "run"
    killed_driver(folder, 100)
    scene = tmp_path / "changed.idp"
    scene.write_text(change((REPO / "edp" / "scenes" / "paper.idp").read_text()))
    done = run_script(MAIN, [*DRIVER, "-out", tmp_path / "other", "-restart", folder], defines={"SCENE": scene.name},
                      cwd=tmp_path)
    assert done.returncode == 3 and words in done.error_line, done.error_line


def test_a_load_changed_only_between_the_sampled_times_is_refused_by_the_scene_s_code(tmp_path):
    """The fingerprint samples the loads at 0.3T and T (here 4.5 and 15): a load that differs only in
    between is told apart by the scene file's code (its setParam lines aside)."""
    paper = (REPO / "edp" / "scenes" / "paper.idp").read_text()
    scene = tmp_path / "scene.idp"
    scene.write_text(paper)
    folder = tmp_path / "run"
    killed_driver(folder, 100, scene=scene)
    scene.write_text(paper.replace("(-10*t)", "(-10*t + 0.01*(t - 4.5)*(t - 15))"))
    done = run_script(MAIN, [*DRIVER, "-out", folder, "-restart", folder], defines={"SCENE": scene.name}, cwd=tmp_path)
    assert done.returncode == 3 and "a scene file whose code" in done.error_line, done.error_line


def test_another_expression_of_the_initial_data_is_refused_by_the_fingerprint(tmp_path):
    """Both runs give β⁰ by an expression (the same parameter value, 'expression:initialBonding'):
    the values at the segments tell them apart."""
    paper = (REPO / "edp" / "scenes" / "paper.idp").read_text()
    (tmp_path / "cracked.idp").write_text(paper + "macro initialBonding(x, y) ((x < 3.) ? 1. : 0.) //\n")
    (tmp_path / "longer.idp").write_text(paper + "macro initialBonding(x, y) ((x < 2.) ? 1. : 0.) //\n")
    folder = tmp_path / "run"
    killed_driver(folder, 100, scene=tmp_path / "cracked.idp")
    done = run_script(MAIN, [*DRIVER, "-out", folder, "-restart", folder], defines={"SCENE": "longer.idp"}, cwd=tmp_path)
    assert done.returncode == 3 and "initial data (their fingerprint differs)" in done.error_line, done.error_line


def test_a_checkpoint_of_another_state_layout_is_refused(tmp_path):
    """A checkpoint whose state lists other arrays (a driver before a change of state.idp) would be
    read into the wrong arrays: its layout name tells it apart."""
    folder = tmp_path / "run"
    killed_driver(folder, 100)
    for checkpoint in folder.glob("checkpoint-?.txt"):
        resealed(checkpoint, lambda lines: [line if not line.startswith("state-") else "state-0" for line in lines])
    done = run_script(MAIN, [*DRIVER, "-out", folder, "-restart", folder])
    assert done.returncode == 3 and "kept another state" in done.error_line, done.error_line


def restarted(folder: Path, *flags, out: Path | None = None):
    return run_script(MAIN, [*DRIVER, *flags, "-out", out or folder, "-restart", folder])


def test_a_checkpoint_naming_a_file_outside_its_folder_is_refused_and_nothing_is_written(tmp_path):
    folder = tmp_path / "run"
    killed_driver(folder, 300)
    victim = tmp_path / "victim.txt"
    victim.write_text("the user's\n")
    (folder / "victim.txt").write_text("the checkpoint folder's\n")
    for checkpoint in folder.glob("checkpoint-?.txt"):
        resealed(checkpoint, lambda lines: [line + " ../victim.txt" if line.startswith("files ") and line != "files end"
                                            else line for line in lines])
    done = restarted(folder, out=tmp_path / "o1")
    assert done.returncode == 3 and "'../victim.txt', which is not one of the run's" in done.error_line, done.error_line
    assert victim.read_text() == "the user's\n"


@pytest.mark.parametrize("entry", ["../victim.txt", "/etc/passwd", "state_12.txt", "body3_0120.vtu", "run.json"])
def test_a_sealed_file_entry_that_is_not_a_run_file_name_is_refused(tmp_path, entry):
    folder = tmp_path / "run"
    killed_driver(folder, 300)
    digest = "0" * 64
    for checkpoint in folder.glob("checkpoint-?.txt"):
        resealed(checkpoint, lambda lines: sum(([line, f"sha256 {digest}  {entry}"] if line.startswith("files ")
                                                and line != "files end" else [line] for line in lines), []))
    done = restarted(folder, out=tmp_path / "o1")
    assert done.returncode == 3 and f"'{digest}  {entry}', which is not one of the run's" in done.error_line, done.error_line


def test_a_fresh_run_removes_the_checkpoints_in_its_folder_before_its_first_step(tmp_path):
    """A copied folder with another run's checkpoints, a run of other inputs into it killed before
    its own first checkpoint: nothing there can be continued (was: rows of both runs, exit 0)."""
    folder = tmp_path / "run"
    killed_driver(folder, 300)
    assert len(list(folder.glob("checkpoint-?.txt"))) == 2
    (folder / "history.csv").unlink()  # so that the kill waits for the second run's rows
    killed_driver(folder, 30, ("-E1", "900", "-checkpointSeconds", "0"), driver=DRIVER[:-2])
    assert not list(folder.glob("checkpoint-*"))
    done = restarted(folder, "-E1", "900")
    assert done.returncode == 3 and "holds no whole checkpoint" in done.error_line, done.error_line


def test_a_checkpoint_with_its_step_changed_is_not_taken(tmp_path):
    """Both frame lines say another step: the seal no longer matches; sealed again, the history's
    digest does not (was: exit 0 and a wrong final state)."""
    folder = tmp_path / "run"
    killed_driver(folder, 300)
    checkpoints = sorted(folder.glob("checkpoint-?.txt"))
    for checkpoint in checkpoints:
        lines = checkpoint.read_text().splitlines()
        step = int(lines[0].split()[1])
        lines[0], lines[-1] = f"checkpoint {step - 50}", f"end {step - 50}"
        checkpoint.write_text("\n".join(lines) + "\n")
    done = restarted(folder, out=tmp_path / "o1")
    assert done.returncode == 3 and "does not match its seal" in done.error_line, done.error_line
    for checkpoint in checkpoints:
        resealed(checkpoint, lambda lines: lines)
    done = restarted(folder, out=tmp_path / "o2")
    assert done.returncode == 3 and "rows are not those of its checkpoint" in done.error_line, done.error_line


def value_lines(lines: list[str]) -> list[int]:
    """The lines of a checkpoint's state arrays (after the layout line, tab-indented values)."""
    start = next(j for j, line in enumerate(lines) if line.startswith("state-"))
    return [j for j in range(start, len(lines)) if lines[j].startswith("\t")]


def first_value(lines: list[str], which: int, text: str) -> list[str]:
    """The checkpoint's lines with the first value of state line `which` written as `text`."""
    j = value_lines(lines)[which]
    return lines[:j] + ["\t".join(["", text, *lines[j].split("\t")[2:]])] + lines[j + 1:]


@pytest.mark.parametrize("damage, words", [
    (lambda lines: lines[:value_lines(lines)[5]] + lines[value_lines(lines)[5] + 1:], "cannot be read"),
    (lambda lines: first_value(lines, 3, "nan"), "cannot be read"),
    (lambda lines: first_value(lines, 0, "1e999"), "cannot be read"),
], ids=["line missing", "nan", "overflow"])
def test_a_damaged_checkpoint_sealed_again_is_refused_with_what_is_wrong(tmp_path, damage, words):
    folder = tmp_path / "run"
    killed_driver(folder, 300)
    for checkpoint in folder.glob("checkpoint-?.txt"):
        resealed(checkpoint, damage)
    done = restarted(folder, out=tmp_path / "o1")
    assert done.returncode == 3 and "is damaged" in done.error_line and words in done.error_line, done.error_line


def test_a_checkpoint_cut_short_is_refused_saying_so(tmp_path):
    folder = tmp_path / "run"
    killed_driver(folder, 300)
    for checkpoint in folder.glob("checkpoint-?.txt"):
        checkpoint.write_bytes(checkpoint.read_bytes()[:-4000])
    done = restarted(folder)
    assert done.returncode == 3 and done.error_line.count("cut short") == 2, done.error_line


def test_a_file_of_the_restart_folder_changed_since_its_checkpoint_is_refused(tmp_path):
    folder = tmp_path / "run"
    killed_driver(folder, 300)
    state = folder / "state_0120.txt"
    state.write_text(state.read_text().replace("1", "2", 1))
    done = restarted(folder, out=tmp_path / "o1")
    assert done.returncode == 3 and "files differ from those its checkpoint" in done.error_line, done.error_line


@pytest.mark.parametrize("made, given, words", [
    (("-runIdentity", "a" * 64), ("-runIdentity", "b" * 64), "was made from other inputs (run identity aaaa"),
    (("-solverIdentity", "a" * 64), ("-solverIdentity", "b" * 64), "was made by other code (solver identity aaaa"),
    ((), ("-solverIdentity", "none"), "-restart needs the solver's identity"),
])
def test_a_checkpoint_of_another_identity_or_none_is_refused(tmp_path, made, given, words):
    folder = tmp_path / "run"
    killed_driver(folder, 100, made)
    done = restarted(folder, *given)
    assert done.returncode == 3 and words in done.error_line, done.error_line
    done = restarted(folder, *made)
    assert done.returncode == 0, done.error_line


def test_a_checkpoint_of_orchestrate_continues_by_hand_with_the_same_code(tmp_path):
    """A run identity on one side only (orchestrate's digest, a hand run's none): the solver's and
    the fingerprint decide."""
    folder = tmp_path / "run"
    killed_driver(folder, 100, ("-runIdentity", "c" * 64))
    done = restarted(folder)
    assert done.returncode == 0, done.error_line


@pytest.mark.parametrize("name", ["runIdentity", "solverIdentity"])
@pytest.mark.parametrize("value", ["abc", "A" * 64, "0" * 63 + "g", "../" + "0" * 61])
def test_an_identity_that_is_no_sha256_is_refused(tmp_path, name, value):
    done = run_script(MAIN, ["-N", "40", f"-{name}", value, "-out", tmp_path / "run"])
    assert done.returncode == 3 and f"parameter {name}" in done.error_line, done.error_line


def test_a_folder_without_a_whole_checkpoint_is_refused(tmp_path):
    (tmp_path / "empty").mkdir()
    (tmp_path / "empty" / "checkpoint-a.txt").write_text("checkpoint 12\nparameters 3\n")  # cut short
    done = run_script(MAIN, ["-out", tmp_path / "run", "-restart", tmp_path / "empty"])
    assert done.returncode == 3 and "holds no whole checkpoint" in done.error_line


PEEL = REPO / "scenes" / "peel.toml"
PEEL_SET = {"body1.mesh.n": 40, "body2.mesh.n": 25, "time.N": 400, "output.times": [0.5, 1.0, 1.5, 2.0],
            "output.checkpointEvery": 9, "output.images": False}


def killed_runner(out: Path, at_rows: int) -> list[str]:
    """`orchestrate run` of the peel scene into `out`, killed (SIGKILL: FreeFem++ dies with it)
    once its history has `at_rows` rows; returns the command."""
    command = [sys.executable, "-m", "orchestrate", "run", str(PEEL), *cli_args(PEEL_SET), "--out", str(out)]
    process = subprocess.Popen(command, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    partial = out.with_name(out.name + ".partial")
    while process.poll() is None and rows(partial) < at_rows:
        time.sleep(0.005)
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert 0 < rows(partial) < 400
    return command


def test_run_resume_continues_a_killed_run_of_the_peel_scene(tmp_path):
    fresh = run(PEEL, tmp_path / "fresh", PEEL_SET)
    out = tmp_path / "run"
    command = killed_runner(out, 150)
    resumed = subprocess.run([*command, "--resume"], cwd=REPO, capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    assert json.loads((out / "run.json").read_text())["restartedFrom"] > 0
    same_results(fresh.folder, out)
    assert "restart: from step" in (out / "run.log").read_text()


def test_a_resumed_run_counts_its_steps_from_its_checkpoint(tmp_path, capsys):
    """Its bar starts at the checkpoint's step, never shows the rows the killed run wrote after it
    (the driver cuts them), and ends at N."""
    from orchestrate.runner import checkpoint_step

    out = tmp_path / "run"
    killed_runner(out, 150)
    partial = out.with_name("run.partial")
    checkpoint, written = checkpoint_step(partial), rows(partial)
    assert 0 < checkpoint <= written  # equal when the kill came right after a checkpoint's step
    run(PEEL, out, PEEL_SET, resume=True, progress=True)
    steps = [int(n) for n in re.findall(r"(\d+)/400\b", capsys.readouterr().err)]
    assert steps[0] == checkpoint and steps[-1] == 400 and steps == sorted(steps)


def test_resume_refuses_a_partial_run_of_other_inputs(tmp_path):
    out = tmp_path / "run"
    killed_runner(out, 50)
    with pytest.raises(RunError, match="holds a run of other inputs \\(the scene differs\\)"):
        run(PEEL, out, {**PEEL_SET, "glue.gammaNu": 2.0}, resume=True)
    anew = run(PEEL, out, {**PEEL_SET, "glue.gammaNu": 2.0, "time.N": 80}, resume=True, force=True)  # discarded
    assert "restartedFrom" not in json.loads((anew.folder / "run.json").read_text())


def test_an_interrupted_sweep_continues_its_runs_from_their_checkpoints(tmp_path):
    out = tmp_path / "sweep"
    base = {**PEEL_SET, "body1.mesh.n": 80, "body2.mesh.n": 50, "time.N": 800, "output.checkpointEvery": 10}
    command = [sys.executable, "-m", "orchestrate", "sweep", str(PEEL), "--grid", "glue.gammaR=0.5,1", *cli_args(base),
               "--workers", "2", "--out", str(out)]
    process = subprocess.Popen(command, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120

    def both_running() -> bool:
        partials = list(out.glob("*.partial"))
        return len(partials) == 2 and all(rows(partial) > 30 for partial in partials)
    while time.time() < deadline and not both_running():
        time.sleep(0.02)
    assert both_running()
    process.send_signal(signal.SIGINT)
    process.wait(timeout=60)
    rows_again = sweep(PEEL, {"glue.gammaR": [0.5, 1.0]}, out, base, workers=2)
    assert [row["status"] for row in rows_again] == ["completed", "completed"]
    restarted = [json.loads((out / row["folder"] / "run.json").read_text()).get("restartedFrom", 0) for row in rows_again]
    assert all(step > 0 for step in restarted), restarted
    fresh = run(PEEL, tmp_path / "fresh", {**base, "glue.gammaR": 1.0})
    same_results(fresh.folder, out / rows_again[1]["folder"])


def test_a_run_with_a_checkpoint_is_not_started_over_unasked(tmp_path):
    out = tmp_path / "run"
    partial = tmp_path / "run.partial"
    killed_runner(out, 50)
    with pytest.raises(RunError, match="--resume to continue it; its files stay there: --force to start over"):
        run(PEEL, out, PEEL_SET)
    assert list(partial.glob("checkpoint-*"))
    anew = run(PEEL, out, PEEL_SET, force=True)
    assert "restartedFrom" not in json.loads((anew.folder / "run.json").read_text())


def test_a_restart_into_another_folder_gives_a_whole_run(tmp_path, uninterrupted):
    source = tmp_path / "killed"
    killed_driver(source, 250)
    target = tmp_path / "elsewhere"
    done = run_script(MAIN, [*DRIVER, "-out", target, "-restart", source])
    assert done.returncode == 0, done.error_line
    same_results(uninterrupted, target)
    from orchestrate import load_result

    load_result(target)  # every file it lists is there, whole


def test_loads_are_told_apart_from_prescribed_displacements_in_the_fingerprint(tmp_path):
    """With a prescribed displacement, the right-hand side holds tgv·g on the prescribed degrees of
    freedom (about 1e28): a change of a traction must still be seen."""
    moving = (REPO / "edp" / "scenes" / "paper.idp").read_text().replace("on(5, ux = 0, uy = 0)", "on(5, ux = 0, uy = 0.01*t)")
    (tmp_path / "moving.idp").write_text(moving)
    (tmp_path / "heavier.idp").write_text(moving.replace("(-10*t)", "(-11*t)"))
    folder = tmp_path / "run"
    killed_driver(folder, 100, scene=tmp_path / "moving.idp")
    done = run_script(MAIN, [*DRIVER, "-out", folder, "-restart", folder], defines={"SCENE": "heavier.idp"}, cwd=tmp_path)
    assert done.returncode == 3 and "other loads, boundary conditions or initial data" in done.error_line


def test_a_restart_factorizes_each_matrix_once_before_its_steps(tmp_path):
    """K1, K2 and the two damage matrices are factorized before the first step continued, once
    each (FreeFEM factorizes at the first solve: the set-up and the restore make it, not step 1;
    the paper's damage leaves the obstacle's active sets empty, so no penalized refactorization)."""
    folder = tmp_path / "run"
    killed_driver(folder, 140)
    done = run_script(MAIN, [*DRIVER, "-out", folder, "-restart", folder, "-v", 3])
    assert done.returncode == 0, done.error_line
    assert done.stdout.split("\nstep ", 1)[0].count("fac_numeric CHOLMoD") == 4


@pytest.fixture(scope="module")
def killed(tmp_path_factory):
    folder = tmp_path_factory.mktemp("killed") / "run"
    killed_driver(folder, 300)
    return folder


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(["drop", "repeat", "swap", "nan", "word"]), where=st.integers(0, 10**6), reseal=st.booleans())
def test_a_checkpoint_with_lines_removed_or_repeated_is_refused_or_gives_the_uninterrupted_run(
        tmp_path_factory, uninterrupted, killed, kind, where, reseal):
    """Never a third thing: exit 3 with a message, or the files of the run never interrupted (a line
    dropped, repeated, or with its last word made nan or a word; was: FreeFEM's Op_ReadKN, exit 8,
    on a nan in the fingerprint or the .pvd count). Sealed again, two value lines swapped are a checkpoint of another state that no check can tell from a
    real one (the seal is a plain SHA-256, not a keyed one): left out."""
    assume(not (reseal and kind == "swap"))
    folder = tmp_path_factory.mktemp("case") / "run"
    shutil.copytree(killed, folder)

    def change(lines):
        j = 1 + where % (len(lines) - 2)
        garbled = lines[j].rsplit(maxsplit=1)[0] + (" nan" if kind == "nan" else " x") if " " in lines[j].strip() else "x"
        return {"drop": lines[:j] + lines[j + 1:], "repeat": lines[:j + 1] + lines[j:],
                "swap": lines[:j] + [lines[j + 1], lines[j]] + lines[j + 2:],
                "nan": lines[:j] + [garbled] + lines[j + 1:], "word": lines[:j] + [garbled] + lines[j + 1:]}[kind]

    for checkpoint in folder.glob("checkpoint-?.txt"):
        if reseal:
            resealed(checkpoint, change)
        else:
            lines = checkpoint.read_text().splitlines()
            checkpoint.write_text("\n".join(change(lines[:-2]) + lines[-2:]) + "\n")
    done = restarted(folder)
    if done.returncode == 0:
        same_results(uninterrupted, folder)
    else:
        assert done.returncode == 3 and done.error_line.startswith(("restart folder", "checkpoint")), done.error_line


def test_a_checkpoint_before_any_output_reads_nothing_from_standard_input(tmp_path):
    """With no file written yet the checkpoint hashes no file (FreeFEM's && evaluates both sides:
    a bare `sha256sum --` would wait on the terminal)."""
    process = subprocess.Popen(freefem_command(MAIN, ["-N", "40", "-outTimes", "none", "-checkpointEvery", "5",
                                                      "-out", str(tmp_path / "run")]),
                               cwd=REPO, env=freefem_env(), stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    try:
        assert process.wait(timeout=60) == 0
    finally:
        process.kill()
        process.stdin.close()


def test_a_file_on_the_files_line_without_its_sha256_is_refused(tmp_path):
    folder = tmp_path / "run"
    killed_driver(folder, 300)
    shutil.copy(folder / "state_0120.txt", folder / "state_0130.txt")
    for checkpoint in folder.glob("checkpoint-?.txt"):
        resealed(checkpoint, lambda lines: [line + " state_0130.txt" if line.startswith("files ") and line != "files end"
                                            else line for line in lines])
    done = restarted(folder, out=tmp_path / "o1")
    assert done.returncode == 3 and "'state_0130.txt' it holds no SHA-256 of" in done.error_line, done.error_line
