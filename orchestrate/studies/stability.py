"""Stability study: python -m orchestrate study stability [SCENE].

The explicit terms bound the time step (docs/model.md §7): the elastic k* = 2/ρ and, with tangential
glue, 2/ρ_τ and 2/ρ_ν (the paper's scheme; the others take the glue implicit, docs/model.md §9). For several
data the bound the driver predicts (its run facts) is set against the threshold observed by
bisection on N, over a horizon where the loads are held, so a stable run only creeps and an
unstable one grows or is stopped by the driver's growth and chatter checks.
"""
from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from orchestrate.freefem import REPO, SolverError
from orchestrate.manifest import read_json
from orchestrate.outputs import claim_folder, refuse_folder, write_csv, write_text
from orchestrate.parameters import ORDER
from orchestrate.plots import log_axes, pyplot, save
from orchestrate.progress import counter, wanted
from orchestrate.runner import run
from orchestrate.scene import Scene
from orchestrate.studies.reports import stability_report

NAME = "stability"  # the command, as its folders' made-by.json records it

GLUE_SCENE = REPO / "scenes" / "shear.toml"
# The shear scene with γ_ν = 0 (the glue never debonds, so p_τ β R*(slip) is a linear spring),
# soft bodies (E = 10: the elastic bound is far away) and the top's displacement held after t = 1;
# the paper's scheme unless a case names another (the scene itself takes bdf2).
GLUE_ALONE = {"time.scheme": "euler", "body1.mesh.n": 8, "body2.mesh.n": 11, "glue.gammaNu": 0.0,
              "body1.material.E": 10.0,
              "body2.material.E": 10.0, "body1.boundary.0.value": "0.2*min(t, 1)",
              "body1.boundary.1.value": "0.2*min(t, 1)"}
ELASTIC, GLUE, NORMAL, SOURCE = "kStar", "rhoTau", "rhoNu", "zetaCritical1"  # the run facts (run.json) of the bounds
# The same set-up for the normal glue: the top's lift opens Γ_C, p_τ = 0 and no debonding (m_d = 0),
# so γ_ν β² (−R(g_h))₊ is a linear spring on the opening (below L).
NORMAL_ALONE = {**GLUE_ALONE, "glue.pTau": 0.0, "glue.debondMobility": 0.0}
# Above its bound the normal glue pulls Γ_C shut and the contact stops it: the runs chatter, bounded,
# and only the chatter check (ten alternating steps) sees it, so the horizon holds many steps even
# where the observed threshold lies far above the predicted one.
NORMAL_HORIZON = 50.0
IMPLICIT = ("semi-implicit", "bdf2")
# The damage source alone: no loads (u stays 0), λ_u = 0, so a uniform ζ obeys the scalar law
# ζ' = λ_D (1 − ζ)/ζ + λ_w with the equilibrium ζ_eq = λ_D/(λ_D − λ_w) = 0.1, started 1 % above it
# (the flat mode: the diffusion does not act on it). Linearized, ζ − ζ_eq decays at the rate λ_D/ζ_eq².
SOURCE_ALONE = {"body1.boundary.1.fy": "0", "body1.boundary.2.fx": "0", "body1.mesh.n": 6, "body2.mesh.n": 8,
                **{f"body{i}.damage.{key}": value for i in (1, 2)
                   for key, value in (("lambdaU", 0.0), ("lambdaD", 1.0), ("lambdaW", -9.0), ("zeta0", 0.101))}}
ZETA_EQUILIBRIUM = 1.0 / (1.0 + 9.0)
FILES = ("stability.csv", "README.md", "stability.png")


def predicted_bound(folder: Path, fact: str, k: float) -> float | None:
    """A bound as the driver computed it (run.json, written at set-up) in the last run into
    `folder` (time step k), which may have stopped (runner.run leaves `<folder>.failed` then, and
    removes it when a run succeeds): k* itself; glueLimit/ρ_τ or glueLimit/ρ_ν (None without that glue); or
    the step at which the damage source's level ζc = sqrt(k λ_D/limit) reaches ζ_eq,
    k (ζ_eq/ζc)²."""
    failed = folder.with_name(folder.name + ".failed")
    facts = read_json((failed if failed.exists() else folder) / "run.json")
    value = facts.get(fact)
    if fact in (GLUE, NORMAL):
        return facts["glueLimit"] / value if value else None
    if fact == SOURCE:
        return k * (ZETA_EQUILIBRIUM / value) ** 2
    return value


