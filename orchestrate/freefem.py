"""Launching FreeFem++ with the project's plugin path.

Debian's /etc/freefem++.pref points at a plugin folder that does not exist; the plugins
(iovtk, gmsh, msh3, lapack, shell) are in /usr/lib/freefem++, the project's own (factorsplit,
blocksolve, built by `make setup`) in edp/plugins. FF_LOADPATH names both for any working folder;
FF_VERBOSITY=0 keeps FreeFEM from echoing the script, OMP_THREAD_LIMIT=1 makes CHOLMOD's
factorizations faster (a user's own value is kept). The scripts include their
libraries by paths relative to their own folder, so no include path is needed.

No path a user chooses ever reaches FreeFEM's macro preprocessor or its source text: a run is
launched in its own folder with fixed file names (runner.py); the only paths FreeFEM is given are
the script's and, in FF_LOADPATH, the plugin folder's (through a link where the repository's
location holds a character that list cannot carry).
"""
from __future__ import annotations

import atexit
import errno
import functools
import os
import shutil
import signal
import subprocess
import tempfile
import unicodedata
from dataclasses import dataclass
from pathlib import Path

from orchestrate.identity import plugins_fault, solver_identity

REPO = Path(__file__).resolve().parent.parent
MAIN = REPO / "edp" / "main.edp"
PLUGIN_DIR = Path("/usr/lib/freefem++")
OWN_PLUGINS = REPO / "edp" / "plugins"

# Exit codes of edp/main.edp (edp/lib/params.idp), and FreeFEM's own.
EXIT_MEANING = {
    1: "FreeFEM compile error",
    2: "FreeFEM could not load a plugin",
    3: "bad input",
    4: "a solver loop did not converge",
    5: "a broken invariant (NaN, bounds, gap)",
    6: "FreeFEM's internal check failed (an operation on arrays or matrices of mismatched sizes)",
    8: "FreeFEM run-time error",
    74: "a file could not be written",
}
# The exit code of a file that could not be written or read (a full disk, a file-size limit, a
# read-only or missing folder, no permission): the driver's (edp/lib/facts.idp, failWrite) and
# every command's (orchestrate/cli); sysexits.h's EX_IOERR, which FreeFEM's own codes (1, 2, 6, 8)
# and the driver's (3, 4, 5) leave free.
FILE_PROBLEM = 74

# What to do about an OSError, by its errno.
FILE_ADVICE = {
    errno.ENOSPC: "the disk is full: free space, or write elsewhere",
    errno.EDQUOT: "the disk quota is used up: free space, or write elsewhere",
    errno.EFBIG: "a file-size limit (ulimit -f) was reached: raise it, or write less (fewer output times)",
    errno.EROFS: "the file system is read-only: choose a folder on a writable one",
    errno.EACCES: "no permission: choose a folder you can write (and read), or change its permissions",
    errno.EPERM: "not permitted: choose a folder you can write (and read), or change its permissions",
    errno.ENOENT: "it, or a folder on its path, does not exist: check the path, or make the folder first",
    errno.ENOTDIR: "a part of its path is a file, not a folder: check the path",
    errno.EISDIR: "it is a folder where a file is needed: check the path",
    errno.ENAMETOOLONG: "its path or a name in it is too long: choose a shorter one",
    errno.ELOOP: "its path runs through a loop of symbolic links: check the path",
    errno.EIO: "the disk reported an input/output error: check the disk",
}


def file_problem(error: OSError, where: str = "a file") -> str:
    """One line for an OSError: the file (both, for a rename; `where` when the error names none),
    what went wrong and what to do."""
    names = " -> ".join(str(name) for name in (error.filename, error.filename2) if name is not None) or where
    advice = FILE_ADVICE.get(error.errno, "check the path and the disk")
    return f"{names}: {error.strerror or error}; {advice}"


class FileProblem(RuntimeError):
    """A run or command that could not write (or read) a file: its message is file_problem's line
    and what became of the files written so far."""


# Signals that end FreeFem++ for a reason the user can act on.
KILLED = {signal.SIGXFSZ: "killed by SIGXFSZ: a file outgrew the file-size limit (ulimit -f); the files are cut short",
          signal.SIGKILL: "killed by SIGKILL (out of memory, or ended by hand)",
          signal.SIGSEGV: "crashed (SIGSEGV), often from memory exhaustion"}


class InputError(ValueError):
    """Input refused before anything runs; the message names the field and what is allowed."""


class SolverError(RuntimeError):
    """FreeFem++ stopped with a non-zero exit code."""

    def __init__(self, returncode: int, message: str, log_tail: str):
        self.returncode = returncode
        self.message = message
        self.log_tail = log_tail
        meaning = EXIT_MEANING.get(returncode, KILLED.get(-returncode, f"killed by signal {-returncode}")
                                   if returncode < 0 else "unexpected exit")
        super().__init__(f"FreeFem++ exit {returncode} ({meaning}): {message}")


