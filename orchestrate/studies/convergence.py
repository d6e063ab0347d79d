"""Convergence study of a scene: python -m orchestrate study convergence SCENE.

Ladders of runs, each level halving what the ladder refines:
  lockstep  h and k together: body 1 with n1₀·2^ℓ elements per side, body 2 with n2₀·2^ℓ, N₀·2^ℓ steps
  time      k alone, on a fixed fine mesh: one ladder per time scheme (--schemes), N from --time-N
  space     h alone, at a fixed small step
The meshes must be nested under n → 2n (the paper's structured family is) so that the error norms
of the lockstep and space ladders are exact; the time ladders use one mesh. Every run saves its
state (u, ζ, β) at the N₀ instants of its ladder's coarsest level, which all its levels share;
edp/tools/errors.edp measures there the distance of each level to the reference and to the next
level. The reference of the lockstep and space ladders is their finest level; the time ladders
share one reference run, the most accurate scheme listed at twice their finest N. The error of a
level is the maximum over the instants, as in Theorem 2.1 of the seed. Observed rates are
least-squares slopes over the finest three levels measured.

A level of a time ladder may be refused (exit 3: its step exceeds a bound of an explicit term) or
stopped (exit 5: the run broke an invariant); the table says which and why, and the rates use the
levels that ran.
"""
from __future__ import annotations

import shlex
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from orchestrate.compare import instant_distances
from orchestrate.freefem import InputError
from orchestrate.manifest import facts
from orchestrate.outputs import claim_folder, write_csv, write_text
from orchestrate.plots import pyplot, save
from orchestrate.progress import wanted
from orchestrate.results import load_result
from orchestrate.scene import Scene, toml_value
from orchestrate.studies.reports import QUANTITIES, LABELS, convergence_report, expected_order
from orchestrate.sweep import plan_runs, run_jobs

NAME = "convergence"  # the command, as its folders' made-by.json records it

KINDS = ("lockstep", "time", "space")
ACCURACY = ("bdf2", "semi-implicit", "euler")  # most accurate first: the time ladders' reference


@dataclass(frozen=True)
class Ladder:
    name: str            # lockstep, space, or "time" + the scheme
    kind: str            # lockstep, time or space
    levels: list[dict]   # overrides per level, coarse to fine
    instants: int        # the shared instants: the coarsest level's steps
    scheme: str | None = None
    reference: dict | None = None  # the run every level is measured against; None: the finest level

    def step(self, level: int) -> int:
        return self.levels[level]["time.N"]


def ladders(n1: int, n2: int, steps: int, count: int, time_mesh_level: int, space_steps_level: int,
            kinds=KINDS, schemes=(None,), time_steps: int | None = None, time_count: int | None = None) -> list[Ladder]:
    """The ladders of the study; `schemes` None: the scene's own."""
    def mesh(level):
        return {"body1.mesh.n": n1 * 2 ** level, "body2.mesh.n": n2 * 2 ** level}

    time_steps, time_count = time_steps or steps, time_count or count
    studied = []
    if "lockstep" in kinds:
        studied.append(Ladder("lockstep", "lockstep", [{**mesh(level), "time.N": steps * 2 ** level}
                                                       for level in range(count)], steps))
    if "time" in kinds:
        listed = [scheme for scheme in schemes if scheme]
        best = next((scheme for scheme in ACCURACY if scheme in listed), None)
        reference = {**mesh(time_mesh_level), "time.N": time_steps * 2 ** time_count,
                     **({"time.scheme": best} if best else {})}
        for scheme in schemes:
            chosen = {"time.scheme": scheme} if scheme else {}
            studied.append(Ladder("time" + (f" {scheme}" if scheme else ""), "time",
                                  [{**mesh(time_mesh_level), "time.N": time_steps * 2 ** level, **chosen}
                                   for level in range(time_count)], time_steps, scheme, reference))
    if "space" in kinds:
        studied.append(Ladder("space", "space", [{**mesh(level), "time.N": steps * 2 ** space_steps_level}
                                                 for level in range(count)], steps))
    return studied


def slope(sizes, errors) -> float:
    """Least-squares slope of log(error) against log(size)."""
    return float(np.polyfit(np.log(sizes), np.log(errors), 1)[0])


