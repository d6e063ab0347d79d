"""Parameter sweeps: the cartesian product of scene overrides, one run folder each, on
dask.distributed (a LocalCluster by default, an existing cluster given its scheduler address).

Each combination has its own folder: a readable prefix of its values and a hash of the whole
combination, so two combinations never share one. A failed run is recorded with its error and the
others go on. A folder is skipped only when its manifest is whole and records the same inputs
(scene after overrides, solver sources, what determines the meshes: runner.inputs_of), so an
interrupted sweep started again runs only what is missing, and an edited input runs again.
`sweep.csv` has a row per run, written even when the sweep is interrupted.
"""
from __future__ import annotations

import hashlib
import itertools
import json
import logging
import re
from pathlib import Path

from orchestrate.manifest import IncompleteRun, verify_manifest
from orchestrate.reports import write_csv
from orchestrate.scene import Scene, SceneError, parse_value

FIGURES = ("normV", "contactForce", "contactLength", "betaMin", "betaMean", "zetaMin1", "zetaMin2",
           "vmMax1", "vmMax2", "gapMax")


def parse_grid(items: list[str]) -> dict[str, list]:
    """["time.N=20,40", "glue.gammaNu=0,1"] → {"time.N": [20, 40], "glue.gammaNu": [0, 1]}."""
    grid = {}
    for item in items:
        key, separator, values = item.partition("=")
        if not separator or not key.strip() or not values.strip():
            raise SceneError(f"--grid {item!r}: expected key=value1,value2,... e.g. --grid time.N=20,40")
        if key.strip() in grid:
            raise SceneError(f"--grid {key.strip()} is given twice: list all its values in one --grid")
        grid[key.strip()] = [parse_value(value.strip()) for value in values.split(",")]
    return grid


def require_distinct(grid: dict[str, list]) -> None:
    """A value listed twice would be the same run twice in one folder: refused."""
    for key, values in grid.items():
        if not values:
            raise SceneError(f"--grid {key}: no values")
        for index, value in enumerate(values):
            if any(type(value) is type(other) and value == other for other in values[:index]):
                raise SceneError(f"--grid {key}: the value {value!r} is listed twice")


def folder_name(assignment: dict) -> str:
    """A folder name unique to the combination: its values, only [A-Za-z0-9._=+-] kept and cut to
    a readable length, then 10 hex digits of the combination's hash (no paths, no dot first)."""
    readable = "__".join(f"{key}={value}" for key, value in assignment.items()) or "base"
    readable = re.sub(r"[^A-Za-z0-9._=+-]", "_", readable)[:100].lstrip(".") or "run"
    key = hashlib.sha256(json.dumps(list(assignment.items()), sort_keys=False).encode()).hexdigest()[:10]
    return f"{readable}-{key}"


def run_one(scene_data: dict, folder: str) -> dict:
    """Task of a worker: one run, never raising (its failure is a row of sweep.csv)."""
    from orchestrate.runner import run

    try:
        run(Scene.model_validate(scene_data), folder, force=True, resume=True, progress=False)
    except Exception as error:  # a failed run is data for the sweep, not the end of it
        return {"status": "failed", "error": f"{type(error).__name__}: {error}".splitlines()[0]}
    return row_of(Path(folder), "completed")


def row_of(folder: Path, status: str) -> dict:
    summary = json.loads((folder / "summary.json").read_text())
    final = summary["final"]
    return {"status": status, "error": "", "warnings": "; ".join(summary.get("warnings", [])),
            "wallSeconds": summary.get("wallSeconds"),
            "contactItersPerStep": summary.get("contactItersPerStep"), **{name: final.get(name) for name in FIGURES}}


def completed_before(folder: Path, digest: str) -> bool:
    """The folder holds a whole run of exactly these inputs."""
    if not (folder / "manifest.json").is_file() or folder.is_symlink():
        return False
    try:
        return verify_manifest(folder).get("inputs", {}).get("digest") == digest
    except IncompleteRun:
        return False


def make_client(workers: int, scheduler: str | None):
    from dask.distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler)
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=logging.ERROR)
    return Client(cluster)


def resolved_values(scene: Scene, assignment: dict) -> dict:
    """The assignment's values as the validated scene holds them (1 for a real is 1.0), so that a
    folder is named by what runs, however the value was written."""
    from orchestrate.parameters import scene_value

    data = scene.model_dump(mode="json")
    return {key: scene_value(data, key) for key in assignment}


def plan(scene: str | Path, assignments: list[dict], out: Path, base: dict | None = None) -> tuple[list, list]:
    """Rows for runs of the scene with each assignment of overrides (on top of `base`), in folders
    of `out` named by the values that run, and the jobs among them still to run. Two combinations
    that make the same run are refused."""
    from orchestrate.runner import inputs_of

    rows, jobs, seen = [], [], {}
    for assignment in assignments:
        row = {**assignment, "folder": folder_name(assignment)}
        rows.append(row)
        try:
            resolved = Scene.load(scene, {**(base or {}), **assignment})
        except SceneError as error:
            row.update(status="invalid", error=" | ".join(str(error).splitlines()[1:]) or str(error))
            continue
        row["folder"] = folder_name(resolved_values(resolved, assignment))
        digest = inputs_of(resolved)["digest"]
        if digest in seen:
            raise SceneError(f"--grid: {seen[digest]} and {assignment} are the same run: list each value once")
        seen[digest] = assignment
        folder = out / row["folder"]
        if completed_before(folder, digest):
            row.update(row_of(folder, "skipped (complete)"))
        else:
            jobs.append((row, resolved.model_dump(mode="json"), str(folder)))
    return rows, jobs


