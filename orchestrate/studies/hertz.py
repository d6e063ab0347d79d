"""Hertz line contact (scenes/hertz.toml) against the analytic solution, over mesh levels.

For two cylinders' line contact (here a half-cylinder of radius R on a block, plane strain) the
elastic solution with contact force F per unit thickness is
  a = 2√(FR/(πE*)),  p0 = 2F/(πa),  p(x) = p0√(1 − x²/a²),  1/E* = (1 − ν1²)/E1 + (1 − ν2²)/E2.
Each level runs the scene with both meshes' contact-zone size 1/n; F is the computed contact force
(history.csv), and from the contact line (contact .vtu: the pressure λ_j/∫ψ_j at the nodes of θ1_h,
so the nodal forces λ_j) each segment's pressure, its force over its length (each node's force
shared among its segments as its basis function's integral over them: at degree 2 the nodal
tractions alternate between a segment's ends and its middle, a segment's force does not), and
  a_moment  = 2√(Σ λ_j x_j² / Σ λ_j), the half-width whose second moment the elliptical law has
              (exact for it: ∫p x² / ∫p = a²/4), from all the nodal forces;
  a_closed  = half the closed length of Γ_C (history.csv), resolved to the node spacing only;
  p0        = the pressure at x = 0 (a node of both meshes): c0 of the parabola c0 + c1 x + c2 x²
              whose means over the four segments nearest it fit their pressures (least squares);
  profile   = max |p_e − mean of p_analytic over e| / p0_analytic over the segments e within
              |x| < 0.9 a.
Case *force* is load control: the cylinder's top is free to move down (a roller in x only, the
body held by the contact alone: a floating body) under a uniform pressure F/(2R) whose total is
the F case *same* needed at that level; its approach (the mean descent of the top) is an output,
and *vs pressed* is the distance of its a_moment and p0 to those of *same* at the same level.
The errors are relative to the analytic values at the level's own F. They do not all fall to 0:
Hertz's law is for a parabolic gap between half-spaces, and a circle's gap exceeds x²/(2R) by
about x⁴/(8R³) (a relative a²/(4R²) at x = a: 0.4 % at the scene's approach, 0.2; the report
gives it for its runs) on bodies of finite size. The mesh's
own error is measured apart: *mesh a*, *mesh p0* are each level's distance to the finest level's
value (relative to the analytic), and their observed orders between successive levels are log2
of the ratio of those distances (each level halves the size).
Each case runs at every degree of --orders (space.order: continuous P1 or P2 displacements), its
node counts those of the displacement (at degree 2 the vertices and the edges' middles), its
nodal forces λ_j = pressure × ∫ψ_j with the degree's weights (Simpson's at degree 2). --set
changes the scene for every run (e.g. a smaller approach); the *force* case replaces body 2's
boundary conditions, so a --set of them does not reach it.
With --adapt-targets, the cases *same* and *dissimilar* also run on adapted meshes: an
`orchestrate adapt` loop per target and degree from the scene's meshes at n = --pilot (each run
with its estimate, nodes, a and p0); and for each case and degree the report gives the fewest
nodes with which each mesh family holds a and p0 within 0.2 % of Hertz's.
Writes hertz.csv, README.md, pressure.png and vonmises.png into --out (the runs are made in a
temporary folder and removed).
"""
from __future__ import annotations

import csv
import json
import math
import shlex
import tempfile
from pathlib import Path

import numpy as np

from orchestrate.adapt import adapt
from orchestrate.freefem import REPO, InputError
from orchestrate.manifest import displacement_nodes
from orchestrate.outputs import claim_folder, created, refuse_folder, write_figure, write_text
from orchestrate.progress import wanted
from orchestrate.results import cell_field, load_result
from orchestrate.runner import run
from orchestrate.scene import toml_value

NAME = "hertz"  # the command, as its folders' made-by.json records it
FILES = ("hertz.csv", "README.md", "pressure.png", "vonmises.png")
RADIUS = 8.0  # R of meshes/hertz_cylinder.geo, which scenes/hertz.toml keeps
CASES = {"same": {}, "dissimilar": {"body2.material.E": 600.0, "body2.material.nu": 0.2, "body2.material.eta": 3.0}}
LOADED = "force"  # scenes/hertz.toml under a prescribed force instead of a prescribed approach
STUDY_KEYS = ("body1.mesh.n", "body2.mesh.n", "output.images", "space.order")  # what the study sets per run
COLUMNS = ["case", "order", "mesh", "n", "target", "cycle", "estimate", "nodes1", "nodes2", "F", "a", "aMoment",
           "aClosed", "p0", "p0Computed",
           "errorA", "errorAClosed", "errorP0", "errorProfile", "meshA", "meshP0", "orderA", "orderP0",
           "approach", "pressedA", "pressedP0"]


