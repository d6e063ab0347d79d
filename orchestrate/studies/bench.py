"""python -m orchestrate bench: how long for a given error, on the paper's scene, on this machine.

Variants: every time scheme (euler, the paper's; semi-implicit; bdf2) on each mesh family
(uniform: the paper's structured meshes, body 1 with n1 = 6·2^ℓ elements per side, body 2 with
4/3 as many; graded: scenes/paper_graded.toml, graded toward the singular points, n1 = 6·2^ℓ and
body 2 with 11/24 as many), at each degree of the displacements (P1, P2: space.order), the
active-set contact solver throughout (Bermúdez–Moreno against it: tests/test_fast_paths.py); and
bdf2 on adapted meshes: `orchestrate adapt` (orchestrate/adapt.py) from the paper's uniform pilot
(P1: n1 = 24, n2 = 32; P2: n1 = 12, n2 = 16, the same nodes) at each estimate target of the degree, its last run timed
as every other run (the whole loop's wall time beside it, adaptSeconds), at the N of a time error
of fraction × the target. P2 runs one level fewer of each family than P1, two at least: its
level ℓ has the nodes of P1's level ℓ + 1.

Steps per level, balanced (docs/model-choices.md, "Steps for a target time error"): each scheme's time
error model comes from the pilots of time.N = "auto" (orchestrate/steps.py) on uniform level 0;
at every level the space error s_ℓ of a family is bdf2's measured error there (bdf2 itself aims
at fraction·s_{ℓ−1}/4, 1e-4 at level 0: the space error falls by less than 4 a level, so its time
error stays below fraction·s_ℓ), and every other scheme takes the N whose estimated time error
is fraction·s_ℓ (default fraction 1/4).

The reference is the graded mesh two levels finer than the finest measured of the highest degree
run, at that degree, the check an independent one of the same size: the graded level between them
split once (nested in that level, so its nodes are not the reference's), both bdf2 with the N of a
1e-6 time error. The check's distance to the
reference bounds what the reference's own error can do to the figures; the report says whether
it is four times below the smallest error reported.

Per point (the fastest of REPEATS runs when a run takes under REPEAT_BELOW seconds): wall time
split into start-up, meshing (warm cache), set-up (with the condensation on the factor, when the
scene's solver makes it), contact columns (the dense ones of condensation = columns, made in the
loop as nodes first become active, run.json contactColumnSeconds), the rest of the loop and
output, the
overhead ratio (time per step, columns aside, over the back-substitutions a step cannot avoid,
timed in the same run, MEASURE sets spread over its steps 2 … N so that they meet the machine's
phases as the loop did), and the same for the steps after the first, which does once what the
others do not (bdf2's semi-implicit start, the first active sets): the median over the steps
followed by sets of the step's time over a set's, with its quartiles (run.json
overheadPairedMedian, ...: each pair timed in one phase of the machine, where the run's mean
step and mean set drift apart by ±20 %), peak memory after set-up and at the end (run.json),
and ‖u(T) − u_ref(T)‖_V/‖u_ref(T)‖_V.

"How long for a given error" is then answered by a run, not only read off a curve: for each target
error two levels of a variant bracket, the coarsest n1 between them that reaches it is searched
(`search_rows`), and the report gives each variant's fastest run at or below each target. Also:
the sparse solvers timed on each matrix of the finest uniform level. Writes bench.csv, README.md
and workprecision.png.
"""
from __future__ import annotations

import csv
import json
import tempfile
import time
from pathlib import Path

import numpy as np
from matplotlib.ticker import FuncFormatter

from orchestrate.adapt import adapt
from orchestrate.compare import instant_distances
from orchestrate.freefem import REPO, InputError, SolverError, run_script
from orchestrate.manifest import displacement_nodes, facts
from orchestrate.mesh import forget_whole_files
from orchestrate.outputs import claim_folder, refuse_folder, write_csv, write_text
from orchestrate.parameters import ORDER
from orchestrate.plots import log_axes, pyplot, save
from orchestrate.results import load_result
from orchestrate.runner import run
from orchestrate.scene import Scene
from orchestrate.steps import steps_for, time_error_model
from orchestrate.studies.reports import bench_report

NAME = "bench"  # the command, as its folders' made-by.json records it

