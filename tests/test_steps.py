"""time.N = "auto" (orchestrate/steps.py): the N chosen for a target time error reaches it, and
does not overshoot it by much, measured against an independent reference — bdf2 with many more
steps on the same meshes; the plan is a file of the run; bad requests are refused by name."""
import json

import pytest

from orchestrate import run
from orchestrate.freefem import REPO
from orchestrate.runner import resolve_steps
from orchestrate.scene import Scene, SceneError
from orchestrate.steps import relative_distance

pytestmark = pytest.mark.physics

PAPER = REPO / "scenes" / "paper.toml"
QUIET = {"output.times": "final", "output.fields": ["state"], "output.images": False}
REFERENCE_STEPS = 640  # bdf2: its own time error about 1e-9 here, below every target


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    folder = tmp_path_factory.mktemp("reference") / "run"
    return run(PAPER, folder, {**QUIET, "time.scheme": "bdf2", "time.N": REFERENCE_STEPS}).folder


# Each scheme at two targets; the euler pilots start where its elastic bound lets them (N >= 20).
@pytest.mark.parametrize("scheme, target", [("euler", 1e-2), ("semi-implicit", 1e-4), ("semi-implicit", 2e-5),
                                            ("bdf2", 1e-6), ("bdf2", 1e-7)])
def test_the_chosen_steps_reach_the_target_time_error(tmp_path, reference, scheme, target):
    result = run(PAPER, tmp_path / "run", {**QUIET, "time.scheme": scheme, "time.N": "auto", "time.targetError": target})
    plan = json.loads((result.folder / "steps.json").read_text())
    assert plan == json.loads((result.folder / "summary.json").read_text())["timeSteps"]
    assert len(result.history["t"]) == plan["N"] and plan["targetError"] == target
    measured = relative_distance(result.folder, reference, plan["N"], REFERENCE_STEPS)
    assert 0.3 * target <= measured <= 1.2 * target, (plan, measured)
    assert Scene.load(result.folder / "scene.toml").time.N == plan["N"]  # the folder's scene reruns it as it ran


@pytest.mark.unit
def test_a_continued_run_keeps_its_plan(tmp_path):
    scene = Scene.load(PAPER, {"time.N": "auto", "time.targetError": 1e-3})
    (tmp_path / "steps.json").write_text(json.dumps({"N": 37}))
    planned, plan = resolve_steps(scene, tmp_path, None, restart=True)
    assert planned.time.N == 37 and planned.time.targetError is None and plan == {"N": 37}


@pytest.mark.parametrize("overrides, words", [
    ({"time.N": "auto"}, 'N = "auto" needs targetError'),
    ({"time.targetError": 1e-3}, 'targetError applies to N = "auto" only (N = 40 here)'),
    ({"time.N": "auto", "time.targetError": 0.0}, "time.targetError = 0.0: Input should be greater than 0"),
    ({"time.N": "auto", "time.targetError": 0.9}, "time.targetError = 0.9: Input should be less than or equal to 0.5"),
    ({"time.N": "sometimes"}, "time.N = 'sometimes': Input should be an integer in [1, 10000000] or \"auto\""),
    ({"time.N": 2.5}, "time.N = 2.5: Input should be an integer"),
])
@pytest.mark.unit
def test_bad_step_requests_are_refused_by_name(overrides, words):
    with pytest.raises(SceneError) as caught:
        Scene.load(PAPER, overrides)
    assert words in str(caught.value)


@pytest.mark.unit
def test_a_given_N_replaces_auto_and_its_target():
    scene = Scene.load(REPO / "scenes" / "polymer_pad.toml", {"time.N": 50})
    assert scene.time.N == 50 and scene.time.targetError is None


def test_pilots_that_never_run_say_why(tmp_path):
    """euler with E = 1e7: its elastic bound refuses every pilot up to N = 10240."""
    with pytest.raises(SceneError) as caught:
        run(PAPER, tmp_path / "run", {**QUIET, "time.N": "auto", "time.targetError": 1e-2, "body1.material.E": 1e7})
    message = str(caught.value)
    assert "no pilots from N = 10 to 10240" in message and "exceeds the explicit elastic bound" in message
    assert "give time.N yourself" in message


@pytest.mark.unit
def test_a_target_beyond_the_largest_n_says_the_n_it_needs_and_the_cap(monkeypatch, tmp_path):
    """An error model of order 1 with error 1e-3 at N = 40 needs N = 40·(1e-3/1e-12) = 4e10 for
    1e-12 (was: "N = -1.48431e+09 is out of range", an integer overflow in the driver)."""
    from orchestrate import steps

    model = {"firstPilot": 10, "finestPilotError": 1e-3, "orderUsed": 1.0, "schemeOrder": 1}
    monkeypatch.setattr(steps, "time_error_model", lambda scene, work, run, cache, trust_geo=False: model)
    scene = Scene.load(PAPER, {"time.N": "auto", "time.targetError": 1e-12})
    with pytest.raises(steps.StepsError, match=r"needs N = 40,000,000,000 steps, above the largest N, 10,000,000: "
                                               r"give time.targetError >= 4e-09"):
        steps.choose_steps(scene, tmp_path, run)
    scene = Scene.load(PAPER, {"time.N": "auto", "time.targetError": 1e-300})
    with pytest.raises(steps.StepsError, match="needs N = inf steps"):
        steps.choose_steps(scene, tmp_path, run)


@pytest.mark.unit
def test_a_pilot_mesh_that_cannot_be_made_is_said_to_be_the_rule_s(tmp_path):
    from orchestrate import steps
    from orchestrate.mesh import MeshError

    def unmeshable(*args, **kwargs):
        raise MeshError("body1: gmsh made no triangles")

    scene = Scene.load(PAPER, {"time.N": "auto", "time.targetError": 1e-3, "body1.mesh.n": 24})
    with pytest.raises(steps.StepsError, match=r"one level coarser than the scene's \(body1.mesh.n = 12, "
                                               r"body2.mesh.n = 16\), and those cannot be meshed: body1: gmsh"):
        steps.pilot(scene, 20, tmp_path / "pilot", unmeshable, None)
