"""Initial data by position (docs/model-choices.md "Initial data"): ζ⁰ per body as an expression of
x, y at the nodes, β⁰ as an expression of the position on Γ_C, its means on the segments, checked
against the expression evaluated independently (orchestrate.expr.evaluate) or integrated by hand
where the model keeps them exactly, and refused with the position when a value leaves [0, 1]."""
from __future__ import annotations

import meshio
import numpy as np
import pytest

from orchestrate import expr
from orchestrate.freefem import REPO
from orchestrate.results import read_state
from orchestrate.runner import SolverError, run
from orchestrate.scene import SceneError, Scene
from tests.conftest import solve

pytestmark = pytest.mark.solver

ZETA0 = "1 - 0.6*exp(-((x - 0.3)^2 + (y - 0.4)^2)/0.05)"
BETA0 = "0.5 + 0.4*sin(3*x)"


def frozen_scene(folder, zeta0: str = ZETA0, beta0: str = BETA0, load: str = "0"):
    """Two unit squares in contact, body 1's top moved by (0, load): without a damage source
    (λ_D = λ_u = λ_w = 0), diffusion (κ = 0) or rebonding (γ_r = 0), and at rest, ζ and β keep their
    initial values: (M/k) ζⁿ = (M/k) ζⁿ⁻¹, and β's update vanishes with the gap."""
    path = folder / "frozen.toml"
    path.write_text(f"""title = "initial data kept"
[time]
T = 1.0
N = 4
scheme = "semi-implicit"
[body1.mesh]
rectangle = [0.0, 1.0, 0.0, 1.0]
n = 7
contactLabel = 1
[body1.material]
kappa = 0.0
[body1.damage]
lambdaD = 0.0
lambdaU = 0.0
lambdaW = 0.0
zeta0 = "{zeta0}"
[[body1.boundary]]
type = "displacement"
label = 3
component = "y"
value = "{load}"
[[body1.boundary]]
type = "displacement"
label = 3
component = "x"
value = "0"
[body2.mesh]
rectangle = [0.0, 1.0, -1.0, 0.0]
n = 5
contactLabel = 3
[[body2.boundary]]
type = "clamped"
label = 1
[glue]
gammaR = 0.0
beta0 = "{beta0}"
[output]
fields = ["bodies", "contact", "state"]
images = false
""")
    return path


def values(text: str, points: np.ndarray) -> np.ndarray:
    tree = expr.parse(text, ("x", "y"))
    return np.array([expr.evaluate(tree, px, py, 0.0) for px, py in points[:, :2]])


def test_initial_damage_and_bonding_are_the_expressions_at_their_nodes(tmp_path):
    """In double precision: the state file's ζ (node order of the mesh file), the expression at the
    nodes, and β (segments of θ1_h, which here is body 1's bottom, x = s, y = 0), its exact means."""
    result = run(frozen_scene(tmp_path), tmp_path / "run")
    state = read_state(result.folder / "state_0004.txt")
    nodes = meshio.read(result.folder / "body1.msh").points
    assert np.allclose(state["zeta1"], values(ZETA0, nodes), rtol=0, atol=1e-14)
    assert state["zeta1"].min() < 0.5  # the pre-damaged zone is there
    a, b = state["s"][:-1], state["s"][1:]
    mean = 0.5 + 0.4 * (np.cos(3 * a) - np.cos(3 * b)) / (3 * (b - a))  # of BETA0 on each segment
    assert np.allclose(state["beta"], mean, rtol=0, atol=1e-10)
    assert result.params["beta0"] == "expression:initialBonding"
    assert result.params["zeta01"] == "expression:initialDamage1" and result.params["zeta02"] == 1


def test_a_cracked_part_of_the_interface_stays_unbonded_under_load(tmp_path):
    """β's update carries β₊ in both terms: where β⁰ = 0 it stays 0 whatever the gap does, while
    the bonded part loses bonds when the body is pulled off (so the load did reach the glue). The
    crack's tip is the node x = 3/7 of body 1's bottom (n = 7), so β⁰ is 0 or 1 on every segment."""
    result = run(frozen_scene(tmp_path, zeta0="1", beta0="x > 0.4285714", load="0.05*t"), tmp_path / "run")
    line = result.fields("contact")
    midpoints = line.points[line.cells_dict["line"]].mean(axis=1)[:, 0]
    beta = line.cell_data_dict["beta"]["line"]
    assert np.all(beta[midpoints < 3 / 7] == 0)
    assert 0 < beta[midpoints > 3 / 7].max() < 1


@pytest.mark.parametrize("override, words", [
    ({"glue.beta0": "2*x"}, ["initial bonding beta0", "initialBonding", "outside [0, 1]", "at ("]),
    ({"body1.damage.zeta0": "0.5 - y"}, ["initial damage zeta0 of body 1", "initialDamage1", "outside [0, 1]"]),
])
def test_initial_data_outside_the_unit_interval_are_refused_with_the_position(tmp_path, override, words):
    with pytest.raises(SolverError) as error:
        run(frozen_scene(tmp_path), tmp_path / "run", override)
    assert all(word in str(error.value) for word in words), str(error.value)


@pytest.mark.unit
def test_an_initial_value_in_time_or_out_of_range_is_refused_in_the_scene():
    with pytest.raises(SceneError, match=r"glue.beta0 = 't\*x'.*name 't' is not allowed.*expression of the position"):
        Scene.load(REPO / "scenes" / "peel.toml", {"glue.beta0": "t*x"})
    with pytest.raises(SceneError, match=r"body2.damage.zeta0 = '1.5': 1.5 is outside \[0, 1\]"):
        Scene.load(REPO / "scenes" / "peel.toml", {"body2.damage.zeta0": "1.5"})


def test_a_number_and_an_expression_for_the_same_initial_data_are_refused(tmp_path):
    """A hand-written scene giving the macro, with the flag as well: one of the two would be ignored."""
    scene = tmp_path / "scene.idp"
    scene.write_text((REPO / "edp" / "scenes" / "paper.idp").read_text() + "macro initialBonding(x, y) (x < 3.) //\n")
    completed, _ = solve(tmp_path / "out", "-beta0", 0.5, scene=scene)
    assert completed.returncode == 3
    assert "beta0 is given as a number and, by the scene, as an expression of x, y (macro initialBonding)" in \
        completed.error_line
