"""python -m orchestrate bench: run time against error for the paper's scene on this machine.

Three variants, each a lock-step ladder (n doubled and time step halved together, N = 20·2^ℓ),
run one after the other so that no run competes with another for the two cores:
  uniform, pdas   the paper's structured meshes, body 1 with 6·2^ℓ elements per side, the
                  active-set contact solver (the default)
  uniform, bm     the same runs with Bermúdez–Moreno, the paper's contact algorithm
  graded, pdas    scenes/paper_graded.toml: gmsh meshes graded toward the singular points by a
                  power of the distance, n = 6·2^ℓ for body 1 (the grading strengthens with ℓ)
Per level (the fastest of REPEATS runs): the time split (FreeFem++ start-up, meshing with an empty
cache, set-up, time loop, output), the overhead ratio (time per step over the back-substitutions
a step cannot avoid, measured in the same process), and the error ‖u(T) − u_ref(T)‖_V/‖u_ref(T)‖_V
against one common reference for every variant: the graded mesh one level finer than the finest
measured graded level, with twice its steps (edp/tools/errors.edp interpolates each run onto the
reference's meshes). With --check-reference, a uniform run finer than every measured level is
also measured against the reference (that distance bounds what the reference's own error can do
to the figures), and every run against it, so the graded gains can be read against either.
Also: the sparse solvers timed on each matrix of the finest uniform level, and the graded meshes'
gain at equal error (both work–precision curves interpolated in log–log). Writes bench.csv,
README.md and workprecision.png.
"""
from __future__ import annotations

import csv
import json
import tempfile
from pathlib import Path

import numpy as np

from orchestrate.convergence import distances
from orchestrate.freefem import REPO, run_script
from orchestrate.manifest import facts
from orchestrate.plots import log_axes, pyplot, save
from orchestrate.reports import bench_report, write_csv
from orchestrate.results import load_result
from orchestrate.runner import run

REFERENCE = "reference"
CHECK = "reference check"
MEASURE = 10  # repetitions of the unavoidable back-substitutions timed after each run
REPEATS = 3  # runs of each measured level, the fastest kept: this machine's timings drift by ±20 %


PAPER, GRADED = REPO / "scenes" / "paper.toml", REPO / "scenes" / "paper_graded.toml"


def level(l: int, steps: int | None = None) -> dict:
    """Level l of the ladder: n1 = 6·2^l, n2 = 8·2^l, N = 20·2^l unless `steps` is given."""
    return {"body1.mesh.n": 6 * 2 ** l, "body2.mesh.n": 8 * 2 ** l, "time.N": steps or 20 * 2 ** l}


def uniform_level(l: int, steps: int | None = None) -> dict:
    # structured given explicitly: every level is meshed, none read from the committed default
    return {**level(l, steps), "body1.mesh.structured": True, "body2.mesh.structured": True}


def variants(levels: int, check_reference: bool = False) -> dict[str, tuple[Path, list[dict]]]:
    """`levels` measured uniform levels; one fewer graded, whose next level, with twice its steps,
    is the reference; the check is the uniform level two finer than the last, at the reference's N."""
    uniform = [uniform_level(l) for l in range(levels)]
    ladders = {"uniform, pdas": (PAPER, uniform),
               "uniform, bm": (PAPER, [{**overrides, "solver.contactSolver": "bm"} for overrides in uniform]),
               "graded, pdas": (GRADED, [level(l) for l in range(levels - 1)]),
               REFERENCE: (GRADED, [level(levels - 1, 20 * 2 ** levels)])}
    if check_reference:
        ladders[CHECK] = (PAPER, [uniform_level(levels + 1, 20 * 2 ** levels)])
    return ladders


def timed_run(scene: Path, overrides: dict, folder: Path, cache: Path) -> dict:
    base = {"output.times": "final", "output.fields": ["state"], "output.images": False}
    result = run(scene, folder, {**base, **overrides}, force=True, mesh_cache=cache,
                 solver_flags=("-measureSolves", MEASURE))
    timing = json.loads((folder / "summary.json").read_text())["timing"]
    steps = overrides["time.N"]
    measured = timing["backsubsPerStep"] * MEASURE
    solver_wall = timing["solver"] - measured
    counts = facts(folder)
    return {"nodes1": counts["nodes1"], "nodes2": counts["nodes2"], "N": steps,
            "startup": solver_wall - (timing["solverTotalCpu"] - measured), "meshing": timing["meshing"],
            "setup": timing["solverSetupCpu"], "loop": timing["solverLoopCpu"] - measured,
            "output": timing["solverOutputCpu"], "wall": timing["meshing"] + solver_wall,
            "overheadRatio": (timing["solverLoopCpu"] - measured) / steps / timing["backsubsPerStep"],
            "contactIters": float(result.history["contactIters"].mean()), "normV": float(result.history["normV"][-1])}


def fastest_run(scene: Path, overrides: dict, folder: Path, cache: Path, repeats: int) -> dict:
    """The fastest of `repeats` runs (by FreeFem++'s own wall time); meshing is the first run's,
    with the cache still empty."""
    runs = [timed_run(scene, overrides, folder, cache) for _ in range(repeats)]
    best = min(runs, key=lambda row: row["wall"] - row["meshing"])
    return {**best, "meshing": runs[0]["meshing"], "wall": best["wall"] - best["meshing"] + runs[0]["meshing"]}