def dying_with_parent(command: list[str]) -> list[str]:
    """A command that gets SIGKILL when the thread that started it ends (a sweep's worker ended by
    an interruption, a runner killed, leaves no FreeFem++ or gmsh running): util-linux's setpriv
    sets that before exec, with no Python code run between fork and exec (which is unsafe in a
    process with threads). Started with start_new_session, the child also has a process group of
    its own, so that it and whatever it starts can be ended together."""
    return ["setpriv", "--pdeathsig", "KILL", "--", *command] if shutil.which("setpriv") else command


def require_plain_path(path: Path, what: str) -> None:
    """Refuse a path with a control character or bytes that are not UTF-8: FreeFEM, JSON, TOML
    and the terminal cannot all carry it faithfully. Every other character works."""
    text = str(path)
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        raise InputError(f"{what} {text.encode('utf-8', 'surrogateescape').decode('utf-8', 'backslashreplace')} is not valid UTF-8: "
                         "rename it with UTF-8 characters") from None
    bad = sorted({repr(c) for c in text if unicodedata.category(c) == "Cc"})
    if bad:
        raise InputError(f"{what} {text!r} contains the control character(s) {', '.join(bad)}: "
                         "use printable characters")


def freefem_binary() -> str:
    path = shutil.which("FreeFem++")
    if path is None:
        raise FileNotFoundError("FreeFem++ not found: run `make setup` (apt packages freefem++ libfreefem++)")
    require_own_plugins(REPO)
    return path


@functools.cache
def require_own_plugins(repo: Path) -> None:
    """The project's plugins are built from their sources for this FreeFem++ (their stamps, as
    bin/plugins check reads them), once a process: a missing one would stop FreeFEM with a bare
    load error, a stale one run old code."""
    fault = plugins_fault(repo / "edp" / "plugins")
    if fault:
        raise FileNotFoundError(fault)


def on_load_path(folder: str | Path) -> bool:
    """Whether FF_LOADPATH can name `folder`: FreeFEM splits it at every ';' and turns every '\\'
    into '/'."""
    return not set(str(folder)) & set(";\\")


@functools.cache
def own_plugins_on_load_path() -> Path:
    """edp/plugins, or, for a repository in a folder FF_LOADPATH cannot name, a link to it in a
    private temporary folder, which goes when this process ends."""
    if on_load_path(OWN_PLUGINS):
        return OWN_PLUGINS
    temporary = tempfile.gettempdir()
    folder = Path(tempfile.mkdtemp(prefix="ff-plugins-", dir=temporary if on_load_path(temporary) else "/tmp"))
    creator = os.getpid()  # a forked child leaves the link to the process that made it
    atexit.register(lambda: os.getpid() == creator and shutil.rmtree(folder, True))
    (folder / "plugins").symlink_to(OWN_PLUGINS, target_is_directory=True)
    return folder / "plugins"


def freefem_env() -> dict[str, str]:
    env = dict(os.environ)
    # the project's first: a plugin of the same name elsewhere in the list is not taken (FreeFEM
    # still looks in the working folder and the folders of the freefem++.pref files before)
    env["FF_LOADPATH"] = f"{own_plugins_on_load_path()};{PLUGIN_DIR}"
    env.setdefault("FF_VERBOSITY", "0")
    # CHOLMOD's factorizations run OpenMP regions; without a limit they cost this machine ~1.8x
    # the wall time of a factorization in context switches (docs/freefem-facts.md); same results
    env["OMP_THREAD_LIMIT"] = env.get("OMP_THREAD_LIMIT") or "1"  # as bin/ff's ${OMP_THREAD_LIMIT:-1}
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
    process = subprocess.Popen(dying_with_parent(freefem_command(script, args, defines)), cwd=cwd or REPO,
                               env=freefem_env(), text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               start_new_session=True)
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
    args = list(map(str, args))
    if Path(script).resolve() == MAIN and "-solverIdentity" not in args:  # as bin/ff: checkpoints know their code
        command += ["-solverIdentity", solver_identity(MAIN)]  # before the caller's: a last flag keeps its place
    return command + args


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


def run_logged(script: Path | str, args, log: Path, cwd: Path, defines: dict[str, str] | None = None,
               append: bool = False, meanwhile=None) -> Completed:
    """Run a FreeFEM script in folder `cwd` with its output (stdout and stderr) written to `log`
    (after what it holds, with `append`); meanwhile(), when given, is called once it started.
    An exception here (KeyboardInterrupt included) ends its process group. The signals Python
    ignores (SIGXFSZ, SIGPIPE) stay ignored in the child: past a file-size limit the driver's write
    then fails, which it checks, and it stops naming the file (exit 74) instead of dying unexplained."""
    with open(log, "a" if append else "w") as sink:
        process = subprocess.Popen(dying_with_parent(freefem_command(script, args, defines)), cwd=cwd,
                                   env=freefem_env(), text=True, stdout=sink, stderr=subprocess.STDOUT,
                                   start_new_session=True, restore_signals=False)
        try:
            if meanwhile:
                meanwhile()
            process.wait()
        except BaseException:
            stop_group(process)
            raise
    text = log.read_text(errors="replace")
    return Completed(process.returncode, text, "")
