"""A cantilever peel (scenes/cantilever.toml) against beam theory.

An elastic arm of thickness h, plane strain, bonded to a stiff clamped substrate beyond a crack
of length a₀ from its free end, whose free end is lifted by a prescribed δ(t), slowly enough to be
quasi-static; the glue is rate-independent (debondMobility = "inf", docs/model.md §9) with the
adhesion energy ε_a and shearDebonding on, so the fracture energy is G_c = ε_a whatever the mode
mixity (up to the truncation's ε_a δ₀²/(2L²), below 1e-4 of it here). Beam theory for the arm
clamped a + χh from its end (χh: the root's compliance, from the glue and the substrate):
  compliance C(a) = (a + χh)³/(3E′I),  on the propagation branch P = √(2E′I G_c)/(a + χh),
  and the front starts at δ_c = (a₀ + χh)² √(2G_c/(E′I))/3,
E′ = E/(1 − ν²) in plane strain (E in plane stress), I = h³/12. χ is fitted once, from the
compliance of the initial elastic branch (the steps before any debonding: surfaceEnergy and
debondDissipation still 0). Measured from
history.csv: P the lifting force per unit width (reactionY1_4), a the front (debondFront, from
Γ_C's start at the free end: the crack's length), read where the front passes each a/h by
linear interpolation between steps; the front's start is the opening where it has moved by h/8
(the cohesive zone forms before: the front moves by 0.01 h at about 0.85 δ_c; the report gives
both). Writes cantilever.csv (one row per a/h), onset.csv, README.md and peel.png into --out (the
run in a temporary folder).
"""
from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from orchestrate.freefem import REPO
from orchestrate.outputs import claim_folder, refuse_folder, write_csv, write_figure, write_text
from orchestrate.plots import pyplot
from orchestrate.progress import wanted
from orchestrate.runner import run
from orchestrate.scene import Scene
from orchestrate.studies.reports import reproduce

NAME = "cantilever"  # the command, as its folders' made-by.json records it
FILES = ("cantilever.csv", "onset.csv", "README.md", "peel.png")
SCENE = REPO / "scenes" / "cantilever.toml"
CRACK = 8.0  # a₀, set here (β⁰ = x > a₀) so that the theory's a₀ is the run's
COLUMNS = ["a_over_h", "force", "force_theory", "error"]
ONSET_COLUMNS = ["moved_over_h", "opening", "opening_theory", "error"]
STARTED, FORMING = 1 / 8, 0.01  # the front's moves (over h) that count as its start, and as the zone forming


@dataclass(frozen=True)
class Size:
    """The arm's length, its elements along Γ_C, the steps, the lift rate δ/t (T = 1) and the a/h read."""
    length: float
    n: int
    steps: int
    lift: float
    ratios: tuple[int, ...]


FULL = Size(40.0, 320, 1200, 6.0, tuple(range(10, 31, 2)))
SMALL = Size(20.0, 160, 600, 3.0, (10, 12, 14))  # what tests/test_adhesion.py runs: a/h to 15


@dataclass(frozen=True)
class Beam:
    """The arm's beam theory: E′I, G_c, a₀ and the fitted χh."""
    stiffness: float   # E′I
    energy: float      # G_c
    crack: float       # a₀
    root: float        # χh

    def force(self, a):
        return math.sqrt(2 * self.stiffness * self.energy) / (np.asarray(a) + self.root)

    def onset(self) -> float:
        return (self.crack + self.root) ** 2 * math.sqrt(2 * self.energy / self.stiffness) / 3

    def compliance(self, a) -> float:
        return (a + self.root) ** 3 / (3 * self.stiffness)


def overrides(size: Size, lift: str) -> dict:
    return {"time.N": size.steps, "body1.mesh.rectangle": [0.0, size.length, 0.0, 1.0], "body1.mesh.n": size.n,
            "body2.mesh.rectangle": [0.0, size.length, -1.0, 0.0], "body2.mesh.n": size.n // 4,
            "body1.boundary.0.value": lift, "glue.beta0": f"x > {CRACK:g}", "output.images": False}


