"""Errors at the edge (issue 47, item 6): a file the driver or a command cannot write is one line
naming the file and what to do, with its own exit code (74, FILE_PROBLEM), never a traceback, never the code of
another failure. A file-size limit stands for a full disk (writes fail part-way; FreeFEM's
streams report nothing), a path through a file for a missing or unwritable folder."""
import resource
from pathlib import Path
import signal
import subprocess
import sys

import pytest

from conftest import cli_args
from orchestrate.freefem import FILE_PROBLEM, MAIN, REPO, freefem_command, freefem_env

pytestmark = pytest.mark.runs

PAPER = REPO / "scenes" / "paper.toml"
COARSE = {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.N": 40, "output.images": False}


def limited(bytes_: int):
    """A child's file-size limit, with SIGXFSZ ignored: past it a write fails (EFBIG), as on a full disk."""
    def apply():
        resource.setrlimit(resource.RLIMIT_FSIZE, (bytes_, bytes_))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    return apply


def driver(out, *flags, limit: int | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(freefem_command(MAIN, ["-N", "40", "-n1", "6", "-n2", "8", *flags, "-out", str(out)]),
                          cwd=REPO, env=freefem_env(), capture_output=True, text=True,
                          preexec_fn=limited(limit) if limit else None)


def error_lines(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.startswith("ERROR: ")]


@pytest.mark.parametrize("flags, limit, name", [
    ((), 12_000, "history.csv"),                                    # the history grows past the limit
    (("-outTimes", "all", "-outFields", "bodies"), 8_000, "_0001.vtu"),  # savevtk's file cut short
    (("-outTimes", "all", "-outFields", "state"), 7_000, "state_0001.txt"),
    (("-outTimes", "all", "-outFields", "contact"), 20_000, "history.csv"),
    (("-checkpointEvery", "2"), 30_000, "checkpoint-"),
])
def test_a_write_that_fails_part_way_stops_the_driver_naming_the_file(tmp_path, flags, limit, name):
    done = driver(tmp_path / "run", *flags, limit=limit)
    lines = error_lines(done.stdout + done.stderr)
    assert done.returncode == FILE_PROBLEM, (done.stdout + done.stderr)[-800:]
    assert len(lines) == 1 and "cannot write" in lines[0] and name in lines[0] and "file-size limit" in lines[0]


def test_an_output_folder_that_cannot_be_made_is_a_file_problem_naming_it(tmp_path):
    (tmp_path / "plain").write_text("a file, not a folder")
    done = driver(tmp_path / "plain" / "run")
    assert done.returncode == FILE_PROBLEM and "cannot create the output folder" in error_lines(done.stdout + done.stderr)[0]


def command(out, overrides: dict) -> list[str]:
    return [sys.executable, "-m", "orchestrate", "run", str(PAPER), *cli_args(overrides), "--out", str(out)]


@pytest.mark.parametrize("overrides, limit, words", [
    ({**COARSE, "output.times": "all"}, 12_000, [f"FreeFem++ exit {FILE_PROBLEM}", "cannot write", "file-size limit"]),
    ({**COARSE, "output.images": True}, 60_000, ["file-size limit"]),  # an image past the limit: Python's write
])
def test_orchestrate_says_a_failed_write_in_one_line_with_its_own_exit_code(tmp_path, overrides, limit, words):
    done = subprocess.run(command(tmp_path / "run", overrides), cwd=REPO, capture_output=True, text=True,
                          preexec_fn=limited(limit))
    assert done.returncode == FILE_PROBLEM, done.stderr[-1500:]
    assert "Traceback" not in done.stderr and done.stderr.startswith("error: ")
    first = done.stderr.splitlines()[0]
    for word in words:
        assert word in first, first
    assert not (tmp_path / "run").exists()  # nothing cut short is published


def test_a_run_into_a_folder_under_a_file_is_one_line_with_its_own_exit_code(tmp_path):
    (tmp_path / "plain").write_text("a file, not a folder")
    done = subprocess.run(command(tmp_path / "plain" / "run", COARSE), cwd=REPO, capture_output=True, text=True)
    assert done.returncode == FILE_PROBLEM and "Traceback" not in done.stderr
    assert done.stderr.count("\n") == 1 and "not a folder" in done.stderr, done.stderr


# --- found by an adversarial pass ----------------------------------------------------------------

@pytest.mark.unit
def test_a_command_s_folder_that_cannot_be_written_is_said_before_its_work(tmp_path):
    """bench ran its minutes of measurements before it found its --out on a read-only file
    system; every command that takes an --out folder now says so first (as root, /proc stands for
    a folder no one may write)."""
    from orchestrate.outputs import refuse_folder

    with pytest.raises(OSError) as error:
        refuse_folder(Path("/proc/no-such/out"), "bench", False)
    assert error.value.filename == "/proc" and "it cannot be written" in error.value.strerror


@pytest.mark.unit
def test_an_image_too_large_to_draw_and_flags_that_change_a_run_are_refused_before_anything_runs(tmp_path, capsys):
    from orchestrate.cli import main
    from orchestrate.freefem import InputError
    from orchestrate.runner import run

    assert main(["render", str(tmp_path), "--size", "100,100", "--dpi", "2400"]) == 2
    assert "megapixels, more than the 300 an image can be drawn with here" in capsys.readouterr().err
    with pytest.raises(InputError, match="solver_flags .*-measureSolves, -memoryLimitMB only"):
        run(PAPER, tmp_path / "run", COARSE, solver_flags=("-gammaNu", "5"))
    assert not (tmp_path / "run.partial").exists()
