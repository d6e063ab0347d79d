"""Two runs compared in the norms of the model: python -m orchestrate compare RUN_A RUN_B.

At every time both runs saved their state (state_NNNN.txt, output.fields "state"),
edp/tools/errors.edp measures ‖u_A − u_B‖_V, ‖ζ_A − ζ_B‖_L² and ‖β_A − β_B‖_L²(Γ_C)
(docs/model.md section 11 for the symbols). The coarser run's P1 fields are interpolated onto the
finer run's meshes and integrated there; the figures are exact when the meshes are nested (every
triangle of the coarser mesh is a union of triangles of the finer one: the same mesh, or the
structured family under n → 2n), otherwise the interpolation error of the coarser run is part of
them, and the report says which. The two runs must cover the same bodies: their meshes may differ,
their domains may not.

The histories (history.csv) of both runs are drawn over each other in history.png of the
comparison folder, next to comparison.csv (one row per common time): a new folder, or with
--force one an earlier comparison wrote, whose files alone it replaces (outputs.py).
"""
from __future__ import annotations

import contextlib
import csv
import io
import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from orchestrate.freefem import REPO, run_script
from orchestrate.outputs import claim_folder, write_csv, write_text
from orchestrate.results import Result, load_result

NAME = "compare"  # the command, as its folders' made-by.json records it

QUANTITIES = ("errorV", "errorZeta", "errorBeta")
NORMS = {"errorV": "normV", "errorZeta": "normZeta", "errorBeta": "normBeta"}
SAME_TIME = 1e-6  # of the smaller time step: output times of two runs that are the same instant


def state_times(result: Result) -> list[tuple[float, Path]]:
    """(t, file) of every state the run saved (those its manifest lists: no other file of the
    folder), in time order (t is each file's first number)."""
    found = []
    for path in (result.folder / name for name in result.files if name.startswith("state_")):
        with open(path) as handle:
            found.append((float(handle.read(64).split()[0]), path))
    return sorted(found)


def common_states(a: Result, b: Result) -> list[tuple[Path, Path]]:
    """The pairs of state files of a and b at the same instants: times within SAME_TIME of the
    smaller step of each other (output times are multiples of each run's k)."""
    times_a, times_b = state_times(a), state_times(b)
    missing = [str(run.folder) for run, times in ((a, times_a), (b, times_b)) if not times]
    pairs = []
    if not missing:
        tolerance = SAME_TIME * min(a.params["k"], b.params["k"])
        for t, path in times_a:
            nearest = min(times_b, key=lambda entry: abs(entry[0] - t))
            if abs(nearest[0] - t) <= tolerance:
                pairs.append((path, nearest[1]))
    if not pairs:
        why = (f"{' and '.join(missing)} saved no state (state_NNNN.txt)" if missing
               else "they saved their states at no common time (output.times)")
        raise RuntimeError(f"cannot compare {a.folder} and {b.folder}: {why}. compare reads the unknowns from the "
                           "state files: run with output.fields including \"state\" (e.g. --set "
                           "'output.fields=[\"bodies\", \"stress\", \"contact\", \"state\"]') and common output.times")
    return pairs


def instant_distances(run: Path, reference: Path, run_steps: int, reference_steps: int, instants: int) -> list[dict]:
    """errors.edp between two run folders at the shared instants j/instants·T, j = 1..instants
    (their state files of those steps)."""
    pairs = [tuple(folder / f"state_{j * steps // instants:04d}.txt"
                   for folder, steps in ((run, run_steps), (reference, reference_steps))) for j in range(1, instants + 1)]
    return pair_distances(load_result(run), load_result(reference), pairs)


def pair_distances(run: Result, reference: Result, pairs: list[tuple[Path, Path]]) -> list[dict]:
    """errors.edp on pairs of state files (of `run`, of `reference`): one row per pair. The tool
    reads file names from its pairs file as words, so it runs in a scratch folder that links every
    file it needs under a plain name."""
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        for side, result in (("run", run), ("ref", reference)):
            for body in (1, 2):
                (scratch / f"{side}{body}.msh").symlink_to(result.mesh_file(body).resolve())
        lines = []
        for j, (state, reference_state) in enumerate(pairs):
            (scratch / f"run_{j:04d}.txt").symlink_to(Path(state).resolve())
            (scratch / f"ref_{j:04d}.txt").symlink_to(Path(reference_state).resolve())
            lines.append(f"run_{j:04d}.txt ref_{j:04d}.txt")
        (scratch / "pairs.txt").write_text(f"{len(lines)}\n" + "\n".join(lines) + "\n")
        done = run_script(REPO / "edp" / "tools" / "errors.edp",
                          ["-mesh1", "run1.msh", "-mesh2", "run2.msh", "-refMesh1", "ref1.msh", "-refMesh2", "ref2.msh",
                           "-pairs", "pairs.txt", "-out", "errors.csv"], cwd=scratch)
        if done.returncode != 0:
            raise RuntimeError(f"errors.edp failed for {run.folder} against {reference.folder}: {done.error_line}")
        with open(scratch / "errors.csv") as handle:
            return [{key: float(value) for key, value in row.items()} for row in csv.DictReader(handle)]


def triangulation(path: Path):
    """The nodes and triangles of a gmsh mesh file."""
    import meshio

    with contextlib.redirect_stdout(io.StringIO()):  # meshio's gmsh reader prints an empty line
        mesh = meshio.read(path)
    return mesh.points[:, :2], mesh.cells_dict["triangle"]


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


