"""One run of a scene: mesh, write the FreeFEM scene, run edp/main.edp, render, summarize.

The run is built in `<out>.partial` and renamed to `<out>` only when complete, so an output
folder appears whole or not at all. A solver failure leaves `<out>.failed` (with run.log and
whatever the solver wrote); an interruption (SIGINT, SIGTERM) ends FreeFem++'s process group and
leaves `<out>.partial` with a file INTERRUPTED saying so.
"""
from __future__ import annotations

import json
import platform
import re
import shutil
import signal
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from importlib import metadata
from pathlib import Path

from orchestrate.freefem import MAIN, REPO, SolverError, run_logged
from orchestrate.mesh import body_mesh
from orchestrate.results import Result, load_result
from orchestrate.scene import Scene, to_freefem_scene

STEP = re.compile(r"^step (\d+)/(\d+) ")
SETUP = re.compile(r"^set-up: .*, ([0-9.eE+-]+) s$")
DONE = re.compile(r"^done: \d+ steps in ([0-9.eE+-]+) s")
TIMING = re.compile(r"^timing: setup (\S+) loop (\S+) output (\S+) backsubs-per-step (\S+)")


class RunError(RuntimeError):
    """A run that could not start (its folder exists) or was interrupted."""


class Interrupted(RunError):
    pass


