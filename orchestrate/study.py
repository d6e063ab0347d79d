"""Convergence study of a scene: python -m orchestrate study convergence SCENE.

Three ladders of runs, each level halving what the ladder refines:
  lockstep  h and k together: body 1 with n1₀·2^ℓ elements per side, body 2 with n2₀·2^ℓ, N₀·2^ℓ steps
  time      k alone, on a fixed fine mesh
  space     h alone, at a fixed small step
The meshes must be nested under n → 2n (the paper's structured family is) so that the error norms
are exact. Every run saves its state (u, ζ, β) at the N₀ instants of the coarsest level, which all
levels share; edp/tools/errors.edp measures there the distance of each level to the finest level
of its ladder (the reference) and to the next level. The error of a level is the maximum over the
instants, as in Theorem 2.1 of the seed. Observed rates are log₂ of successive error ratios and a
least-squares slope over the finest three levels below the reference.
"""
from __future__ import annotations

import csv
import math
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from orchestrate.freefem import REPO, run_script
from orchestrate.plots import log_axes, pyplot, save
from orchestrate.results import load_result, read_state
from orchestrate.scene import Scene
from orchestrate.sweep import plan, run_jobs

QUANTITIES = ("errorV", "errorZeta", "errorBeta")
LABELS = {"errorV": "‖u − u_ref‖_V", "errorZeta": "‖ζ − ζ_ref‖_L2", "errorBeta": "‖β − β_ref‖_L2(Γ_C)"}
THEORY = {"lockstep": 0.75, "space": 0.75, "time": 1.0}  # Theorem 2.1: c(h^{3/4} + k)


@dataclass(frozen=True)
class Ladder:
    name: str
    levels: list[dict]  # overrides per level, coarse to fine

    def step(self, level: int) -> int:
        return self.levels[level]["time.N"]


def ladders(n1: int, n2: int, steps: int, count: int, time_mesh_level: int, space_steps_level: int) -> list[Ladder]:
    def mesh(level):
        return {"body1.mesh.n": n1 * 2 ** level, "body2.mesh.n": n2 * 2 ** level}

    return [Ladder("lockstep", [{**mesh(level), "time.N": steps * 2 ** level} for level in range(count)]),
            Ladder("time", [{**mesh(time_mesh_level), "time.N": steps * 2 ** level} for level in range(count)]),
            Ladder("space", [{**mesh(level), "time.N": steps * 2 ** space_steps_level} for level in range(count)])]


def distances(run: Path, reference: Path, run_steps: int, reference_steps: int, instants: int) -> list[dict]:
    """errors.edp between two run folders at the shared instants j/instants·T, j = 1..instants.
    The tool reads file names from its pairs file as words, so it runs in a scratch folder that
    links every file it needs under a plain name."""
    load_result(run), load_result(reference)
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        for side, folder in (("run", run), ("ref", reference)):
            for body in (1, 2):
                (scratch / f"{side}{body}.msh").symlink_to(folder / f"body{body}.msh")
        lines = []
        for j in range(1, instants + 1):
            for side, folder, steps in (("run", run, run_steps), ("ref", reference, reference_steps)):
                (scratch / f"{side}_{j:04d}.txt").symlink_to(folder / f"state_{j * steps // instants:04d}.txt")
            lines.append(f"run_{j:04d}.txt ref_{j:04d}.txt")
        (scratch / "pairs.txt").write_text(f"{len(lines)}\n" + "\n".join(lines) + "\n")
        done = run_script(REPO / "edp" / "tools" / "errors.edp",
                          ["-mesh1", "run1.msh", "-mesh2", "run2.msh", "-refMesh1", "ref1.msh", "-refMesh2", "ref2.msh",
                           "-pairs", "pairs.txt", "-out", "errors.csv"], cwd=scratch)
        if done.returncode != 0:
            raise RuntimeError(f"errors.edp failed for {run} against {reference}: {done.error_line}")
        with open(scratch / "errors.csv") as handle:
            return [{key: float(value) for key, value in row.items()} for row in csv.DictReader(handle)]


