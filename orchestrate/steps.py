"""How many time steps for a target time error: `time.N = "auto"` with `time.targetError`.

The rule (docs/model-choices.md, "Steps for a target time error"): a scheme of order p has a
time error e(N) ≈ C/N^p once N is in its asymptotic range. Three pilot runs at N_a, 2N_a and 4N_a,
on the scene's meshes one level coarser, give the two distances d₁ = ‖u_{N_a}(T) − u_{2N_a}(T)‖_V
and d₂ = ‖u_{2N_a}(T) − u_{4N_a}(T)‖_V; their ratio is 2^q, q the observed order. The error of the
finest pilot is then d₂/(2^p − 1), and N = ⌈4N_a·(e(4N_a)/target)^{1/p}⌉ with p = min(q, the
scheme's order) (a lower observed order gives more steps, never fewer). N_a is the smallest of
10·2^j that runs (an explicit bound may refuse the smaller) and whose observed order is within
[0.8, 1.3] times the scheme's (else the pilots are not yet asymptotic and N_a is doubled). Errors
are relative to ‖u(T)‖_V. It is an estimate on coarser meshes, not a bound: the run records it
(steps.json) next to the N it chose.

The pilots are runs: the functions that make them take the runner's `run` as an argument
(runner.py passes its own), so that this module, which the runner uses, imports no runner.
"""
from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

from orchestrate.freefem import SolverError
from orchestrate.mesh import MeshError
from orchestrate.parameters import ORDER, PARAMETERS
FIRST_PILOT, MOST_DOUBLINGS = 10, 10
STEP_FAILURES = (3, 4, 5)  # exits a smaller step can cure: a bound refused, a loop or an invariant broke
ASYMPTOTIC = (0.8, 1.3)  # observed order / the scheme's, for pilots in their asymptotic range


class StepsError(RuntimeError):
    """No N could be chosen: the pilots never ran, or never reached their asymptotic range."""