SCHEMES = tuple(ORDER)
FAMILIES = {"uniform": REPO / "scenes" / "paper.toml", "graded": REPO / "scenes" / "paper_graded.toml"}
DEGREES = (1, 2)  # of the displacements (space.order)
ADAPTED = "adapted"  # the family of meshes adapt designs, and the estimates it designs them for, per degree:
ADAPT_TARGETS = {1: (0.05, 0.02, 0.01, 0.005), 2: (0.005, 0.002, 0.001, 0.0005)}  # P2's estimate is 0.6 of its error
PILOT_N = {1: 1, 2: 0.5}  # adapt's pilot: the uniform scene's n times this, so both degrees start from its nodes
MARKERS = {"uniform": "o", "graded": "s", ADAPTED: "^"}
LINES = {1: ":", 2: "-"}  # P1 dotted, P2 solid
LOOP_LINES = {1: (0, (6, 2, 1, 2)), 2: "--"}  # the adapt loops': P1 dash-dotted, P2 dashed
REFERENCE, CHECK = "reference", "reference check"
MEASURE = 30  # sets of the unavoidable back-substitutions timed in each run, spread over steps 2 … N
REPEATS, REPEAT_BELOW = 3, 20.0  # this machine's timings drift by ±20 %: short runs are repeated
FIRST_TARGET = 1e-4  # bdf2's time target at level 0, below every space error reported
REFERENCE_TARGET = 1e-6  # the time error of the reference and of the check
MOST_DOUBLINGS = 6  # of N, for a level whose N an explicit bound refuses
TARGETS = (1e-2, 2e-3)  # the errors the report reads every curve at, and searches a mesh for
SEARCH_RUNS = 5  # most runs of the search for the coarsest mesh that reaches a target
N1_STEP = {"uniform": 2, "graded": 1}  # uniform body 1 has a node at the load jump x = 3: n1 even


def degree_level_count(levels: int, degree: int) -> int:
    """A family's levels at a degree: P2 one fewer than P1 (its level ℓ has the nodes of P1's ℓ + 1),
    two at least."""
    return max(2, levels - (degree - 1))


def mesh_size(family: str, n1: int) -> dict:
    """Body 1 with n1 elements per side, body 2 in the ratio of the family's scene (uniform: the
    paper's 32/24; graded: 11/24, where body 2 holds little of the error), rounded to the nearest
    integer, ties to even; uniform structured given explicitly (every mesh made, none read from the
    committed default)."""
    scene = Scene.load(FAMILIES[family])
    overrides = {"body1.mesh.n": n1, "body2.mesh.n": max(1, round(n1 * scene.body2.mesh.n / scene.body1.mesh.n))}
    if family == "uniform":
        overrides.update({"body1.mesh.structured": True, "body2.mesh.structured": True})
    return overrides


def level_n1(l: int) -> int:
    """Body 1's elements per side at level l (6/6, 6/12, ... of the paper's 6 × 6 body)."""
    return 6 * 2 ** l


def mesh_level(family: str, l: int) -> dict:
    return mesh_size(family, level_n1(l))


def variant_name(scheme: str, family: str, degree: int) -> str:
    return f"{scheme}, {family}, P{degree}"


def split_name(name: str) -> tuple[str, str, int]:
    """scheme, family and degree of a variant's name."""
    scheme, family, degree = name.split(", ")
    return scheme, family, int(degree.removeprefix("P"))


def timed_run(scene: Path, overrides: dict, folder: Path, cache: Path) -> dict:
    base = {"output.times": "final", "output.fields": ["state"], "output.images": False}
    forget_whole_files()  # meshing timed as a command run afresh pays it: each mesh read once, from the cache
    result = run(scene, folder, {**base, **overrides}, force=True, progress=False, mesh_cache=cache,
                 solver_flags=("-measureSolves", MEASURE))
    timing = json.loads((folder / "summary.json").read_text())["timing"]
    steps = overrides["time.N"]
    counts = facts(folder)
    measured = timing["backsubsPerStep"] * counts["backsubSets"]  # timed in the loop (steps 2 … N)
    solver_wall = timing["solver"] - measured
    columns = counts["contactColumnSeconds"]  # made in the loop, when a node first becomes active
    output = timing["solverOutputCpu"]  # the files, written in the loop
    loop = timing["solverLoopCpu"] - measured - columns - output
    return {"nodes1": displacement_nodes(counts, "1"), "nodes2": displacement_nodes(counts, "2"), "N": steps,
            "startup": solver_wall - (timing["solverTotalCpu"] - measured), "meshing": timing["meshing"],
            "setup": timing["solverSetupCpu"], "columns": columns, "loop": loop,
            "output": output, "wall": timing["meshing"] + solver_wall,
            "overheadRatio": loop / steps / timing["backsubsPerStep"], "firstStep": counts["firstStepSeconds"],
            **later_overhead(counts),
            "setupMemoryMB": counts.get("setupPeakMemoryMB"), "peakMemoryMB": counts.get("peakMemoryMB"),
            "contactIters": float(result.history["contactIters"].mean()), "normV": float(result.history["normV"][-1])}