def fit_beam(scene: Scene, lift: np.ndarray, force: np.ndarray, elastic: np.ndarray) -> Beam:
    """E′I and G_c of the scene; χh from the least-squares compliance of the elastic branch."""
    glue = scene.glue
    y0, y1 = scene.body1.mesh.rectangle[2:]
    thickness = y1 - y0
    material = scene.body1.material
    modulus = material.E / (1 - material.nu ** 2) if material.planeStrain else material.E  # E′
    stiffness = modulus * thickness ** 3 / 12
    onset = math.sqrt(glue.adhesionEnergy / glue.gammaNu)
    energy = glue.adhesionEnergy * (1 - onset ** 2 / (2 * glue.L ** 2))
    compliance = float(np.dot(lift[elastic], force[elastic]) / np.dot(force[elastic], force[elastic]))
    return Beam(stiffness, energy, CRACK, (3 * stiffness * compliance) ** (1 / 3) - CRACK)


def crossing(front: np.ndarray, values: np.ndarray, position: float) -> float:
    """`values` where the front first passes `position`, linear between the two steps around it."""
    j = int(np.argmax(front >= position))
    if front[j] < position or j == 0:
        raise RuntimeError(f"the front never passed {position:g} (it reached {front.max():g}): lift further")
    share = (position - front[j - 1]) / (front[j] - front[j - 1])
    return float(values[j - 1] + share * (values[j] - values[j - 1]))


@dataclass(frozen=True)
class Peel:
    rows: list[dict]   # cantilever.csv
    onset: list[dict]  # onset.csv
    beam: Beam


def cantilever(out: str | Path, size: Size = FULL, progress: bool | str = "auto", force: bool = False) -> Peel:
    """The peel into cantilever.csv, onset.csv, README.md and peel.png in `out` (a new folder, or with
    `force` one this study wrote)."""
    shown = wanted(progress)
    out = Path(out)
    refuse_folder(out, f"study {NAME}", force)
    lift_text = f"{size.lift:g}*t"
    with tempfile.TemporaryDirectory(prefix="cantilever-") as scratch:
        history = run(SCENE, Path(scratch) / "run", overrides(size, lift_text), progress=shown).history
    scene = Scene.load(SCENE)  # the overrides leave the arm's section, its material and the glue as they are
    lift = np.concatenate([[0.0], size.lift * history["t"]])
    force_ = np.concatenate([[0.0], history["reactionY1_4"]])
    front = np.concatenate([[CRACK], history["debondFront"]])
    untouched = np.concatenate([[False], (history["surfaceEnergy"] == 0) & (history["debondDissipation"] == 0)])
    beam = fit_beam(scene, lift, force_, untouched)
    rows = []
    for ratio in size.ratios:
        measured, theory = crossing(front, force_, ratio), float(beam.force(ratio))
        rows.append({"a_over_h": ratio, "force": measured, "force_theory": theory, "error": measured / theory - 1})
    onset = [{"moved_over_h": moved, "opening": crossing(front, lift, CRACK + moved),
              "opening_theory": beam.onset()} for moved in (STARTED, FORMING)]
    for row in onset:
        row["error"] = row["opening"] / row["opening_theory"] - 1
    folder = claim_folder(out, f"study {NAME}", FILES, force)
    write_csv(folder / "cantilever.csv", rows, COLUMNS)
    write_csv(folder / "onset.csv", onset, ONSET_COLUMNS)
    write_text(folder / "README.md", report(rows, onset, beam, scene, size, int(untouched.sum())))
    plot(folder / "peel.png", lift, force_, front, beam, size)
    return Peel(rows, onset, beam)


