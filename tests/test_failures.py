"""Failures are loud (one line naming the step, the field and the value; a non-zero exit code)
and keep what was computed."""
import pytest

from conftest import SCENES, solve

pytestmark = pytest.mark.solver


@pytest.mark.parametrize("solver, iterations", [("bm", 3), ("pdas", 1)])
def test_a_contact_loop_that_does_not_converge_stops_the_run(tmp_path, solver, iterations):
    # Bermúdez–Moreno needs some 50 iterations here, the active set at least 2 at the first step.
    done, result = solve(tmp_path / "run", "-contactSolver", solver, "-contactMaxIt", iterations)
    assert done.returncode == 4
    assert "step 1/40" in done.error_line and "contactMaxIt" in done.error_line
    assert (tmp_path / "run" / "params_used.json").exists()
    assert (tmp_path / "run" / "history.csv").read_text().startswith("n,t,normV")


def test_a_broken_invariant_stops_the_run_and_keeps_earlier_steps(tmp_path):
    # Debonding this strong takes β below 0 in one explicit step (the glue's own bound, refused
    # first, allowed here).
    done, result = solve(tmp_path / "run", "-gammaNu", 1e7, "-gammaR", 0, "-allowUnstable", 1)
    assert done.returncode == 5
    assert "beta min" in done.error_line and "below 0" in done.error_line
    step = int(done.error_line.split("step ")[1].split("/")[0])
    assert step > 1
    assert len(result.history["t"]) == step  # earlier steps and the failing one are on record
    assert result.history["betaMin"][-1] < 0


@pytest.mark.parametrize("args, words", [
    (["-gamaNu", "2"], ["unknown flag -gamaNu", "-gammaNu"]),
    (["-nu1", "0.7"], ["nu1 = 0.7", "nu1 in (-1, 0.5)"]),
    (["-N", "0"], ["N = 0", "N in [1, 10000000]"]),
    (["-N", "99999999999999999999"], ["-N = 99999999999999999999", "out of range", "2^53"]),
    (["-N", "40", "-N", "80"], ["-N is given twice", "'40'", "'80'"]),
    (["-E1", "1e999"], ["-E1 = 1e999", "not a finite number"]),
    (["-T", "1e999"], ["-T = 1e999", "not a finite number"]),
    (["-divergenceFactor", "1e999"], ["-divergenceFactor = 1e999", "not a finite number"]),
    (["-eta1", "1e-300"], ["N >= 3.84615e+302", "more than the 10^7", "units"]),
    (["-T", "1e-300"], ["matrix K of body 1", "not finite", "rescale the units"]),
    (["-N", "ten"], ["-N", "integer", "ten"]),
    (["-E2", "-5"], ["E2 = -5", "E2 in (0, inf)"]),
    (["-contactLabel1", "9"], ["contactLabel1 = 9", "labels: 1, 2, 3, 4, 5"]),
    (["-mesh2", "nowhere.msh"], ["-mesh2", "nowhere.msh", "not found"]),
    (["-outTimes", "0.5,x"], ["outTimes", "'x'"]),
    (["extra"], ["unexpected argument 'extra'"]),
    (["-contactSolver", "newton"], ["contactSolver", "newton", "pdas, bm"]),
    (["-linearSolver", "PARDISO"], ["linearSolver", "PARDISO", "CHOLMOD, UMFPACK"]),
    (["-outFields", "bodies,vorticity"], ["outFields", "vorticity", "bodies, stress, contact, state"]),
    (["-skipIdle", "2"], ["skipIdle", "0 or 1"]),
    (["-divergenceFactor", "0.5"], ["divergenceFactor = 0.5", "divergenceFactor in (1, inf)"]),
    (["-zeta01", "1.5"], ["zeta01 = 1.5", "zeta01 in [0, 1]"]),
    (["-T", "-1"], ["T = -1", "T in (0, inf)"]),
    (["-geo1", "meshes/nowhere.geo", "-n1", "12"], ["-geo1", "not found"]),
])
def test_bad_input_is_refused_with_the_field_and_the_allowed_range(tmp_path, args, words):
    done, _ = solve(tmp_path / "run", *args)
    assert done.returncode == 3
    for word in words:
        assert word in done.error_line, (word, done.error_line)


def test_a_body_that_would_float_is_refused(tmp_path):
    done, _ = solve(tmp_path / "run", scene=SCENES / "floating.idp")
    assert done.returncode == 3
    assert "body 2 is not held" in done.error_line and "x-translation" in done.error_line


def test_a_nan_stops_the_run_at_the_step_where_it_appears(tmp_path):
    done, result = solve(tmp_path / "run", scene=SCENES / "nan_load.idp")
    assert done.returncode == 5
    assert "step 1/40" in done.error_line and "is not finite" in done.error_line
    assert not list((tmp_path / "run").glob("*.vtu"))


def test_the_python_layer_suggests_its_own_flags(tmp_path):
    """The driver says -allowUnstable 1; through `orchestrate run` the advice is --allow-unstable."""
    from orchestrate.freefem import REPO
    from orchestrate.runner import SolverError, run

    with pytest.raises(SolverError) as error:
        run(REPO / "scenes" / "paper.toml", tmp_path / "run", {"time.N": 5, "output.images": False})
    assert "--allow-unstable" in error.value.message and "-allowUnstable 1" not in error.value.message


def test_bin_ff_ends_a_failure_with_its_error_line_and_names_a_missing_scene(tmp_path):
    """bin/ff, the users' way to run the driver: the exit code of FreeFem++, its one ERROR line
    last (FreeFEM's call trace after exit(3) dropped), and a -DSCENE file that is not there named
    before FreeFEM's lexer fails on it without a name."""
    import subprocess
    import time

    from orchestrate.freefem import REPO

    def ff(*arguments):
        return subprocess.run([str(REPO / "bin" / "ff"), "edp/main.edp", *arguments], cwd=REPO,
                              capture_output=True, text=True)

    done = ff("-T", "-1", "-out", str(tmp_path / "run"))
    assert done.returncode == 3
    assert done.stdout.splitlines()[-1] == "ERROR: parameter T = -1 is out of range: allowed T in (0, inf)"
    missing = ff("-DSCENE=nowhere.idp")
    assert missing.returncode == 3 and "the -DSCENE file 'nowhere.idp' is not there" in missing.stderr
    shown = ff("-help")
    assert shown.returncode == 0 and "-outFields (subset, default 'bodies,stress,contact,state'" in shown.stdout
    # A signal to bin/ff ends the run (FreeFem++ is bin/ff's own process, not an orphaned child).
    running = subprocess.Popen([str(REPO / "bin" / "ff"), "edp/main.edp", "-N", "100000", "-out", str(tmp_path / "long")],
                               cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    history = tmp_path / "long" / "history.csv"
    while not history.exists():
        assert running.poll() is None, "the long run ended by itself"
        time.sleep(0.05)
    running.terminate()
    assert running.wait(timeout=10) != 0
    rows = history.read_text().count("\n")
    time.sleep(1.0)  # an orphaned FreeFem++ would write some hundred rows meanwhile
    assert history.read_text().count("\n") == rows