def force_controlled(force: float) -> dict:
    """The overrides that press the cylinder by `force` (ramped like the approach, then held): a
    uniform pressure on its flat top of width 2R, which only a roller in x holds otherwise."""
    return {"body2.boundary": [{"type": "roller", "label": 2, "component": "x"},
                               {"type": "traction", "label": 2, "fy": f"-{force / (2 * RADIUS)!r}*min(t, 1)"}]}


def approach(result) -> float:
    """The mean descent of the cylinder's flat top (its highest nodes)."""
    cylinder = result.fields("body2")
    top = cylinder.points[:, 1] > cylinder.points[:, 1].max() - 1e-5 * RADIUS
    return float(-cylinder.point_data["u"][top, 1].mean())


def effective_modulus(params: dict) -> float:
    return 1 / ((1 - params["nu1"] ** 2) / params["E1"] + (1 - params["nu2"] ** 2) / params["E2"])


def analytic(force: float, radius: float, modulus: float) -> tuple[float, float]:
    """Half-width a and peak pressure p0 of the line contact for force F."""
    half_width = 2 * math.sqrt(force * radius / (math.pi * modulus))
    return half_width, 2 * force / (math.pi * half_width)


def nodal_weights(line) -> np.ndarray:
    """∫ψ_j of θ1_h's nodes from the contact line's cells: half a segment's length to each end
    (a line, degree 1), or Simpson's sixth to each end and two thirds to the middle (a quadratic
    edge, degree 2: its ends, then its middle)."""
    weight = np.zeros(len(line.points))
    cells = line.cells[0].data
    length = np.linalg.norm(line.points[cells[:, 1]] - line.points[cells[:, 0]], axis=1)
    shares = (0.5, 0.5) if cells.shape[1] == 2 else (1 / 6, 1 / 6, 2 / 3)
    for column, share in enumerate(shares):
        np.add.at(weight, cells[:, column], share * length)
    return weight


def contact_line(result) -> tuple[np.ndarray, ...]:
    """x of θ1_h's nodes and their nodal forces (pressure × ∫ψ_j); the x of each segment's middle,
    its length and its pressure (its force over its length, each node's force shared among its
    segments as its basis function's integral over them: the trapezoid's, or Simpson's, mean of
    the nodal pressures); each in x order."""
    line = result.fields("contact")
    x, pressure = line.points[:, 0], line.point_data["pressure"]
    cells = line.cells[0].data
    if cells.shape[1] == 3:
        mean = (pressure[cells[:, 0]] + 4 * pressure[cells[:, 2]] + pressure[cells[:, 1]]) / 6
    else:
        mean = (pressure[cells[:, 0]] + pressure[cells[:, 1]]) / 2
    middle, length = 0.5 * (x[cells[:, 0]] + x[cells[:, 1]]), np.abs(x[cells[:, 1]] - x[cells[:, 0]])
    nodes, segments = np.argsort(x), np.argsort(middle)
    return x[nodes], (pressure * nodal_weights(line))[nodes], middle[segments], length[segments], mean[segments]


def segment_means(a: float, p0: float, middle: np.ndarray, length: np.ndarray) -> np.ndarray:
    """The mean of the elliptical pressure over each segment (Gauss–Legendre, 8 points)."""
    points, weights = np.polynomial.legendre.leggauss(8)
    x = middle[:, None] + 0.5 * length[:, None] * points[None, :]
    return (p0 * np.sqrt(np.clip(1 - (x / a) ** 2, 0, None))) @ weights / 2