def later_overhead(counts: dict) -> dict:
    """The overhead ratio of the steps after the first: the median of the paired ratios and their
    quartiles (NaN for a run of one step, which pairs none)."""
    if not counts.get("overheadPairs"):
        return {"laterOverheadRatio": float("nan"), "laterOverheadLow": float("nan"), "laterOverheadHigh": float("nan")}
    return {"laterOverheadRatio": counts["overheadPairedMedian"], "laterOverheadLow": counts["overheadPairedLow"],
            "laterOverheadHigh": counts["overheadPairedHigh"]}


def fastest_run(scene: Path, overrides: dict, folder: Path, cache: Path) -> dict:
    """The fastest of up to REPEATS runs (by wall time; the cache is warm from the second on, so
    meshing is read from it); a first run that takes REPEAT_BELOW seconds or more is kept alone."""
    runs = [timed_run(scene, overrides, folder, cache)]
    if runs[0]["wall"] < REPEAT_BELOW:
        runs += [timed_run(scene, overrides, folder, cache) for _ in range(REPEATS - 1)]
    return min(runs, key=lambda row: row["wall"])


def stable_run(scene: Path, overrides: dict, folder: Path, cache: Path) -> dict:
    """fastest_run at the overrides' N, doubled while an explicit bound refuses it."""
    for _ in range(MOST_DOUBLINGS):
        try:
            return fastest_run(scene, overrides, folder, cache)
        except SolverError as error:
            if error.returncode != 3:
                raise
            overrides = {**overrides, "time.N": 2 * overrides["time.N"]}
    raise RuntimeError(f"no stable N up to {overrides['time.N']} for {overrides}")


def final_distance(run_folder: Path, reference: Path) -> float:
    """‖u(T) − u_ref(T)‖_V / ‖u_ref(T)‖_V."""
    steps = [load_result(folder).params["N"] for folder in (run_folder, reference)]
    row = instant_distances(run_folder, reference, steps[0], steps[1], 1)[0]
    return row["errorV"] / row["normV"]


def solver_table(folder: Path, steps: int) -> list[dict]:
    """Factorization and solve times of every sparse solver on every matrix of a level."""
    done = run_script(REPO / "edp" / "tools" / "solvers.edp",
                      ["-mesh1", "mesh1.msh", "-mesh2", "mesh2.msh", "-N", steps, "-out", "."], cwd=folder)
    if done.returncode != 0:
        raise RuntimeError(f"solvers.edp failed: {done.error_line}")
    with open(folder / "solvers.csv") as handle:
        return [{**row, "dofs": int(row["dofs"]), "factorSeconds": float(row["factorSeconds"]),
                 "solveSeconds": float(row["solveSeconds"])} for row in csv.DictReader(handle)]


def error_models(scratch: Path) -> dict[str, dict]:
    """Each scheme's time error model: the pilots of time.N = "auto" on uniform level 0."""
    models = {}
    for scheme in SCHEMES:
        scene = Scene.load(FAMILIES["uniform"], {**mesh_level("uniform", 1), "time.scheme": scheme})
        models[scheme] = time_error_model(scene, scratch / "pilots" / scheme, run, scratch / "meshes")
    return models


def references(levels: int, degree: int, models: dict, scratch: Path) -> list[dict]:
    """The reference and its check at `degree`, above `levels` graded levels measured at it."""
    steps = steps_for(models["bdf2"], REFERENCE_TARGET)[0]
    rows = []
    for name, overrides in ((REFERENCE, mesh_level("graded", levels + 1)),
                            (CHECK, {**mesh_level("graded", levels), "body1.mesh.refine": 1, "body2.mesh.refine": 1})):
        folder = scratch / name.replace(" ", "-")
        rows.append({"variant": name, "scheme": "bdf2", "family": "graded", "degree": degree, "level": "",
                     "folder": folder,
                     **timed_run(FAMILIES["graded"], {**overrides, "space.order": degree, "time.scheme": "bdf2",
                                                      "time.N": steps}, folder, scratch / "meshes")})
    return rows


