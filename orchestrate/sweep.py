"""Parameter sweeps: the cartesian product of scene overrides, one run folder each, on
dask.distributed (a LocalCluster by default, an existing cluster given its scheduler address).

The grid's keys are those of --set (a boundary condition by its label, body1.boundary[label=4].fy,
or by its index); its values come as a TOML list per key, which takes any value (expressions with
commas among them), as plain values split at commas, or from a grid file (TOML, a list per key).

Each combination has its own folder: a readable prefix of its values and a hash of the whole
combination, so two combinations never share one. A failed run is recorded with its error and the
others go on. A folder is skipped only when its manifest is whole and records the same inputs
(scene after overrides, solver sources, what determines the meshes: runner.inputs_of), so an
interrupted sweep started again runs only what is missing, and an edited input runs again.
`sweep.csv` has a row per run, written even when the sweep is interrupted. A sweep into the folder
of an earlier one adds to its table: the earlier rows are kept (a combination run again replaces
its row), the columns are the union of the swept keys, and a row's cell of a key its sweep did not
sweep holds the value its run ran with (blank for a run that never started).
"""
from __future__ import annotations

import csv
import fcntl
import hashlib
import itertools
import json
import logging
import math
import os
import re
import tomllib
from contextlib import contextmanager
from pathlib import Path

from orchestrate.arguments import split_assignment
from orchestrate.formats import SWEEP_COLUMNS, SWEEP_FIGURES
from orchestrate.freefem import InputError
from orchestrate.manifest import IncompleteRun
from orchestrate.outputs import claim_growing_folder, write_csv
from orchestrate.parameters import scene_value
from orchestrate.progress import counter, wanted
from orchestrate.results import Result, load_result
from orchestrate.runner import SUFFIXES, RunError, inputs_of, run, signals_as_interrupt
from orchestrate.scene import Scene, SceneError, apply_overrides, parse_value, read_toml, resolve_keys
from orchestrate.schema import shown

FIGURES = SWEEP_FIGURES  # the history's final values a row holds (edp/lib/formats.toml, [sweep])


LIST_EXAMPLE = '\'body1.boundary[label=4].fy=["-10*min(t, 0.5)", "-20*t"]\''
GRID_FORMS = "KEY=[V1, V2, ...] (a TOML list: any values, expressions as strings in quotes) or KEY=V1,V2,... " \
             "(plain values without commas)"


def parse_grid(items: list[str]) -> dict[str, list]:
    """["time.N=20,40", 'body1.boundary[label=4].fy=["-10*min(t, 1)", "-20*t"]'] →
    {"time.N": [20, 40], "body1.boundary[label=4].fy": ["-10*min(t, 1)", "-20*t"]}."""
    grid = {}
    for item in items:
        key, text = split_assignment(item, "--grid", "key=value1,value2,... or key=[value1, value2, ...]",
                                     "time.N=20,40")
        if key in grid:
            raise SceneError(f"--grid {shown(key, False)} is given twice: list all its values in one --grid")
        grid[key] = grid_values(key, text)
    return grid


def grid_values(key: str, text: str) -> list:
    """The values of one --grid: a TOML array, or plain values split at every comma, where a piece
    that cannot stand alone (a bracket or quote not closed: `min(t, 1)` cut in two) is refused
    rather than swept as two wrong values."""
    if text.startswith("["):
        try:
            values = tomllib.loads(f"values = {text}")["values"]
        except tomllib.TOMLDecodeError as error:
            raise SceneError(f"--grid {shown(f'{key}={text}', False)}: not a TOML list ({error}); write {GRID_FORMS}, "
                             f"e.g. --grid {LIST_EXAMPLE}") from None
        except RecursionError:
            raise too_deep(f"--grid {key}") from None
        require_shallow(values, f"--grid {key}")
        return values
    pieces = [piece.strip() for piece in text.split(",")]
    for piece in pieces:
        if not piece or cut_short(piece):
            what = "an empty value" if not piece else f"{shown(piece)} is part of a value cut at a comma"
            raise SceneError(f"--grid {shown(f'{key}={text}', False)}: {what}; KEY=V1,V2 splits at every comma: give "
                             f"the values as a TOML list, --grid '{shown(key, False)}=[V1, V2, ...]', e.g. --grid "
                             f"{LIST_EXAMPLE}")
    return [parse_value(piece) for piece in pieces]