def measure(result, radius: float) -> dict:
    params, history = result.params, result.history
    force = float(history["contactForce"][-1])
    a, p0 = analytic(force, radius, effective_modulus(params))
    x, nodal, middle, length, pressure = contact_line(result)
    a_moment = 2 * math.sqrt(float(np.sum(nodal * x ** 2) / np.sum(nodal)))
    a_closed = float(history["contactLength"][-1]) / 2
    # p ≈ c0 + c1 x + c2 x² near x = 0, whose mean over a segment of middle m and length L is
    # c0 + c1 m + c2 (m² + L²/12): fitted to the four segments nearest x = 0, p0 = c0
    near = np.argsort(np.abs(middle))[:4]
    m, L = middle[near], length[near]
    p0_computed = float(np.linalg.lstsq(np.column_stack([np.ones(4), m, m ** 2 + L ** 2 / 12]), pressure[near],
                                        rcond=None)[0][0])
    inside = np.abs(middle) + length / 2 < 0.9 * a
    profile = float(np.max(np.abs(pressure[inside] - segment_means(a, p0, middle[inside], length[inside]))) / p0)
    return {"F": force, "a": a, "aMoment": a_moment, "aClosed": a_closed, "p0": p0, "p0Computed": p0_computed,
            "errorA": abs(a_moment - a) / a, "errorAClosed": abs(a_closed - a) / a,
            "errorP0": abs(p0_computed - p0) / p0, "errorProfile": profile}


def hertz(out: str | Path, levels: int = 4, coarsest: int = 8, progress: bool | str = "auto",
          force: bool = False, orders: tuple[int, ...] = (1,), settings: dict | None = None,
          adapt_targets: tuple[float, ...] = (), pilot: int = 4) -> list[dict]:
    """The cases over the mesh levels at each degree of `orders`, and with `adapt_targets` the
    cases same and dissimilar on adapted meshes (an adapt loop from n = `pilot` per target), into
    hertz.csv, README.md and the figures in `out` (a new folder, or with `force` one this study
    wrote: outputs.py); settings: scene values for every run (dotted keys, as run's overrides; not
    those the study sets); progress: each run's bar, True, False or "auto" (where one can be seen:
    progress.py)."""
    shown = wanted(progress)
    out = Path(out)
    settings = settings or {}
    taken = [key for key in settings if key in STUDY_KEYS]
    if taken:
        raise InputError(f"--set {taken[0]}: the study sets it for each run (--levels, --coarsest and --orders give the "
                         "meshes and degrees; no images)")
    wrong = [target for target in adapt_targets if not 0 < target < 1]
    if wrong:
        raise InputError(f"--adapt-targets {wrong[0]:g}: give relative estimates in (0, 1), e.g. 0.02,0.01")
    refuse_folder(out, f"study {NAME}", force)  # now, not after the runs
    rows, finest = [], {}
    with tempfile.TemporaryDirectory(prefix="hertz-") as scratch:
        for order in orders:
            def level_run(name: str, n: int, overrides: dict):
                return run(REPO / "scenes" / "hertz.toml", Path(scratch) / f"{name}-P{order}-n{n}",
                           {**overrides, "body1.mesh.n": n, "body2.mesh.n": n, "output.images": False,
                            "space.order": order}, progress=shown)

            for case, overrides in CASES.items():
                for level in range(levels):
                    n = coarsest * 2 ** level
                    result = level_run(case, n, {**settings, **overrides})
                    rows.append({"case": case, "order": order, "mesh": "graded", "n": n, **measure(result, RADIUS),
                                 **node_counts(result)})
                    finest[f"{case}, P{order}"] = (rows[-1], result)
                mesh_errors([row for row in rows if (row["case"], row["order"]) == (case, order)])
            kept = {key: value for key, value in settings.items() if not key.startswith("body2.boundary")}
            for pressed in [row for row in rows if (row["case"], row["order"]) == ("same", order)]:
                result = level_run(LOADED, pressed["n"], {**kept, **force_controlled(pressed["F"])})
                row = {"case": LOADED, "order": order, "mesh": "graded", "n": pressed["n"], **measure(result, RADIUS),
                       **node_counts(result), "approach": approach(result)}
                row["pressedA"] = abs(row["aMoment"] - pressed["aMoment"]) / pressed["aMoment"]
                row["pressedP0"] = abs(row["p0Computed"] - pressed["p0Computed"]) / pressed["p0Computed"]
                rows.append(row)
            mesh_errors([row for row in rows if (row["case"], row["order"]) == (LOADED, order)])
        for order in orders:
            for target in adapt_targets:
                for case, overrides in CASES.items():
                    rows += adapted(Path(scratch) / f"{case}-P{order}-adapt{target:g}", case, order, target, pilot,
                                    {**settings, **overrides}, shown)
        write(claim_folder(out, f"study {NAME}", FILES, force), rows, finest, levels, coarsest, orders, settings,
              adapt_targets, pilot)
    return rows