def measured_run(family: str, scheme: str, degree: int, n1: int, level, target: float, model: dict,
                 reference: Path, folder: Path, scratch: Path) -> dict:
    """A bench row: the family's meshes at n1, the N whose estimated time error is `target`."""
    steps, estimated = steps_for(model, target)
    row = {"variant": variant_name(scheme, family, degree), "scheme": scheme, "family": family, "degree": degree,
           "level": level, "n1": n1, "folder": folder, "timeTarget": target,
           **stable_run(FAMILIES[family], {**mesh_size(family, n1), "space.order": degree, "time.scheme": scheme,
                                           "time.N": steps}, folder, scratch / "meshes")}
    row["estimatedTimeError"] = estimated * (steps / row["N"]) ** model["orderUsed"]  # N doubled?
    row["errorToReference"] = final_distance(folder, reference)
    return row


def predicted_n1(coarse: dict, fine: dict, error: float, step: int) -> int:
    """The n1 at which the line through two runs in log(error)–log(n1) reaches `error`, rounded
    up to a multiple of step."""
    slope = np.log(fine["errorToReference"] / coarse["errorToReference"]) / np.log(fine["n1"] / coarse["n1"])
    n1 = coarse["n1"] * (error / coarse["errorToReference"]) ** (1 / slope)
    return int(step * np.ceil(n1 / step - 1e-9))


def search_label(target: float) -> str:
    return f"search {100 * target:g} %"


def by_n1(levels: list[dict], searched: list[dict]) -> list[dict]:
    """A variant's runs, one per n1: a search run replaces the level run at its n1."""
    return list(({row["n1"]: row for row in levels} | {row["n1"]: row for row in searched}).values())


def bracket(runs: list[dict], target: float) -> tuple[dict | None, dict | None]:
    """The coarsest run at or below the target and the finest coarser run above it (None where
    there is none)."""
    below = [row for row in runs if row["errorToReference"] <= target]
    fine = min(below, key=lambda row: row["n1"], default=None)
    above = [row for row in runs if row["errorToReference"] > target and fine and row["n1"] < fine["n1"]]
    return max(above, key=lambda row: row["n1"], default=None), fine


def search(family: str, scheme: str, degree: int, levels: list[dict], target: float, fraction: float,
           model: dict, reference: Path, scratch: Path) -> list[dict]:
    """The coarsest mesh that reaches `target`, between two levels that bracket it: secant steps in
    log(error)–log(n1), every run at the N for a time error of fraction·target, until a run at or
    below the target (at those steps) is one step of n1 above a run above it, or SEARCH_RUNS runs."""
    label, step, searched = search_label(target), N1_STEP[family], []
    for _ in range(SEARCH_RUNS):
        coarse, fine = bracket(by_n1(levels, searched), target)
        if coarse is None:
            break
        n1 = max(predicted_n1(coarse, fine, target, step), coarse["n1"] + step)
        if n1 >= fine["n1"]:
            n1 = fine["n1"] - step  # predicted to be the coarsest: the mesh below must show it
        if n1 <= coarse["n1"]:
            if fine["level"] == label:
                break
            n1 = fine["n1"]  # a level run, at its level's steps: run it at the target's
        folder = scratch / f"{scheme}-{family}-P{degree}" / f"search-{target:g}-n1-{n1}"
        searched.append(measured_run(family, scheme, degree, n1, label, fraction * target, model, reference, folder,
                                     scratch))
    return searched


def search_rows(family: str, degree: int, levels: list[dict], targets, fraction: float, models: dict,
                reference: Path, scratch: Path) -> list[dict]:
    """`search` for every scheme of a family at a degree and every target error."""
    return [row for scheme in SCHEMES for target in targets
            for row in search(family, scheme, degree, [row for row in levels if row["scheme"] == scheme], target,
                              fraction, models[scheme], reference, scratch)]