def cut_short(piece: str) -> bool:
    """A bracket or a quote of the text left open (or closed without being opened)."""
    return any(piece.count(opening) != piece.count(closing) for opening, closing in ("()", "[]", "{}")) \
        or any(piece.count(quote) % 2 for quote in "\"'")


# Lists and tables nested in one key's values: a swept list of boundary conditions is 3 deep. Deeper
# is no grid, and Python's recursion (the TOML reader, the scene's validation) would fail nameless.
MAX_NESTING = 16


def nests_deeper(values: list, limit: int = MAX_NESTING) -> bool:
    """Lists or tables nested more than `limit` deep inside `values` (a grid key's own list)."""
    return any(_nests(value, limit) for value in values)


def _nests(value, limit: int) -> bool:
    if not isinstance(value, (list, dict)):
        return False
    if limit == 0:
        return True
    inner = value.values() if isinstance(value, dict) else value
    return any(_nests(item, limit - 1) for item in inner)


def require_shallow(values: list, where: str) -> None:
    if nests_deeper(values):
        raise too_deep(where)


def too_deep(where: str) -> SceneError:
    return SceneError(f"{where}: its values nest lists or tables more than {MAX_NESTING} deep; a grid gives each key "
                      "a list of values (a list of lists to sweep a list, a list of lists of tables to sweep "
                      "boundary conditions)")


def read_grid_file(path: str | Path) -> dict[str, list]:
    """A grid file: TOML whose keys are scene keys and values lists, `"body1.boundary[label=4].fy" =
    ["-10*t", "-20*t"]` one a line, or in tables (`[glue]` then `gammaNu = [0, 1]`); keys are
    joined by dots down to each list, in the file's order."""
    path = Path(path)
    grid: dict[str, list] = {}
    _flatten(read_toml(path, "grid"), "", grid, path)
    return grid


def _flatten(table: dict, prefix: str, grid: dict, path: Path) -> None:
    for name, value in table.items():
        key = prefix + name
        if isinstance(value, dict) and prefix.count(".") >= MAX_NESTING:
            raise SceneError(f"grid file {path}: {shown(key, False)} nests tables more than {MAX_NESTING} deep: no "
                             "scene key is that long (e.g. body1.boundary.1.fy)")
        if isinstance(value, dict):
            _flatten(value, f"{key}.", grid, path)
        elif not isinstance(value, list):
            raise SceneError(f"grid file {path}: {shown(key, False)} = {shown(value)} is not a list: give its values "
                             f"as one, e.g. {shown(key, False)} = [{shown(value)}, ...] (a list of lists to sweep a "
                             "list)")
        elif key in grid:
            raise SceneError(f"grid file {path}: {shown(key, False)} is given twice: list all its values once")
        else:
            require_shallow(value, f"grid file {path}: {key}")
            grid[key] = value


def grid_of(items: list[str], path: str | Path | None) -> dict[str, list]:
    """The grid of the command line: the grid file's keys, then those of --grid; a key in both is
    refused."""
    grid = read_grid_file(path) if path else {}
    for key, values in parse_grid(items).items():
        if key in grid:
            raise SceneError(f"--grid {shown(key, False)} is also in --grid-file {path}: give its values in one place")
        grid[key] = values
    if not grid:
        raise SceneError(f"nothing to sweep: give --grid {GRID_FORMS}, or --grid-file FILE")
    return grid