def adapted(folder: Path, case: str, order: int, target: float, pilot: int, overrides: dict, progress) -> list[dict]:
    """Each run of an adapt loop (orchestrate/adapt.py) from the scene's meshes at n = `pilot`:
    its estimate, nodes, a and p0."""
    loop = adapt(REPO / "scenes" / "hertz.toml", folder, target, progress=progress,
                 overrides={**overrides, "body1.mesh.n": pilot, "body2.mesh.n": pilot, "output.images": False,
                            "space.order": order})
    rows = []
    for cycle in loop:
        result = load_result(folder / cycle["folder"])
        rows.append({"case": case, "order": order, "mesh": "adapted", "n": pilot, "target": target,
                     "cycle": cycle["cycle"], "estimate": cycle["relative"], **measure(result, RADIUS),
                     **node_counts(result)})
    return rows


def mesh_errors(ladder: list[dict]) -> None:
    """Each level's distance to the finest level's a and p0, and the orders between levels."""
    top = ladder[-1]
    for row in ladder[:-1]:
        row["meshA"] = abs(row["aMoment"] - top["aMoment"]) / row["a"]
        row["meshP0"] = abs(row["p0Computed"] - top["p0Computed"]) / row["p0"]
    for coarse, fine in zip(ladder[:-2], ladder[1:-1]):
        for order, distance in (("orderA", "meshA"), ("orderP0", "meshP0")):
            fine[order] = math.log2(coarse[distance] / fine[distance]) if fine[distance] > 0 else float("nan")


def node_counts(result) -> dict:
    """The displacement's nodes per body (run.json: at degree 2 the vertices and the edges' middles)."""
    counts = json.loads((result.folder / "run.json").read_text())
    return {f"nodes{body}": displacement_nodes(counts, str(body)) for body in (1, 2)}


def write(out: Path, rows: list[dict], finest: dict, levels: int, coarsest: int, orders: tuple[int, ...] = (1,),
          settings: dict | None = None, adapt_targets: tuple[float, ...] = (), pilot: int = 4) -> None:
    """The table, the report and the figures; `finest` maps each case and degree to its finest
    (row, result)."""
    with created(out / "hertz.csv", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS, restval="")
        writer.writeheader()
        writer.writerows(rows)
    plot_pressure(out / "pressure.png", finest)
    plot_von_mises(out / "vonmises.png", finest[f"same, P{orders[-1]}"][1])
    write_text(out / "README.md", report(rows, levels, coarsest, orders, settings or {}, adapt_targets, pilot))


def reproduce_line(levels: int, coarsest: int, orders: tuple[int, ...], settings: dict,
                   adapt_targets: tuple[float, ...] = (), pilot: int = 4) -> str:
    line = f"python -m orchestrate study {NAME} --levels {levels} --coarsest {coarsest}"
    if orders != (1,):
        line += " --orders " + ",".join(map(str, orders))
    if adapt_targets:
        line += " --adapt-targets " + ",".join(f"{target:g}" for target in adapt_targets) + f" --pilot {pilot}"
    return line + "".join(f" --set {shlex.quote(f'{key}={toml_value(value)}')}" for key, value in settings.items())