def measure(ladder: Ladder, folders: list[Path | None], errors: list[str], reference: Path, scene: Scene) -> list[dict]:
    """One row per level: sizes, errors against the reference and against the next level; a level
    that did not run (folder None) has its error message instead."""
    rows = []
    for level, overrides in enumerate(ladder.levels):
        row = {"ladder": ladder.name, "kind": ladder.kind, "scheme": ladder.scheme or scene.time.scheme, "level": level,
               "n1": overrides["body1.mesh.n"], "n2": overrides["body2.mesh.n"], "N": overrides["time.N"],
               "k": scene.time.T / overrides["time.N"], "status": errors[level] or "ran"}
        rows.append(row)
        if folders[level] is None:
            continue
        row.update(h1=facts(folders[level])["contactLength"] / overrides["body1.mesh.n"],
                   seconds=load_result(folders[level]).history["stepSeconds"].sum())
        if folders[level] == reference:
            continue
        reference_steps = ladder.reference["time.N"] if ladder.reference else ladder.step(-1)
        to_reference = instant_distances(folders[level], reference, ladder.step(level), reference_steps, ladder.instants)
        norm = max(r["normV"] for r in to_reference)
        for quantity in QUANTITIES:
            row[quantity] = max(r[quantity] for r in to_reference)
        row["relativeErrorV"] = row["errorV"] / norm
        row["relativeErrorVAtT"] = to_reference[-1]["errorV"] / to_reference[-1]["normV"]
        if level + 1 < len(folders) and folders[level + 1] is not None:
            to_next = instant_distances(folders[level], folders[level + 1], ladder.step(level), ladder.step(level + 1),
                                ladder.instants)
            for quantity in QUANTITIES:
                row["next" + quantity[len("error"):]] = max(r[quantity] for r in to_next)
    return rows


def rates(rows: list[dict], ladder: str) -> dict[str, dict[str, float]]:
    """Per quantity: the slope over the finest three levels measured, against the reference and
    from successive differences (the latter free of the reference's own error); NaN with fewer
    than two such levels."""
    measured = [row for row in rows if row["ladder"] == ladder and "errorV" in row][-3:]
    with_next = [row for row in rows if row["ladder"] == ladder and "nextV" in row][-3:]
    size = "k" if measured and measured[0]["kind"] == "time" else "h1"
    result = {}
    for quantity in QUANTITIES:
        name = quantity[len("error"):]
        result[quantity] = {
            "reference": slope([r[size] for r in measured], [r[quantity] for r in measured]) if len(measured) >= 2 else float("nan"),
            "successive": slope([r[size] for r in with_next], [r["next" + name] for r in with_next]) if len(with_next) >= 2 else float("nan")}
    return result


def convergence(scene_path: str | Path, out: str | Path, *, count: int = 6, n1: int = 6, n2: int = 8, steps: int = 20,
                time_mesh_level: int = 3, space_steps_level: int = 4, kinds=KINDS, schemes=(None,),
                time_steps: int | None = None, time_count: int | None = None, workers: int = 2,
                progress: bool | str = "auto", force: bool = False, settings: dict | None = None) -> list[dict]:
    """Run the ladders and write convergence.csv, README.md and convergence.png in `out`, the runs
    in out/runs: a new folder, or with `force` one an earlier study wrote, whose complete runs are
    then reused (outputs.py); progress: a bar of the runs, True, False or "auto" (where one can be
    seen: progress.py); settings: scene values for every run (dotted keys, as run's overrides),
    none of those a ladder sets per level."""
    shown = wanted(progress)
    out = Path(out).resolve()
    settings = settings or {}
    refuse_ladder_keys(settings)
    scene = Scene.load(scene_path, settings)
    claim_folder(out, f"study {NAME}", FILES, force, folders=("runs",))
    studied = ladders(n1, n2, steps, count, time_mesh_level, space_steps_level, kinds, schemes, time_steps, time_count)
    jobs, planned, references = [], {}, {}
    for ladder in studied:
        times = [j * scene.time.T / ladder.instants for j in range(1, ladder.instants + 1)]
        base = {**settings, "output.times": times, "output.fields": ["state"], "output.images": False}
        rows, ladder_jobs = plan_runs(scene_path, ladder.levels, out / "runs" / ladder.name.replace(" ", "-"), base)
        planned[ladder.name] = rows
        jobs += ladder_jobs
        if ladder.reference and "time" not in references:
            rows, reference_jobs = plan_runs(scene_path, [ladder.reference], out / "runs" / "time-reference", base)
            references["time"] = rows[0]
            jobs += reference_jobs
    run_jobs(jobs, workers, None, shown)
    tolerated = [row for ladder in studied if ladder.kind == "time" for row in planned[ladder.name]]
    failed = [row for rows in (*planned.values(), list(references.values())) for row in rows
              if row["status"] in ("failed", "invalid", "interrupted") and row not in tolerated]
    if failed:
        raise RuntimeError("runs of the study failed: " + "; ".join(f"{r['folder']}: {r['error']}" for r in failed))
    table = []
    for ladder in studied:
        folder = out / "runs" / ladder.name.replace(" ", "-")
        rows = planned[ladder.name]
        folders = [folder / row["folder"] if row["status"] in ("completed", "skipped (complete)") else None for row in rows]
        errors = ["" if path else row["error"] for path, row in zip(folders, rows)]
        reference = out / "runs" / "time-reference" / references["time"]["folder"] if ladder.reference else folders[-1]
        if reference is None:
            raise RuntimeError(f"the reference of the {ladder.name} ladder did not run: {errors[-1]}")
        table += measure(ladder, folders, errors, reference, scene)
    write_csv(out / "convergence.csv", table, COLUMNS)
    plot(out / "convergence.png", table, studied)
    command = (f"python -m orchestrate study convergence {Path(scene_path).as_posix()} "
               f"--ladders {','.join(ladder for ladder in KINDS if ladder in kinds)} --levels {count} --n1 {n1} --n2 {n2} "
               f"--N {steps} --time-mesh-level {time_mesh_level} --space-steps-level {space_steps_level}"
               + (f" --schemes {','.join(schemes)} --time-N {time_steps or steps} --time-levels {time_count or count}"
                  if "time" in kinds and all(schemes) else "")
               + "".join(f" --set {shlex.quote(f'{key}={toml_value(value)}')}" for key, value in settings.items()))
    observed = {ladder.name: rates(table, ladder.name) for ladder in studied}
    write_text(out / "README.md", convergence_report(table, observed, command, studied))
    return table


