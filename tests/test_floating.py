"""Bodies held by the contact alone (docs/model-choices.md, "Floating bodies"): the rigid modes a
body's Dirichlet conditions leave free are unknowns of the contact problem, which then enforces
the body's balance at every step; checked against closed-form solutions, and the loads or
conditions no contact can hold refused with the free motion named."""
from __future__ import annotations

import json
import re

import meshio
import numpy as np
import pytest

from orchestrate.results import read_state
from orchestrate.runner import SolverError, run

pytestmark = pytest.mark.solver

Q, E1, E2, NU = 2.0, 1000.0, 400.0, 0.3


def elastic_block(body: int, rectangle: list[float], n: int, contact: int, E: float, boundary: str) -> str:
    """A rectangle body (meshes/rectangle.geo: labels 1 bottom, 2 right, 3 top, 4 left) without
    damage, of viscosity 1: E ≥ 400 makes its viscous response die within a few steps of 0.1."""
    return (f"[body{body}.mesh]\nrectangle = {rectangle}\nn = {n}\ncontactLabel = {contact}\n"
            f"[body{body}.material]\nE = {E}\nnu = {NU}\nmu = 0.0\neta = 1.0\n"
            f"[body{body}.damage]\nlambdaD = 0.0\nlambdaU = 0.0\n" + boundary.replace("BODY", f"body{body}"))


def stacked_blocks(folder, pressure: float = -Q, lift: float = 0.0, roller: str = "x", steps: int = 10, start: int = 0):
    """Body 1 (0,1)×(−1,0) on rollers at its bottom and left; body 2 (0,1)×(lift, lift + 0.5) held
    only at its left side, in the `roller` component (x: its vertical motion is free), and pressed
    by fy = `pressure` on its top. No damage, no glue; after ten steps of k = 0.1 (the
    semi-implicit scheme damps the viscous response by (1 + kE/η)⁻¹ a step) u is the elastic
    solution: uniform compression q in both bodies. start: the first steps in three substeps each."""
    base = ('[[BODY.boundary]]\ntype = "roller"\nlabel = 1\ncomponent = "y"\n'
            '[[BODY.boundary]]\ntype = "roller"\nlabel = 4\ncomponent = "x"\n')
    block = (f'[[BODY.boundary]]\ntype = "roller"\nlabel = 4\ncomponent = "{roller}"\n'
             f'[[BODY.boundary]]\ntype = "traction"\nlabel = 3\nfy = "{pressure}"\n')
    path = folder / "blocks.toml"
    path.write_text(f'title = "a block resting on a block"\n[time]\nT = 1.0\nN = {steps}\nscheme = "semi-implicit"\n'
                    + f'startSteps = {start}\nstartSubsteps = 3\n'
                    + elastic_block(1, [0.0, 1.0, -1.0, 0.0], 7, 3, E1, base)
                    + elastic_block(2, [0.0, 1.0, lift, lift + 0.5], 5, 1, E2, block)
                    + '[glue]\nbeta0 = 0.0\ngammaR = 0.0\n[output]\nfields = ["contact", "state"]\nimages = false\n')
    return path


