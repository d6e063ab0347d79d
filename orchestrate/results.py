"""Reading what a solver run wrote: history.csv, params_used.json and the VTK files, through the
file formats and checks of manifest.py (which knows nothing of this module)."""
from __future__ import annotations

import bisect
import hashlib
import io
import json
import math
import os
import re
import tempfile
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from orchestrate.freefem import REPO, InputError
from orchestrate.manifest import (FACTS, MANIFEST, PARTS, STATE_ARRAYS, IncompleteRun, check_files,  # noqa: F401
                                  read_state, verify_manifest)
from orchestrate.schema import shown

if TYPE_CHECKING:  # meshio is imported where a field is read: a run that reads none never loads it
    import meshio

# A time asked of a run's outputs (grid, fields, render --time) is the output time within this
# fraction of the run's T, and no other: round-off in a time typed or computed, never another step.
SAME_TIME = 1e-9
STEP = re.compile(r"_([0-9]+)\.vtu$")  # a .vtu's step n in its name (edp/lib/output.idp)


@dataclass(frozen=True)
class Result:
    """A run folder of edp/main.edp, read as one version of it: every file is read whole, its
    SHA-256 checked against the digests its manifest gave when the folder was loaded (`expected`;
    taken from manifest.json, else run.json's fileDigests, at the first read when not given), and
    parsed from the bytes checked. A folder replaced or changed while it is read is refused, never
    read half from one run and half from another."""

    folder: Path
    expected: dict[str, str] | None = field(default=None, compare=False, repr=False)

    @cached_property
    def digests(self) -> dict[str, str] | None:
        """Each file's SHA-256 by name, as this folder's manifest (or run.json) recorded it."""
        if self.expected is not None:
            return self.expected
        return listed_digests(self.folder)

    def read(self, name: str) -> bytes:
        """A file of the run, read whole and checked against its recorded SHA-256."""
        path = self.folder / name
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            raise IncompleteRun(f"{path}: missing (the folder was changed or replaced since it was loaded)") from None
        digests = self.digests
        if digests is not None and name != FACTS and hashlib.sha256(data).hexdigest() != digests.get(name):
            raise IncompleteRun(f"{path}: not the file its manifest records (changed, or the folder replaced, since it "
                                "was loaded): load the run again")
        return data

    def snapshot(self, name: str, target: Path) -> Path:
        """The run's file `name` as checked (read), copied to `target`: what a tool reads is that one version."""
        target.write_bytes(self.read(name))
        return target

    @cached_property
    def history(self) -> dict[str, np.ndarray]:
        """history.csv by column name, one entry per time step."""
        table = np.genfromtxt(io.BytesIO(self.read("history.csv")), delimiter=",", names=True, ndmin=1)
        return {name: np.asarray(table[name]) for name in table.dtype.names}

    @cached_property
    def files(self) -> list[str]:
        """The names of the run's files: those its manifest lists (a run of orchestrate), else those
        run.json lists (none without either). A reader takes no other file of the folder."""
        if self.digests is not None:
            return sorted({*self.digests, FACTS} if (self.folder / FACTS).is_file() else self.digests)
        try:
            return sorted(json.loads((self.folder / FACTS).read_bytes())["files"])
        except (OSError, ValueError, KeyError, TypeError):
            return []

    @cached_property
    def params(self) -> dict:
        return json.loads(self.read("params_used.json"))

    @cached_property
    def summary(self) -> dict:
        """summary.json, what the runner recorded of the run (runs of orchestrate)."""
        return json.loads(self.read("summary.json"))

    @cached_property
    def outputs(self) -> list[tuple[float, dict[str, str]]]:
        """(time, {part: .vtu file name}) for every output in solution.pvd, in time order: the files
        of each step n (their names give it) at t = n·k, the driver's own time (params_used.json's
        k), not the .pvd's, which has 6 digits: 0.0333333 for 1/30, and one time for two steps
        closer than that."""
        if "solution.pvd" not in self.files:
            return []
        by_step: dict[int, dict[str, str]] = {}
        for dataset in ElementTree.fromstring(self.read("solution.pvd")).iter("DataSet"):
            name = dataset.get("file")
            by_step.setdefault(int(STEP.search(name)[1]), {})[PARTS[int(dataset.get("part"))]] = name
        return [(step * self.params["k"], files) for step, files in sorted(by_step.items())]

    def output_at(self, time: float | None, parts=(), option: str = "time") -> tuple[float, dict[str, str]]:
        """The output (time, files) holding `parts` at `time` (default: the last): the one whose
        time is within SAME_TIME·T of it. A time no output has is refused, named as `option`, with
        the nearest output times: a field is never taken from another time than the one asked."""
        unknown = [part for part in parts if part not in PARTS]
        if unknown:
            raise InputError(f"part {shown(unknown[0])}: a run's parts are {', '.join(PARTS)}")
        written = [(t, files) for t, files in self.outputs if set(parts) <= set(files)]
        if not written:
            raise FileNotFoundError(f"{self.folder} has no {' or '.join(parts) or '.vtu'} output files (output.times, "
                                    "output.fields)")
        if time is None:
            return written[-1]
        times = [t for t, _ in written]
        try:
            asked = math.nan if isinstance(time, bool) else float(time)  # True is no time 1
        except (TypeError, ValueError):
            asked = math.nan
        place = bisect.bisect_left(times, asked) if math.isfinite(asked) else None
        near = [] if place is None else [j for j in (place - 1, place) if 0 <= j < len(times)]
        for j in near:
            if abs(times[j] - asked) <= SAME_TIME * self.params["T"]:
                return written[j]
        nearest = f"; the nearest: t = {' and '.join(f'{times[j]:.12g}' for j in near)}" if near else ""
        raise InputError(f"{option} {shown(time if math.isnan(asked) else asked)}: not an output time of "
                         f"{self.folder} (its {len(times)} output times run from {times[0]:.12g} to "
                         f"{times[-1]:.12g}{nearest}; a time is an output's within {SAME_TIME:g}·T)")

    def mesh_snapshot(self, body: int, target: Path) -> Path:
        """A body's mesh copied to `target`: the run folder's own, as checked (runs of orchestrate),
        else the file the driver read (mesh_file)."""
        name = f"body{body}.msh"
        if name in self.files:
            return self.snapshot(name, target)
        target.write_bytes(self.mesh_file(body).read_bytes())
        return target

    def mesh_file(self, body: int) -> Path:
        """The gmsh file of a body: the run folder's copy (runs of orchestrate), else the file the
        driver read (params_used.json: a relative name as the driver resolves it, from the folder
        FreeFem++ ran in, which is not on record: the current folder or the repository)."""
        own = self.folder / f"body{body}.msh"
        if own.is_file():
            return own
        named = Path(self.params[f"meshFile{body}"])
        candidates = [named] if named.is_absolute() else [Path.cwd() / named, REPO / named]
        for path in candidates:
            if path.is_file():
                return path
        raise FileNotFoundError(f"{self.folder}: the mesh of body {body} ({named}) is not in "
                                f"{' or '.join(str(path.parent) for path in candidates)}: run compare from the folder "
                                "FreeFem++ ran in")

    def fields(self, part: str, time: float | None = None) -> meshio.Mesh:
        """The mesh and fields of one part ("body1", "body2", "contact") at an output time
        (default: the last one written; another time is refused: output_at)."""
        import meshio

        name = self.output_at(time, (part,))[1][part]
        with tempfile.TemporaryDirectory() as scratch:  # meshio reads a path: the bytes checked, in a private copy
            return meshio.read(self.snapshot(name, Path(scratch) / "part.vtu"))

    def grid(self, part: str, time: float | None = None):
        """One part at an output time (default the last; a time within 1e-9·T of an output's is
        that output's, any other is refused naming the nearest) as a pyvista dataset, for pyvista's own
        filters: a body's triangles with u, ζ (point data) and the stresses (cell data: one value
        a triangle), the contact line with gap, pressure and slip. u has a zero third component,
        so `grid.warp_by_vector("u", factor=10)` draws the deformed body, and
        `grid.sample_over_line((3, 0.5, 0), (3, 6, 0))` gives σ22 along a line
        (docs/usage.md, "Fields as pyvista datasets")."""
        import pyvista

        grid = pyvista.from_meshio(self.fields(part, time))
        if part != "contact":  # the labelled boundary edges carry no field of the body
            grid = grid.extract_cells_by_type(pyvista.CellType.TRIANGLE)
        return grid