def grid_fields(scene: str | Path, grid: dict[str, list], base: dict | None) -> dict[str, str]:
    """Each grid key → that key by index in the scene with `base` applied, which refuses, before
    anything runs, a label no condition or several carry and two keys naming one value, also a
    grid key and a --set key (the grid would overrule the --set value, or every run be refused)."""
    data = read_toml(Path(scene), "scene")
    given = resolve_keys(data, base or {})
    fields = resolve_keys(apply_overrides(data, base or {}), grid, "--grid")
    for key, field in fields.items():
        other = next((set_key for set_key, set_field in given.items() if set_field == field), None)
        if other is not None:
            raise SceneError(f"--grid {key} and --set {other} name the same value ({field}): give it once")
    return fields


def require_distinct(grid: dict[str, list]) -> None:
    """A value listed twice would be the same run twice in one folder: refused."""
    for key, values in grid.items():
        if not values:
            raise SceneError(f"--grid {shown(key, False)}: no values: list at least one")
        for index, value in enumerate(values):
            if any(type(value) is type(other) and value == other for other in values[:index]):
                raise SceneError(f"--grid {shown(key, False)}: the value {shown(value)} is listed twice")


def folder_name(assignment: dict) -> str:
    """A folder name unique to the combination: its values, only [A-Za-z0-9._=+-] kept and cut to
    a readable length, then 10 hex digits of the combination's hash (no paths, no dot first)."""
    readable = "__".join(f"{key}={value}" for key, value in assignment.items()) or "base"
    readable = re.sub(r"[^A-Za-z0-9._=+-]", "_", readable)[:100].lstrip(".") or "run"
    key = hashlib.sha256(json.dumps(list(assignment.items()), sort_keys=False).encode()).hexdigest()[:10]
    return f"{readable}-{key}"


def run_one(scene_data: dict, folder: str, trust_geo: bool = False) -> dict:
    """Task of a worker: one run, never raising (its failure is a row of sweep.csv)."""
    try:
        result = run(Scene.model_validate(scene_data), folder, force=True, resume=True, progress=False,
                     trust_geo=trust_geo)
        return row_of(result, "completed")
    except Exception as error:  # a failed run is data for the sweep, not the end of it
        return {"status": "failed", "error": f"{type(error).__name__}: {error}".splitlines()[0]}


def row_of(result: Result, status: str) -> dict:
    """A run's row of sweep.csv, from its summary.json as its manifest records it."""
    summary = result.summary
    final = summary["final"]
    return {"status": status, "error": "", "warnings": "; ".join(summary.get("warnings", [])),
            "wallSeconds": summary.get("wallSeconds"),
            "contactItersPerStep": summary.get("contactItersPerStep"), **{name: final.get(name) for name in FIGURES}}


def completed_before(folder: Path, digest: str) -> Result | None:
    """The folder's run when it is a whole run of exactly these inputs."""
    if not (folder / "manifest.json").is_file() or folder.is_symlink():
        return None
    try:
        result = load_result(folder)
        return result if json.loads(result.read("inputs.json")).get("digest") == digest else None
    except (IncompleteRun, ValueError):
        return None


def require_importable_main() -> None:
    """A LocalCluster's workers are spawned processes, which first run the main script again from
    its file: a script read from standard input (`python - < script.py`) has none, and every worker
    would fail with Dask's "Nanny failed to start"."""
    import __main__

    path = getattr(__main__, "__file__", None)
    if path is not None and getattr(__main__, "__spec__", None) is None and not os.path.isfile(path):
        raise InputError(f"the sweep's worker processes cannot start: they import the main script again, and "
                         f"{path} is no file (a script read from standard input, `python - < script.py`). Save the "
                         "script to a file and run `python script.py`, or give scheduler= a running Dask "
                         "scheduler's address")


def make_client(workers: int, scheduler: str | None):
    from dask.distributed import Client, LocalCluster

    if scheduler:
        return Client(scheduler)
    require_importable_main()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=logging.ERROR)
    return Client(cluster)


def resolved_values(scene: Scene, assignment: dict, fields: dict[str, str]) -> dict:
    """The assignment's values as the validated scene holds them (1 for a real is 1.0), under the
    keys as written (`fields`: each key by index), so that a folder is named by what runs, however
    the value was written."""
    data = scene.model_dump(mode="json")
    return {key: scene_value(data, fields[key]) for key in assignment}