def search_status(rows: list[dict], name: str, target: float) -> str:
    """How the search for `target` ended for a variant, for the report."""
    family = split_name(name)[1]
    if family == ADAPTED:
        return "none: its meshes are designed for targets of the estimate"
    label, step = search_label(target), N1_STEP[family]
    levels = [row for row in rows if row["variant"] == name and isinstance(row["level"], int)]
    searched = [row for row in rows if row["variant"] == name and row["level"] == label]
    if not searched:
        return "not searched: no two levels bracket it"
    coarse, fine = bracket(by_n1(levels, searched), target)
    if fine is None or coarse is None:
        return f"open after {len(searched)} runs: none at the search's steps brackets it"
    if fine["level"] == label and fine["n1"] - coarse["n1"] == step:
        return f"n1 = {fine['n1']} reaches it, {coarse['n1']} does not"
    return f"open after {len(searched)} runs: n1 = {coarse['n1']} above it, {fine['n1']} at or below"


def pilot_size(degree: int) -> dict:
    """adapt's pilot at a degree: the uniform scene's meshes, at P2 with half its n (the same nodes)."""
    scene = Scene.load(FAMILIES["uniform"])
    return {f"body{body}.mesh.n": round(getattr(scene, f"body{body}").mesh.n * PILOT_N[degree]) for body in (1, 2)}


def adapted_rows(degree: int, targets, fraction: float, model: dict, reference: Path, scratch: Path) -> list[dict]:
    """bdf2 on the meshes `adapt` designs for each estimate target (from the uniform scene's pilot),
    the last run of each loop timed as every other run, at the N of a time error of fraction × the
    target."""
    rows = []
    for goal in targets:
        steps, estimated = steps_for(model, fraction * goal)
        overrides = {**pilot_size(degree), "space.order": degree, "time.scheme": "bdf2", "time.N": steps}
        loop_folder = scratch / f"bdf2-{ADAPTED}-P{degree}" / f"adapt-{goal:g}"
        start = time.perf_counter()
        loop = adapt(FAMILIES["uniform"], loop_folder, goal, overrides={**overrides, "output.images": False},
                     progress=False)
        spent = time.perf_counter() - start
        last = loop[-1]["cycle"]
        sizes = {f"body{body}.mesh.sizes": str(loop_folder / "sizes" / f"cycle{last}" / f"body{body}.pos")
                 for body in (1, 2) if last > 0}
        folder = scratch / f"bdf2-{ADAPTED}-P{degree}" / f"target-{goal:g}"
        row = {"variant": variant_name("bdf2", ADAPTED, degree), "scheme": "bdf2", "family": ADAPTED,
               "degree": degree,
               "level": f"target {100 * goal:g} %", "n1": "", "folder": folder, "timeTarget": fraction * goal,
               "estimatedTimeError": estimated,
               **stable_run(FAMILIES["uniform"], {**overrides, **sizes}, folder, scratch / "meshes"),
               "adaptSeconds": spent, "adaptCycles": last, "adaptTarget": goal,
               "pilot": ", ".join(f"n{body} = {n}" for body, n in enumerate(pilot_size(degree).values(), 1)),
               "adaptEstimate": loop[-1]["relative"]}
        row["errorToReference"] = final_distance(folder, reference)
        rows.append(row)
    return rows


def family_rows(family: str, degree: int, levels: int, fraction: float, models: dict, reference: Path,
                scratch: Path) -> list[dict]:
    """Every scheme at every level of a family at a degree, N balanced against the level's space error."""
    rows, space = [], []
    for l in range(levels):
        target = FIRST_TARGET if l == 0 else fraction * space[-1] / 4
        for scheme in sorted(SCHEMES, key=lambda s: -ORDER[s]):  # the second order first: it sets the space error
            if ORDER[scheme] == 1:
                target = fraction * space[-1]
            row = measured_run(family, scheme, degree, level_n1(l), l, target, models[scheme], reference,
                               scratch / f"{scheme}-{family}-P{degree}" / f"level{l}", scratch)
            if ORDER[scheme] == 2:
                space.append(row["errorToReference"])
            rows.append(row)
    return rows