def coarser(mesh) -> dict:
    """A mesh one level coarser: one refinement fewer, else half the elements per side."""
    if mesh.refine > 0:
        return {"refine": mesh.refine - 1}
    return {"n": max(2, mesh.n // 2)}


def pilot_overrides(scene, steps: int) -> dict:
    overrides = {"time.N": steps, "output.times": "final", "output.fields": ["state"], "output.images": False,
                 "output.checkpointEvery": steps, "output.checkpointSeconds": 0.0}  # none: a pilot is short
    for name, body in (("body1", scene.body1), ("body2", scene.body2)):
        overrides.update({f"{name}.mesh.{key}": value for key, value in coarser(body.mesh).items()})
    return overrides


def pilot(scene, steps: int, folder: Path, run, mesh_cache: Path | None, trust_geo: bool = False) -> Path | str:
    """A pilot run at N = steps into `folder` (by `run`, the runner's), or why it did not run when
    a step bound refused N or the run broke down at it (a smaller step may not); any other failure
    is the scene's and ends the search."""
    manual = scene.model_copy(update={"time": scene.time.model_copy(update={"N": steps, "targetError": None})})
    overrides = pilot_overrides(scene, steps)
    try:
        run(manual, folder, overrides, force=True, progress=False, mesh_cache=mesh_cache, trust_geo=trust_geo)
    except SolverError as error:
        if error.returncode not in STEP_FAILURES:
            raise StepsError(f"time.N = 'auto': the pilot run at N = {steps} failed: {error}") from None
        return error.message
    except MeshError as error:  # the pilots' meshes are this rule's, not the user's: say so
        meshes = ", ".join(f"{key} = {value}" for key, value in overrides.items() if ".mesh." in key)
        raise StepsError(f"time.N = 'auto' runs its pilots on meshes one level coarser than the scene's ({meshes}), "
                         f"and those cannot be meshed: {error}; give time.N yourself") from None
    return folder


def relative_distance(first: Path, second: Path, first_steps: int, second_steps: int) -> float:
    from orchestrate.compare import instant_distances  # numpy's: a run of a given N never loads it

    row = instant_distances(first, second, first_steps, second_steps, 1)[0]
    return row["errorV"] / row["normV"] if row["normV"] > 0 else 0.0


def time_error_model(scene, work: Path, run, mesh_cache: Path | None = None, trust_geo: bool = False) -> dict:
    """The pilots of a scene (time.scheme, time.T and the meshes one level coarser than its own),
    made by `run` (the runner's): the N_a they settled on, the order used and the finest pilot's
    error (steps 1 and 2 of the rule). Pilot folders are made under `work` and removed."""
    order = ORDER[scene.time.scheme]
    work.mkdir(parents=True, exist_ok=True)
    folders: dict[int, Path | str] = {}

    def ran(steps: int) -> bool:
        if steps not in folders:
            folders[steps] = pilot(scene, steps, work / f"N{steps}", run, mesh_cache, trust_geo)
        return isinstance(folders[steps], Path)

    pilots = []
    try:
        steps = FIRST_PILOT
        for _ in range(MOST_DOUBLINGS):
            if ran(steps) and ran(2 * steps) and ran(4 * steps):
                d1 = relative_distance(folders[steps], folders[2 * steps], steps, 2 * steps)
                d2 = relative_distance(folders[2 * steps], folders[4 * steps], 2 * steps, 4 * steps)
                observed = math.log2(d1 / d2) if d1 > 0 and d2 > 0 else float(order)
                pilots.append({"N": steps, "distance1": d1, "distance2": d2, "observedOrder": observed})
                if ASYMPTOTIC[0] <= observed / order <= ASYMPTOTIC[1] or d2 == 0:
                    break
            steps *= 2
        else:
            failed = {steps: why for steps, why in folders.items() if isinstance(why, str)}
            last = f"; at N = {max(failed)}: {failed[max(failed)]}" if failed else ""
            raise StepsError(f"time.N = 'auto': no pilots from N = {FIRST_PILOT} to {FIRST_PILOT * 2 ** MOST_DOUBLINGS} "
                             f"both ran and showed the {scene.time.scheme} scheme's order {order} (measured: "
                             f"{json.dumps(pilots) if pilots else 'none'}{last}); give time.N yourself")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    last = pilots[-1]
    p = max(0.5, min(last["observedOrder"], order))
    return {"scheme": scene.time.scheme, "schemeOrder": order,
            "pilotMeshes": {name: coarser(body.mesh) for name, body in (("body1", scene.body1), ("body2", scene.body2))},
            "pilots": pilots, "orderUsed": p, "firstPilot": last["N"], "finestPilotError": last["distance2"] / (2 ** p - 1)}


def error_at(model: dict, steps: float) -> float:
    """The time error the pilots' model gives at N = steps."""
    return model["finestPilotError"] * (4 * model["firstPilot"] / steps) ** model["orderUsed"]


def steps_for(model: dict, target: float) -> tuple[int, float]:
    """Step 3 of the rule: the N for a target time error, and the error estimated at that N."""
    finest, error, p = 4 * model["firstPilot"], model["finestPilotError"], model["orderUsed"]
    needed = finest * (error / target) ** (1 / p) if error > 0 else 0.0
    if not needed < 2.0 ** 62:  # beyond every N: told by choose_steps, never rounded to a wrong integer
        return math.inf, 0.0
    chosen = max(model["firstPilot"], math.ceil(needed))
    return chosen, error_at(model, chosen)


def choose_steps(scene, work: Path, run, mesh_cache: Path | None = None, trust_geo: bool = False) -> dict:
    """The plan for a scene with time.N = "auto": its N and how it was found (steps.json); the
    pilots made by `run` (the runner's)."""
    model = time_error_model(scene, work, run, mesh_cache, trust_geo)
    chosen, estimated = steps_for(model, scene.time.targetError)
    most = int(PARAMETERS["N"].bounds["le"])
    if chosen > most:
        reachable = error_at(model, most)
        raise StepsError(f"time.targetError = {scene.time.targetError:g}: the pilots' error model (order "
                         f"{model['orderUsed']:.3g}, {model['finestPilotError']:.3g} at N = {4 * model['firstPilot']}) "
                         f"needs N = {chosen:,} steps, above the largest N, {most:,}: give time.targetError >= "
                         f"{reachable:.3g}, or a higher-order time.scheme")
    return {"rule": "time.N = 'auto' (orchestrate/steps.py)", "targetError": scene.time.targetError, **model,
            "N": chosen, "estimatedError": estimated}
