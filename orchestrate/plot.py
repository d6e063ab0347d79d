"""Figures of runs: python -m orchestrate plot SOURCE --y Y [--x X].

A sweep's final figures against a swept value (plot_sweep): it reads the sweep's table
(sweep.csv, orchestrate/sweep.py), whose swept keys are its columns before `folder`. The figure
(`--y`: a run figure such as normV, or wallSeconds) is drawn against one swept key (`--x`, default
the first), one curve per combination of the other swept values. Runs that did not complete are
left out and named under the plot. Numeric values are placed by value; others (expressions,
words) one after the other, in the order the sweep listed them.

Two columns of a run's history against each other (plot_columns): a force against a
displacement, an energy against time (`--x`, default t). SOURCE is a run folder, or a sweep's
folder, whose every completed run gives a curve labelled by its swept values. Each run is read
through its manifest (orchestrate/results.py); a sweep's runs are those its record lists.
"""
from __future__ import annotations

import math
import textwrap
from pathlib import Path

from orchestrate.freefem import InputError
from orchestrate.outputs import MARK, claim_file, plain_name, read_record
from orchestrate.plots import plain, pyplot, save
from orchestrate.render import column_label, steady_axis, units_of
from orchestrate.results import Result, load_result
from orchestrate.schema import shown
from orchestrate.sweep import FIGURES, read_table

DONE = ("completed", "skipped (complete)")
FORMATS = (".png", ".pdf", ".svg")
MEASURED = (*FIGURES, "wallSeconds", "contactItersPerStep")


def read_sweep(folder: str | Path) -> tuple[list[str], list[dict]]:
    """The swept keys and the rows of a sweep folder's sweep.csv."""
    path = Path(folder) / "sweep.csv"
    if not path.is_file():
        raise FileNotFoundError(f"{folder} holds no sweep.csv: give the --out folder of a sweep")
    keys, rows = read_table(path)
    if not rows:
        raise InputError(f"{path} holds a sweep's header and no rows: nothing to draw")
    return keys, rows