def bench(out: str | Path, levels: int = 5, fraction: float = 0.25, uniform_levels: int | None = None,
          targets=TARGETS, adapt_targets=ADAPT_TARGETS, degrees=DEGREES, force: bool = False) -> list[dict]:
    """At each degree of `degrees`: `levels` graded levels and `uniform_levels` uniform ones
    (default as many: uniform meshes need one more level for the same error) at P1, one fewer of
    each at P2 (degree_level_count); for each error of `targets` the levels bracket, the search
    for the coarsest mesh that reaches it; the adapted meshes of each estimate of
    `adapt_targets[degree]`. The reference: two graded levels above the finest measured at the
    highest degree. `out`: a new folder, or with `force` one an earlier bench wrote (outputs.py)."""
    counts = {"uniform": uniform_levels or levels, "graded": levels}
    missing = [degree for degree in degrees if degree not in adapt_targets]
    if missing:  # now, not after the other degrees' runs
        raise InputError(f"degree {missing[0]}: no targets of the estimate for its adapted meshes")
    out = Path(out).resolve()
    refuse_folder(out, NAME, force)  # now, not after the runs
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        models = error_models(scratch)
        top = max(degrees)
        reference, check = references(degree_level_count(levels, top), top, models, scratch)
        rows = [reference, check]
        for degree in degrees:
            for family in FAMILIES:
                levels_run = family_rows(family, degree, degree_level_count(counts[family], degree), fraction, models,
                                         reference["folder"], scratch)
                rows += levels_run + search_rows(family, degree, levels_run, targets, fraction, models,
                                                 reference["folder"], scratch)
            rows += adapted_rows(degree, adapt_targets[degree], fraction, models["bdf2"], reference["folder"],
                                 scratch)
        check["errorToReference"] = final_distance(check["folder"], reference["folder"])
        for row in rows:
            if row["variant"] not in (REFERENCE, CHECK):
                row["errorToCheck"] = final_distance(row["folder"], check["folder"])
        finest = finest_level(rows, variant_name("euler", "uniform", min(degrees)))["folder"]
        (scratch / "solvers").mkdir()
        for body in (1, 2):
            (scratch / "solvers" / f"mesh{body}.msh").write_bytes((finest / f"body{body}.msh").read_bytes())
        solvers = solver_table(scratch / "solvers", load_result(finest).params["N"])
    rows = rows[2:] + rows[:2]
    flags = (f"--levels {levels} --uniform-levels {counts['uniform']} --time-fraction {fraction:g} "
             f"--targets {percent_list(targets)} --degrees {','.join(str(degree) for degree in degrees)}"
             + "".join(f" --adapt-targets{'' if degree == 1 else '-p2'} {percent_list(adapt_targets[degree])}"
                       for degree in degrees))
    write(claim_folder(out, NAME, FILES, force), rows, solvers, models, flags, fraction, targets)
    return rows


def percent_list(fractions) -> str:
    return ",".join(f"{100 * fraction:g}" for fraction in fractions)


def finest_level(rows: list[dict], name: str) -> dict:
    """A variant's row at its finest level (search runs aside); of the adapted meshes, the most
    accurate."""
    own = [row for row in rows if row["variant"] == name]
    levels = [row for row in own if isinstance(row["level"], int)]
    if levels:
        return max(levels, key=lambda row: row["level"])
    return min(own, key=lambda row: row["errorToReference"])


def curve(rows: list[dict], name: str, key: str = "errorToReference") -> list[tuple[float, float]]:
    """(error, wall) of a variant's runs, its levels and search runs, by increasing error (`key`:
    which reference)."""
    return sorted((row[key], row["wall"]) for row in rows if row["variant"] == name)


def wall_at(points: list[tuple[float, float]], error: float) -> float | None:
    """The wall time of a work–precision curve at `error`, interpolated linearly in
    log(error)–log(time); None outside the curve's range."""
    for (e0, w0), (e1, w1) in zip(points, points[1:]):
        if e0 <= error <= e1:
            fraction = np.log(error / e0) / np.log(e1 / e0) if e1 > e0 else 0.0
            return float(np.exp(np.log(w0) + fraction * np.log(w1 / w0)))
    return None


def at_targets(rows: list[dict], targets, key: str = "errorToReference") -> dict[str, dict[float, float | None]]:
    """Every variant's wall time at each target, its curve interpolated (None where it does not
    reach it)."""
    return {name: {target: wall_at(curve(rows, name, key), target) for target in targets} for name in variants(rows)}


def cheapest(rows: list[dict], targets, key: str = "errorToReference") -> dict[str, dict[float, dict | None]]:
    """Every variant's fastest run whose error is at most each target (None where none is)."""
    return {name: {target: min((row for row in rows if row["variant"] == name and row[key] <= target),
                               key=lambda row: row["wall"], default=None) for target in targets}
            for name in variants(rows)}


