"""Launching FreeFem++ with the project's plugin and include paths.

Debian's /etc/freefem++.pref points at a plugin folder that does not exist; the plugins
(iovtk, gmsh, msh3, lapack, shell) are in /usr/lib/freefem++. FF_LOADPATH and FF_INCLUDEPATH
fix both paths for any working folder; FF_VERBOSITY=0 keeps FreeFEM from echoing the script.
"""
from __future__ import annotations

import ctypes
import os
import shutil
import signal
import subprocess
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
MAIN = REPO / "edp" / "main.edp"
PLUGIN_DIR = Path("/usr/lib/freefem++")

# Exit codes of edp/main.edp (edp/lib/params.idp), and FreeFEM's own.
EXIT_MEANING = {
    1: "FreeFEM compile error",
    2: "FreeFEM could not load a plugin",
    3: "bad input",
    4: "a solver loop did not converge",
    5: "a broken invariant (NaN, bounds, gap)",
    8: "FreeFEM run-time error",
}


class SolverError(RuntimeError):
    """FreeFem++ stopped with a non-zero exit code."""

    def __init__(self, returncode: int, message: str, log_tail: str):
        self.returncode = returncode
        self.message = message
        self.log_tail = log_tail
        meaning = EXIT_MEANING.get(returncode, f"killed by signal {-returncode}" if returncode < 0 else "unexpected exit")
        super().__init__(f"FreeFem++ exit {returncode} ({meaning}): {message}")


_LIBC = ctypes.CDLL(None, use_errno=True)
PR_SET_PDEATHSIG = 1


def _own_group_dying_with_parent() -> None:
    """In the child, before exec: a process group of its own (so that it and whatever it starts
    can be ended together), and SIGKILL when the process that started it dies (a sweep's worker
    ended by an interruption leaves no FreeFem++ running). Only a system call: safe after fork."""
    os.setsid()
    _LIBC.prctl(PR_SET_PDEATHSIG, signal.SIGKILL)


def freefem_binary() -> str:
    path = shutil.which("FreeFem++")
    if path is None:
        raise FileNotFoundError("FreeFem++ not found: run `make setup` (apt packages freefem++ libfreefem++)")
    return path


def freefem_env() -> dict[str, str]:
    env = dict(os.environ)
    env["FF_LOADPATH"] = str(PLUGIN_DIR)
    env["FF_INCLUDEPATH"] = str(REPO / "edp" / "lib")
    env.setdefault("FF_VERBOSITY", "0")
    return env


@dataclass
class Completed:
    returncode: int
    stdout: str
    stderr: str

    @property
    def error_line(self) -> str:
        """The solver's one-line message ("ERROR: ..."), or the last line FreeFEM printed."""
        for line in (self.stderr + "\n" + self.stdout).splitlines():
            if line.startswith("ERROR: "):
                return line[len("ERROR: "):]
        lines = [line for line in (self.stdout + self.stderr).splitlines() if line.strip()]
        return lines[-1] if lines else ""


def run_script(script: Path | str, args: list[str] = (), cwd: Path | None = None,
               timeout: float | None = None, defines: dict[str, str] | None = None) -> Completed:
    """Run a FreeFEM script to completion in its own process group; return code and output."""
    process = subprocess.Popen(freefem_command(script, args, defines), cwd=cwd or REPO, env=freefem_env(),
                               text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               preexec_fn=_own_group_dying_with_parent)
    try:
        stdout, stderr = process.communicate(timeout=timeout)
    except BaseException:
        stop_group(process)
        raise
    return Completed(process.returncode, stdout, stderr)


def freefem_command(script: Path | str, args=(), defines: dict[str, str] | None = None) -> list[str]:
    # -D must follow the script: before it, FreeFEM takes the first such argument for the script.
    command = [freefem_binary(), "-nw", str(script)]
    command += [f"-D{name}={value}" for name, value in (defines or {}).items()]
    return command + list(map(str, args))


def stop_group(process: subprocess.Popen) -> None:
    """End a FreeFem++ process and anything it started (gmsh), politely first."""
    try:
        os.killpg(process.pid, signal.SIGTERM)
        process.wait(timeout=5)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.wait()
    except ProcessLookupError:
        pass


def run_logged(script: Path | str, args, log: Path, on_line=None, defines: dict[str, str] | None = None) -> Completed:
    """Run a FreeFEM script with its output (stdout and stderr) streamed into `log` and, line by
    line, to on_line. An exception here (KeyboardInterrupt included) ends its process group."""
    with open(log, "w") as sink:
        process = subprocess.Popen(freefem_command(script, args, defines), cwd=REPO, env=freefem_env(), text=True,
                                   stdout=subprocess.PIPE, stderr=subprocess.STDOUT, bufsize=1,
                                   preexec_fn=_own_group_dying_with_parent, restore_signals=False)
        try:
            for line in process.stdout:
                sink.write(line)
                if on_line:
                    on_line(line)
            process.wait()
        except BaseException:
            stop_group(process)
            raise
    text = log.read_text()
    return Completed(process.returncode, text, "")