# Combinations a sweep runs without being told to: above, planning alone takes minutes (a few ms a
# scene) and the runs days, so a grid of that size is more likely a slip than a plan.
MAX_UNASKED = 1000


def require_asked(grid: dict[str, list], yes: bool) -> None:
    count = math.prod(len(values) for values in grid.values())
    if count > MAX_UNASKED and not yes:
        sizes = " × ".join(f"{len(values)} ({key})" for key, values in grid.items())
        raise SceneError(f"--grid: {count} combinations ({sizes}), above the {MAX_UNASKED} a sweep runs unasked: "
                         "pass --yes (yes=True) to plan and run them all, or list fewer values")


def plan(scene: str | Path, grid: dict[str, list], out: Path, base: dict | None = None,
         yes: bool = False) -> tuple[list, list]:
    """Rows for runs of the scene with each combination of the grid's values (on top of `base`),
    in folders of `out` named by the values that run, and the jobs among them still to run. Its
    keys are checked first; more than MAX_UNASKED combinations need `yes`, and two combinations
    that make the same run are refused."""
    require_distinct(grid)
    require_asked(grid, yes)
    fields = grid_fields(scene, grid, base)
    return plan_runs(scene, [dict(zip(grid, values)) for values in itertools.product(*grid.values())], out, base,
                     fields)


def plan_runs(scene: str | Path, assignments: list[dict], out: Path, base: dict | None = None,
              fields: dict[str, str] | None = None) -> tuple[list, list]:
    """`plan` for a list of assignments (the studies' ladders); `fields`: each key as the scene
    model spells it (grid_fields), the keys themselves when not given."""
    fields = fields or {key: key for assignment in assignments for key in assignment}
    rows, jobs, seen = [], [], {}
    for assignment in assignments:
        row = {**assignment, "folder": folder_name(assignment)}
        rows.append(row)
        try:
            resolved = Scene.load(scene, {**(base or {}), **assignment}, grid=tuple(assignment))
        except SceneError as error:
            row.update(status="invalid", error=" | ".join(str(error).splitlines()[1:]) or str(error))
            continue
        row["folder"] = folder_name(resolved_values(resolved, assignment, fields))
        digest = inputs_of(resolved)["digest"]
        if digest in seen:
            raise SceneError(f"--grid: {shown(seen[digest])} and {shown(assignment)} are the same run: list each value "
                             "once")
        seen[digest] = assignment
        folder = out / row["folder"]
        done = completed_before(folder, digest)
        if done:
            row.update(row_of(done, "skipped (complete)"))
        else:
            jobs.append((row, resolved.model_dump(mode="json"), str(folder)))
    return rows, jobs


def sweep(scene: str | Path, grid: dict[str, list], out: str | Path, base: dict | None = None, *,
          workers: int = 2, scheduler: str | None = None, progress: bool | str = "auto",
          yes: bool = False, trust_geo: bool = False) -> list[dict]:
    """Run every combination of `grid` (dotted scene keys → lists of values) over the scene with
    `base` overrides; returns its rows of sweep.csv (written in `out`, also when interrupted, after
    the rows of earlier sweeps into `out`: the module's docstring). Keys
    are those of --set: `body1.boundary[label=4].fy` names a boundary condition by its label.
    progress: a bar of the runs, True, False or "auto" (where one can be seen: progress.py); yes:
    run more than MAX_UNASKED combinations; trust_geo: as for `run`."""
    visible = wanted(progress)
    if not 1 <= workers <= MAX_WORKERS:
        raise InputError(f"workers = {shown(workers)}: give 1 to {MAX_WORKERS} (each worker is a process that runs "
                         "FreeFem++; more than the machine's cores only queue)")

    out = Path(out).resolve()
    rows, jobs = plan(scene, grid, out, base, yes)
    claim_growing_folder(out, "sweep", ["sweep.csv"], [row["folder"] for row in rows], SUFFIXES)
    with sweep_lock(out):
        earlier_keys, earlier = earlier_table(out / "sweep.csv")
        try:
            run_jobs(jobs, min(workers, len(jobs)), scheduler, visible, trust_geo)
        finally:
            keys = [*earlier_keys, *(key for key in grid if key not in earlier_keys)]
            write_table(out / "sweep.csv", with_values_run(out, merged(earlier, rows), keys), keys)
    return rows