def variants(rows: list[dict]) -> list[str]:
    return list(dict.fromkeys(row["variant"] for row in rows if row["variant"] not in (REFERENCE, CHECK)))


FILES = ("bench.csv", "README.md", "workprecision.png")
COLUMNS = ["variant", "scheme", "family", "degree", "level", "n1", "nodes1", "nodes2", "N", "timeTarget", "estimatedTimeError", "wall",
           "startup", "meshing", "setup", "columns", "loop", "output", "firstStep", "overheadRatio", "laterOverheadRatio",
           "laterOverheadLow", "laterOverheadHigh",
           "setupMemoryMB", "peakMemoryMB", "contactIters", "normV", "errorToReference", "errorToCheck", "adaptSeconds",
           "adaptCycles", "adaptTarget", "adaptEstimate"]


def write(out: Path, rows: list[dict], solvers: list[dict], models: dict, flags: str, fraction: float,
          targets) -> None:
    write_csv(out / "bench.csv", rows, COLUMNS)
    plot(out / "workprecision.png", rows, targets)
    command = f"python -m orchestrate bench {flags}"
    statuses = {name: {target: search_status(rows, name, target) for target in targets} for name in variants(rows)}
    write_text(out / "README.md", bench_report(rows, solvers, models, command, fraction, cheapest(rows, targets),
                                               statuses, at_targets(rows, targets),
                                               at_targets(rows, targets, "errorToCheck")))


def plot(target: Path, rows: list[dict], targets) -> None:
    """Wall time against error, one curve per variant (levels and search runs: colour the scheme,
    marker the family, line the degree), the target errors dotted; beside it, the time split of
    each variant's finest level."""
    names = variants(rows)
    figure, (left, right) = pyplot().subplots(1, 2, figsize=(14, 5.5 + 0.12 * len(names)),
                                              gridspec_kw={"width_ratios": [3, 2]})
    colours = {scheme: f"C{i}" for i, scheme in enumerate(SCHEMES)}
    for name in names:
        scheme, family, degree = split_name(name)
        errors, walls = zip(*curve(rows, name))
        style = dict(color=colours[scheme], marker=MARKERS[family], linestyle=LINES[degree],
                     markerfacecolor=colours[scheme] if degree > 1 else "none")
        left.loglog(np.array(errors) * 100, walls, label=name, **style)
        if family == ADAPTED:  # the whole loop that designed them: pilot, estimates, meshing, every cycle
            loops = sorted((row["errorToReference"], row["adaptSeconds"]) for row in rows if row["variant"] == name)
            left.loglog([100 * e for e, _ in loops], [w for _, w in loops], **{**style, "linestyle": LOOP_LINES[degree]},
                        alpha=0.45, label=f"{name}: the whole adapt loop")
    for error in targets:
        left.axvline(100 * error, color="0.6", linestyle=":", linewidth=1)
        left.annotate(f"target {100 * error:g} %", (100 * error, 0), xycoords=("data", "axes fraction"),
                      xytext=(-3, 4), textcoords="offset points", rotation=90, ha="right", va="bottom", fontsize=8,
                      color="0.4")
    left.invert_xaxis()
    for axis in (left.xaxis, left.yaxis):
        axis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))  # 1, 10: not 10⁰, 10¹
    log_axes(left, "relative error of u(T) in the V norm (%)", "wall time of a run (s)", fontsize=7, ncol=2)
    parts = ("startup", "meshing", "setup", "columns", "loop", "output")
    finest = [finest_level(rows, name) for name in names]
    bottom = np.zeros(len(finest))
    for part in parts:
        values = np.array([row[part] for row in finest]).clip(min=0)
        right.barh(range(len(finest)), values, left=bottom, label=part)
        bottom += values
    right.set_yticks(range(len(finest)), [f"{row['variant']}: {level_label(row)}, N = {row['N']}" for row in finest],
                     fontsize=7)
    right.invert_yaxis()
    right.set_xlabel("wall time of the finest level (s)")
    right.legend(fontsize=8)
    save(figure, target)


def level_label(row: dict) -> str:
    return f"level {row['level']}" if isinstance(row["level"], int) else row["level"]


def number(text: str) -> float:
    """The number a command-line value spells, NaN (outside every range) when it spells none."""
    try:
        return float(text)
    except ValueError:
        return float("nan")
