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
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from orchestrate.freefem import REPO, run_script
from orchestrate.manifest import facts
from orchestrate.plots import pyplot, save
from orchestrate.reports import QUANTITIES, LABELS, THEORY, convergence_report, write_csv
from orchestrate.results import load_result
from orchestrate.scene import Scene
from orchestrate.sweep import plan, run_jobs


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
        row = {"ladder": ladder.name, "level": level, "n1": overrides["body1.mesh.n"], "n2": overrides["body2.mesh.n"],
               "N": overrides["time.N"], "h1": facts(folders[level])["contactLength"] / overrides["body1.mesh.n"],
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
    write_csv(out / "convergence.csv", table, COLUMNS)
    plot(out / "convergence.png", table)
    command = (f"python -m orchestrate study convergence {Path(scene_path).as_posix()} --levels {count} --n1 {n1} --n2 {n2} "
               f"--N {steps} --time-mesh-level {time_mesh_level} --space-steps-level {space_steps_level}")
    observed = {ladder.name: rates(table, ladder.name) for ladder in studied}
    (out / "README.md").write_text(convergence_report(table, observed, command))
    return table


COLUMNS = ["ladder", "level", "n1", "n2", "N", "h1", "k", "errorV", "relativeErrorV", "errorZeta", "errorBeta",
           "nextV", "nextZeta", "nextBeta", "seconds"]


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


# --- command line ---------------------------------------------------------------------------

NAME, HELP = "convergence", "lock-step, time-only and space-only ladders, errors and rates"


def add_arguments(parser) -> None:
    from orchestrate.cli import at_least_two, positive

    parser.add_argument("scene", help="a scene whose meshes are nested under n -> 2n, e.g. scenes/paper.toml")
    parser.add_argument("--levels", type=at_least_two, default=6, help="levels per ladder, the finest is the reference")
    parser.add_argument("--n1", type=positive, default=6, help="body 1 elements per side at the coarsest level")
    parser.add_argument("--n2", type=positive, default=8, help="body 2 elements per side at the coarsest level")
    parser.add_argument("--N", type=positive, default=20, help="time steps at the coarsest level")
    parser.add_argument("--time-mesh-level", type=int, default=3, help="mesh level of the time-only ladder")
    parser.add_argument("--space-steps-level", type=int, default=4, help="step level of the space-only ladder")
    parser.add_argument("--workers", type=positive, default=2)
    parser.add_argument("--out", default="results/convergence")


def command(options) -> int:
    convergence(options.scene, options.out, count=options.levels, n1=options.n1, n2=options.n2, steps=options.N,
                time_mesh_level=options.time_mesh_level, space_steps_level=options.space_steps_level,
                workers=options.workers, progress=sys.stderr.isatty())
    print((Path(options.out) / "README.md").read_text())
    return 0