def slope(sizes, errors) -> float:
    """Least-squares slope of log(error) against log(size)."""
    return float(np.polyfit(np.log(sizes), np.log(errors), 1)[0])


def measure(ladder: Ladder, folders: list[Path], instants: int, scene: Scene) -> list[dict]:
    """One row per level: sizes, errors against the reference and against the next level."""
    reference, rows = len(folders) - 1, []
    for level, overrides in enumerate(ladder.levels):
        contact_length = read_state(sorted(folders[level].glob("state_*.txt"))[0])["s"][-1]
        row = {"ladder": ladder.name, "level": level, "n1": overrides["body1.mesh.n"], "n2": overrides["body2.mesh.n"],
               "N": overrides["time.N"], "h1": contact_length / overrides["body1.mesh.n"],
               "k": scene.time.T / overrides["time.N"], "seconds": load_result(folders[level]).history["stepSeconds"].sum()}
        if level < reference:
            to_reference = distances(folders[level], folders[reference], ladder.step(level), ladder.step(reference), instants)
            to_next = distances(folders[level], folders[level + 1], ladder.step(level), ladder.step(level + 1), instants)
            norm = max(r["normV"] for r in to_reference)
            for quantity in QUANTITIES:
                row[quantity] = max(r[quantity] for r in to_reference)
                row["next" + quantity[len("error"):]] = max(r[quantity] for r in to_next)
            row["relativeErrorV"] = row["errorV"] / norm
        rows.append(row)
    return rows


def rates(rows: list[dict], ladder: str) -> dict[str, dict[str, float]]:
    """Per quantity: the slope over the finest three levels below the reference, against the
    reference and from successive differences (the latter free of the reference's own error)."""
    measured = [row for row in rows if row["ladder"] == ladder and "errorV" in row][-3:]
    size = "k" if ladder == "time" else "h1"
    result = {}
    for quantity in QUANTITIES:
        name = quantity[len("error"):]
        result[quantity] = {"reference": slope([r[size] for r in measured], [r[quantity] for r in measured]),
                            "successive": slope([r[size] for r in measured], [r["next" + name] for r in measured])}
    return result


def convergence(scene_path: str | Path, out: str | Path, *, count: int = 6, n1: int = 6, n2: int = 8, steps: int = 20,
                time_mesh_level: int = 3, space_steps_level: int = 4, workers: int = 2, progress: bool = False) -> list[dict]:
    """Run the three ladders and write convergence.csv, README.md and convergence.png in `out`."""
    out = Path(out).resolve()
    scene = Scene.load(scene_path)
    instants = steps
    times = [j * scene.time.T / instants for j in range(1, instants + 1)]
    base = {"output.times": times, "output.fields": ["state"], "output.images": False}
    studied = ladders(n1, n2, steps, count, time_mesh_level, space_steps_level)
    jobs, planned = [], {}
    for ladder in studied:
        rows, ladder_jobs = plan(scene_path, ladder.levels, out / "runs" / ladder.name, base)
        planned[ladder.name] = rows
        jobs += ladder_jobs
    run_jobs(jobs, workers, None, progress)
    failed = [row for rows in planned.values() for row in rows if row["status"] in ("failed", "invalid")]
    if failed:
        raise RuntimeError("runs of the study failed: " + "; ".join(f"{r['folder']}: {r['error']}" for r in failed))
    table = []
    for ladder in studied:
        folders = [out / "runs" / ladder.name / row["folder"] for row in planned[ladder.name]]
        table += measure(ladder, folders, instants, scene)
    write_outputs(out, table, scene_path, count, n1, n2, steps, time_mesh_level, space_steps_level)
    return table


COLUMNS = ["ladder", "level", "n1", "n2", "N", "h1", "k", "errorV", "relativeErrorV", "errorZeta", "errorBeta",
           "nextV", "nextZeta", "nextBeta", "seconds"]