def report(rows: list[dict], levels: int, coarsest: int, orders: tuple[int, ...] = (1,), settings: dict | None = None,
           adapt_targets: tuple[float, ...] = (), pilot: int = 4) -> str:
    def cell(row, key, digits=4):
        value = row.get(key, "")
        return "" if value == "" else f"{value:.{digits}g}"

    lines = ["# Hertz line contact against the analytic solution", "",
             "Reproduce (from the repository root):", "", "```sh",
             reproduce_line(levels, coarsest, orders, settings or {}, adapt_targets, pilot), "```", "",
             "```text", (__doc__ or "").split("\n\n", 1)[1].split("Writes")[0].strip(), "```", "",
             gap_floor(rows), "",
             "Cases: *same* is scenes/hertz.toml (E = 200, ν = 0.3 for both bodies); *dissimilar* gives the "
             "cylinder E = 600, ν = 0.2 (η = 3, the same relaxation time); *force* is *same* under the force "
             "*same* needed (its approach the scene's: 0.2 unless --set changed it), the cylinder held by the contact "
             "alone. *P1*, *P2*: the "
             "displacements' degree (space.order); nodes are the displacement's.", "",
             "| case | degree | n | nodes (block, cylinder) | F | a | a (moment) | error a | a (closed) | error | p0 | "
             "p0 computed | error p0 | profile error | mesh a | mesh p0 | order a | order p0 | approach | "
             "vs pressed a | vs pressed p0 |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]

    def percent(row, key):
        return f"{100 * row[key]:.3f} %" if key in row else ""

    for row in (row for row in rows if row["mesh"] == "graded"):
        lines.append(f"| {row['case']} | P{row['order']} | {row['n']} | {row['nodes1']}, {row['nodes2']} | {cell(row, 'F')} | "
                     f"{cell(row, 'a')} | {cell(row, 'aMoment')} | {percent(row, 'errorA')} | "
                     f"{cell(row, 'aClosed')} | {percent(row, 'errorAClosed')} | {cell(row, 'p0')} | "
                     f"{cell(row, 'p0Computed')} | {percent(row, 'errorP0')} | {percent(row, 'errorProfile')} | "
                     f"{percent(row, 'meshA')} | {percent(row, 'meshP0')} | {cell(row, 'orderA', 3)} | "
                     f"{cell(row, 'orderP0', 3)} | {cell(row, 'approach')} | {percent(row, 'pressedA')} | "
                     f"{percent(row, 'pressedP0')} |")
    adapted_rows = [row for row in rows if row["mesh"] == "adapted"]
    if adapted_rows:
        lines += adapted_report(adapted_rows, pilot, percent) + fewest_nodes(rows, orders)
    lines += ["", "![pressure](pressure.png)", "", "![von Mises](vonmises.png)", ""]
    return "\n".join(lines)


def adapted_report(rows: list[dict], pilot: int, percent) -> list[str]:
    if not rows:
        return []
    lines = ["", "## Adapted meshes", "",
             f"Cases *same* and *dissimilar* through `orchestrate adapt scenes/hertz.toml --target E` (the study's --set "
             f"too) from the scene's meshes at n = {pilot}: the pilot (cycle 0), then meshes each body's .geo makes "
             "with the sizes the Zienkiewicz–Zhu estimate of the previous run designs, until the estimate η/‖u_h‖_V "
             "is at most the target (docs/usage.md, \"Adapted meshes\").", "",
             "| case | degree | target | cycle | nodes (block, cylinder) | estimate | error a | error p0 | profile error |",
             "|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {row['case']} | P{row['order']} | {row['target']:g} | {row['cycle']} | {row['nodes1']}, {row['nodes2']} | "
              f"{percent(row, 'estimate')} | {percent(row, 'errorA')} | {percent(row, 'errorP0')} | "
              f"{percent(row, 'errorProfile')} |" for row in rows]
    return lines


WITHIN = 0.002  # the accuracy the fewest-nodes table asks of a and p0 (relative)


def fewest_nodes(rows: list[dict], orders: tuple[int, ...]) -> list[str]:
    """Per case and degree, the run with the fewest nodes (both bodies) whose a and p0 are both
    within WITHIN of Hertz's, on each mesh family (an adapt loop's pilot, the scene's own mesh, is
    not one of its designs); and P2's over P1's, the best family of each."""
    lines = ["", f"## Fewest nodes with a and p0 within {100 * WITHIN:g} %", "",
             "Nodes of both bodies; each family's run with the fewest whose a (moment) and p0 are both that close to "
             "Hertz's values (the model's floor above included).", "",
             "| case | " + " | ".join(f"P{order} graded | P{order} adapted" for order in orders)
             + (" | P2 / P1 |" if orders == (1, 2) else " |"),
             "|---|" + "---|---|" * len(orders) + ("---|" if orders == (1, 2) else "")]
    for case in dict.fromkeys(row["case"] for row in rows):
        best, cells = {}, []
        for order in orders:
            for mesh in ("graded", "adapted"):
                family = [row for row in rows if (row["case"], row["order"], row["mesh"]) == (case, order, mesh)
                          and row.get("cycle") != 0]
                good = [row for row in family if row["errorA"] <= WITHIN and row["errorP0"] <= WITHIN]
                run = min(good, key=lambda row: row["nodes1"] + row["nodes2"], default=None)
                cells.append("not run" if not family else "none" if run is None else
                             f"{run['nodes1'] + run['nodes2']} (a {100 * run['errorA']:.3f} %, p0 {100 * run['errorP0']:.3f} %)")
                if run is not None:
                    best[order] = min(best.get(order, math.inf), run["nodes1"] + run["nodes2"])
        if orders == (1, 2):
            cells.append(f"{best[2] / best[1]:.2f}" if len(best) == 2 else "-")
        lines.append(f"| {case} | " + " | ".join(cells) + " |")
    return lines


def gap_floor(rows: list[dict]) -> str:
    """How far a circle's gap is from Hertz's parabola at the edge of these runs' contact."""
    a = max(row["a"] for row in rows if (row["case"], row["mesh"]) == ("same", "graded"))
    return (f"In these runs a = {a:.4g} at most (case *same*): a circle's gap exceeds Hertz's parabola by a relative "
            f"a²/(4R²) = {100 * a * a / (4 * RADIUS ** 2):.3f} % at x = a.")


def plot_pressure(path: Path, finest: dict) -> None:
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(6.4, 4.0), constrained_layout=True)
    colours = {}  # one per case, whatever its degree; P1 hollow circles, P2 dots
    for case, (row, result) in finest.items():
        _, _, x, _, pressure = contact_line(result)  # each segment's pressure at its middle
        n, a, p0, degree = row["n"], row["a"], row["p0"], row["order"]
        colour = colours.setdefault(case.split(",")[0], f"C{len(colours)}")
        shown = np.abs(x) < 1.6 * a
        prefix = f"{case}: " if case else ""
        style = {"marker": "o", "ms": 6, "mfc": "none"} if degree == 1 else {"marker": ".", "ms": 5}
        axis.plot(x[shown], pressure[shown], ls="none", color=colour, label=f"{prefix}per segment (n = {n})", **style)
        if degree == finest_degree(finest, case):
            curve = np.linspace(-a, a, 401)
            axis.plot(curve, p0 * np.sqrt(1 - (curve / a) ** 2), "-", color=colour, lw=1,
                      label=f"{case.split(',')[0] + ': ' if case else ''}Hertz, F = {row['F']:.3g}")
    axis.set_xlabel("x (m)")
    axis.set_ylabel("contact pressure (N/m²)")
    axis.legend(fontsize=8)
    axis.grid(alpha=0.3)
    write_figure(figure, path, dpi=150)
    plt.close(figure)