LADDER_KEYS = ("body1.mesh.n", "body2.mesh.n", "time.N", "output.times", "output.fields", "output.images")


def refuse_ladder_keys(settings: dict) -> None:
    """A setting of what the ladders set per level (or the study for every run) would be lost."""
    taken = [key for key in settings if key in LADDER_KEYS]
    if taken:
        raise InputError(f"--set {taken[0]}: the study sets it for each run (the levels' meshes and steps, the saved "
                         "states, no images); give the ladder's --n1, --n2, --N or --time-N instead")


FILES = ("convergence.csv", "README.md", "convergence.png")
COLUMNS = ["ladder", "kind", "scheme", "level", "n1", "n2", "N", "h1", "k", "status", "errorV", "relativeErrorV",
           "relativeErrorVAtT", "errorZeta", "errorBeta", "nextV", "nextZeta", "nextBeta", "seconds"]


def plot(target: Path, table: list[dict], studied: list[Ladder]) -> None:
    """One panel per ladder: its errors against h or k, with the expected order dotted."""
    import matplotlib.ticker

    figure, axes = pyplot().subplots(1, len(studied), figsize=(5 * len(studied), 4.6), squeeze=False)
    for axis, ladder in zip(axes[0], studied):
        rows = [row for row in table if row["ladder"] == ladder.name and "errorV" in row]
        size = "k" if ladder.kind == "time" else "h1"
        order = expected_order(ladder.kind, rows[0]["scheme"] if rows else None)
        sizes = np.array([row[size] for row in rows])
        for quantity, marker in zip(QUANTITIES, "osd"):
            if not rows:
                break
            errors = np.array([row[quantity] for row in rows])
            axis.loglog(sizes, errors, marker + "-", label=LABELS[quantity])
            axis.loglog(sizes, errors[-1] * (sizes / sizes[-1]) ** order, ":", color=axis.lines[-1].get_color(), lw=1)
        axis.set_xlabel("time step k" if ladder.kind == "time" else "mesh size h1 (body 1)")
        axis.set_title(f"{ladder.name}: dotted = {'k' if ladder.kind == 'time' else 'h'}^{order:g}")
        axis.grid(True, which="both", alpha=0.3)
        axis.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    axes[0][0].set_ylabel("max over t of the error")
    axes[0][0].legend(fontsize=8)
    save(figure, target)


def time_mesh_level(levels: int, given: int | None) -> int:
    """The time ladders' mesh level: 3 by default, never finer than the space ladder's finest
    (levels − 1), whose meshes the study's space errors are measured on."""
    if given is None:
        return min(3, levels - 1)
    if not 0 <= given <= levels - 1:
        raise InputError(f"--time-mesh-level {given}: give a level in [0, {levels - 1}] (the space ladder's levels, "
                         f"--levels {levels})")
    return given
