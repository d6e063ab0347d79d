"""Two runs compared in the norms of the model: python -m orchestrate compare RUN_A RUN_B.

At every time either run saved its state (state_NNNN.txt, output.fields "state") within the
interval both cover, edp/tools/errors.edp measures ‖u_A − u_B‖_V, ‖ζ_A − ζ_B‖_L² and
‖β_A − β_B‖_L²(Γ_C) (docs/model.md section 11 for the symbols). A run that saved no state at one
of those times is interpolated linearly in time between its neighbouring states (the report
marks it). The integrals are taken on the reference's meshes (the reference: the run with more
displacement nodes, then the higher degree, then more steps), the other run's strains (exact in
their own space on its mesh) and ζ evaluated at their quadrature points; the figures are exact
when the meshes are nested (every triangle of the other's mesh is a union of triangles of the
reference's: the same mesh, or the structured family under n → 2n) and the other's displacements
are of a degree not above the reference's (P1 in P2, not P2 in P1); otherwise the reference
triangles that straddle the other's element edges integrate a jump, a small error without a
systematic sign (docs/model-choices.md, "Error norms between meshes"), and the report says which.
The two runs must cover the same bodies: their meshes may differ, their domains may not.

The histories (history.csv) of both runs are drawn over each other in history.png of the
comparison folder, next to comparison.csv (one row per time): a new folder, or with
--force one an earlier comparison wrote, whose files alone it replaces (outputs.py).
"""
from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
import math
import tempfile
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from orchestrate.freefem import REPO, run_script
from orchestrate.manifest import FACTS, STATE_ARRAYS, parse_state, write_state
from orchestrate.outputs import claim_folder, write_csv, write_text
from orchestrate.results import Result, load_result

NAME = "compare"  # the command, as its folders' made-by.json records it

QUANTITIES = ("errorV", "errorZeta", "errorBeta")
NORMS = {"errorV": "normV", "errorZeta": "normZeta", "errorBeta": "normBeta"}
SAME_TIME = 1e-9  # relative: two output times that are one instant (edp/tools/errors.edp's rule)


def same_instant(t: float, u: float) -> bool:
    return abs(t - u) <= SAME_TIME * max(abs(t), abs(u))


def state_times(result: Result) -> list[tuple[float, str]]:
    """(t, file name) of every state the run saved (those its manifest lists: no other file of the
    folder), in time order (t is each file's first number, of the bytes the manifest records)."""
    return sorted((float(result.read(name).split(maxsplit=1)[0]), name) for name in result.files if name.startswith("state_"))


def paired_states(a: Result, b: Result, scratch: Path) -> list[tuple[Path, Path, str]]:
    """(state of a, state of b, which run was interpolated: "A", "B" or "") at every time either
    run saved its state within the interval both cover, each a file of `scratch`: a saved state as
    its run's manifest records it (Result.snapshot), so that the tools read one version of each run.
    Times within SAME_TIME of each other are one instant (output times are multiples of each run's k,
    to round-off), as errors.edp takes them; at a time one run did not save, its state is the linear
    interpolation in time of its two neighbours."""
    runs = {"A": a, "B": b}
    times = {"A": state_times(a), "B": state_times(b)}
    missing = [str(run.folder) for run, saved in ((a, times["A"]), (b, times["B"])) if not saved]
    if missing:
        refuse(a, b, f"{' and '.join(missing)} saved no state (state_NNNN.txt)")
    start = max(saved[0][0] for saved in times.values())
    end = min(saved[-1][0] for saved in times.values())
    instants = []
    for t, _ in sorted(times["A"] + times["B"]):
        inside = (start <= t or same_instant(t, start)) and (t <= end or same_instant(t, end))
        if inside and not (instants and same_instant(t, instants[-1])):
            instants.append(t)
    if not instants:
        refuse(a, b, "the times at which they saved their states (output.times) do not overlap")
    pairs = []
    for j, t in enumerate(instants):
        files, interpolated = [], ""
        for side, saved in times.items():
            nearest = min(saved, key=lambda entry: abs(entry[0] - t))
            target = scratch / f"{side}_{j:04d}.txt"
            if same_instant(nearest[0], t):
                files.append(runs[side].snapshot(nearest[1], target))
            else:
                files.append(interpolated_state(runs[side], saved, t, target))
                interpolated = side
        pairs.append((files[0], files[1], interpolated))
    return pairs


def refuse(a: Result, b: Result, why: str) -> None:
    raise RuntimeError(f"cannot compare {a.folder} and {b.folder}: {why}. compare reads the unknowns from the "
                       "state files: run with output.fields including \"state\" (e.g. --set "
                       "'output.fields=[\"bodies\", \"stress\", \"contact\", \"state\"]') and output.times "
                       "that overlap")


