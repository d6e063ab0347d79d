"""One adhesive interface opened in mode I (scenes/mode_one.toml) against its fracture energy.

Two stiff blocks glued over their whole face, on rollers, the upper one lifted by a prescribed
δ(t) = 0.05 t: Γ_C opens uniformly. In the rate-independent limit (debondMobility = "inf",
docs/model.md §9) the bonding keeps β = min(1, ε_a/(γ_ν o²)) along the opening o, so the traction
is γ_ν o up to δ₀ = √(ε_a/γ_ν) and ε_a²/(γ_ν o³) beyond, and the work of separation per unit
length up to o = L is the closed form
  G(L) = ε_a/2 + ε_a/2 (1 − δ₀²/L²) = ε_a (1 − δ₀²/(2L²)),
ε_a itself for L ≫ δ₀. Measured: the work of the lifting force (the top's reaction, history.csv
reactionY1_3, per unit width) along δ by the trapezoid rule, less what the blocks store and
dissipate at T (history.csv elasticEnergy, viscousDissipation: about 1e-6 of it, the blocks being
stiff), over a ladder of N. The step's bonding is frozen at βⁿ⁻¹ in step 1 (docs/model.md §9),
so the traction lags the law by a step past δ₀ and the work exceeds G, by an amount that falls
with k (observed order 2: results/mode-one).
Writes mode-one.csv, README.md and traction.png into --out (the runs in a temporary folder).
"""
from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np

from orchestrate.freefem import REPO
from orchestrate.outputs import claim_folder, refuse_folder, write_csv, write_figure, write_text
from orchestrate.plots import pyplot
from orchestrate.progress import wanted
from orchestrate.runner import run
from orchestrate.scene import Scene
from orchestrate.studies.reports import reproduce

NAME = "mode-one"  # the command, as its folders' made-by.json records it
FILES = ("mode-one.csv", "README.md", "traction.png")
SCENE = REPO / "scenes" / "mode_one.toml"
LIFT = "0.05*t"  # the top's prescribed lift δ(t), set here so that the measurement's δ is the run's
LIFT_RATE = 0.05
STEPS = (100, 200, 400, 800, 1600)
COLUMNS = ["N", "k", "work", "theory", "error", "stored", "debondShare"]


def closed_form(scene: Scene) -> tuple[float, float]:
    """G(L) = ε_a (1 − δ₀²/(2L²)) of the scene's glue, and δ₀."""
    glue = scene.glue
    onset = math.sqrt(glue.adhesionEnergy / glue.gammaNu)
    return glue.adhesionEnergy * (1 - onset ** 2 / (2 * glue.L ** 2)), onset


def separation(history, width: float) -> tuple[float, float]:
    """The work of separation per unit length, and the blocks' share subtracted from it."""
    lift = np.concatenate([[0.0], LIFT_RATE * history["t"]])
    force = np.concatenate([[0.0], history["reactionY1_3"]])
    work = float(np.sum(0.5 * (force[1:] + force[:-1]) * np.diff(lift))) / width
    stored = float(history["elasticEnergy"][-1] + history["viscousDissipation"][-1]) / width
    return work - stored, stored


def mode_one(out: str | Path, steps=STEPS, progress: bool | str = "auto", force: bool = False) -> list[dict]:
    """The ladder of N into mode-one.csv, README.md and traction.png in `out` (a new folder, or with
    `force` one this study wrote)."""
    shown = wanted(progress)
    out = Path(out)
    refuse_folder(out, f"study {NAME}", force)
    scene = Scene.load(SCENE)
    theory, onset = closed_form(scene)
    x0, x1 = scene.body1.mesh.rectangle[:2]
    rows, curves = [], {}
    with tempfile.TemporaryDirectory(prefix="mode-one-") as scratch:
        for count in steps:
            result = run(SCENE, Path(scratch) / f"N{count}", {"time.N": count, "body1.boundary.2.value": LIFT,
                                                              "output.images": False}, progress=shown)
            history = result.history
            work, stored = separation(history, x1 - x0)
            rows.append({"N": count, "k": scene.time.T / count, "work": work, "theory": theory,
                         "error": work / theory - 1, "stored": stored / work,
                         "debondShare": float(history["debondDissipation"][-1]) / (x1 - x0) / work})
            curves[count] = (LIFT_RATE * history["t"], history["reactionY1_3"] / (x1 - x0))
    folder = claim_folder(out, f"study {NAME}", FILES, force)
    write_csv(folder / "mode-one.csv", rows, COLUMNS)
    write_text(folder / "README.md", report(rows, scene, onset, steps))
    plot(folder / "traction.png", curves, scene, onset)
    return rows