@contextmanager
def sigterm_as_interrupt():
    """Turn SIGTERM into an exception while a run is in progress (main thread only), so the
    FreeFem++ process group is ended and the partial folder marked, as for Ctrl-C."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise Interrupted(f"interrupted by signal {signum}")

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def package_versions() -> dict[str, str]:
    versions = {"python": platform.python_version()}
    for name in ("numpy", "meshio", "pyvista", "vtk", "matplotlib", "gmsh", "pydantic", "dask", "distributed"):
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def default_folder(scene_path: Path | None) -> Path:
    return REPO / "results" / (scene_path.stem if scene_path else "run")


def run(scene: Scene | str | Path, out: str | Path | None = None, overrides: dict | None = None, *,
        force: bool = False, progress: bool = False, mesh_cache: Path | None = None,
        solver_flags: tuple = ()) -> Result:
    """Run a scene (a Scene or a .toml path, with dotted-key overrides) into folder `out`.
    mesh_cache: another mesh cache folder (the benchmark's, to time meshing); solver_flags:
    extra driver flags that change no result (e.g. -measureSolves 10)."""
    scene_path = None if isinstance(scene, Scene) else Path(scene)
    scene = Scene.load(scene_path, overrides) if scene_path else scene.with_overrides(overrides or {})
    out = (Path(out) if out else default_folder(scene_path)).resolve()  # FreeFem++ runs in the repository
    if out.exists() and not force:
        raise RunError(f"{out} exists: choose another --out or pass --force to replace it")
    partial, failed = out.with_name(out.name + ".partial"), out.with_name(out.name + ".failed")
    shutil.rmtree(partial, ignore_errors=True)
    partial.mkdir(parents=True)
    started = time.perf_counter()
    try:
        with sigterm_as_interrupt():
            summary = build(scene, partial, progress, mesh_cache, solver_flags)
    except (KeyboardInterrupt, Interrupted) as error:
        reason = str(error) or "Ctrl-C"
        (partial / "INTERRUPTED").write_text(f"This run was interrupted ({reason}); its files are incomplete.\n")
        raise Interrupted(f"run interrupted; the incomplete files are in {partial}") from None
    except SolverError:
        shutil.rmtree(failed, ignore_errors=True)
        partial.rename(failed)
        raise
    except FileNotFoundError:  # FreeFem++ itself missing: its own message says how to install it
        raise
    except OSError as error:  # a full disk, a folder that cannot be written: keep what exists
        raise RunError(f"cannot write the run ({error.strerror}: {error.filename}); is the disk full? "
                       f"The files written so far are in {partial}") from None
    summary["wallSeconds"] = round(time.perf_counter() - started, 3)
    (partial / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    shutil.rmtree(failed, ignore_errors=True)
    if out.exists():
        retired = out.with_name(out.name + ".replaced")
        shutil.rmtree(retired, ignore_errors=True)
        out.rename(retired)
        partial.rename(out)
        shutil.rmtree(retired)
    else:
        partial.rename(out)
    return load_result(out)


def require_complete(folder: Path, steps: int) -> None:
    """FreeFEM's streams report no write error: a run that exited 0 must still have written a
    history row per step, with every column, and every file its solution.pvd lists."""
    lines = (folder / "history.csv").read_text().splitlines() if (folder / "history.csv").exists() else []
    columns = lines[0].count(",") if lines else -1
    complete = len(lines) == steps + 1 and all(line.count(",") == columns for line in lines)
    if complete and (folder / "solution.pvd").exists():
        listed = re.findall(r'file="([^"]+)"', (folder / "solution.pvd").read_text())
        complete = all((folder / name).stat().st_size > 0 for name in listed if (folder / name).exists()) \
            and all((folder / name).exists() for name in listed)
    if not complete:
        raise OSError(28, f"FreeFem++ finished but wrote {max(len(lines) - 1, 0)} of {steps} history rows or "
                          f"an empty .vtu file", str(folder))


def build(scene: Scene, folder: Path, progress: bool, mesh_cache: Path | None = None, solver_flags: tuple = ()) -> dict:
    """Everything of a run inside `folder`; returns the summary (without the total wall time)."""
    timing = {}
    (folder / "scene.toml").write_text(scene.to_toml())
    clock = time.perf_counter()
    with ThreadPoolExecutor(2) as pool:  # each body is meshed in a process of its own: two at once
        meshes = list(pool.map(lambda body: body_mesh(body.mesh.source(), body.mesh.numbers(), body.mesh.refine,
                                                      mesh_cache), (scene.body1, scene.body2)))
    timing["meshing"] = time.perf_counter() - clock
    scene_file = folder / "scene.idp"
    scene_file.write_text(to_freefem_scene(scene, *meshes))

    clock = time.perf_counter()
    solver_cpu = {}
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=scene.time.N, unit="step", desc=folder.name.removesuffix(".partial"), leave=False)

    def on_line(line: str) -> None:
        if (match := STEP.match(line)) and bar is not None:
            bar.update(int(match.group(1)) - bar.n)
        elif match := SETUP.match(line):
            solver_cpu["setup"] = float(match.group(1))
        elif match := DONE.match(line):
            solver_cpu["total"] = float(match.group(1))
        elif match := TIMING.match(line):
            solver_cpu.update(zip(("setupCpu", "loopCpu", "outputCpu", "backsubsPerStep"), map(float, match.groups())))

    try:
        done = run_logged(MAIN, ["-out", folder, *solver_flags], folder / "run.log", on_line,
                          defines={"SCENE": scene_file})
    finally:
        if bar is not None:
            bar.close()
    timing["solver"] = time.perf_counter() - clock
    if done.returncode != 0:
        tail = "\n".join(done.stdout.splitlines()[-15:])
        raise SolverError(done.returncode, done.error_line, tail)

    require_complete(folder, scene.time.N)
    result = Result(folder)
    clock = time.perf_counter()
    if scene.output.images and result.outputs:
        from orchestrate.render import render_all
        render_all(result, folder)
    timing["images"] = time.perf_counter() - clock
    timing["solverSetupCpu"] = solver_cpu.get("setupCpu")
    timing["solverLoopCpu"] = solver_cpu.get("loopCpu")
    timing["solverOutputCpu"] = solver_cpu.get("outputCpu")
    timing["solverTotalCpu"] = solver_cpu.get("total")
    timing["backsubsPerStep"] = solver_cpu.get("backsubsPerStep")
    final = {name: float(values[-1]) for name, values in result.history.items()}
    return {
        "title": scene.title,
        "status": "completed",
        "final": final,
        "contactItersPerStep": float(result.history["contactIters"].mean()),
        "timing": {name: round(value, 6) if value is not None else None for name, value in timing.items()},
        "versions": {"freefem": result.params.get("freefemVersion"), **package_versions()},
        "scene": scene.model_dump(mode="json"),
    }