def degree(result: Result) -> int:
    """The degree of a run's displacements (params_used.json's order; 1 for a run from before it)."""
    order = result.params.get("order", 1)
    if order not in (1, 2):
        raise RuntimeError(f"{result.folder}: params_used.json gives order = {order!r}, not a degree the driver has (1, 2)")
    return order


def interpolated_state(result: Result, saved: list[tuple[float, str]], t: float, out: Path) -> Path:
    """The state at t between two saved states of one run (linear in time: second order), written in
    the format of edp/lib/stateFile.idp. The trace coordinates s are the run's own and do not change
    with time."""
    after = next(j for j, (time, _) in enumerate(saved) if time > t)
    (t0, name0), (t1, name1) = saved[after - 1], saved[after]
    first, second = parse_state(result.read(name0)), parse_state(result.read(name1))
    if not np.array_equal(first["s"], second["s"]):
        raise RuntimeError(f"{result.folder}: {name0} and {name1}: their trace coordinates differ, not states of one run")
    weight = (t - t0) / (t1 - t0)
    write_state(out, {"t": t, **{name: (1 - weight) * first[name] + weight * second[name] for name in STATE_ARRAYS},
                      "s": first["s"]})
    return out


def instant_distances(run: Path, reference: Path, run_steps: int, reference_steps: int, instants: int) -> list[dict]:
    """errors.edp between two run folders at the shared instants j/instants·T, j = 1..instants
    (their state files of those steps, as their manifests record them)."""
    results = (load_result(run), load_result(reference))
    with tempfile.TemporaryDirectory() as scratch:
        pairs = [tuple(result.snapshot(f"state_{j * steps // instants:04d}.txt", Path(scratch) / f"{side}_{j:04d}.txt")
                       for side, result, steps in (("run", results[0], run_steps), ("ref", results[1], reference_steps)))
                 for j in range(1, instants + 1)]
        return pair_distances(*results, pairs)


def pair_distances(run: Result, reference: Result, pairs: list[tuple[Path, Path]]) -> list[dict]:
    """errors.edp on pairs of state files (of `run`, of `reference`: private copies, paired_states'
    or instant_distances'): one row per pair. The tool reads file names from its pairs file as
    words, so it runs in a scratch folder that holds every file it needs under a plain name (the
    meshes as the runs' manifests record them)."""
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        for side, result in (("run", run), ("ref", reference)):
            for body in (1, 2):
                result.mesh_snapshot(body, scratch / f"{side}{body}.msh")
        lines = []
        for j, (state, reference_state) in enumerate(pairs):
            (scratch / f"run_{j:04d}.txt").symlink_to(Path(state).resolve())
            (scratch / f"ref_{j:04d}.txt").symlink_to(Path(reference_state).resolve())
            lines.append(f"run_{j:04d}.txt ref_{j:04d}.txt")
        (scratch / "pairs.txt").write_text(f"{len(lines)}\n" + "\n".join(lines) + "\n")
        done = run_script(REPO / "edp" / "tools" / "errors.edp",
                          ["-mesh1", "run1.msh", "-mesh2", "run2.msh", "-refMesh1", "ref1.msh", "-refMesh2", "ref2.msh",
                           "-pairs", "pairs.txt", "-out", "errors.csv"], cwd=scratch,
                          defines={"RUNORDER": str(degree(run)), "REFORDER": str(degree(reference))})
        if done.returncode != 0:
            raise RuntimeError(f"errors.edp failed for {run.folder} against {reference.folder}: {done.error_line}")
        with open(scratch / "errors.csv") as handle:
            return [{key: float(value) for key, value in row.items()} for row in csv.DictReader(handle)]


def triangulation(path: Path):
    """The nodes and triangles of a run's mesh file: gmsh's format, or FreeFEM's, in which a run
    holds a mesh with triangles below gmshload's area limit (orchestrate/mesh.py, write_freefem):
    "nv nt nbe", nv lines "x y label", nt lines "i j k region" numbered from 1, then the edges."""
    with open(path, "rb") as handle:
        gmsh = handle.read(11) == b"$MeshFormat"
    if not gmsh:
        numbers = np.array(Path(path).read_bytes().split(), dtype=float)
        nodes, triangles = int(numbers[0]), int(numbers[1])
        points = numbers[3: 3 + 3 * nodes].reshape(nodes, 3)[:, :2]
        corners = numbers[3 + 3 * nodes: 3 + 3 * nodes + 4 * triangles].reshape(triangles, 4)[:, :3]
        return points, corners.astype(int) - 1
    import meshio

    with contextlib.redirect_stdout(io.StringIO()):  # meshio's gmsh reader prints an empty line
        mesh = meshio.read(path)
    return mesh.points[:, :2], mesh.cells_dict["triangle"]