def finest_degree(finest: dict, case: str) -> int:
    """The highest degree `finest` holds of the case `case` names ("same, P2" → "same"): the one
    whose analytic curve is drawn (the degrees' forces differ by less than the line's width)."""
    return max(row["order"] for key, (row, _) in finest.items() if key.split(",")[0] == case.split(",")[0])


def plot_von_mises(path: Path, result) -> None:
    """Von Mises stress (plane strain, σ33 included) of both bodies near the contact, drawn on the
    undeformed meshes (the approach is 0.2 m: the gap left between the arc and the block is the
    part of it outside the contact)."""
    import matplotlib.pyplot as plt
    import matplotlib.tri as mtri

    figure, axis = plt.subplots(figsize=(6.4, 4.0), constrained_layout=True)
    meshes = [result.fields(body) for body in ("body1", "body2")]
    top = max(float(cell_field(mesh, "vonMises").max()) for mesh in meshes)  # (cells, 1) arrays
    for mesh in meshes:
        triangles = mtri.Triangulation(mesh.points[:, 0], mesh.points[:, 1], mesh.cells_dict["triangle"])
        shading = axis.tripcolor(triangles, facecolors=cell_field(mesh, "vonMises").ravel(), vmin=0, vmax=top, cmap="viridis")
    axis.set_xlim(-2.5, 2.5)
    axis.set_ylim(-2.0, 1.2)
    axis.set_aspect("equal")
    axis.set_xlabel("x (m)")
    axis.set_ylabel("y (m)")
    figure.colorbar(shading, ax=axis, label="von Mises stress, plane strain (N/m²)")
    write_figure(figure, path, dpi=150)
    plt.close(figure)


def gallery_figures(result, folder: Path) -> list[Path]:
    """The gallery's Hertz figures of one run: its pressure against the analytic curve at its own
    F, and the von Mises stress under the contact."""
    import tomllib

    scene = tomllib.loads((result.folder / "scene.toml").read_text())
    row = {"n": scene["body1"]["mesh"]["n"], "order": scene.get("space", {}).get("order", 1), **measure(result, RADIUS)}
    paths = [folder / "pressure.png", folder / "vonmises.png"]
    plot_pressure(paths[0], {"": (row, result)})
    plot_von_mises(paths[1], result)
    return paths
