"""Reliability: bad input refused clearly at every entry point, no way to run code through a
scene, nothing lost on failures and interruptions, and deterministic results."""
import json
import os
import re
import resource
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from conftest import SCENES, gmsh_mesh, solve
from orchestrate import Scene, SceneError, SolverError, load_result, run
from orchestrate import runner as runner_module
from orchestrate.freefem import FILE_PROBLEM, MAIN, REPO, run_script
from orchestrate.manifest import IncompleteRun
from orchestrate.scene import to_freefem_scene
from orchestrate.sweep import folder_name

pytestmark = pytest.mark.runs

PAPER_TOML = REPO / "scenes" / "paper.toml"
PAPER = PAPER_TOML.read_text()
COARSE = {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.N": 20, "output.images": False}

# --- no code through a scene ---------------------------------------------------------------------

INJECTIONS = [
    ('fy = "-10*t"', 'fy = "exec(\\"rm -rf /\\")"'),
    ('fy = "-10*t"', 'fy = "x); exec(1); (1"'),
    ('fy = "-10*t"', 'fy = "-10*t // comment"'),
    ('fy = "-10*t"', 'fy = "-10*t /* comment */"'),
    ('fy = "-10*t"', 'fy = "-10*t\\nmacro evil 1 //"'),
    ('fy = "-10*t"', 'fy = "-10*t; cout << 1"'),
    ('fy = "-10*t"', 'fy = "include \\"/etc/passwd\\""'),
    ('fy = "-10*t"', 'fy = "load \\"shell\\""'),
    ('fy = "-10*t"', 'fy = "t#x"'),
    ('fy = "-10*t"', 'fy = "Stringification(t)"'),
    ('fy = "-10*t"', 'fy = "ARGV[0]"'),
    ('fy = "-10*t"', 'fy = "$(id)"'),
    ('fy = "-10*t"', 'fy = "`id`"'),
    ('fy = "-10*t"', 'fy = "mkdir(\\"/tmp/x\\")"'),
    ('fx = "10*y*t"', 'fx = "int2d(Th1)(1)"'),
    ('geo = "meshes/paper_body1.geo"', 'geo = "../../etc/passwd.geo"'),
    ('geo = "meshes/paper_body1.geo"', 'geo = "/etc/evil.geo"'),
    ('geo = "meshes/paper_body1.geo"', 'geo = "meshes/../../outside.geo"'),
    ('geo = "meshes/paper_body1.geo"', 'geo = "meshes/paper_body1.geo\\"); exec(\\"ls"'),
    ('label = 5', 'label = "5, ux = 0); exec(\\"ls\\"); on(5"'),
    ('linearSolver = "CHOLMOD"', 'linearSolver = "CHOLMOD\\"); exec(\\"ls\\"); (\\""'),
    ('times = "final"', 'times = "final\\"); exec(\\"ls\\"); (\\""'),
    ('contactLabel = 1', 'contactLabel = "1; exec"'),
    ('n = 24', 'n = 24\nparameters = { "n; rm -rf" = 1 }'),
    ('planeStrain = false', 'plane = "stress\\"); exec(\\""'),
]


@pytest.fixture
def no_freefem(monkeypatch):
    """Any attempt to start FreeFem++ fails the test."""
    def forbidden(*args, **kwargs):
        raise AssertionError("FreeFem++ was started")
    monkeypatch.setattr(runner_module, "run_logged", forbidden)


@pytest.mark.parametrize("old, new", INJECTIONS, ids=[new[:40] for _, new in INJECTIONS])
@pytest.mark.unit
def test_injection_attempts_are_refused_before_freefem_starts(tmp_path, no_freefem, old, new):
    assert old in PAPER
    scene = tmp_path / "evil.toml"
    scene.write_text(PAPER.replace(old, new, 1))
    with pytest.raises(SceneError):
        run(scene, tmp_path / "out")
    assert not (tmp_path / "out").exists() and not (tmp_path / "out.partial").exists()


GENERATED_LINE = re.compile(
    r'// .*|setParam\("[A-Za-z0-9]+", (-?[0-9][0-9.e+-]*|"[A-Za-z0-9_.,+-]*")\);'
    r'|macro (dirichlet|loads)[12]\((ux, uy|vx, vy)\) [A-Za-z0-9_ .,+\-*/^()=<>?:!]* //'
    r'|macro boundaryLabels[12] [0-9]+(, [0-9]+)* //'
    r'|macro sceneLabels(?P<b>[12])( requireLabel\(Th(?P=b), [0-9]+, (?P=b), "body(?P=b)\.(mesh\.contactLabel = '
    r'([0-9]+|\[[0-9]+(, [0-9]+)*\])|boundary\.[0-9]+\.label = [0-9]+)", meshFile(?P=b)\);)+ //')


@pytest.mark.unit
def test_the_generated_freefem_scene_holds_only_data_and_whitelisted_expressions():
    scene = Scene.load(PAPER_TOML, {"body1.boundary.1.fy": "-10*t*(x <= 3) + sin(y)^2/max(t, 1e-3)"})
    text = to_freefem_scene(scene)
    for line in text.splitlines():
        assert GENERATED_LINE.fullmatch(line), line
    assert 'setParam("mesh1", "body1.msh");' in text  # no path: the run's folder holds its meshes


@pytest.mark.unit
def test_sweep_folder_names_cannot_leave_the_sweep_folder():
    for value in ("../../etc", "/etc/passwd", "a/../../b", "..", "x\ny"):
        name = folder_name({"title": value})
        assert "/" not in name and "\n" not in name and not name.startswith(".")


# --- bad input at every entry point -------------------------------------------------------------

def rectangle(tmp_path, name, **numbers):
    return gmsh_mesh("meshes/rectangle.geo", tmp_path / f"{name}.msh", **numbers)


def test_contact_traces_of_different_extents_meet_on_their_overlap(tmp_path):
    """Once refused as "not the same segment" (docs/model.md §10 allows it): Γ_C is the overlap, body 1's
    whole trace [0, 2] here, since body 2's [0, 3] covers it."""
    upper = rectangle(tmp_path, "upper", x1=2, y0=0, y1=1, n=4)
    lower = rectangle(tmp_path, "lower", x1=3, y0=-1, y1=0, n=6)
    done, _ = solve(tmp_path / "run", "-mesh1", upper, "-mesh2", lower, scene=SCENES / "blocks.idp")
    assert done.returncode == 0, done.error_line
    facts = json.loads((tmp_path / "run" / "run.json").read_text())
    assert facts["contactLength"] == pytest.approx(2.0, rel=1e-12) and facts["traceNodes1"] == 5


def test_a_flag_without_its_value_is_refused(tmp_path):
    done = run_script(MAIN, ["-out", tmp_path / "run", "-N"])
    assert done.returncode == 3 and "flag -N needs a value" in done.error_line


def test_an_unreadable_mesh_file_is_refused(tmp_path):
    garbage = tmp_path / "garbage.msh"
    garbage.write_text("this is not a mesh\n")
    done, _ = solve(tmp_path / "run", "-mesh1", garbage)
    assert done.returncode == 3 and "is not a gmsh 2.2 mesh" in done.error_line


def cli(*args, cwd=REPO, env=None):
    return subprocess.run([sys.executable, "-m", "orchestrate", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, env=env)


@pytest.mark.parametrize("args, code, words", [
    (["run", "scenes/nowhere.toml"], 2, ["not found"]),
    (["run", "scenes/paper.toml", "--set", "time.N"], 2, ["expected key=value"]),
    (["run", "scenes/paper.toml", "--set", "time.NN=20"], 2, ["time.NN: unknown key", "did you mean 'N'"]),
    (["sweep", "scenes/paper.toml", "--grid", "time.N"], 2, ["expected key=value1,value2"]),
    (["sweep", "scenes/paper.toml", "--grid", "time.N=20", "--workers", "0"], 2, ["--workers", ">= 1"]),
    (["study", "convergence", "scenes/paper.toml", "--levels", "1"], 2, ["at least 2 levels"]),
    (["render", "scenes"], 2, ["not a run folder"]),
    (["flyto", "scenes/paper.toml"], 2, ["invalid choice"]),
])
def test_bad_command_lines_are_refused(tmp_path, args, code, words):
    done = cli(*args, "--out", tmp_path / "out") if args[0] in ("run", "sweep") else cli(*args)
    assert done.returncode == code
    for word in words:
        assert word in done.stderr, (word, done.stderr)
    assert not (tmp_path / "out").exists()


@pytest.mark.unit
def test_bad_input_through_the_python_api(tmp_path):
    with pytest.raises(SceneError, match="time.N = 0"):
        run(PAPER_TOML, tmp_path / "a", {"time.N": 0})
    with pytest.raises(SceneError, match="body1.material.nu = 0.5"):
        Scene.load(PAPER_TOML).with_overrides({"body1.material.nu": 0.5})
    with pytest.raises(SceneError, match="unknown key"):
        Scene.from_dict({"time": {"T": 1, "N": 20}, "bodyone": {}})
    with pytest.raises(FileNotFoundError, match="not a run folder"):
        load_result(tmp_path)


# --- nothing is lost ----------------------------------------------------------------------------

def leftover_freefem(marker) -> list[str]:
    listing = subprocess.run(["pgrep", "-af", "FreeFem"], capture_output=True, text=True).stdout
    return [line for line in listing.splitlines() if str(marker) in line]


@pytest.mark.parametrize("signal_number", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_an_interrupted_run_ends_freefem_and_leaves_a_marked_partial_folder(tmp_path, signal_number):
    out = tmp_path / "long"
    process = subprocess.Popen([sys.executable, "-m", "orchestrate", "run", str(PAPER_TOML), "--set", "time.N=100000",
                                "--set", "output.images=false", "--out", str(out)], cwd=REPO, text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    log = tmp_path / "long.partial" / "run.log"
    deadline = time.time() + 60
    while time.time() < deadline and not (log.exists() and "step 5/" in log.read_text()):
        time.sleep(0.1)
    process.send_signal(signal_number)
    _, stderr = process.communicate(timeout=30)
    assert process.returncode != 0 and "interrupted" in stderr
    assert (tmp_path / "long.partial" / "INTERRUPTED").exists() and not out.exists()
    time.sleep(0.5)
    assert leftover_freefem(tmp_path) == []


def test_an_interrupted_sweep_started_again_runs_only_the_missing_runs(tmp_path):
    out = tmp_path / "sweep"
    command = ["sweep", PAPER_TOML, "--grid", "glue.gammaNu=0.5,1,1.5,2", "--set", "time.N=600", "--set",
               "body1.mesh.n=12", "--set", "body2.mesh.n=16", "--set", "output.images=false", "--workers", 1,
               "--out", out]
    process = subprocess.Popen([sys.executable, "-m", "orchestrate", *map(str, command)], cwd=REPO,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and len(list(out.glob("*/summary.json"))) < 1:
        time.sleep(0.2)
    process.send_signal(signal.SIGINT)
    process.communicate(timeout=60)
    time.sleep(1)
    assert leftover_freefem(out) == []
    finished = {path.parent.name for path in out.glob("*/summary.json")}
    assert 1 <= len(finished) < 4
    done = cli(*command)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = [line for line in done.stdout.splitlines() if line.startswith("glue.gammaNu=")]
    assert len(lines) == 4
    for line in lines:
        name = line.split()[0]
        assert ("skipped (complete)" in line) == (name in finished), line


def test_a_freefem_crash_gives_its_message_and_the_log_tail(tmp_path):
    with pytest.raises(SolverError) as error:
        run(PAPER_TOML, tmp_path / "out", {**COARSE, "body1.boundary.1.fy": "1/(t - t)"})
    assert error.value.returncode == 8 and "run-time error" in str(error.value)
    assert "Div by 0" in error.value.log_tail
    assert (tmp_path / "out.failed" / "run.log").exists()


def test_missing_freefem_gives_an_install_hint(tmp_path):
    env = {**os.environ, "PATH": str(tmp_path)}
    done = cli("run", PAPER_TOML, "--out", tmp_path / "out", env=env)
    assert done.returncode != 0 and "FreeFem++ not found" in done.stderr and "make setup" in done.stderr


def test_missing_gmsh_gives_an_install_hint(tmp_path):
    (tmp_path / "bin").mkdir()
    (tmp_path / "bin" / "FreeFem++").symlink_to("/usr/bin/FreeFem++")
    env = {**os.environ, "PATH": str(tmp_path / "bin")}
    done = subprocess.run(["FreeFem++", "-nw", str(MAIN), "-n1", "12", "-out", str(tmp_path / "run")],
                          capture_output=True, text=True, cwd=REPO, env=env)
    output = done.stdout + done.stderr
    assert done.returncode == 3 and "gmsh is not installed" in output and "make setup" in output


def limited_file_size(ignore_sigxfsz: bool):
    """A preexec function: writes beyond 150 kB fail, as on a nearly full disk (the committed
    meshes fit; body 2's .vtu of the default scene, 218 kB, does not)."""
    def limit():
        if ignore_sigxfsz:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (150_000, 150_000))
    return limit


def test_a_file_size_limit_stops_the_run_with_a_clear_message_and_keeps_what_was_written(tmp_path):
    # Python ignores SIGXFSZ, and so does FreeFem++ under the runner: the write past the limit
    # fails, the driver's check of it stops the run naming the file (exit 74), and the folder
    # stays <out>.partial, to be continued with --resume once the limit is raised.
    out = tmp_path / "run"
    done = subprocess.run([sys.executable, "-m", "orchestrate", "run", str(PAPER_TOML), "--set", "time.N=1000",
                           "--set", "time.T=25", "--set", "output.images=false", "--out", str(out)],
                          cwd=REPO, capture_output=True, text=True, preexec_fn=limited_file_size(True))
    assert done.returncode == FILE_PROBLEM and "file-size limit" in done.stderr and "--resume" in done.stderr, done.stderr
    assert not out.exists()
    rows = (tmp_path / "run.partial" / "history.csv").read_text().splitlines()
    assert 10 < len(rows) < 1000  # what was written before stays


def test_files_cut_short_without_an_error_are_never_taken_as_a_run(tmp_path):
    # FreeFem++ run by hand with SIGXFSZ ignored: its writes fail without a word from FreeFEM's
    # streams, so the driver reads each file back and stops naming the one cut short (exit 74);
    # what it left is never taken as a run.
    out = tmp_path / "hand"
    done = subprocess.run(["bin/ff", str(MAIN), "-out", str(out)], cwd=REPO,
                          capture_output=True, text=True, preexec_fn=limited_file_size(True))
    assert done.returncode == FILE_PROBLEM and "cannot write" in done.stdout + done.stderr and (out / "run.json").exists()
    with pytest.raises(IncompleteRun, match="cut short|cannot be read back|did not finish"):
        load_result(out)
    rendered = cli("render", out)
    assert rendered.returncode != 0 and "did not finish" in rendered.stderr and not (out / "fields.png").exists()


def test_a_run_whose_files_are_cut_short_is_not_published(tmp_path, monkeypatch):
    real = runner_module.run_logged

    def then_truncate(script, args, log, cwd, defines=None, append=False, meanwhile=None):
        done = real(script, args, log, cwd, defines, append, meanwhile)
        vtu = cwd / "body2_0020.vtu"
        vtu.write_bytes(vtu.read_bytes()[:5000])  # what a full disk leaves
        return done
    monkeypatch.setattr(runner_module, "run_logged", then_truncate)
    with pytest.raises(IncompleteRun, match="body2_0020.vtu"):
        run(PAPER_TOML, tmp_path / "run", COARSE)
    assert not (tmp_path / "run").exists() and "body2_0020.vtu" in (tmp_path / "run.failed" / "run.log").read_text()


# --- determinism --------------------------------------------------------------------------------

def test_the_same_scene_twice_gives_identical_results(tmp_path):
    first = run(PAPER_TOML, tmp_path / "a", {"output.images": False})
    second = run(PAPER_TOML, tmp_path / "b", {"output.images": False})
    for column, values in first.history.items():
        if column != "stepSeconds":  # a measured time, the only thing that may differ
            assert np.array_equal(values, second.history[column]), column
    for name in ("body1_0040.vtu", "body2_0040.vtu", "contact_0040.vtu"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name