@pytest.mark.parametrize("lift, start", [(0.0, 0), (0.05, 0), (0.05, 2)])
def test_a_block_held_by_the_contact_alone_carries_the_uniform_pressure(tmp_path, lift, start):
    """Uniform compression, exact in P1 on the non-matching traces: u¹ = (ν q x/E1, −q (y + 1)/E1),
    u² = (ν q x/E2, −q/E1 − q (y − lift)/E2 − lift), the contact pressure q at every node. Body 2's
    vertical translation is held by nothing but the contact, whose force balances the load at
    every step, from the first (lowered from a gap of `lift`, it closes it in that step); also
    through a start in substeps, whose operators of k/3 and of k again hold the free mode too."""
    result = run(stacked_blocks(tmp_path, lift=lift, start=start), tmp_path / "run")
    facts = json.loads((result.folder / "run.json").read_text())
    assert facts["freeMotion1"] == "none" and facts["freeMotion2"] == "y-translation"
    assert np.allclose(result.history["contactForce"], Q, rtol=1e-12)
    assert result.history["forceBalance"].max() <= 1e-12 * Q
    state = read_state(result.folder / "state_0010.txt")
    x1, y1 = meshio.read(result.folder / "body1.msh").points[:, :2].T
    x2, y2 = meshio.read(result.folder / "body2.msh").points[:, :2].T
    assert np.allclose(state["u1"][0::2], NU * Q * x1 / E1, rtol=0, atol=1e-13)
    assert np.allclose(state["u1"][1::2], -Q * (y1 + 1) / E1, rtol=0, atol=1e-13)
    assert np.allclose(state["u2"][0::2], NU * Q * x2 / E2, rtol=0, atol=1e-13)
    assert np.allclose(state["u2"][1::2], -Q / E1 - Q * (y2 - lift) / E2 - lift, rtol=0, atol=1e-13)
    pressure = result.fields("contact").point_data["pressure"]
    assert np.allclose(pressure, Q, rtol=1e-10)


def test_a_load_that_pulls_a_floating_body_away_is_refused_naming_its_motion(tmp_path):
    with pytest.raises(SolverError) as error:
        run(stacked_blocks(tmp_path, pressure=Q), tmp_path / "run")
    message = error.value.message
    assert error.value.returncode == 3
    assert "step 1/10" in message and "no contact state balances the loads on the floating body 2" in message
    assert "along its free translation towards body 1 they sum to -2, away from it" in message


def test_a_floating_body_nothing_presses_is_refused_as_undetermined(tmp_path):
    with pytest.raises(SolverError) as error:
        run(stacked_blocks(tmp_path, pressure=0.0), tmp_path / "run")
    assert "nothing presses the floating body 2 onto body 1" in error.value.message
    assert "where it rests is undetermined" in error.value.message


def test_two_bodies_free_to_move_together_are_refused_before_the_loop(tmp_path):
    """Body 1 on a roller in x only: both bodies are free in y, and a contact between them cannot
    hold the pair (each body alone it could)."""
    path = stacked_blocks(tmp_path)
    path.write_text(path.read_text().replace('[[body1.boundary]]\ntype = "roller"\nlabel = 1\ncomponent = "y"\n',
                                             '[[body1.boundary]]\ntype = "traction"\nlabel = 1\nfy = "2.0"\n'))
    with pytest.raises(SolverError) as error:
        run(path, tmp_path / "run")
    message = error.value.message
    assert "bodies 1 and 2 are not held" in message and "body 1's y-translation and body 2's y-translation" in message
    assert "step" not in message.split(":")[0]


def test_a_sliding_motion_the_frictionless_contact_cannot_hold_is_refused(tmp_path):
    """Body 2 held in y only is free to slide along Γ_C: no normal contact force holds that."""
    with pytest.raises(SolverError) as error:
        run(stacked_blocks(tmp_path, roller="y"), tmp_path / "run")
    message = error.value.message
    assert "body 2 is not held: its Dirichlet conditions leave free its x-translation" in message
    assert "sliding along Gamma_C" in message


