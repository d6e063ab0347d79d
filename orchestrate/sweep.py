"""Parameter sweeps: the cartesian product of scene overrides, one run folder each, on
dask.distributed (a LocalCluster by default, an existing cluster given its scheduler address).

A failed run is recorded with its error and the others go on. A run whose folder holds a
complete run of the same inputs (scene after overrides, solver sources, mesh sources) is not run
again, so an interrupted sweep started again runs only what is missing. `sweep.csv` has a row
per run: its parameters, status, error, final-time figures and wall time.
"""
from __future__ import annotations

import csv
import hashlib
import itertools
import json
import logging
import re
from pathlib import Path

from orchestrate.freefem import REPO
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
        grid[key.strip()] = [parse_value(value.strip()) for value in values.split(",")]
    return grid


def folder_name(assignment: dict) -> str:
    """A folder name from the parameters of a run; only [A-Za-z0-9._=+-] survive (no paths)."""
    name = "__".join(f"{key}={value}" for key, value in assignment.items()) or "base"
    return re.sub(r"[^A-Za-z0-9._=+-]", "_", name)[:200].lstrip(".")


def source_digest() -> str:
    """The solver's FreeFEM sources (driver, libraries) and the mesh sources: a change reruns
    every run. Tools such as edp/tools/errors.edp do not change a run."""
    digest = hashlib.sha256()
    solver = [REPO / "edp" / "main.edp", *(REPO / "edp" / "lib").glob("*.idp")]
    for path in sorted([*solver, *(REPO / "meshes").glob("*.geo")]):
        digest.update(path.relative_to(REPO).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def inputs_digest(scene: Scene, sources: str) -> str:
    text = json.dumps(scene.model_dump(mode="json"), sort_keys=True) + sources
    return hashlib.sha256(text.encode()).hexdigest()


def run_one(scene_data: dict, folder: str, digest: str) -> dict:
    """Task of a worker: one run, never raising (its failure is a row of sweep.csv)."""
    from orchestrate.runner import run

    try:
        result = run(Scene.model_validate(scene_data), folder, force=True)
    except Exception as error:  # a failed run is data for the sweep, not the end of it
        return {"status": "failed", "error": f"{type(error).__name__}: {error}".splitlines()[0]}
    (Path(folder) / "inputs.sha256").write_text(digest + "\n")
    return row_of(Path(folder), "completed")


def row_of(folder: Path, status: str) -> dict:
    summary = json.loads((folder / "summary.json").read_text())
    final = summary["final"]
    return {"status": status, "error": "", "wallSeconds": summary.get("wallSeconds"),
            "contactItersPerStep": summary.get("contactItersPerStep"), **{name: final.get(name) for name in FIGURES}}


def completed_before(folder: Path, digest: str) -> bool:
    marker = folder / "inputs.sha256"
    return marker.exists() and (folder / "summary.json").exists() and marker.read_text().strip() == digest


def make_client(workers: int, scheduler: str | None):
    from dask.distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler)
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=logging.ERROR)
    return Client(cluster)


def plan(scene: str | Path, assignments: list[dict], out: Path, base: dict | None = None) -> tuple[list, list]:
    """Rows for runs of the scene with each assignment of overrides (on top of `base`), in folders
    of `out` named by the assignment, and the jobs among them still to run."""
    sources = source_digest()
    rows, jobs = [], []
    for assignment in assignments:
        row = {**assignment, "folder": folder_name(assignment)}
        rows.append(row)
        try:
            resolved = Scene.load(scene, {**(base or {}), **assignment})
        except SceneError as error:
            row.update(status="invalid", error=" | ".join(str(error).splitlines()[1:]))
            continue
        folder = out / row["folder"]
        digest = inputs_digest(resolved, sources)
        if completed_before(folder, digest):
            row.update(row_of(folder, "skipped (complete)"))
        else:
            jobs.append((row, resolved.model_dump(mode="json"), str(folder), digest))
    return rows, jobs


def sweep(scene: str | Path, grid: dict[str, list], out: str | Path, base: dict | None = None, *,
          workers: int = 2, scheduler: str | None = None, progress: bool = False) -> list[dict]:
    """Run every combination of `grid` (dotted scene keys → values) over the scene with `base`
    overrides; returns the rows of sweep.csv (written in `out`)."""
    out = Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    keys = list(grid)
    assignments = [dict(zip(keys, values)) for values in itertools.product(*(grid[key] for key in keys))]
    rows, jobs = plan(scene, assignments, out, base)
    run_jobs(jobs, workers, scheduler, progress)
    write_table(out / "sweep.csv", rows, keys)
    return rows


def run_jobs(jobs, workers: int, scheduler: str | None, progress: bool) -> None:
    """Run the jobs of `plan` on dask.distributed; each row gets its status and figures.
    An interruption (SIGINT, SIGTERM) closes the cluster: its workers end, and their FreeFem++
    children with them (freefem.py); the same sweep started again runs what did not finish."""
    if not jobs:
        return
    from dask.distributed import as_completed

    from orchestrate.runner import sigterm_as_interrupt

    client = make_client(workers, scheduler)
    try:
        with sigterm_as_interrupt():
            futures = {client.submit(run_one, data, folder, digest, pure=False): row
                       for row, data, folder, digest in jobs}
            bar = None
            if progress:
                from tqdm import tqdm
                bar = tqdm(total=len(futures), unit="run", desc="runs")
            for future in as_completed(futures):
                futures[future].update(future.result())
                if bar is not None:
                    bar.update(1)
            if bar is not None:
                bar.close()
    finally:
        cluster = client.cluster
        client.close()
        if cluster is not None:
            cluster.close()


def write_table(path: Path, rows: list[dict], keys: list[str]) -> None:
    columns = [*keys, "folder", "status", "error", "wallSeconds", "contactItersPerStep", *FIGURES]
    partial = path.with_suffix(".csv.partial")
    with open(partial, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    partial.replace(path)
