"""Shared helpers: run FreeFem++ scripts and the solver, mesh with the gmsh command line."""
from __future__ import annotations

import hashlib
import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from orchestrate.freefem import REPO, Completed, run_script
from orchestrate.results import Result

TESTS = Path(__file__).resolve().parent
SCENES = TESTS / "scenes"

# A suite started in the background of a non-interactive shell (`make test &`, nohup) inherits
# SIGINT ignored, and so would every process it starts: the tests that interrupt a run with
# SIGINT would then wait on a run that never sees it. A handler here is reset to the default in
# every child, as in a terminal.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


def gmsh_mesh(geo: str | Path, target: Path, **numbers: float) -> Path:
    """Mesh a .geo file with the gmsh command line; numbers become -setnumber values."""
    command = ["gmsh", "-2", str(REPO / geo), "-o", str(target)]
    for name, value in numbers.items():
        command += ["-setnumber", name, repr(float(value))]
    subprocess.run(command, check=True, capture_output=True)
    return target


def solve(out: Path, *args, scene: Path | None = None, order: int = 1) -> tuple[Completed, Result]:
    """Run edp/main.edp into `out` and return the completed process and its result folder. A scene
    file is passed by its bare name from its own folder (a path in -DSCENE goes through FreeFEM's
    macro reader, which cuts it at '#'); order 2 compiles the driver with -DORDER=2."""
    defines = ({"SCENE": scene.name} if scene else {}) | ({"ORDER": str(order)} if order != 1 else {})
    flags = ["-order", str(order)] if order != 1 else []
    done = run_script(REPO / "edp" / "main.edp", [*map(str, args), *flags, "-out", str(out)], defines=defines or None,
                      cwd=scene.parent if scene else None)
    return done, Result(out)


def solve_ok(out: Path, *args, scene: Path | None = None, order: int = 1) -> Result:
    done, result = solve(out, *args, scene=scene, order=order)
    assert done.returncode == 0, f"solver failed ({done.returncode}): {done.error_line}\n{done.stdout[-2000:]}"
    return result


@pytest.fixture(scope="session")
def session_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("runs")


def resealed(checkpoint: Path, change) -> None:
    """A checkpoint's lines changed by `change` and sealed again as its format says (the SHA-256 of
    every line above the seal): what a careful forger writes, caught by the checks behind the seal.
    A checkpoint the kill cut while it was written (no frame lines) is left as it is: the driver never takes it."""
    whole = checkpoint.read_text().splitlines()
    if len(whole) < 4 or not whole[0].startswith("checkpoint ") or not whole[-1].startswith("end "):
        return
    lines = change(whole[:-2])
    body = "".join(line + "\n" for line in lines)
    step = lines[0].split()[1]
    checkpoint.write_text(body + f"seal {hashlib.sha256(body.encode()).hexdigest()}\nend {step}\n")


def rows(folder: Path) -> int:
    """The rows of a run folder's history.csv (-1 without one)."""
    try:
        return (folder / "history.csv").read_bytes().count(b"\n") - 1
    except FileNotFoundError:
        return -1


def same_results(first: Path, second: Path) -> None:
    """Every result file of `first` is in `second` with the same bytes; history.csv without its
    last column, the measured stepSeconds."""
    def results(folder: Path) -> list[str]:
        return sorted(path.name for path in folder.iterdir() if path.suffix in (".vtu", ".pvd") or path.name.startswith("state_"))

    names = results(first)
    assert names == results(second)
    for name in names:
        assert (first / name).read_bytes() == (second / name).read_bytes(), name
    history = [[line.rsplit(",", 1)[0] for line in (folder / "history.csv").read_text().splitlines()]
               for folder in (first, second)]
    assert history[0] == history[1]


def cli_args(overrides: dict) -> list[str]:
    """--set options of `python -m orchestrate` for scene overrides (values as TOML writes them)."""
    return [item for key, value in overrides.items()
            for item in ("--set", f"{key}={json.dumps(value) if not isinstance(value, bool) else str(value).lower()}")]


TIERS = ("unit", "solver", "physics", "runs")  # pyproject.toml's markers: what each test guards


def pytest_collection_modifyitems(items):
    """A test outside every tier would run in no `make` target but the whole suite: refused."""
    untiered = [item.nodeid for item in items if not any(item.get_closest_marker(tier) for tier in TIERS)]
    if untiered:
        raise pytest.UsageError(f"tests in no tier ({', '.join(TIERS)}): {', '.join(untiered[:5])}")


# A `unit` test starts no solver and no mesher (make test-fast runs where neither is installed):
# while one runs, starting FreeFem++ or gmsh from this process fails it.
_UNIT_RUNNING = {"now": False}


def _refuse_solver_in_unit_tests(event, args):
    if _UNIT_RUNNING["now"] and event == "subprocess.Popen":
        argv = args[1] if isinstance(args[1], (list, tuple)) else [args[1]]
        if any(word in str(part) for part in argv for word in ("FreeFem++", "gmsh")):
            raise RuntimeError(f"a unit test started {' '.join(map(str, argv))[:120]}: mark it with its tier, not unit")


sys.addaudithook(_refuse_solver_in_unit_tests)


@pytest.fixture(autouse=True)
def _unit_tests_start_no_solver(request):
    _UNIT_RUNNING["now"] = request.node.get_closest_marker("unit") is not None
    yield
    _UNIT_RUNNING["now"] = False