MAX_WORKERS = 256  # a LocalCluster of more processes than this takes minutes to start on any machine


@contextmanager
def sweep_lock(folder: Path):
    """The sweep folder held by one sweep at a time (an exclusive lock on it while it runs): two
    sweeps into one folder would each write sweep.csv from what it read before the other wrote."""
    handle = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise RunError(f"another sweep is running in {folder}: wait for it to end, then run this one (it adds its "
                           "rows to the same sweep.csv), or choose another --out") from None
        yield
    finally:
        os.close(handle)


def read_table(path: Path) -> tuple[list[str], list[dict]]:
    """The swept keys (the columns before `folder`) and the rows of a sweep.csv."""
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            reader = csv.DictReader(handle)
            rows = list(reader)
            columns = reader.fieldnames or []
    except (UnicodeDecodeError, csv.Error) as error:
        raise InputError(f"{path} is not a sweep's table ({error})") from None
    if "folder" not in columns:
        raise InputError(f"{path} holds no sweep's rows (a header with the swept keys, then folder, status, ...)")
    return columns[:columns.index("folder")], rows


def earlier_table(path: Path) -> tuple[list[str], list[dict]]:
    """The table of the sweeps into this folder before (none: no keys, no rows), read before anything
    runs: one that cannot be read is refused, never written over."""
    if not os.path.lexists(path):
        return [], []
    try:
        return read_table(path)
    except InputError as error:
        raise InputError(f"--out {path.parent}: {error}: this sweep would add its rows to it; move it away to start "
                         "a new table, or choose another --out") from None


def merged(earlier: list[dict], rows: list[dict]) -> list[dict]:
    """The earlier rows, each replaced by this sweep's row of the same run folder, then this sweep's others."""
    by_folder = {row["folder"]: row for row in rows}
    kept = [by_folder.pop(row["folder"], row) for row in earlier]
    return kept + list(by_folder.values())


def with_values_run(out: Path, rows: list[dict], keys: list[str]) -> list[dict]:
    """The rows with a value for each key: a key a row's sweep did not sweep has the value its run
    ran with, from the scene.toml of its folder, or of the folder a failed or interrupted run left
    (blank where none is: a run that never started)."""
    return [{**row, **{key: value_run(out / row["folder"], key) for key in keys if key not in row}} for row in rows]


def value_run(folder: Path, key: str):
    for scene in (folder.with_name(folder.name + suffix) / "scene.toml" for suffix in ("", ".failed", ".partial")):
        try:
            data = tomllib.loads(scene.read_text(encoding="utf-8"))
            return scene_value(data, resolve_keys(data, [key])[key])
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError, SceneError, KeyError, IndexError, ValueError,
                TypeError):
            continue
    return ""


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
    import signal

    for pid in pids:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def run_jobs(jobs, workers: int, scheduler: str | None, progress: bool, trust_geo: bool = False) -> None:
    """Run the jobs of `plan` on dask.distributed; each row gets its status and figures.
    An interruption (SIGINT, SIGTERM, SIGHUP) closes the cluster: its workers end, and their
    FreeFem++ children with them (freefem.py); the same sweep started again runs what did not
    finish."""
    if not jobs:
        return
    from dask.distributed import as_completed

    client = make_client(workers, scheduler)
    own = list(client.run(os.getpid).values()) if client.cluster is not None else []
    interrupted = False
    try:
        with signals_as_interrupt():
            futures = {client.submit(run_one, data, folder, trust_geo, pure=False): row for row, data, folder in jobs}
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
    write_csv(path, rows, [*keys, *SWEEP_COLUMNS, *FIGURES])
