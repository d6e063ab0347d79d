"""Progress on stderr or in a notebook, shown only where someone watches.

`progress` in the API (run, sweep and the studies) is True, False or "auto": "auto" shows a bar
when the output can show one, a terminal (stderr is a tty) or a Jupyter kernel (tqdm.auto draws
its widget there when ipywidgets is installed, text otherwise), and nothing in pipes and CI logs.
The commands show one on a terminal.

A run's bar (RunBar) says what the run is doing: choosing N, meshing, set-up, the steps of the
loop, reading the files back, rendering an image. It follows the loop through history.csv, where
the driver writes and flushes a row per step (edp/lib/output.idp): every POLL seconds it reads
the step of the file's last complete row from its tail, a read of a few kB that costs the solver
nothing. The driver writes nothing between its start and the history's header (openHistory,
right after its set-up; on a restart, the history cut back to the checkpoint's rows), so the
file changing from what it was at launch marks the end of set-up. The rate and the time left are
measured from there (loop_pace): measured from the launch, a set-up longer than the loop made the
first estimate many times the whole run.
"""
from __future__ import annotations

import os
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path

from orchestrate.freefem import InputError

POLL = 0.1  # seconds between looks at history.csv: tqdm's own refresh interval
TAIL = 8192  # bytes read from the end of history.csv: several rows (one is under 1 kB)
FORMAT = "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} {elapsed}{postfix}"
NOTE_WIDTH = 28  # a run's notes padded to one width, so that its bar keeps its length


def notebook_kernel() -> bool:
    """Running in a Jupyter kernel (IPython's shell there has a kernel; a terminal's has none).
    IPython is asked only when something already imported it, as a kernel has."""
    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None and hasattr(ipython, "get_ipython") else None
    return getattr(shell, "kernel", None) is not None


def wanted(progress) -> bool:
    """Whether to show progress: True and False as given; "auto" when stderr is a terminal or
    this is a notebook's kernel."""
    if progress is True or progress is False:
        return progress
    if progress != "auto":
        raise InputError(f"progress = {progress!r}: give True, False or 'auto' (a bar on a terminal or in a notebook)")
    isatty = getattr(sys.stderr, "isatty", None)
    return bool(isatty and isatty()) or notebook_kernel()


def counter(progress, total: int, unit: str, desc: str):
    """A bar counting `total` units (a sweep's runs, a study's cases); inert when not wanted."""
    from tqdm.auto import tqdm

    return tqdm(total=total, unit=unit, desc=desc, disable=not wanted(progress))


def loop_pace(start: tuple[float, int] | None, now: float, step: int, total: int) -> tuple[float, float] | None:
    """(steps per second, seconds left) of the loop at time `now` with `step` of `total` steps
    done, measured from `start` = (time, step done) at the end of set-up; None during set-up
    (start None) and until a step of the loop is done."""
    if start is None:
        return None
    seconds, steps = now - start[0], step - start[1]
    if steps <= 0 or seconds <= 0:
        return None
    rate = steps / seconds
    return rate, (total - step) / rate


def pace_note(pace: tuple[float, float] | None) -> str:
    """The bar's note on the loop: its rate and the time left, once loop_pace has them."""
    if pace is None:
        return "first step"
    from tqdm import tqdm

    rate, left = pace
    speed = f"{rate:.0f} step/s" if rate >= 100 else f"{rate:.3g} step/s" if rate >= 1 else f"{1 / rate:.3g} s/step"
    return f"{speed}, {tqdm.format_interval(left)} left"


def last_step(history: Path) -> int | None:
    """The step of history.csv's last complete row; None with no file or no row yet."""
    try:
        with open(history, "rb") as handle:
            handle.seek(max(0, os.fstat(handle.fileno()).st_size - TAIL))
            tail = handle.read()
    except FileNotFoundError:
        return None
    rows = tail[:tail.rfind(b"\n")].rsplit(b"\n", 1)
    try:
        return int(rows[-1].split(b",", 1)[0])
    except ValueError:  # the header, or nothing complete yet
        return None


def signature(path: Path) -> tuple | None:
    """What tells a file changed: its inode, size and modification time (None: no file)."""
    try:
        status = os.stat(path)
    except FileNotFoundError:
        return None
    return status.st_ino, status.st_size, status.st_mtime_ns


class RunProgress:
    """What a run reports of its progress (its phase, its steps); this one, for when nobody
    watches, drops every report."""

    def phase(self, text: str) -> None:
        pass

    def steps(self, total: int, done: int) -> None:
        pass

    @contextmanager
    def following(self, history: Path):
        yield

    def close(self) -> None:
        pass


class RunBar(RunProgress):
    """A run's bar: its steps out of N, and a note saying what the run is doing."""

    def __init__(self, name: str, total: int | None, done: int):
        from tqdm.auto import tqdm

        self.bar = tqdm(total=total, initial=done, desc=name, unit="step", leave=False, bar_format=FORMAT)

    def phase(self, text: str) -> None:
        self.bar.set_postfix_str(f"{text:<{NOTE_WIDTH}}")

    def steps(self, total: int, done: int) -> None:
        """The loop's steps, `done` of them already (a restart's checkpoint), once N is known."""
        if total != self.bar.total:  # time.N = "auto": a bar reset to its N (a notebook's widget too)
            started = self.bar.start_t
            self.bar.reset(total)
            self.bar.start_t = started  # the elapsed time stays the run's
        self.bar.n = done
        self.bar.refresh()

    @contextmanager
    def following(self, history: Path):
        """The loop's steps from the rows history.csv gains while the block runs (FreeFem++);
        "set-up" until the file changes, then the loop's rate and time left."""
        launch, start, stop = signature(history), None, threading.Event()

        def look(noted: bool = True) -> None:
            nonlocal start
            now = time.monotonic()
            if start is None:
                if signature(history) == launch:
                    return
                start = (now, last_step(history) or self.bar.n)  # read after the change: this run's rows
            self.bar.n = max(last_step(history) or 0, self.bar.n)
            if noted:
                self.phase(pace_note(loop_pace(start, now, self.bar.n, self.bar.total)))
            else:
                self.bar.refresh()

        def watch() -> None:
            while not stop.wait(POLL):
                look()

        self.phase("set-up")
        watcher = threading.Thread(target=watch, daemon=True)
        watcher.start()
        try:
            yield
        finally:
            stop.set()
            watcher.join()
            look(noted=False)  # the last rows: the bar ends on the step the run reached

    def close(self) -> None:
        self.bar.close()


@contextmanager
def run_progress(progress, name: str, total: int | None, done: int):
    """The progress of one run named `name` (a RunBar when wanted, else the silent RunProgress)
    of `total` steps (None: not known yet), `done` of them already (a restart's); closed after."""
    shown = RunBar(name, total, done) if wanted(progress) else RunProgress()
    try:
        yield shown
    finally:
        shown.close()