def grows(history, fact: str) -> bool:
    """Over a horizon where the data are steady: ‖u‖_V at T more than ten times its value at t = 1
    (the loads are held after t = 1, so a stable run only creeps), or, for the damage source,
    ζ farther from ζ_eq at T than at the start."""
    if fact == SOURCE:
        start = abs(SOURCE_ALONE["body1.damage.zeta0"] - ZETA_EQUILIBRIUM)
        return bool(abs(history["zetaMin1"][-1] - ZETA_EQUILIBRIUM) > start)
    at_one = history["normV"][int(np.argmin(np.abs(history["t"] - 1.0)))]
    return bool(history["normV"][-1] > 10 * at_one)


def is_unstable(scene_path, overrides: dict, folder: Path, fact: str, progress: bool) -> bool:
    """Unstable: the run stops on divergence (exit 5), or it grows (`grows`)."""
    try:
        result = run(scene_path, folder, overrides, force=True, progress=progress)
    except SolverError as error:
        if error.returncode == 5:
            return True
        raise
    return grows(result.history, fact)


def smallest_stable_steps(scene_path, overrides: dict, folder: Path, guess: int, fact: str, progress: bool) -> int:
    """Bisection on N between an unstable and a stable step count around `guess`."""
    def unstable(steps: int) -> bool:
        return is_unstable(scene_path, {**overrides, "time.N": steps}, folder, fact, progress)

    low, high = max(1, int(0.7 * guess)), int(1.4 * guess) + 1
    while not unstable(low):
        low = max(1, low // 2)
    while unstable(high):
        high *= 2
    while high - low > 1:
        middle = (low + high) // 2
        if unstable(middle):
            low = middle
        else:
            high = middle
    return high


def threshold(scene_path, overrides: dict, folder: Path, fact: str, progress: bool = False,
              shortest: float = 5.0) -> dict:
    """The predicted bound (from a short run) against the observed one (bisection on N over a
    horizon T = max(shortest, 200 k*)): the threshold lies between T/N and T/(N − 1)."""
    probe = {**overrides, "solver.allowUnstable": True, "output.times": "none", "output.images": False}
    is_unstable(scene_path, {**probe, "time.T": 1.0, "time.N": 1000}, folder, fact, progress)
    k_star = predicted_bound(folder, fact, 1.0 / 1000)
    if k_star is None:
        raise RuntimeError(f"the run in {folder} has no {fact} among its facts")
    glue_bound = predicted_bound(folder, GLUE, 1.0 / 1000) if fact == ELASTIC else None
    horizon = max(shortest, 200 * k_star)
    steps = smallest_stable_steps(scene_path, {**probe, "time.T": horizon}, folder, round(horizon / k_star), fact,
                                  progress)
    stable_k, unstable_k = horizon / steps, horizon / (steps - 1)
    observed = 0.5 * (stable_k + unstable_k)
    return {"scheme": overrides.get("time.scheme", "euler"), "T": horizon, "predicted": k_star,
            "glueBound": glue_bound, "stableK": stable_k, "unstableK": unstable_k, "observed": observed,
            "difference": observed / k_star - 1, "stableN": steps}


def strong_damage(E: float, horizon: float) -> dict:
    """λ_u large enough that ζ falls far below 1 within the horizon (to about 0.02 at E/η = 5, to
    the obstacle ζ = 0 from E/η = 50 up): ε:ε scales as 1/E² under the scene's loads."""
    lambda_u = 1000.0 * (E / 1000.0) ** 2 * (10.0 / horizon)
    return {"body1.damage.lambdaU": lambda_u, "body2.damage.lambdaU": lambda_u}


def implicit_rows(scene_path, base: dict, E: float, eta: float, folder: Path, progress: bool,
                  multiples=(0.25, 1, 10, 100)) -> list[dict]:
    """The implicit schemes with strong damage at k = m k* (k* the paper's scheme's elastic bound):
    whether the run passes the driver's divergence and chatter checks, its largest growth of ‖u‖_V
    in one step once the loads are held, the ζ it reaches, and ‖u(T)‖_V against bdf2 at k*/16,
    checked by the paper's scheme at k*/16 (referenceCheck: their relative difference)."""
    quiet = {**base, "body1.material.E": E, "body2.material.E": E, "output.times": "none", "output.images": False}
    run(scene_path, folder, {**quiet, "time.T": 1.0, "time.N": 1000, "solver.allowUnstable": True}, force=True,
        progress=progress)
    k_star = predicted_bound(folder, ELASTIC, 1.0 / 1000)
    horizon = max(5.0, 200 * k_star)
    damaged = {**quiet, **strong_damage(E, horizon), "time.T": horizon}
    fine = {**damaged, "time.N": 16 * int(np.ceil(horizon / k_star))}
    check_norm = run(scene_path, folder, fine, force=True, progress=progress).history["normV"][-1]
    reference_norm = run(scene_path, folder, {**fine, "time.scheme": "bdf2"}, force=True,
                         progress=progress).history["normV"][-1]
    reference_facts = read_json(folder / "run.json")
    nodes = reference_facts["nodes1"] + reference_facts["nodes2"]
    rows = []
    for scheme in IMPLICIT:
        for multiple in multiples:
            steps = max(2, round(horizon / (multiple * k_star)))
            row = {"term": "implicit elasticity", "scheme": scheme, "parameter": E / eta, "damage": "strong",
                   "lambdaU": damaged["body1.damage.lambdaU"], "T": horizon, "predicted": k_star,
                   "kOverKStar": horizon / steps / k_star, "stableN": steps,
                   "referenceCheck": check_norm / reference_norm - 1}
            try:
                history = run(scene_path, folder, {**damaged, "time.scheme": scheme, "time.N": steps}, force=True,
                              progress=progress).history
            except SolverError as error:
                if error.returncode != 5:
                    raise
                rows.append({**row, "checks": "stopped: diverged"})
                continue
            below = read_json(folder / "run.json")["zetaBelowCriticalStep"]
            held = history["t"] > 1.0 + 1e-12
            ratios = history["normV"][1:][held[1:]] / history["normV"][:-1][held[1:]]
            rows.append({**row, "checks": "passed", "growth": float(ratios.max()) if ratios.size else float("nan"),
                         "zetaMin": float(min(history["zetaMin1"][-1], history["zetaMin2"][-1])),
                         "zetaZeroFraction": float(history["zetaBelowMin1"][-1] + history["zetaBelowMin2"][-1]) / nodes,
                         "normVDifference": history["normV"][-1] / reference_norm - 1,
                         "zetaBelowCriticalAt": below * horizon / steps if below else None})
    return rows


def elastic_rows(scene_path, held: dict, E: float, eta: float, damage: str, folder: Path, progress: bool) -> list[dict]:
    """The paper's scheme's elastic bound at E/η, with damage ("on") or with λ_u = 0 ("off")."""
    overrides = {**held, "body1.material.E": E, "body2.material.E": E}
    if damage == "off":
        overrides.update({"body1.damage.lambdaU": 0.0, "body2.damage.lambdaU": 0.0})
    return [{"term": "elastic", "parameter": E / eta, "damage": damage,
             **threshold(scene_path, overrides, folder, ELASTIC, progress)}]


def source_rows(scene_path, scheme: str, folder: Path, progress: bool) -> list[dict]:
    """The damage source's bound of a scheme (SOURCE_ALONE)."""
    return [{"term": "damage source", "parameter": ZETA_EQUILIBRIUM, "damage": "on",
             **threshold(scene_path, {**SOURCE_ALONE, "time.scheme": scheme}, folder, SOURCE, progress)}]


def glue_rows(scheme: str, p_tau: float, folder: Path, progress: bool) -> list[dict]:
    """The tangential glue's bound of a scheme at p_τ (GLUE_ALONE)."""
    return [{"term": "tangential glue", "parameter": p_tau, "damage": "on",
             **threshold(GLUE_SCENE, {**GLUE_ALONE, "glue.pTau": p_tau, "time.scheme": scheme}, folder, GLUE, progress)}]


def normal_rows(gamma_nu: float, folder: Path, progress: bool) -> list[dict]:
    """The paper's scheme's normal glue bound at γ_ν (NORMAL_ALONE)."""
    return [{"term": "normal glue", "parameter": gamma_nu, "damage": "on",
             **threshold(GLUE_SCENE, {**NORMAL_ALONE, "glue.gammaNu": gamma_nu}, folder, NORMAL, progress,
                         shortest=NORMAL_HORIZON)}]


YOUNG = (100.0, 316.0, 1000.0, 3162.0, 10000.0)  # the elastic and implicit cases: E over two decades of E/η
GLUE_STIFFNESSES = (100.0, 1000.0, 10000.0)      # the glue-bound cases: p_τ


def stability(scene_path: str | Path, out: str | Path, young=YOUNG, glue=GLUE_STIFFNESSES,
              progress: bool | str = "auto", force: bool = False) -> list[dict]:
    """Predicted and observed bounds of the explicit terms, on `scene_path` with coarse meshes:
    the paper's scheme's elastic k* for several E/η, with damage and with λ_u = 0; the implicit
    schemes far above it with strong damage; the damage source's bound per scheme (SOURCE_ALONE);
    and the paper's scheme's glue bounds 2/ρ_τ and 2/ρ_ν for several p_τ, resp. γ_ν, on the shear
    scene set up so that the glue alone sets the bound (GLUE_ALONE, NORMAL_ALONE; the other schemes
    take the glue implicit and have none). progress: a bar of these cases and
    each run's bar, True, False or "auto" (where one can be seen: progress.py). `out`: a new
    folder, or with `force` one an earlier study wrote (outputs.py)."""
    from functools import partial

    shown = wanted(progress)
    out = Path(out).resolve()
    refuse_folder(out, f"study {NAME}", force)  # now, not after the runs
    eta = Scene.load(scene_path).body1.material.eta
    held = {"body1.boundary.1.fy": "-10*min(t, 1)", "body1.boundary.2.fx": "10*y*min(t, 1)",
            "body1.mesh.n": 6, "body2.mesh.n": 8}
    cases = [(f"elastic, E/η = {E / eta:.3g}, damage {damage}", partial(elastic_rows, scene_path, held, E, eta, damage))
             for E in young for damage in ("on", "off")]
    cases += [(f"implicit schemes, E/η = {E / eta:.3g}", partial(implicit_rows, scene_path, held, E, eta))
              for E in young]
    cases += [(f"damage source, {scheme}", partial(source_rows, scene_path, scheme)) for scheme in ("euler", "bdf2")]
    cases += [(f"tangential glue, euler, p_τ = {p_tau:g}", partial(glue_rows, "euler", p_tau)) for p_tau in glue]
    cases += [(f"normal glue, euler, γ_ν = {gamma_nu:g}", partial(normal_rows, gamma_nu)) for gamma_nu in glue]
    rows = []
    with tempfile.TemporaryDirectory() as scratch, counter(shown, len(cases), "case", "stability") as bar:
        for label, rows_of in cases:
            bar.set_postfix_str(label)
            rows += rows_of(Path(scratch) / "run", shown)
            bar.update(1)
    claim_folder(out, f"study {NAME}", FILES, force)
    write_csv(out / "stability.csv", rows, columns=list(dict.fromkeys(key for row in rows for key in row)))
    sizes = "".join(f" --{flag} {listed(values)!r}" for flag, values, default in
                    (("young", young, YOUNG), ("p-tau", glue, GLUE_STIFFNESSES)) if tuple(values) != default)
    write_text(out / "README.md", stability_report(rows, f"python -m orchestrate study stability "
                                                         f"{Path(scene_path).as_posix()}{sizes}"))
    plot(out / "stability.png", rows)
    return rows


def plot(target: Path, rows: list[dict]) -> None:
    """Left: observed against predicted bounds, one marker per term and scheme. Right: the
    implicit schemes far above k* with strong damage, |‖u(T)‖_V difference| to the reference."""
    figure, (bounds, implicit) = pyplot().subplots(1, 2, figsize=(11, 5))
    series = (("elastic", "off", "euler", "o", "elastic (euler), λ_u = 0"),
              ("elastic", "on", "euler", "s", "elastic (euler), damage on"),
              ("damage source", "on", "euler", "D", "damage source (euler)"),
              ("damage source", "on", "bdf2", "d", "damage source (bdf2)"),
              ("tangential glue", "on", "euler", "^", "tangential glue (euler)"),
              ("normal glue", "on", "euler", "v", "normal glue (euler)"))
    measured = [row for row in rows if "observed" in row]
    for term, damage, scheme, marker, label in series:
        points = [(row["predicted"], row["observed"]) for row in measured
                  if (row["term"], row["damage"], row["scheme"]) == (term, damage, scheme)]
        if points:
            bounds.loglog(*zip(*points), marker, label=label, mfc="none")
    limits = [min(row["predicted"] for row in measured) / 1.5, max(row["predicted"] for row in measured) * 1.5]
    bounds.loglog(limits, limits, "k:", lw=1, label="observed = predicted")
    log_axes(bounds, "predicted bound (2/ρ, 2ζ²/λ_D, glueLimit/ρ_τ …)", "observed threshold k")
    for scheme, marker in zip(IMPLICIT, "os"):
        for ratio in sorted({row["parameter"] for row in rows if row["term"] == "implicit elasticity"}):
            points = [(row["kOverKStar"], abs(row["normVDifference"])) for row in rows
                      if row["term"] == "implicit elasticity" and row["scheme"] == scheme
                      and row["parameter"] == ratio and row["checks"] == "passed"]
            if points:
                implicit.loglog(*zip(*points), marker + ("-" if ORDER[scheme] == 2 else "--"), mfc="none",
                                label=f"{scheme}, E/η = {ratio:.3g}")
    implicit.set_title("stable far above k*, with strong damage: accuracy", fontsize=10)
    if not implicit.get_lines():
        ran = any(row["term"] == "implicit elasticity" for row in rows)
        implicit.text(0.5, 0.5, "no implicit-elasticity case passed its checks" if ran
                      else "no implicit-elasticity cases in this study", ha="center", transform=implicit.transAxes)
        implicit.set_xticks([])
        implicit.set_yticks([])
    log_axes(implicit, "k / k* (k* the paper's scheme's bound)", "|‖u(T)‖_V / reference − 1|", fontsize=7, ncol=2)
    save(figure, target)



def listed(values) -> str:
    return ",".join(f"{value:g}" for value in values)