def test_hertz_under_a_prescribed_force_agrees_with_the_prescribed_approach(tmp_path):
    """The half-cylinder pressed by the force F the displacement-controlled run needed (a uniform
    pressure F/16 on its flat top, on a roller in x: free to move down and to rotate about the
    top's centre, both held by the contact alone): the same F to round-off, the contact width and
    peak pressure within 0.3 % of the displacement-controlled ones (the tops differ: flat there,
    free here), and the approach, the mean descent of the top, within 3 % of the 0.2 prescribed
    there."""
    from orchestrate.freefem import REPO
    from orchestrate.studies.hertz import RADIUS, measure

    coarse = {"body1.mesh.n": 8, "body2.mesh.n": 8, "output.images": False}
    pressed = run(REPO / "scenes" / "hertz.toml", tmp_path / "approach", coarse)
    force = float(pressed.history["contactForce"][-1])
    loaded = run(REPO / "scenes" / "hertz.toml", tmp_path / "force", {**coarse, "body2.boundary": [
        {"type": "roller", "label": 2, "component": "x"},
        {"type": "traction", "label": 2, "fy": f"-{force / 16!r}*min(t, 1)"}]})
    assert loaded.history["contactForce"][-1] == pytest.approx(force, rel=1e-12)
    a, b = measure(pressed, RADIUS), measure(loaded, RADIUS)
    assert abs(a["aMoment"] - b["aMoment"]) <= 3e-3 * a["aMoment"]
    assert abs(a["p0Computed"] - b["p0Computed"]) <= 3e-3 * a["p0Computed"]
    cylinder = loaded.fields("body2")
    top = cylinder.points[:, 1] > cylinder.points[:, 1].max() - 1e-5
    assert cylinder.point_data["u"][top, 1].mean() == pytest.approx(-0.2, rel=0.03)
    facts = json.loads((loaded.folder / "run.json").read_text())
    named = re.fullmatch(r"y-translation and rotation about \((\S+), (\S+)\)", facts["freeMotion2"])
    assert named and abs(float(named[1])) < 1e-9 and float(named[2]) == pytest.approx(8.0, rel=1e-12)


def test_a_light_force_on_a_curved_floating_body_touching_at_one_node_is_held(tmp_path):
    """F = 0.1: the contact half-width (0.1) is below the node spacing (1/8), so one node carries
    the load and holds the descent but not the rotation about the top's centre (it moves that node
    along Γ_C only); the loads have no moment about it, so the run goes on, the rotation taken
    with no net amount in u: the top stays level (its tilt, fitted, moves the apex by less than 1 %
    of the approach; the meshes are not symmetric)."""
    from orchestrate.freefem import REPO

    result = run(REPO / "scenes" / "hertz.toml", tmp_path / "light", {
        "body1.mesh.n": 8, "body2.mesh.n": 8, "output.images": False,
        "body2.boundary": [{"type": "roller", "label": 2, "component": "x"},
                           {"type": "traction", "label": 2, "fy": "-0.00625*min(t, 1)"}]})
    h = result.history
    assert h["contactForce"] == pytest.approx(0.1 * np.minimum(h["t"], 1), rel=1e-10)
    assert h["gapMax"].max() <= result.params["contactTol"] and h["lambdaMin"].min() >= 0
    cylinder = result.fields("body2")
    top = cylinder.points[:, 1] > cylinder.points[:, 1].max() - 1e-5
    x, descent = cylinder.points[top, 0], cylinder.point_data["u"][top, 1]
    level, tilt = np.linalg.lstsq(np.column_stack([np.ones_like(x), x]), descent, rcond=None)[0]
    assert level < 0 and abs(tilt) * 8.0 < 0.01 * abs(level)


@pytest.mark.parametrize("scheme", ["semi-implicit", "bdf2"])
def test_a_block_held_by_the_glue_alone_carries_the_pull(tmp_path, scheme):
    """The upper block free to move vertically, pulled up by fy = q on its top and held by the glue
    alone (implicit in these schemes, docs/model.md §9; no debonding: m_d = 0): at every step its
    balance makes the glue's pull on it −q per unit length, and the interface stays open."""
    path = stacked_blocks(tmp_path, pressure=Q, steps=6)
    text = path.read_text().replace('[glue]\nbeta0 = 0.0\ngammaR = 0.0\n',
                                    '[glue]\nbeta0 = 1.0\ngammaR = 0.0\ngammaNu = 50.0\npTau = 20.0\nL = 1.0\n'
                                    'debondMobility = 0.0\n')
    path.write_text(text.replace('scheme = "semi-implicit"', f'scheme = "{scheme}"'))
    history = run(path, tmp_path / "run").history
    np.testing.assert_allclose(history["forceY2"], -Q, rtol=1e-9)
    np.testing.assert_allclose(history["forceY1"], Q, rtol=1e-9)
    assert np.all(history["contactForce"] == 0) and np.all(history["gapMax"] < 0)
