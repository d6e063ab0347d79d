"""Stability study: python -m orchestrate study stability [SCENE].

The explicit terms bound the time step (MODEL.md §7): the elastic k* = 2/ρ and, with tangential
glue, 2/ρ_τ. For several data the bound the driver predicts (its run facts) is set against the
threshold observed by bisection on N, over a horizon where the loads are held, so a stable run
only creeps and an unstable one grows or is stopped by the driver's growth and chatter checks.
"""
from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from orchestrate.freefem import REPO
from orchestrate.manifest import read_json
from orchestrate.plots import log_axes, pyplot, save
from orchestrate.reports import stability_report, write_csv
from orchestrate.scene import Scene

GLUE_SCENE = REPO / "scenes" / "shear.toml"
# The shear scene with γ_ν = 0 (the glue never debonds, so p_τ β R*(slip) is a linear spring),
# soft bodies (E = 10: the elastic bound is far away) and the top's displacement held after t = 1.
GLUE_ALONE = {"body1.mesh.n": 8, "body2.mesh.n": 11, "glue.gammaNu": 0.0, "body1.material.E": 10.0,
              "body2.material.E": 10.0, "body1.boundary.0.value": "0.2*min(t, 1)",
              "body1.boundary.1.value": "0.2*min(t, 1)"}
ELASTIC, GLUE = "kStar", "rhoTau"  # the run facts (run.json) of the two bounds


def predicted_bound(folder: Path, fact: str) -> float | None:
    """A bound as the driver computed it (run.json, written at set-up) in the last run into
    `folder`, which may have stopped (runner.run leaves `<folder>.failed` then, and removes it
    when a run succeeds): k* itself, or 2/ρ_τ; None without tangential glue (ρ_τ = 0)."""
    failed = folder.with_name(folder.name + ".failed")
    value = read_json((failed if failed.exists() else folder) / "run.json").get(fact)
    if fact == GLUE:
        return 2 / value if value else None
    return value


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


def threshold(scene_path, overrides: dict, folder: Path, fact: str) -> dict:
    """The predicted bound (from a short run) against the observed one (bisection on N over a
    horizon T = max(5, 200 k*)): the threshold lies between T/N and T/(N − 1)."""
    probe = {**overrides, "solver.allowUnstable": True, "output.times": "none", "output.images": False}
    is_unstable(scene_path, {**probe, "time.T": 1.0, "time.N": 1000}, folder)
    k_star = predicted_bound(folder, fact)
    if k_star is None:
        raise RuntimeError(f"the run in {folder} has no {fact} among its facts")
    glue_bound = predicted_bound(folder, GLUE) if fact != GLUE else None
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
                             **threshold(scene_path, overrides, folder, ELASTIC)})
        for p_tau in glue:
            rows.append({"term": "tangential glue", "parameter": p_tau, "damage": "on",
                         **threshold(GLUE_SCENE, {**GLUE_ALONE, "glue.pTau": p_tau}, folder, GLUE)})
    write_csv(out / "stability.csv", rows)
    (out / "README.md").write_text(stability_report(rows, f"python -m orchestrate study stability "
                                                          f"{Path(scene_path).as_posix()}"))
    plot(out / "stability.png", rows)
    return rows


def plot(target: Path, rows: list[dict]) -> None:
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


# --- command line ---------------------------------------------------------------------------

NAME, HELP = "stability", "predicted against observed explicit time-step bound"


def add_arguments(parser) -> None:
    parser.add_argument("scene", nargs="?", default="scenes/paper.toml")
    parser.add_argument("--out", default="results/stability")


def command(options) -> int:
    stability(options.scene, options.out)
    print((Path(options.out) / "README.md").read_text())
    return 0