def number(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def series(keys: list[str], rows: list[dict], x: str, y: str) -> tuple[dict, dict | None, list[str]]:
    """The curves of `y` against `x`: {label of the other swept values: [(position, value)]} in
    position order, the tick labels by position when `x` is not numeric (else None), and the
    folders of the runs left out (a run with no value of `x` too: one of a merged table's that never
    started)."""
    if x not in keys:
        raise InputError(f"--x {shown(x, False)}: not a swept key of the sweep (swept: {', '.join(keys)})")
    if y not in MEASURED:
        raise InputError(f"--y {shown(y, False)}: not a figure of sweep.csv (allowed: {', '.join(MEASURED)})")
    others = [key for key in keys if key != x]
    done = [row for row in rows if row["status"] in DONE and number(row[y]) is not None and row[x] != ""]
    positions = {value: index for index, value in enumerate(dict.fromkeys(row[x] for row in rows if row[x] != ""))}
    numeric = all(number(value) is not None for value in positions)
    curves = {}
    for row in done:
        label = ", ".join(f"{key} = {row[key]}" for key in others)
        curves.setdefault(label, []).append((number(row[x]) if numeric else positions[row[x]], number(row[y])))
    ticks = None if numeric else {index: value for value, index in positions.items()}
    return {label: sorted(points) for label, points in curves.items()}, ticks, [row["folder"] for row in rows if row not in done]


def plot_sweep(folder: str | Path, y: str, x: str | None = None, target: str | Path | None = None,
               log: str = "none", dpi: int = 110, force: bool = False) -> Path:
    """Draw `y` of every completed run against the swept key `x` (default: the first) into `target`
    (default <folder>/<y>-vs-<x>.png; .png, .pdf or .svg), a new file or with `force` an image
    this program drew (outputs.py); log is "none", "x", "y" or "xy"."""
    keys, rows = read_sweep(folder)
    x = x or keys[0]
    target = image_file(target or Path(folder) / f"{y}-vs-{x}.png")
    curves, ticks, left_out = series(keys, rows, x, y)
    if not curves:
        raise InputError(f"{folder}: no run of the sweep completed with a value of {y}: nothing to draw")
    positions = sorted({position for points in curves.values() for position, _ in points})
    values = [value for points in curves.values() for _, value in points]
    require_loggable(log, {"x": (x, None if ticks else positions), "y": (y, values)})
    claim_file(target, force, MARK)
    figure, axis = pyplot().subplots(figsize=(7, 4.5))
    for label, points in curves.items():
        axis.plot(*zip(*points), "o-", label=plain(label) or None)
    axis.set_xscale("log" if "x" in log else "linear")
    if ticks is not None:
        axis.set_xticks(list(ticks), [plain(value) for value in ticks.values()], rotation=20, ha="right", fontsize=8)
    elif len(positions) <= 12:  # few values: a tick at each, in plain numbers (no 2×10¹ on a log axis)
        axis.set_xticks(positions, [f"{value:g}" for value in positions])
        axis.minorticks_off()
    if "y" in log:
        axis.set_yscale("log")
    else:
        steady_axis(axis, values)
    axis.set_xlabel(plain(x))
    completed = history_runs(folder)  # the units label the axis only: no run is read for them
    axis.set_ylabel(column_label(y, units_of(Result(completed[0][1])), " at T") if completed else y)
    axis.grid(True, alpha=0.3)
    if len(curves) > 1:
        axis.legend(fontsize=8)
    name_left_out(axis, "did not complete", left_out)
    save(figure, target, dpi=dpi)
    return target


def image_file(target: str | Path) -> Path:
    target = Path(target)
    if target.suffix not in FORMATS:
        raise InputError(f"--out {target}: give a file name ending in {', '.join(FORMATS)}")
    return target


def require_loggable(log: str, axes: dict[str, tuple[str, list | None]]) -> None:
    """--log refused on an axis it cannot draw whole ({axis: (what it shows, its values, None for
    words)}): matplotlib leaves out every value ≤ 0 without a word (an empty image, or a curve cut
    short) and has no place for a word on a logarithmic axis."""
    for axis, (name, values) in axes.items():
        if axis not in log:
            continue
        if values is None:
            raise InputError(f"--log {log}: the values of {shown(name, False)} are not numbers (expressions or words, "
                             f"drawn one after the other), which a logarithmic axis cannot place: draw it without "
                             f"--log {axis}")
        smallest = min(values)
        if not smallest > 0:
            raise InputError(f"--log {log}: {shown(name, False)} goes down to {smallest:.6g}, and a logarithmic axis "
                             f"shows values > 0 only: draw it without --log {axis}, or draw a column whose values are "
                             "all positive")


def name_left_out(axis, why: str, folders: list[str]) -> None:
    """The runs a figure leaves out, named above it."""
    if folders:
        axis.set_title(plain(textwrap.fill(f"left out ({why}): {', '.join(folders)}", 110)), fontsize=7)


def is_sweep(source: str | Path) -> bool:
    return (Path(source) / "sweep.csv").is_file()


def history_runs(source: str | Path) -> list[tuple[str, Path]]:
    """The runs a history figure draws, each with its label: a run folder alone (no label), or the
    completed runs of a sweep that its record lists, labelled by their swept values."""
    source = Path(source)
    if not is_sweep(source):
        return [("", source)]
    keys, rows = read_sweep(source)
    record = read_record(source)
    own = set(record["folders"]) if record else set()
    return [(", ".join(f"{key} = {row[key]}" for key in keys), source / row["folder"]) for row in rows
            if row["status"] in DONE and plain_name(row["folder"]) and row["folder"] in own]


def plot_columns(source: str | Path, y: str, x: str = "t", target: str | Path | None = None, log: str = "none",
                 dpi: int = 110, force: bool = False) -> Path:
    """Draw the history column `y` against the column `x` of a run, or of every completed run of a
    sweep, into `target` (.png, .pdf or .svg; default: a sweep's <source>/<y>-vs-<x>.png, beside a
    run folder <source>-<y>-vs-<x>.png, since a run folder holds its manifest's files alone), a new
    file or with `force` an image this program drew; log is "none", "x", "y" or "xy"."""
    source = Path(source)
    if x == y:
        raise InputError(f"--x and --y are both {shown(x, False)}: give two different columns (--x defaults to t)")
    if target is None:
        folder = source.resolve()  # "." names its folder too
        target = folder / f"{y}-vs-{x}.png" if is_sweep(folder) else folder.parent / f"{folder.name}-{y}-vs-{x}.png"
    target = image_file(target)
    runs = history_runs(source)
    if not runs:
        raise InputError(f"{source}: no run of the sweep completed: nothing to draw")
    try:
        results = [(label, load_result(folder)) for label, folder in runs]
        histories = [(label, result.history) for label, result in results]
    except FileNotFoundError:
        raise InputError(f"{source} is neither a sweep's folder (no sweep.csv) nor a run folder (no manifest.json, "
                         "no run.json)") from None
    for option, name in (("--x", x), ("--y", y)):
        if not any(name in history for _, history in histories):
            raise InputError(f"{option} {shown(name, False)}: not a column of history.csv (columns: "
                             f"{', '.join(histories[0][1])})")
    drawn = [(label, history) for label, history in histories if x in history and y in history]
    if not drawn:
        raise InputError(f"--x {shown(x, False)}, --y {shown(y, False)}: no run of {source} has both in its "
                         "history.csv")
    require_loggable(log, {"x": (x, [value for _, history in drawn for value in history[x]]),
                           "y": (y, [value for _, history in drawn for value in history[y]])})
    claim_file(target, force, MARK)
    figure, axis = pyplot().subplots(figsize=(7, 4.5))
    for label, history in drawn:
        axis.plot(history[x], history[y], "-", marker="." if len(history[x]) <= 60 else None, label=plain(label) or None)
    axis.set_xscale("log" if "x" in log else "linear")
    if "y" in log:
        axis.set_yscale("log")
    else:
        steady_axis(axis, [value for _, history in drawn for value in history[y]])
    units = units_of(results[0][1])  # a sweep's runs share their scene's units
    axis.set_xlabel(column_label(x, units))
    axis.set_ylabel(column_label(y, units))
    axis.grid(True, alpha=0.3)
    if len(drawn) > 1:
        axis.legend(fontsize=8)
    lacking = [name for name in (x, y) if not all(name in history for _, history in histories)]
    left_out = [folder.name for (_, folder), (_, history) in zip(runs, histories)
                if x not in history or y not in history]
    name_left_out(axis, f"no column {' or '.join(lacking)}", left_out)
    save(figure, target, dpi=dpi)
    return target