def write_outputs(out: Path, table: list[dict], scene_path, count, n1, n2, steps, time_mesh_level, space_steps_level):
    with open(out / "convergence.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(table)
    plot(out / "convergence.png", table)
    command = (f"python -m orchestrate study convergence {Path(scene_path).as_posix()} --levels {count} --n1 {n1} --n2 {n2} "
               f"--N {steps} --time-mesh-level {time_mesh_level} --space-steps-level {space_steps_level}")
    (out / "README.md").write_text(markdown(table, command))


def _format(value) -> str:
    if isinstance(value, float):
        return f"{value:.3e}" if value and (abs(value) < 1e-2 or abs(value) >= 1e4) else f"{value:.4g}"
    return str(value)


def markdown(table: list[dict], command: str) -> str:
    lines = ["# Convergence study", "", "Reproduce (from the repository root):", "", "```sh", command, "```", "",
             "Errors are maxima over the shared instants of the distance to the finest level of each ladder "
             "(the reference); *next* is the distance to the next finer level. Norms as in Theorem 2.1 of the seed: "
             "‖·‖_V = (Σ_ℓ ∫ ε:ε)^½ for u, L² for ζ on the bodies and for β on Γ_C. Nested structured meshes make "
             "every norm exact (edp/tools/errors.edp). The instants are the coarsest level's, shared by all levels.",
             "",
             "Reading the rates: an error against the reference is biased low at the level next to it, because "
             "the reference has an error of its own, so rates against the reference come out high at the fine end; "
             "distances between successive levels decay at the true rate. Both are given; Theorem 2.1 of the seed "
             "predicts at least h^{3/4} in space and k in time.", ""]
    for ladder in ("lockstep", "time", "space"):
        rows = [row for row in table if row["ladder"] == ladder]
        if not rows:
            continue
        lines += [f"## {ladder}", "", "| n1 | n2 | N | " + " | ".join(LABELS[q] for q in QUANTITIES)
                  + " | rel. V error | next V | next ζ | next β | solver s |",
                  "|---|---|---|---|---|---|---|---|---|---|---|"]
        for row in rows:
            values = [row.get(key) for key in ("errorV", "errorZeta", "errorBeta", "relativeErrorV", "nextV", "nextZeta",
                                               "nextBeta")]
            cells = ["reference" if v is None else _format(v) for v in values]
            lines.append(f"| {row['n1']} | {row['n2']} | {row['N']} | " + " | ".join(cells) + f" | {row['seconds']:.1f} |")
        observed = rates(table, ladder)
        size = "k" if ladder == "time" else "h"
        lines += ["", f"Observed rates in {size} over the finest three levels (theory: {size}^{THEORY[ladder]:g}):", ""]
        for quantity in QUANTITIES:
            pair = observed[quantity]
            lines.append(f"- {LABELS[quantity]}: {pair['reference']:.2f} against the reference, "
                         f"{pair['successive']:.2f} from successive differences")
        lines.append("")
    return "\n".join(lines)


def plot(target: Path, table: list[dict]) -> None:
    import matplotlib.ticker

    figure, axes = pyplot().subplots(1, 3, figsize=(15, 4.6))
    for axis, ladder in zip(axes, ("lockstep", "time", "space")):
        rows = [row for row in table if row["ladder"] == ladder and "errorV" in row]
        size = "k" if ladder == "time" else "h1"
        sizes = np.array([row[size] for row in rows])
        for quantity, marker in zip(QUANTITIES, "osd"):
            errors = np.array([row[quantity] for row in rows])
            axis.loglog(sizes, errors, marker + "-", label=LABELS[quantity])
            order = THEORY[ladder]
            axis.loglog(sizes, errors[-1] * (sizes / sizes[-1]) ** order, ":", color=axis.lines[-1].get_color(), lw=1)
        axis.set_xlabel("time step k" if ladder == "time" else "mesh size h1 (body 1)")
        axis.set_title(f"{ladder}: dotted = {('k' if ladder == 'time' else 'h')}^{THEORY[ladder]:g}")
        axis.grid(True, which="both", alpha=0.3)
        axis.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    axes[0].set_ylabel("max over t of the error")
    axes[0].legend(fontsize=8)
    save(figure, target)


# --- stability --------------------------------------------------------------------------------

ELASTIC_BOUND = re.compile(r"k\* = 2/rho = ([0-9.eE+-]+)")
GLUE_BOUND = re.compile(r"2/rho_tau = ([0-9.eE+-]+)")
GLUE_SCENE = Path(__file__).resolve().parent.parent / "scenes" / "shear.toml"
# The shear scene with γ_ν = 0 (the glue never debonds, so p_τ β R*(slip) is a linear spring),
# soft bodies (E = 10: the elastic bound is far away) and the top's displacement held after t = 1.
GLUE_ALONE = {"body1.mesh.n": 8, "body2.mesh.n": 11, "glue.gammaNu": 0.0, "body1.material.E": 10.0,
              "body2.material.E": 10.0, "body1.boundary.0.value": "0.2*min(t, 1)",
              "body1.boundary.1.value": "0.2*min(t, 1)"}


def printed_bound(folder: Path, pattern: re.Pattern) -> float | None:
    """A bound as the driver computed and printed it (edp/lib/stability.idp) in the last run into
    `folder`, which may have stopped (runner.run leaves `<folder>.failed` then, and removes it
    when a run succeeds); None when the run printed none (no tangential glue, say)."""
    failed = folder.with_name(folder.name + ".failed")
    log = (failed if failed.exists() else folder) / "run.log"
    for line in log.read_text().splitlines():
        if line.startswith("stability:") and (match := pattern.search(line)):
            return float(match.group(1))
    return None


def is_unstable(scene_path, overrides: dict, folder: Path) -> bool:
    """Unstable: the run stops on divergence, or ‖u‖_V at T exceeds ten times its value at t = 1
    (the loads are held after t = 1, so a stable run only creeps)."""
    from orchestrate.freefem import SolverError
    from orchestrate.runner import run

    try:
        result = run(scene_path, folder, overrides, force=True)
    except SolverError as error:
        if error.returncode == 5:
            return True
        raise
    history = result.history
    at_one = history["normV"][int(np.argmin(np.abs(history["t"] - 1.0)))]
    return bool(history["normV"][-1] > 10 * at_one)


def smallest_stable_steps(scene_path, overrides: dict, folder: Path, guess: int) -> int:
    """Bisection on N between an unstable and a stable step count around `guess`."""
    low, high = max(1, int(0.7 * guess)), int(1.4 * guess) + 1
    while not is_unstable(scene_path, {**overrides, "time.N": low}, folder):
        low = max(1, low // 2)
    while is_unstable(scene_path, {**overrides, "time.N": high}, folder):
        high *= 2
    while high - low > 1:
        middle = (low + high) // 2
        if is_unstable(scene_path, {**overrides, "time.N": middle}, folder):
            low = middle
        else:
            high = middle
    return high


def threshold(scene_path, overrides: dict, folder: Path, pattern: re.Pattern) -> dict:
    """The predicted bound (from a short run) against the observed one (bisection on N over a
    horizon T = max(5, 200 k*)): the threshold lies between T/N and T/(N − 1)."""
    probe = {**overrides, "solver.allowUnstable": True, "output.times": "none", "output.images": False}
    is_unstable(scene_path, {**probe, "time.T": 1.0, "time.N": 1000}, folder)
    k_star = printed_bound(folder, pattern)
    if k_star is None:
        raise RuntimeError(f"the run in {folder} printed no bound matching {pattern.pattern}")
    glue_bound = printed_bound(folder, GLUE_BOUND) if pattern is not GLUE_BOUND else None
    horizon = max(5.0, 200 * k_star)
    steps = smallest_stable_steps(scene_path, {**probe, "time.T": horizon}, folder, round(horizon / k_star))
    stable_k, unstable_k = horizon / steps, horizon / (steps - 1)
    observed = 0.5 * (stable_k + unstable_k)
    return {"T": horizon, "predicted": k_star, "glueBound": glue_bound, "stableK": stable_k,
            "unstableK": unstable_k, "observed": observed, "difference": observed / k_star - 1, "stableN": steps}


def stability(scene_path: str | Path, out: str | Path, young=(100.0, 316.0, 1000.0, 3162.0, 10000.0),
              glue=(100.0, 1000.0, 10000.0)) -> list[dict]:
    """Predicted and observed explicit bounds: the elastic k* for several E/η, with damage and
    with λ_u = 0, on `scene_path`; the tangential glue bound 2/ρ_τ for several p_τ on the shear
    scene set up so that the glue alone sets the bound (GLUE_ALONE)."""
    out = Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    eta = Scene.load(scene_path).body1.material.eta
    held = {"body1.boundary.1.fy": "-10*min(t, 1)", "body1.boundary.2.fx": "10*y*min(t, 1)"}
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch) / "run"
        for E in young:
            for damage in ("on", "off"):
                overrides = {**held, "body1.mesh.n": 6, "body2.mesh.n": 8, "body1.material.E": E,
                             "body2.material.E": E}
                if damage == "off":
                    overrides.update({"body1.damage.lambdaU": 0.0, "body2.damage.lambdaU": 0.0})
                rows.append({"term": "elastic", "parameter": E / eta, "damage": damage,
                             **threshold(scene_path, overrides, folder, ELASTIC_BOUND)})
        for p_tau in glue:
            rows.append({"term": "tangential glue", "parameter": p_tau, "damage": "on",
                         **threshold(GLUE_SCENE, {**GLUE_ALONE, "glue.pTau": p_tau}, folder, GLUE_BOUND)})
    write_stability(out, rows, scene_path)
    return rows


def bracket(row: dict) -> str:
    """The columns a stability table shares: predicted | observed (bracket) | difference | N | T."""
    return (f"{row['predicted']:.5g} | {row['observed']:.5g} ({row['stableK']:.5g} – {row['unstableK']:.5g}) | "
            f"{100 * row['difference']:+.2f} % | {row['stableN']} | {row['T']:.4g}")


def certain_bound(row: dict) -> float:
    """2/(ρ + ρ_τ) from an elastic row's 2/ρ and 2/ρ_τ: below it the step is stable for certain."""
    return 2 / (2 / row["predicted"] + 2 / row["glueBound"])


def glue_columns(row: dict) -> str:
    """2/ρ_τ and the certain bound 2/(ρ + ρ_τ), for an elastic row run with tangential glue."""
    if not row["glueBound"]:
        return "– | –"
    return f"{row['glueBound']:.4g} | {certain_bound(row):.5g}"


def within_theory(row: dict) -> bool:
    """Does the observed bracket [stableK, unstableK] meet [2/(ρ + ρ_τ), min(2/ρ, 2/ρ_τ)]?"""
    return row["stableK"] <= min(row["predicted"], row["glueBound"]) and row["unstableK"] >= certain_bound(row)


def write_stability(out: Path, rows: list[dict], scene_path) -> None:
    with open(out / "stability.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    elastic = [row for row in rows if row["term"] == "elastic"]
    glue = [row for row in rows if row["term"] == "tangential glue"]
    lines = ["# Stability of the explicit scheme: predicted and observed bound on the time step", "",
             "Reproduce (from the repository root):", "", "```sh",
             f"python -m orchestrate study stability {Path(scene_path).as_posix()}", "```", "",
             "Observed: the smallest stable N by bisection, loads held after t = 1, horizon T = max(5, 200 k*) "
             "(unstable: the run stops on divergence, or ‖u‖_V(T) > 10 ‖u‖_V(1)); the threshold lies between "
             "T/N and T/(N − 1), whose midpoint is given.", "",
             "## Elastic term", "",
             "The paper's scene on coarse meshes (body 1 with 6 elements per side, body 2 with 8) with E varied "
             "in both bodies. Predicted: k* = 2/ρ, ρ = max(bG/η, (2aG + bG)/(2μ + η)) (MODEL.md §7, "
             "edp/lib/stability.idp). With damage on, ζ < 1 lowers the effective ρ, so an unstable step can be "
             "masked; λ_u = 0 keeps ζ = 1. The scene's tangential glue (p_τ = 1) adds its own bound 2/ρ_τ; "
             "the true threshold lies between 2/(ρ + ρ_τ) and min(2/ρ, 2/ρ_τ) (docs/model-choices.md, "
             "\"Explicit glue\"), which matters where ρ_τ is not small against ρ (soft bodies).", "",
             "| E/η | damage | predicted k* | observed k* (bracket) | difference | smallest stable N | T | 2/ρ_τ | 2/(ρ + ρ_τ) |",
             "|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {row['parameter']:.3g} | {'on' if row['damage'] == 'on' else 'λ_u = 0'} | {bracket(row)} | "
              f"{glue_columns(row)} |" for row in elastic]
    undamaged = [row for row in elastic if row["damage"] == "off"]
    worst = max(abs(row["difference"]) for row in undamaged)
    lines += ["", f"Largest difference with λ_u = 0: {100 * worst:.2f} %."]
    with_glue = [row for row in undamaged if row["glueBound"]]
    if with_glue:
        inside = sum(within_theory(row) for row in with_glue)
        lines += [f"With λ_u = 0, {inside} of {len(with_glue)} observed brackets meet the theory's interval "
                  "[2/(ρ + ρ_τ), min(2/ρ, 2/ρ_τ)]."]
    if glue:
        lines += ["", "## Tangential glue term", "",
                  "scenes/shear.toml (n = 8/11) with γ_ν = 0 (the glue never debonds), E = 10 in both bodies (the "
                  "elastic bound is far away) and the top's displacement held after t = 1, p_τ varied. Predicted: "
                  "2/ρ_τ, kρ_τ = λmax(C K⁻¹ Cᵀ W) by power iteration (docs/model-choices.md, \"Explicit glue\").", "",
                  "| p_τ | predicted 2/ρ_τ | observed (bracket) | difference | smallest stable N | T |",
                  "|---|---|---|---|---|---|"]
        lines += [f"| {row['parameter']:.4g} | {bracket(row)} |" for row in glue]
        worst = max(abs(row["difference"]) for row in glue)
        lines += ["", f"Largest difference: {100 * worst:.2f} %."]
    (out / "README.md").write_text("\n".join(lines) + "\n")
    plot_stability(out / "stability.png", rows)


def plot_stability(target: Path, rows: list[dict]) -> None:
    """Observed against predicted bounds, one marker per term, on log axes."""
    figure, axis = pyplot().subplots(figsize=(6, 5))
    series = (("elastic", "off", "o", "elastic, λ_u = 0"), ("elastic", "on", "s", "elastic, damage on"),
              ("tangential glue", "on", "^", "tangential glue"))
    for term, damage, marker, label in series:
        points = [(row["predicted"], row["observed"]) for row in rows if row["term"] == term and row["damage"] == damage]
        if points:
            axis.loglog(*zip(*points), marker, label=label, mfc="none")
    limits = [min(row["predicted"] for row in rows) / 1.5, max(row["predicted"] for row in rows) * 1.5]
    axis.loglog(limits, limits, "k:", lw=1, label="observed = predicted")
    log_axes(axis, "predicted bound (2/ρ, 2/ρ_τ)", "observed threshold k")
    save(figure, target)
