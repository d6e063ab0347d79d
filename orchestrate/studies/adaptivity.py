"""Meshes adapted to the error estimate on the paper's scene, against the true error.

`python -m orchestrate adapt` (orchestrate/adapt.py) from the paper's uniform pilot (scenes/paper.toml,
n = 24; at degree 2, --order 2, n1 = 12, n2 = 16 and lower targets; bdf2 with N = 10, whose time
error is 1e-5 of ‖u‖_V) at each target; every run of each loop
is compared with a reference on the graded meshes (scenes/paper_graded.toml, n1 = 192, n2 = 88,
P2, bdf2 N = 36: the benchmark's, 0.013 % from its independent check there): the true error
‖u(T) − u_ref(T)‖_V/‖u_ref(T)‖_V beside the estimate η/‖u_h‖_V, and their ratio, the effectivity
index; the errors in ζ and β against the same meshes at the loops' N, and the family's rates.
Writes adaptivity.csv (one row per run of every loop), README.md and adaptivity.png (body 1's
adapted mesh of one target, and error against nodes) into --out (the runs in a temporary folder).
"""
from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from orchestrate.adapt import adapt
from orchestrate.compare import compare, triangulation
from orchestrate.freefem import REPO
from orchestrate.outputs import claim_folder, refuse_folder, write_csv, write_figure, write_text
from orchestrate.plots import pyplot
from orchestrate.progress import wanted
from orchestrate.results import load_result
from orchestrate.runner import run
from orchestrate.studies.convergence import slope
from orchestrate.studies.reports import LABELS, QUANTITIES as ERRORS, reproduce

NAME = "adaptivity"
FILES = ("adaptivity.csv", "README.md", "adaptivity.png")
SCENE = REPO / "scenes" / "paper.toml"
SCHEME = {"time.scheme": "bdf2", "time.N": 10, "output.images": False}
COLUMNS = ["target", "cycle", "nodes", "estimate", "error", "effectivity", "errorZeta", "errorBeta", "seconds",
           "loopSeconds"]


@dataclass(frozen=True)
class Size:
    targets: tuple[float, ...]
    reference: tuple[int, int]  # the graded reference's n1, n2
    shown: float                # the target whose last mesh the figure draws
    accuracy: float             # the reference's own relative error in ‖u‖_V, checked independently
    pilot: tuple[int, int] = (24, 32)  # the uniform pilot's n1, n2 (the scene's own)
    referenceOrder: int = 1     # the degree of the reference's displacements
    checked: str = "tests/test_adapt.py"  # where its accuracy was measured


# The benchmark's reference (graded P2, n1 = 192) is 0.013 % from its independent check (results/bench;
# the P1 one at n1 = 384 used before is 0.18 % from it, docs/model-choices.md, "Error norms between
# meshes"); P1 at n1 = 48 is about 1 % (tests/test_adapt.py).
BENCH_REFERENCE = {"reference": (192, 88), "accuracy": 1.3e-4, "referenceOrder": 2, "checked": "results/bench"}
FULL = Size((0.02, 0.01, 0.005, 0.002), shown=0.02, pilot=(24, 32), **BENCH_REFERENCE)
SMALL = Size((0.03,), (48, 22), 0.03, 1e-2)
# Degree 2: its uniform n = 24 already meets 1 %, and its estimate is about 0.6 of the error: lower
# targets from a coarser pilot.
FULL_ORDER2 = Size((0.005, 0.002, 0.001, 0.0005), shown=0.001, pilot=(12, 16), **BENCH_REFERENCE)
SIZES = {1: FULL, 2: FULL_ORDER2}  # the command's, per degree
RATE_ABOVE = 10  # designs whose error is at least this many times the reference's own give the rates