def sweep(scene: str | Path, grid: dict[str, list], out: str | Path, base: dict | None = None, *,
          workers: int = 2, scheduler: str | None = None, progress: bool | str = "auto") -> list[dict]:
    """Run every combination of `grid` (dotted scene keys → values) over the scene with `base`
    overrides; returns the rows of sweep.csv (written in `out`, also when interrupted).
    progress: a bar of the runs, True, False or "auto" (where one can be seen: progress.py)."""
    from orchestrate.progress import wanted

    shown = wanted(progress)
    require_distinct(grid)
    out = Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    keys = list(grid)
    assignments = [dict(zip(keys, values)) for values in itertools.product(*(grid[key] for key in keys))]
    rows, jobs = plan(scene, assignments, out, base)
    try:
        run_jobs(jobs, workers, scheduler, shown)
    finally:
        write_table(out / "sweep.csv", rows, keys)
    return rows


def mark_interrupted(jobs) -> None:
    """Rows and partial folders of the jobs an interruption stopped: the workers that held them
    were ended with their cluster, before they could say so themselves."""
    for row, _, folder in jobs:
        if "status" in row:
            continue
        row.update(status="interrupted", error="the sweep was interrupted before this run finished")
        partial = Path(folder + ".partial")
        if partial.is_dir() and not partial.is_symlink():
            (partial / "INTERRUPTED").write_text("This run was interrupted with its sweep; its files are incomplete.\n")


def stop_workers(pids: list[int]) -> None:
    """End the worker processes of our LocalCluster now (closing it lets their runs go on for
    seconds); their FreeFem++ children die with them (freefem.py)."""
    import os
    import signal

    for pid in pids:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def run_jobs(jobs, workers: int, scheduler: str | None, progress: bool) -> None:
    """Run the jobs of `plan` on dask.distributed; each row gets its status and figures.
    An interruption (SIGINT, SIGTERM, SIGHUP) closes the cluster: its workers end, and their
    FreeFem++ children with them (freefem.py); the same sweep started again runs what did not
    finish."""
    if not jobs:
        return
    from dask.distributed import as_completed

    from orchestrate.progress import counter
    from orchestrate.runner import signals_as_interrupt

    import os

    client = make_client(workers, scheduler)
    own = list(client.run(os.getpid).values()) if client.cluster is not None else []
    interrupted = False
    try:
        with signals_as_interrupt():
            futures = {client.submit(run_one, data, folder, pure=False): row for row, data, folder in jobs}
            with counter(progress, len(futures), "run", "runs") as bar:
                for future in as_completed(futures):
                    futures[future].update(future.result())
                    bar.update(1)
    except BaseException:
        interrupted = True
        stop_workers(own)  # our own workers end at once, and their FreeFem++ with them
        raise
    finally:
        cluster = client.cluster
        client.close()
        if cluster is not None:
            cluster.close()
        if interrupted and cluster is not None:  # its workers are gone: nothing writes those folders any more
            mark_interrupted(jobs)


def write_table(path: Path, rows: list[dict], keys: list[str]) -> None:
    write_csv(path, rows, [*keys, "folder", "status", "error", "warnings", "wallSeconds", "contactItersPerStep", *FIGURES])


# --- command line ---------------------------------------------------------------------------

NAME, HELP = "sweep", "run the cartesian product of overrides on dask.distributed"


def add_arguments(parser) -> None:
    from orchestrate.cli import positive

    parser.add_argument("scene", help="a scene file, e.g. scenes/paper.toml")
    parser.add_argument("--grid", action="append", required=True, metavar="KEY=V1,V2,...",
                        help="values of one scene key, e.g. --grid time.N=20,40 --grid glue.gammaNu=0,1")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override for every run")
    parser.add_argument("--out", default="results/sweep", help="sweep folder (default results/sweep)")
    parser.add_argument("--workers", type=positive, default=2, help="LocalCluster workers (default 2)")
    parser.add_argument("--scheduler", help="address of an existing dask scheduler, e.g. tcp://host:8786")
    parser.add_argument("--images", action="store_true",
                        help="render every run's images (off by default: a sweep's figures are in sweep.csv, and "
                             "`render` draws any run's images later)")


def command(options) -> int:
    import sys

    from orchestrate.cli import parse_assignments

    base = parse_assignments(options.set, "--set")
    if not options.images:
        base.setdefault("output.images", False)
    rows = sweep(options.scene, parse_grid(options.grid), options.out, base,
                 workers=options.workers, scheduler=options.scheduler, progress=sys.stderr.isatty())
    width = max(len(row["folder"]) for row in rows)
    for row in rows:
        figure = f"normV(T) = {row['normV']:.6g}" if row.get("normV") is not None else row.get("error", "")
        print(f"{row['folder']:<{width}}  {row['status']:<18}  {figure}")
    print(f"table: {Path(options.out) / 'sweep.csv'}")
    return 0 if all(row["status"] in ("completed", "skipped (complete)") for row in rows) else 1