def nodes_of_degree(points: np.ndarray, triangles: np.ndarray, order: int) -> int:
    """The nodes of a displacement of degree `order` on a mesh: its vertices, and at degree 2 its
    edges' middles."""
    if order == 1:
        return len(points)
    edges = np.sort(triangles[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    return len(points) + len(np.unique(edges, axis=0))


def area(points: np.ndarray, triangles: np.ndarray) -> float:
    u, v = (points[triangles[:, j]] - points[triangles[:, 0]] for j in (1, 2))
    return float(np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]).sum() / 2)


def edge_lengths(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    return np.linalg.norm(points[triangles] - points[np.roll(triangles, 1, axis=1)], axis=-1)


def covers_one_body(first, second, names) -> None:
    """Raises unless two meshes (points, triangles) cover one body: their bounding boxes within the
    larger mesh size of each other and their areas within 1 % (a curved side's polygon changes
    with h); `names` say which in the message."""
    meshes = (first, second)
    size = max(edge_lengths(*mesh).max() for mesh in meshes)
    boxes = [np.concatenate([points.min(axis=0), points.max(axis=0)]) for points, _ in meshes]
    areas = [area(*mesh) for mesh in meshes]
    if np.abs(boxes[0] - boxes[1]).max() > size or not math.isclose(*areas, rel_tol=0.01):
        raise RuntimeError(f"{names[0]} and {names[1]} are not meshes of the same body (areas {areas[0]:.6g} and "
                           f"{areas[1]:.6g}, bounding boxes {np.round(boxes[0], 6).tolist()} and "
                           f"{np.round(boxes[1], 6).tolist()}): compare runs of one scene, with its meshes refined "
                           "or its steps or data changed")


def nests(coarse, fine) -> bool:
    """Every triangle of the fine mesh lies in one triangle of the coarse mesh (so a P1 field of the
    coarse mesh is P1 on the fine one, and its interpolation there is exact); meshes as
    (points, triangles)."""
    from matplotlib.tri import Triangulation

    points, triangles = coarse
    fine_points, fine_triangles = fine
    corners = fine_points[fine_triangles]                      # (triangles, 3 corners, 2)
    found = Triangulation(*points.T, triangles).get_trifinder()(*corners.mean(axis=1).T)
    if (found < 0).any():
        return False
    a, b, c = (points[triangles[found, j]] for j in range(3))
    matrix = np.stack([b - a, c - a], axis=-1)                 # (triangles, 2, 2)
    local = np.einsum("tij,tkj->tki", np.linalg.inv(matrix), corners - a[:, None])  # barycentric (λ1, λ2)
    size = math.sqrt(area(points, triangles) / len(triangles))
    tolerance = 1e-9 * max(1.0, float(np.abs(points).max()) / size)
    return bool((local >= -tolerance).all() and (local.sum(axis=-1) <= 1 + tolerance).all())


def scene_differences(a: Result, b: Result) -> dict[str, tuple]:
    """Every difference between the problems two runs solved, by name: for two runs of
    orchestrate, every key of their scenes (scene.toml: the material, loads, boundary conditions
    by label, initial data, mesh keys, time grid; the title and what a run writes aside); for a run
    of the driver by hand, every parameter (params_used.json; those of the meshes and the outputs
    aside) and the code of its scene file (run.json's sceneCode: its loads, conditions and initial
    data). The meshes by content either way."""
    if "scene.toml" in a.files and "scene.toml" in b.files:
        values = [{key: value for key, value in flat(tomllib.loads(run.read("scene.toml").decode())).items()
                   if key != "title" and not key.startswith("output.")} for run in (a, b)]
    else:
        skip = {"out", "restart", "runIdentity", "solverIdentity", "checkpointEvery", "checkpointSeconds", "outTimes",
                "outFields", "measureSolves", "memoryLimitMB",
                *(f"{name}{body}" for name in ("meshFile", "mesh", "geo", "n") for body in (1, 2))}
        values = [{**{"order": 1}, **{name: value for name, value in run.params.items() if name not in skip},
                   "scene file's code (loads, conditions, initial data)": json.loads(run.read(FACTS)).get("sceneCode")}
                  for run in (a, b)]  # order 1: what a run from before the parameter ran with
    names = list(dict.fromkeys([*values[0], *values[1]]))
    found = {name: (values[0].get(name), values[1].get(name)) for name in names if values[0].get(name) != values[1].get(name)}
    with tempfile.TemporaryDirectory() as scratch:
        for body in (1, 2):
            contents = [hashlib.sha256(run.mesh_snapshot(body, Path(scratch) / f"{side}.msh").read_bytes()).hexdigest()
                        for side, run in (("a", a), ("b", b))]
            if contents[0] != contents[1]:
                found[f"body {body}'s mesh (by content)"] = tuple(f"SHA-256 {digest[:12]}…" for digest in contents)
    return found


def flat(table: dict, prefix: str = "") -> dict:
    """A scene's keys as dotted names; a body's boundary conditions by their label (and component,
    where a label carries two), as --set names them: body1.boundary[label=4].fy, whatever their
    order in the list."""
    found = {}
    for key, value in table.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            found |= flat(value, f"{name}.")
        elif key == "boundary" and isinstance(value, list) and all(isinstance(item, dict) for item in value):
            labels = [item.get("label") for item in value]
            for item in value:
                which = f"label={item.get('label')}" + (f", component={item.get('component')}"
                                                       if labels.count(item.get("label")) > 1 else "")
                found |= flat({k: v for k, v in item.items() if k != "label"}, f"{name}[{which}].")
        else:
            found[name] = value
    return found


@dataclass
class Comparison:
    """Two runs' distances at their common times. `reference` is the run whose meshes carry the
    integrals and whose norms the relative figures use: the one with more displacement nodes, else
    the one of the higher degree, else the one with more steps, else b."""
    a: Result
    b: Result
    reference: str                       # "a" or "b"
    nested: bool                         # the other run's meshes nest in the reference's, its degree not above: exact
    rows: list[dict] = field(default_factory=list)  # t, errorV, errorZeta, errorBeta, normV, normZeta, normBeta,
    #                                                 interpolated ("A", "B": whose state is interpolated in time; "")
    differences: dict[str, tuple] = field(default_factory=dict)  # by name: (value of a, value of b)
    meshes: list[dict] = field(default_factory=list)  # per body: nodes, triangles and displacement nodes of a and
    #                                                   b, same (one mesh)

    def maximum(self, quantity: str, common: bool = False) -> float:
        """The largest distance over the compared times (Theorem 2.1's norm of the seed: max in time),
        or with `common` over the times both runs saved (no interpolation error in it)."""
        return max(row[quantity] for row in self.chosen(common))

    def relative(self, quantity: str, common: bool = False) -> float:
        """The largest distance over the largest norm of the reference run (0 when both are 0)."""
        return ratio(self.maximum(quantity, common), max(row[NORMS[quantity]] for row in self.chosen(common)))

    def chosen(self, common: bool) -> list[dict]:
        return [row for row in self.rows if not row["interpolated"]] if common else self.rows

    def report(self) -> str:
        reference = self.a if self.reference == "a" else self.b
        lines = [f"A: {self.a.folder}", f"B: {self.b.folder}"]
        if self.differences:
            lines.append("what the two runs solve differs in:")
            lines += [f"  {name}: {value_a!r} (A), {value_b!r} (B)" for name, (value_a, value_b) in self.differences.items()]
        else:
            lines.append("the same problem: every scene key (loads, conditions, initial data) and the meshes' content")
        lines += [f"  body {body} mesh: " + ("the same, " if mesh["same"] else "") +
                  "; ".join(mesh_counts(mesh, run, degree(result)) for run, result in enumerate((self.a, self.b)))
                  for body, mesh in enumerate(self.meshes, 1)]
        lines.append(f"integrated on the meshes of {self.reference.upper()} ({reference.folder.name}); "
                     + ("the other's meshes nest in them: the figures are exact" if self.nested else
                        "the other's meshes do not nest in them, or its degree is higher: the reference triangles "
                        "across its element edges err a little in the figures"))
        lines.append(f"relative: to the norm of {self.reference.upper()} at that time; in the row max, the largest "
                     "distance over the largest norm")
        interpolated = any(row["interpolated"] for row in self.rows)
        if interpolated:
            lines.append("a run marked after t saved no state at that time: its state there is the linear "
                         "interpolation in time of its neighbours, whose error (second order in the interval "
                         "between them) is part of that row; the row 'max, common' is over the times both saved")
        lines.append(f"{'t':>10}     {'‖uA−uB‖_V':>12} {'relative':>10}  {'‖ζA−ζB‖_L2':>12} {'relative':>10}  "
                     f"{'‖βA−βB‖_L2':>12} {'relative':>10}")
        for row in self.rows:
            cells = [f"{row[q]:12.4e} {ratio(row[q], row[NORMS[q]]):10.3e}" for q in QUANTITIES]
            lines.append(f"{row['t']:10.6g} {row['interpolated']:>2}  " + "  ".join(cells))
        cells = [f"{self.maximum(q):12.4e} {self.relative(q):10.3e}" for q in QUANTITIES]
        lines.append(f"{'max':>10}     " + "  ".join(cells))
        if interpolated and self.chosen(True):
            cells = [f"{self.maximum(q, True):12.4e} {self.relative(q, True):10.3e}" for q in QUANTITIES]
            lines.append(f"{'max, common':>14} " + "  ".join(cells))
        return "\n".join(lines)


def mesh_counts(mesh: dict, run: int, order: int) -> str:
    """A run's mesh of a body in the report: its nodes and triangles, and at degree 2 the nodes of
    its displacement (which choose the reference)."""
    own = f", {mesh['displacementNodes'][run]} nodes of its P2 displacement" if order == 2 else ""
    return f"{mesh['nodes'][run]} nodes, {mesh['triangles'][run]} triangles{own} ({'AB'[run]})"


def ratio(distance: float, norm: float) -> float:
    return distance / norm if norm > 0 else (0.0 if distance == 0 else math.inf)


def compare(run_a: str | Path | Result, run_b: str | Path | Result) -> Comparison:
    """The distances of two complete runs (load_result) at every time either saved its state
    (paired_states: the other's state interpolated in time where it saved none)."""
    a, b = (run if isinstance(run, Result) else load_result(run) for run in (run_a, run_b))
    files = {run: [run.mesh_file(body) for body in (1, 2)] for run in (a, b)}
    with tempfile.TemporaryDirectory() as scratch:  # each read once, as the manifest records it
        meshes = {run: [triangulation(run.mesh_snapshot(body, Path(scratch) / f"{side}{body}.msh")) for body in (1, 2)]
                  for side, run in (("a", a), ("b", b))}
    for body in (0, 1):
        covers_one_body(meshes[a][body], meshes[b][body], (files[a][body], files[b][body]))
    nodes = {run: sum(nodes_of_degree(points, triangles, degree(run)) for points, triangles in meshes[run])
             for run in (a, b)}
    finer = (nodes[a], degree(a), a.params["N"]) > (nodes[b], degree(b), b.params["N"])
    reference = "a" if finer else "b"
    run, ref = (b, a) if finer else (a, b)
    nested = degree(run) <= degree(ref) and all(nests(coarse, fine) for coarse, fine in zip(meshes[run], meshes[ref]))
    with tempfile.TemporaryDirectory() as scratch:
        pairs = paired_states(a, b, Path(scratch))
        ordered = [(second, first) if reference == "a" else (first, second) for first, second, _ in pairs]
        rows = pair_distances(run, ref, ordered)
    for row, (_, _, interpolated) in zip(rows, pairs):
        row["interpolated"] = interpolated
    return Comparison(a, b, reference, nested, rows, scene_differences(a, b),
                      mesh_differences(meshes[a], meshes[b], (degree(a), degree(b))))


def mesh_differences(first: list, second: list, degrees: tuple[int, int]) -> list[dict]:
    """Per body, the node and triangle counts of two runs' meshes, their displacements' nodes at
    the runs' degrees, and whether they are one mesh (the same nodes and triangles, in the same
    order)."""
    return [{"nodes": (len(p), len(q)), "triangles": (len(s), len(t)),
             "displacementNodes": (nodes_of_degree(p, s, degrees[0]), nodes_of_degree(q, t, degrees[1])),
             "same": p.shape == q.shape and s.shape == t.shape and bool((p == q).all() and (s == t).all())}
            for (p, s), (q, t) in zip(first, second)]


FILES = ("comparison.csv", "report.txt", "history.png")


def write(comparison: Comparison, out: Path, dpi: int = 110, force: bool = False) -> None:
    """comparison.csv, report.txt and history.png (the two histories over each other) in `out`: a
    new folder, or with `force` one an earlier compare wrote (outputs.py)."""
    from orchestrate.render import plot_history

    claim_folder(out, NAME, FILES, force)
    write_csv(out / "comparison.csv", comparison.rows, ["t", *QUANTITIES, *NORMS.values(), "interpolated"])
    write_text(out / "report.txt", comparison.report() + "\n")
    plot_history({"A": comparison.a, "B": comparison.b}, out / "history.png", dpi=dpi)