def differing_parameters(a: Result, b: Result) -> dict[str, tuple]:
    """The parameters whose values differ, from each run's params_used.json (mesh files aside)."""
    skip = {"out", "meshFile1", "meshFile2", "mesh1", "mesh2", "restart"}
    names = [name for name in {**a.params, **b.params} if name not in skip]
    return {name: (a.params.get(name), b.params.get(name)) for name in names if a.params.get(name) != b.params.get(name)}


@dataclass
class Comparison:
    """Two runs' distances at their common times. `reference` is the run whose meshes carry the
    integrals and whose norms the relative figures use: the one with more nodes, else the one with
    more steps, else b."""
    a: Result
    b: Result
    reference: str                       # "a" or "b"
    nested: bool                         # the other run's meshes nest in the reference's: exact figures
    rows: list[dict] = field(default_factory=list)  # t, errorV, errorZeta, errorBeta, normV, normZeta, normBeta
    parameters: dict[str, tuple] = field(default_factory=dict)
    meshes: list[dict] = field(default_factory=list)  # per body: nodes and triangles of a and b, same (one mesh)

    def maximum(self, quantity: str) -> float:
        """The largest distance over the common times (Theorem 2.1's norm of the seed: max in time)."""
        return max(row[quantity] for row in self.rows)

    def relative(self, quantity: str) -> float:
        """The largest distance over the largest norm of the reference run (0 when both are 0)."""
        return ratio(self.maximum(quantity), max(row[NORMS[quantity]] for row in self.rows))

    def report(self) -> str:
        reference = self.a if self.reference == "a" else self.b
        lines = [f"A: {self.a.folder}", f"B: {self.b.folder}"]
        lines += [f"  {name}: {value_a} (A), {value_b} (B)" for name, (value_a, value_b) in self.parameters.items()]
        lines += [f"  body {body} mesh: " + ("the same, " if mesh["same"] else "") +
                  f"{mesh['nodes'][0]} nodes, {mesh['triangles'][0]} triangles (A); "
                  f"{mesh['nodes'][1]} nodes, {mesh['triangles'][1]} triangles (B)" for body, mesh in enumerate(self.meshes, 1)]
        lines.append(f"integrated on the meshes of {self.reference.upper()} ({reference.folder.name}); "
                     + ("the other's meshes nest in them: the figures are exact" if self.nested else
                        "the other's meshes do not nest in them: its interpolation error is part of the figures"))
        lines.append(f"relative: to the norm of {self.reference.upper()} at that time; in the row max, the largest "
                     "distance over the largest norm")
        lines.append(f"{'t':>10}  {'‖uA−uB‖_V':>12} {'relative':>10}  {'‖ζA−ζB‖_L2':>12} {'relative':>10}  "
                     f"{'‖βA−βB‖_L2':>12} {'relative':>10}")
        for row in self.rows:
            cells = [f"{row[q]:12.4e} {ratio(row[q], row[NORMS[q]]):10.3e}" for q in QUANTITIES]
            lines.append(f"{row['t']:10.6g}  " + "  ".join(cells))
        cells = [f"{self.maximum(q):12.4e} {self.relative(q):10.3e}" for q in QUANTITIES]
        lines.append(f"{'max':>10}  " + "  ".join(cells))
        return "\n".join(lines)


def ratio(distance: float, norm: float) -> float:
    return distance / norm if norm > 0 else (0.0 if distance == 0 else math.inf)


def compare(run_a: str | Path | Result, run_b: str | Path | Result) -> Comparison:
    """The distances of two complete runs (load_result) at every time both saved their state."""
    a, b = (run if isinstance(run, Result) else load_result(run) for run in (run_a, run_b))
    pairs = common_states(a, b)
    files = {run: [run.mesh_file(body) for body in (1, 2)] for run in (a, b)}
    meshes = {run: [triangulation(path) for path in paths] for run, paths in files.items()}  # each read once
    for body in (0, 1):
        covers_one_body(meshes[a][body], meshes[b][body], (files[a][body], files[b][body]))
    nodes = {run: sum(len(points) for points, _ in meshes[run]) for run in (a, b)}
    finer = (nodes[a], a.params["N"]) > (nodes[b], b.params["N"])
    reference = "a" if finer else "b"
    run, ref = (b, a) if finer else (a, b)
    nested = all(nests(coarse, fine) for coarse, fine in zip(meshes[run], meshes[ref]))
    ordered = [(second, first) for first, second in pairs] if reference == "a" else pairs
    rows = pair_distances(run, ref, ordered)
    return Comparison(a, b, reference, nested, rows, differing_parameters(a, b), mesh_differences(meshes[a], meshes[b]))


def mesh_differences(first: list, second: list) -> list[dict]:
    """Per body, the node and triangle counts of two runs' meshes and whether they are one mesh
    (the same nodes and triangles, in the same order)."""
    return [{"nodes": (len(p), len(q)), "triangles": (len(s), len(t)),
             "same": p.shape == q.shape and s.shape == t.shape and bool((p == q).all() and (s == t).all())}
            for (p, s), (q, t) in zip(first, second)]


FILES = ("comparison.csv", "report.txt", "history.png")


def write(comparison: Comparison, out: Path, dpi: int = 110, force: bool = False) -> None:
    """comparison.csv, report.txt and history.png (the two histories over each other) in `out`: a
    new folder, or with `force` one an earlier compare wrote (outputs.py)."""
    from orchestrate.render import plot_history

    claim_folder(out, NAME, FILES, force)
    write_csv(out / "comparison.csv", comparison.rows, ["t", *QUANTITIES, *NORMS.values()])
    write_text(out / "report.txt", comparison.report() + "\n")
    plot_history({"A": comparison.a, "B": comparison.b}, out / "history.png", dpi=dpi)