def final_distance(run_folder: Path, reference: Path) -> float:
    """‖u(T) − u_ref(T)‖_V / ‖u_ref(T)‖_V."""
    steps = [load_result(folder).params["N"] for folder in (run_folder, reference)]
    row = distances(run_folder, reference, steps[0], steps[1], 1)[0]
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


def bench(out: str | Path, levels: int = 5, check_reference: bool = False) -> list[dict]:
    out = Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        for name, (scene, ladder) in variants(levels, check_reference).items():
            slug = name.replace(", ", "-").replace(" ", "-")
            repeats = 1 if name in (REFERENCE, CHECK) else REPEATS  # the longest runs, never compared in time
            for index, overrides in enumerate(ladder):
                folder = scratch / slug / f"level{index}"
                rows.append({"variant": name, "level": index, "folder": folder,
                             **fastest_run(scene, overrides, folder, scratch / "meshes" / slug, repeats)})
        folder_of = {row["variant"]: row["folder"] for row in rows}  # a variant's last (finest) level
        for key, reference in (("errorToReference", REFERENCE), ("errorToCheck", CHECK)):
            for row in rows:
                if reference in folder_of and row["variant"] != reference:
                    row[key] = final_distance(row["folder"], folder_of[reference])
        # the finest measured uniform level: h1 = 6/96 at the default five levels
        finest = folder_of["uniform, pdas"]
        fine = load_result(finest).params
        (scratch / "solvers").mkdir()
        for body in (1, 2):
            (scratch / "solvers" / f"mesh{body}.msh").write_bytes((finest / f"body{body}.msh").read_bytes())
        solvers = solver_table(scratch / "solvers", fine["N"])
    write(out, rows, solvers, levels, check_reference)
    return rows


def curve(rows: list[dict], name: str, key: str = "errorToReference") -> list[tuple[float, float]]:
    """(error, wall) of a variant's measured levels, by increasing error (`key`: which reference)."""
    return sorted((row[key], row["wall"]) for row in rows if row["variant"] == name)


def wall_at(points: list[tuple[float, float]], error: float) -> float | None:
    """The wall time of a work–precision curve at `error`, interpolated linearly in
    log(error)–log(time); None outside the curve's range."""
    for (e0, w0), (e1, w1) in zip(points, points[1:]):
        if e0 <= error <= e1:
            fraction = np.log(error / e0) / np.log(e1 / e0) if e1 > e0 else 0.0
            return float(np.exp(np.log(w0) + fraction * np.log(w1 / w0)))
    return None


def graded_gains(rows: list[dict], key: str = "errorToReference") -> list[tuple[float, float]]:
    """(error, gain) at every measured error, uniform or graded, that both curves span: the
    uniform wall time over the graded wall time at that error."""
    uniform, graded = curve(rows, "uniform, pdas", key), curve(rows, "graded, pdas", key)
    gains = []
    for error in sorted({error for error, _ in uniform + graded}):
        walls = wall_at(uniform, error), wall_at(graded, error)
        if None not in walls:
            gains.append((error, walls[0] / walls[1]))
    return gains


def gain_lines(rows: list[dict], check_reference: bool) -> list[str]:
    """The graded meshes' gain at every error both curves span, against each reference."""
    keys = [("errorToReference", "against the reference")] + ([("errorToCheck", "against the reference check")]
                                                              if check_reference else [])
    lines = []
    for key, against in keys:
        gains = graded_gains(rows, key)
        text = ", ".join(f"{gain:.2f}× at {100 * error:.2f} %" for error, gain in gains) or "the two curves share no error range"
        lines.append(f"- {against}: {text}")
    return lines


COLUMNS = ["variant", "level", "nodes1", "nodes2", "N", "wall", "startup", "meshing", "setup", "loop", "output",
           "overheadRatio", "contactIters", "normV", "errorToReference", "errorToCheck"]


def write(out: Path, rows: list[dict], solvers: list[dict], levels: int, check_reference: bool) -> None:
    write_csv(out / "bench.csv", rows, COLUMNS)
    plot(out / "workprecision.png", rows)
    command = f"python -m orchestrate bench --levels {levels}" + (" --check-reference" if check_reference else "")
    (out / "README.md").write_text(bench_report(rows, solvers, command, check_reference, gain_lines(rows, check_reference)))


def plot(target: Path, rows: list[dict]) -> None:
    figure, axis = pyplot().subplots(figsize=(7, 5))
    for name, marker in zip(("uniform, pdas", "uniform, bm", "graded, pdas"), "osd"):
        points = curve(rows, name)
        if points:
            errors, walls = zip(*points)
            axis.loglog(errors, walls, marker + "-", label=name)
    axis.invert_xaxis()
    log_axes(axis, "relative error ‖u_h(T) − u_ref(T)‖_V / ‖u_ref(T)‖_V", "wall time of a run (s)")
    save(figure, target)


# --- command line ---------------------------------------------------------------------------

NAME, HELP = "bench", "run time against error on this machine (results/bench)"


def add_arguments(parser) -> None:
    from orchestrate.cli import at_least_two

    parser.add_argument("--levels", type=at_least_two, default=5,
                        help="measured uniform levels (one fewer graded: the next graded level is the reference)")
    parser.add_argument("--check-reference", action="store_true",
                        help="also run a uniform level finer than every other and measure every run against it too "
                             "(about six minutes more)")
    parser.add_argument("--out", default="results/bench")


def command(options) -> int:
    bench(options.out, levels=options.levels, check_reference=options.check_reference)
    print((Path(options.out) / "README.md").read_text())
    return 0