def adaptivity(out: str | Path, size: Size = FULL, order: int = 1, progress: bool | str = "auto",
               force: bool = False) -> list[dict]:
    """The study at `size`, its adapted runs' displacements of degree `order` (the reference's
    degree is the size's)."""
    shown = wanted(progress)
    out = Path(out)
    refuse_folder(out, f"study {NAME}", force)
    rows, meshes = [], None
    with tempfile.TemporaryDirectory(prefix="adaptivity-") as scratch:
        scratch = Path(scratch)
        n1, n2 = size.reference
        graded = {**SCHEME, "body1.mesh.n": n1, "body2.mesh.n": n2, "space.order": size.referenceOrder}
        reference = run(REPO / "scenes" / "paper_graded.toml", scratch / "reference", {**graded, "time.N": 36},
                        progress=shown)
        # ζ and β carry a time error at N = 10 far above their space error: they are compared
        # with the reference's meshes at the loops' own steps
        same_steps = run(REPO / "scenes" / "paper_graded.toml", scratch / "same-steps", graded, progress=shown)
        for target in size.targets:
            start = time.perf_counter()
            pilot = {"body1.mesh.n": size.pilot[0], "body2.mesh.n": size.pilot[1]}
            loop = adapt(SCENE, scratch / f"adapt-{target:g}", target,
                         overrides={**SCHEME, **pilot, "space.order": order}, progress=shown)
            spent = time.perf_counter() - start
            for row in loop:
                result = load_result(scratch / f"adapt-{target:g}" / row["folder"])
                distance = compare(result, reference).rows[-1]
                error = distance["errorV"] / distance["normV"]
                in_space = compare(result, same_steps).rows[-1]
                rows.append({"target": target, "cycle": row["cycle"], "nodes": row["nodes1"] + row["nodes2"],
                             "estimate": row["relative"], "error": error, "effectivity": row["relative"] / error,
                             "errorZeta": in_space["errorZeta"], "errorBeta": in_space["errorBeta"],
                             "seconds": row["seconds"], "loopSeconds": spent})
            if target == size.shown:
                last = scratch / f"adapt-{target:g}" / loop[-1]["folder"]
                meshes = [triangulation(last / f"body{body}.msh") for body in (1, 2)]
    folder = claim_folder(out, f"study {NAME}", FILES, force)
    write_csv(folder / "adaptivity.csv", rows, COLUMNS)
    write_text(folder / "README.md", report(rows, size, order))
    plot(folder / "adaptivity.png", rows, meshes, size)
    return rows


def report(rows: list[dict], size: Size, order: int = 1) -> str:
    command = (f"python -m orchestrate study {NAME}" + (f" --order {order}" if order != 1 else "")
               + ("" if size == SIZES[order] else "  # at another size"))
    degree = f" --set space.order={order}" if order != 1 else ""
    pilot = "" if size.pilot == (24, 32) else f" --set body1.mesh.n={size.pilot[0]} --set body2.mesh.n={size.pilot[1]}"
    lines = ["# Meshes adapted to the error estimate, against the true error", "", *reproduce(command),
             f"`orchestrate adapt scenes/paper.toml --target E --set time.scheme=bdf2 --set time.N=10{degree}{pilot}` "
             f"from the uniform pilot n1 = {size.pilot[0]}, n2 = {size.pilot[1]}; *nodes*: the displacement's (at degree 2 the vertices and the edges' "
             "middles); *estimate*: η/‖u_h‖_V at T (edp/tools/estimate.edp, the Zienkiewicz–Zhu "
             "recovery of the strains); *error*: ‖u(T) − u_ref(T)‖_V/‖u_ref(T)‖_V against scenes/paper_graded.toml at "
             f"n1 = {size.reference[0]}, n2 = {size.reference[1]}, degree {size.referenceOrder} (bdf2, N = 36); "
             "*effectivity*: estimate/error; *seconds*: the run's wall time; *loop*: the whole `adapt`, estimates and "
             f"meshing included. The reference's own error is about {100 * size.accuracy:.3g} % ({size.checked}): "
             f"below about {1000 * size.accuracy:.2g} % it is part of the error column, and of the effectivity.", "",
             "| target | cycle | nodes | estimate | error | effectivity | run | loop |", "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {row['target']:g} | {row['cycle']} | {row['nodes']} | {100 * row['estimate']:.3f} % | "
              f"{100 * row['error']:.3f} % | {row['effectivity']:.2f} | {row['seconds']:.2f} s | "
              f"{row['loopSeconds']:.1f} s |" for row in rows]
    used = designs(rows, size)
    lines += ["", f"Observed rates of the adapted family, against the nodes N of the design that met each target "
              f"(the last run of its loop), over those whose error is at least {RATE_ABOVE} times the reference's own "
              f"({', '.join(str(row['nodes']) for row in used) or 'none'} nodes); h ~ N^(-1/2) on a uniform mesh, so "
              "N^(-a) is what h^(2a) is there (P1's best in ‖·‖_V: N^(-1/2); P2's: N^(-1)). Errors at T: ‖u‖_V as above; "
              "‖ζ − ζ_ref‖_L2 and ‖β − β_ref‖_L2(Γ_C), absolute, against the reference's meshes at the loops' "
              "N = 10 (at N = 36 their time error would be most of the figure; columns errorZeta, errorBeta of "
              "adaptivity.csv). The estimate is of ‖ε(u)‖: the designs refine for u, not for ζ or β.", ""]
    floors = above_floor(used, rows)
    lines += [f"- {label}: a = {rate:.2f} (h^{2 * rate:.2f}); the designs' errors are {floors[label][0]:.1f} to "
              f"{floors[label][1]:.1f} times the smallest of the study" if rate == rate
              else f"- {label}: fewer than two designs" for label, rate in adapted_rates(used).items()]
    lines += ["", "The smallest error of each quantity over all the study's runs bounds what the reference's own error "
              "adds to it. Only ‖u‖_V's reference has an independent check; for ζ and β, a design whose error is "
              "within a few times that smallest one bends the rate low: their rates are then lower bounds."]
    return "\n".join(lines) + "\n"


