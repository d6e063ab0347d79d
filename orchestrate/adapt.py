"""Meshes designed from a run's own error estimate: python -m orchestrate adapt SCENE --target E.

A pilot run of the scene as it is; then, while its estimate (orchestrate/estimate.py: the
Zienkiewicz–Zhu recovery of the strains, the largest η/‖u_h‖_V over the saved states) exceeds the
target, each body is meshed again from its own .geo with the element sizes the estimate designs
(a gmsh view, mesh.sizes; the .geo's constant adapted = 1 drops its Transfinite lines, so Γ_C is
graded too) and the scene runs again. Of each body's mesh keys, geo (or rectangle), parameters,
contactLabel and timeLimit hold for every run; n, structured and sizes give the pilot's mesh, whose
sizes each design then replaces (a design is graded, never structured); refine is refused, since
splitting a design's triangles would give it 4^refine times the triangles designed. Every run is
a plain run of the scene, in out/runs/cycleN with its manifest, meshes and restart as any other;
the size fields it ran on are kept in out/sizes/cycleN, and out/adapt.csv lists each cycle's
nodes, estimate and wall time (written after every cycle, so a loop that fails keeps the record of
those it finished). No state passes from one run to the next: each is the scene's whole run on its
own meshes.
"""
from __future__ import annotations

import re
import shutil
import time
from pathlib import Path

from orchestrate.estimate import estimate
from orchestrate.freefem import InputError
from orchestrate.manifest import displacement_nodes, facts
from orchestrate.outputs import claim_folder, write_csv, write_text
from orchestrate.runner import run
from orchestrate.scene import Scene
from orchestrate.schema import shown

NAME = "adapt"
FILES = ("adapt.csv", "README.md")
COLUMNS = ["cycle", "nodes1", "nodes2", "estimate", "relative", "seconds", "folder"]
CYCLES = 4
CYCLE = re.compile(r"cycle[0-9]+(\.partial|\.failed|\.lock)?")  # a cycle's run folder, its work folders, its sizes


def adapt(scene: str | Path, out: str | Path, target: float, cycles: int = CYCLES, overrides: dict | None = None,
          progress: bool | str = "auto", force: bool = False, trust_geo: bool = False) -> list[dict]:
    """The pilot and the adapted runs of `scene` (with `overrides`, as run takes them) into `out`
    until the relative estimate is at most `target` or `cycles` designs are spent; one row per
    run (adapt.csv)."""
    if not 0 < target < 1:
        raise InputError(f"--target {target:g}: give the relative estimate to reach, in (0, 1), e.g. 0.01")
    if cycles < 1:
        raise InputError(f"--cycles {cycles}: give at least 1")
    require_adaptable(Scene.load(scene, overrides))
    out = Path(out)
    claim_folder(out, NAME, FILES, force, folders=("runs", "sizes"))
    forget_cycles(out)
    rows, sizes = [], {}
    for cycle in range(cycles + 1):
        folder = out / "runs" / f"cycle{cycle}"
        start = time.perf_counter()
        result = run(scene, folder, {**(overrides or {}), **sizes}, progress=progress, force=force,
                     trust_geo=trust_geo)
        seconds = time.perf_counter() - start
        design = out / "sizes" / f"cycle{cycle + 1}"
        design.mkdir(parents=True, exist_ok=True)
        paths = (design / "body1.pos", design / "body2.pos")
        states = estimate(result, target, paths)
        worst = max(states, key=lambda row: row["relative"])
        established = facts(result.folder)
        rows.append({"cycle": cycle, "nodes1": displacement_nodes(established, "1"),
                     "nodes2": displacement_nodes(established, "2"),
                     "estimate": worst["estimate"], "relative": worst["relative"], "seconds": seconds,
                     "folder": f"runs/cycle{cycle}"})
        write_csv(out / "adapt.csv", rows, COLUMNS)  # the cycles so far, should a later one fail
        if worst["relative"] <= target or cycle == cycles:
            shutil.rmtree(design)  # no run takes it
            break
        sizes = {f"body{body}.mesh.sizes": str(path.resolve()) for body, path in enumerate(paths, 1)}
    write_text(out / "README.md", report(rows, scene, target))
    return rows


def require_adaptable(scene: Scene) -> None:
    """A scene whose every mesh key the loop honours (the module's docstring: refine is refused) and
    whose runs save the states the estimate reads, refused before the pilot runs."""
    if "state" not in scene.output.fields:
        raise InputError(f"output.fields = {shown(scene.output.fields)}: adapt estimates each run from the states it "
                         'saves: add "state" (the default has it)')
    if scene.output.times == "none":
        raise InputError('output.times = "none": adapt estimates each run from the states it saves at its output '
                         'times: give "final" (the default), "all" or a list of times')
    for name in ("body1", "body2"):
        refine = getattr(scene, name).mesh.refine
        if refine:
            raise InputError(f"{name}.mesh.refine = {refine}: adapt designs the element sizes itself, and splitting a "
                             f"design's triangles {refine} times would give it {4 ** refine} times the triangles "
                             f"designed: give the pilot's fineness by {name}.mesh.n, with --set {name}.mesh.refine=0")


def forget_cycles(out: Path) -> None:
    """An earlier adapt's cycles (a --force run replaces them): none is left beside the new ones,
    so the folder holds one loop's runs."""
    for kind in ("runs", "sizes"):
        for path in (out / kind).glob("cycle*") if (out / kind).is_dir() else ():
            if CYCLE.fullmatch(path.name) and not path.is_symlink():
                shutil.rmtree(path) if path.is_dir() else path.unlink()


def report(rows: list[dict], scene, target: float) -> str:
    reached = rows[-1]["relative"] <= target
    lines = [f"# Adapted meshes for {scene}", "",
             f"Target: η/‖u_h‖_V ≤ {target:g} (the largest over the saved states). "
             + (f"Reached at cycle {rows[-1]['cycle']}." if reached else
                f"NOT reached in {rows[-1]['cycle']} designs: run again with more --cycles."), "",
             "| cycle | nodes (body 1, 2) | estimate η | η/‖u_h‖_V | wall time | run |", "|---|---|---|---|---|---|"]
    lines += [f"| {row['cycle']} | {row['nodes1']}, {row['nodes2']} | {row['estimate']:.4e} | {row['relative']:.4e} | "
              f"{row['seconds']:.2f} s | {row['folder']} |" for row in rows]
    lines += ["", f"All runs together: {sum(row['seconds'] for row in rows):.2f} s of wall time."]
    return "\n".join(lines) + "\n"