def report(rows: list[dict], onset: list[dict], beam: Beam, scene: Scene, size: Size, elastic: int) -> str:
    glue, material = scene.glue, scene.body1.material
    command = "python -m orchestrate study cantilever" + ("" if size == FULL else "  # at another size")
    worst = max(abs(row["error"]) for row in rows)
    lines = ["# A cantilever peel against beam theory", "", *reproduce(command),
             f"scenes/cantilever.toml: an arm (0, {size.length:g}) × (0, 1), h = 1, "
             f"{'plane strain' if material.planeStrain else 'plane stress'} (E = {material.E:g}, "
             f"ν = {material.nu:g}; {size.n // size.length:g} segments per h along Γ_C), bonded to a stiff clamped "
             f"substrate beyond a crack a₀ = {CRACK:g} from its free end, which is lifted by δ = {size.lift:g} t over "
             f"N = {size.steps} steps (bdf2). Glue γ_ν = {glue.gammaNu:g}, p_τ = {glue.pTau:g}, rate-independent "
             "(debondMobility = inf), "
             f"ε_a = {glue.adhesionEnergy:g}, shearDebonding on: G_c = ε_a (1 − δ₀²/(2L²)) = {beam.energy:.6g}.", "",
             f"Beam theory: P = √(2E′I G_c)/(a + χh), E′I = {beam.stiffness:.6g}; χh = {beam.root:.4f} from the "
             f"compliance of the {elastic} steps of the initial elastic branch (C₀ = (a₀ + χh)³/(3E′I) = "
             f"{beam.compliance(CRACK):.5f}). *force*: the lifting force per unit width (history.csv reactionY1_4) "
             "where the front (debondFront) passes a, linear between steps.", "",
             "| a/h | force | beam theory | error |", "|---|---|---|---|"]
    lines += [f"| {row['a_over_h']} | {row['force']:.6f} | {row['force_theory']:.6f} | {100 * row['error']:+.2f} % |"
              for row in rows]
    lines += ["", f"Largest error on the propagation branch: {100 * worst:.2f} %.", "",
              "The front's start: the opening at which debondFront has moved by a share of h, against "
              f"δ_c = (a₀ + χh)² √(2G_c/(E′I))/3 = {beam.onset():.5f}. The cohesive zone forms before δ_c "
              "(the glue softens where the opening passes δ₀), so the front moves by 0.01 h earlier; h/8 is its start.",
              "", "| moved | opening | δ_c | error |", "|---|---|---|---|"]
    lines += [f"| {row['moved_over_h']:g} h | {row['opening']:.5f} | {row['opening_theory']:.5f} | "
              f"{100 * row['error']:+.2f} % |" for row in onset]
    return "\n".join(lines) + "\n"


def plot(target: Path, lift: np.ndarray, force: np.ndarray, front: np.ndarray, beam: Beam, size: Size) -> None:
    """The force against the lift and against the crack length, each with beam theory."""
    figure, (left, right) = pyplot().subplots(1, 2, figsize=(11, 4.5))
    cracks = np.linspace(CRACK, front.max(), 400)
    theory = beam.force(cracks)
    elastic = np.linspace(0, beam.onset(), 2)
    left.plot(elastic, elastic / beam.compliance(CRACK), "k--", lw=1, label="elastic branch, C(a₀)")
    left.plot(theory * beam.compliance(cracks), theory, "k-", lw=2.5, alpha=0.35, label="beam theory")
    left.plot(lift, force, "C0-", lw=1, label="run")
    left.set_xlabel("lift δ of the free end")
    left.set_ylabel("force P per unit width")
    right.plot(cracks, theory, "k-", lw=2.5, alpha=0.35, label="√(2E′I G_c)/(a + χh)")
    propagating = front > CRACK + STARTED
    right.plot(front[propagating], force[propagating], "C0-", lw=1, label="run (debondFront)")
    right.set_xlabel("crack length a (h = 1)")
    right.set_ylabel("force P per unit width")
    for axis in (left, right):
        axis.grid(True, alpha=0.3)
        axis.legend(fontsize=8)
    figure.suptitle(f"cantilever peel: χh = {beam.root:.3f}, G_c = {beam.energy:.4g}, N = {size.steps}", fontsize=10)
    write_figure(figure, target, dpi=110, bbox_inches="tight")