# The quantities' labels (the convergence study's), by this study's columns: ‖u‖_V's is relative.
QUANTITIES = {LABELS[name]: column for name, column in zip(ERRORS, ("error", "errorZeta", "errorBeta"))}


def designs(rows: list[dict], size: Size) -> list[dict]:
    """The run that met each target (its loop's last, its estimate at most the target), where its
    error in ‖u‖_V is well above the reference's own (RATE_ABOVE times): closer, the reference's
    error would bend the rate."""
    last = {row["target"]: row for row in rows}
    return [row for row in last.values()
            if row["estimate"] <= row["target"] and row["error"] >= RATE_ABOVE * size.accuracy]


def adapted_rates(used: list[dict]) -> dict[str, float]:
    """−(the least-squares slope of log error against log nodes) per quantity; NaN below two designs."""
    return {label: -slope([row["nodes"] for row in used], [row[key] for row in used]) if len(used) >= 2
            else float("nan") for label, key in QUANTITIES.items()}


def above_floor(used: list[dict], rows: list[dict]) -> dict[str, tuple[float, float]]:
    """Per quantity, how many times the smallest error any run of the study shows (an upper bound on
    what the reference's own error adds) the designs' errors are, the least and the most: ζ and β
    have no independent check of their reference, and a design near that floor bends their rate low."""
    result = {}
    for label, key in QUANTITIES.items():
        floor = min(row[key] for row in rows)
        ratios = [row[key] / floor for row in used] if floor > 0 else [float("inf")]
        result[label] = (min(ratios, default=float("nan")), max(ratios, default=float("nan")))
    return result


def plot(target: Path, rows: list[dict], meshes, size: Size) -> None:
    figure, (left, right) = pyplot().subplots(1, 2, figsize=(12, 5.2))
    for body, (points, triangles) in enumerate(meshes or [], 1):
        left.triplot(points[:, 0], points[:, 1], triangles, lw=0.15, color=f"C{body - 1}")
    left.set_aspect("equal")
    left.set_title(f"the last adapted meshes of --target {size.shown:g}", fontsize=10)
    left.set_xlabel("x (m)")
    left.set_ylabel("y (m)")
    for index, goal in enumerate(dict.fromkeys(row["target"] for row in rows)):
        loop = [row for row in rows if row["target"] == goal]
        nodes = [row["nodes"] for row in loop]
        right.loglog(nodes, [row["error"] for row in loop], "o-", color=f"C{index}", label=f"error, target {goal:g}")
        right.loglog(nodes, [row["estimate"] for row in loop], "x--", color=f"C{index}", alpha=0.6,
                     label=f"estimate, target {goal:g}")
    right.set_xlabel("nodes (both bodies)")
    right.set_ylabel("relative error in ‖·‖_V at T")
    right.grid(True, which="both", alpha=0.3)
    right.legend(fontsize=7)
    write_figure(figure, target, dpi=110, bbox_inches="tight")