def listed_digests(folder: Path) -> dict[str, str] | None:
    """The SHA-256 of each file of a run folder by name: its manifest's (runs of orchestrate), else
    run.json's fileDigests (a finished run of the driver by hand), else None: a run that stopped
    (run.json written at its set-up, finished false) has no record, and its files are read as
    they are (load_result refuses such a folder; a Result of it is for what a failure left)."""
    if (folder / MANIFEST).is_file():
        entries = json.loads((folder / MANIFEST).read_bytes())["files"]
        return {name: entry["sha256"] for name, entry in entries.items()}
    if (folder / FACTS).is_file():
        digests = json.loads((folder / FACTS).read_bytes()).get("fileDigests")
        return dict(digests) if isinstance(digests, dict) else None
    return None


def load_result(folder: str | Path) -> Result:
    """A complete run folder: one whose manifest matches every file (a run of orchestrate), or,
    for a folder FreeFem++ wrote by hand (run.json, no manifest), one whose files all read back
    whole (orchestrate/manifest.py). Raises FileNotFoundError for a folder that is no run, and
    IncompleteRun for one that is cut short, unfinished or changed."""
    folder = Path(folder)
    runner_files = [name for name in ("inputs.json", "summary.json", "scene.toml") if os.path.lexists(folder / name)]
    if (folder / MANIFEST).is_file():
        manifest = verify_manifest(folder)
        return Result(folder, {name: entry["sha256"] for name, entry in manifest["files"].items()})
    if runner_files:  # the runner writes its manifest last: without it the run is unfinished or changed
        raise IncompleteRun(f"{folder}: a run of orchestrate ({', '.join(runner_files)}) without its manifest.json: "
                            "unfinished, or changed since; not trusted")
    if (folder / FACTS).is_file():
        return Result(folder, dict(check_files(folder)["fileDigests"]))
    if not os.path.lexists(folder):
        raise FileNotFoundError(f"{folder} does not exist: give a run's folder")
    raise FileNotFoundError(f"{folder} is not a run folder (no manifest.json, no run.json)")


def cell_field(mesh: meshio.Mesh, name: str) -> np.ndarray:
    """A cell field on the triangles (FreeFEM's .vtu also holds boundary edges as line cells)."""
    return mesh.cell_data_dict[name]["triangle"]