def report(rows: list[dict], scene: Scene, onset: float, steps) -> str:
    glue = scene.glue
    command = "python -m orchestrate study mode-one" + ("" if tuple(steps) == STEPS else
                                                       " --steps " + ",".join(str(n) for n in steps))
    lines = ["# One adhesive interface opened in mode I: the work of separation against G_c", "",
             *reproduce(command),
             f"scenes/mode_one.toml: two stiff blocks (E = {scene.body1.material.E:g}) glued over their whole face "
             f"(γ_ν = {glue.gammaNu:g}, ε_a = {glue.adhesionEnergy:g}, debondMobility = inf, L = {glue.L:g}), on "
             f"rollers, the top lifted by δ = {LIFT}: Γ_C opens uniformly, past δ₀ = √(ε_a/γ_ν) = {onset:g} to L at "
             f"T = {scene.time.T:g}. *work*: ∫ F dδ of the lifting force per unit width (trapezoid rule over the "
             "steps) less what the blocks store and dissipate at T (*stored*, its share); *theory*: "
             "G(L) = ε_a (1 − δ₀²/(2L²)), the rate-independent law's work up to o = L (ε_a for L ≫ δ₀); "
             "*debond share*: the dissipation the run books beyond ε_a (0 in the limit). bdf2; the step's glue "
             "holds β at βⁿ⁻¹, so the traction lags the law by a step past δ₀ and the work exceeds G.", "",
             "| N | k | work | theory | error | stored | debond share |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {row['N']} | {row['k']:.4g} | {row['work']:.6e} | {row['theory']:.6e} | {100 * row['error']:+.3f} % | "
              f"{row['stored']:.1e} | {row['debondShare']:.2e} |" for row in rows]
    if len(rows) > 1:
        order = math.log2(abs(rows[-2]["error"] / rows[-1]["error"])) if rows[-1]["error"] else float("nan")
        lines += ["", f"Observed order of the error in k over the last two levels: {order:.2f}."]
    return "\n".join(lines) + "\n"


def plot(target: Path, curves: dict, scene: Scene, onset: float) -> None:
    """The traction against the opening of each N, and the law's curve."""
    glue = scene.glue
    figure, axis = pyplot().subplots(figsize=(7, 4.5))
    opening = np.linspace(0, glue.L, 2000)
    law = np.where(opening <= onset, glue.gammaNu * opening,
                   glue.adhesionEnergy ** 2 / (glue.gammaNu * np.maximum(opening, onset) ** 3))
    axis.plot(opening, law, "k-", lw=2.5, alpha=0.35, label="rate-independent law")
    for count, (lift, traction) in curves.items():
        axis.plot(lift, traction, "-", lw=1, label=f"N = {count}")
    axis.set_xscale("log")
    axis.set_xlabel("opening δ (the lift; the blocks' strain is below 1e-5 of it)")
    axis.set_ylabel("traction F / width")
    axis.set_title(f"mode I: γ_ν = {glue.gammaNu:g}, ε_a = {glue.adhesionEnergy:g}, L = {glue.L:g}", fontsize=10)
    axis.grid(True, which="both", alpha=0.3)
    axis.legend(fontsize=8)
    write_figure(figure, target, dpi=110, bbox_inches="tight")
