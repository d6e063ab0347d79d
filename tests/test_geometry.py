"""Contact boundaries of different extents and initial gaps (docs/model.md §10, docs/model-choices.md
"Contact geometry"), each against an exact property of the discrete problem, and the geometry
a scene may not have, refused before the time loop with the body, the label and the quantity."""
from __future__ import annotations

import meshio
import numpy as np
import pytest

from orchestrate.freefem import REPO, InputError
from orchestrate.studies.hertz import contact_line, hertz, measure
from orchestrate.results import read_state
from orchestrate.runner import SolverError, run
from orchestrate.scene import SceneError

pytestmark = pytest.mark.physics

NO_GLUE = """
[glue]
beta0 = 0.0
gammaR = 0.0
"""


def scene(folder, name: str, body1: str, body2: str, extra: str = "", steps: int = 20):
    """A scene of two rectangles (meshes/rectangle.geo: labels 1 bottom, 2 right, 3 top, 4 left)."""
    path = folder / f"{name}.toml"
    path.write_text(f'title = "{name}"\n[time]\nT = 1.0\nN = {steps}\nscheme = "semi-implicit"\n'
                    f"{body1}\n{body2}\n{NO_GLUE}{extra}\n"
                    '[output]\ntimes = "all"\nfields = ["contact", "state"]\nimages = false\n')
    return path


def pressed_block(rectangle: list[float], n: int, contact: int, press: str) -> str:
    """Body 1: a rectangle whose top is moved by u = (0, press); its bottom is the contact side."""
    return (f"[body1.mesh]\nrectangle = {rectangle}\nn = {n}\ncontactLabel = {contact}\n"
            '[[body1.boundary]]\ntype = "displacement"\nlabel = 3\ncomponent = "x"\nvalue = "0"\n'
            f'[[body1.boundary]]\ntype = "displacement"\nlabel = 3\ncomponent = "y"\nvalue = "{press}"\n')


def clamped_base(rectangle: list[float], n: int) -> str:
    """Body 2: a rectangle clamped at its bottom, its top the contact side."""
    return (f"[body2.mesh]\nrectangle = {rectangle}\nn = {n}\ncontactLabel = 3\n"
            '[[body2.boundary]]\ntype = "clamped"\nlabel = 1\n')


def final_state(result):
    return read_state(result.folder / f"state_{result.params['N']:04d}.txt")


def test_an_initial_gap_is_a_translation_of_the_closed_problem(tmp_path):
    """Body 2 lowered by δ (the same mesh, translated: g0 = δ) with body 1's top moved by −ct is, step by step,
    the problem without gap whose top moves by δ − ct, translated by −δ: body 1's strains, the
    viscous and damage terms see no translation, g_h(u − δ e_y) = g_h(u) + δ and π1 δ = δ. So the
    bodies meet at t = δ/c, the forces and ζ agree to round-off and u¹ differs by exactly δ."""
    delta, c = 0.01, 0.02
    gap = run(scene(tmp_path, "gap", pressed_block([0.0, 1.0, 0.0, 1.0], 6, 1, f"-{c}*t"),
                    clamped_base([0.0, 1.0, -1.0 - delta, -delta], 8)), tmp_path / "gap")
    closed = run(scene(tmp_path, "closed", pressed_block([0.0, 1.0, 0.0, 1.0], 6, 1, f"{delta}-{c}*t"),
                       clamped_base([0.0, 1.0, -1.0, 0.0], 8)), tmp_path / "closed")
    h, g = gap.history, closed.history
    apart, touching = h["t"] < delta / c - 1e-9, h["t"] > delta / c + 1e-9
    assert np.all(h["contactForce"][apart] == 0) and np.all(h["contactLength"][apart] == 0)
    assert np.all(h["contactForce"][touching] > 0) and np.all(h["contactLength"][touching] == pytest.approx(1.0))
    scale = g["contactForce"].max()
    assert np.all(np.abs(h["contactForce"][~apart & ~touching]) <= 1e-12 * scale)  # they just meet
    assert np.allclose(h["contactForce"], g["contactForce"], rtol=0, atol=1e-9 * scale)
    assert np.all(h["gapMax"] <= gap.params["contactTol"])
    assert np.allclose(h["zetaMin1"], g["zetaMin1"], rtol=1e-12) and np.allclose(h["zetaMin2"], g["zetaMin2"], rtol=1e-12)
    a, b = final_state(gap), final_state(closed)
    assert np.allclose(a["u1"][1::2], b["u1"][1::2] - delta, rtol=0, atol=1e-12)
    assert np.allclose(a["u1"][0::2], b["u1"][0::2], rtol=0, atol=1e-12)
    assert np.allclose(a["u2"], b["u2"], rtol=0, atol=1e-12)
    line = gap.fields("contact")
    assert np.allclose(line.point_data["initialGap"], delta, rtol=1e-12)
    assert "initialGap" not in closed.fields("contact").point_data


def test_a_short_block_on_a_long_base_is_in_contact_on_its_own_extent(tmp_path):
    """A block whose ends fall inside the base's trace segments: θ1_h is the base's trace on the
    block's extent, with a node at each end (docs/model.md §10). π1 reproduces constants there (body
    2's hats sum to 1 on Γ_C), so the contact forces on the two bodies cancel to round-off; the
    closed length is the block's width, and no node outside it carries a force."""
    base = ("[body1.mesh]\nrectangle = [-3.0, 3.0, -2.0, 0.0]\nn = 24\ncontactLabel = 3\n"
            '[[body1.boundary]]\ntype = "clamped"\nlabel = 1\n')
    block = ("[body2.mesh]\nrectangle = [-0.55, 0.45, 0.0, 1.0]\nn = 8\ncontactLabel = 1\n"
             '[[body2.boundary]]\ntype = "displacement"\nlabel = 3\ncomponent = "x"\nvalue = "0"\n'
             '[[body2.boundary]]\ntype = "displacement"\nlabel = 3\ncomponent = "y"\nvalue = "-0.01*t"\n')
    result = run(scene(tmp_path, "block", base, block), tmp_path / "block")
    h = result.history
    scale = h["contactForce"].max()
    assert scale > 0
    assert np.all(h["forceBalance"] <= 1e-12 * scale)
    assert h["contactLength"][-1] == pytest.approx(1.0, rel=1e-12)
    line = result.fields("contact")
    x = line.points[:, 0]
    assert x.min() == pytest.approx(-0.55, abs=1e-12) and x.max() == pytest.approx(0.45, abs=1e-12)
    assert np.all(line.point_data["pressure"] >= 0) and np.all(line.point_data["gap"] <= result.params["contactTol"])


def refused(tmp_path, name: str, body1: str, body2: str) -> str:
    with pytest.raises(SolverError) as error:
        run(scene(tmp_path, name, body1, body2), tmp_path / name)
    assert error.value.returncode == 3
    return error.value.message


def test_contact_boundaries_that_do_not_overlap_are_refused(tmp_path):
    message = refused(tmp_path, "apart", pressed_block([4.0, 5.0, 0.0, 1.0], 4, 1, "-0.01*t"),
                      clamped_base([0.0, 3.0, -1.0, 0.0], 6))
    assert "do not overlap" in message and "label 1" in message and "label 3" in message


def test_bodies_that_overlap_at_the_start_are_refused(tmp_path):
    message = refused(tmp_path, "overlap", pressed_block([0.0, 1.0, 0.0, 1.0], 6, 1, "-0.01*t"),
                      clamped_base([0.0, 1.0, -1.0, 0.02], 8))
    assert "overlap at the start" in message and "label 3" in message and "0.02" in message


def test_a_contact_boundary_that_does_not_face_the_other_is_refused(tmp_path):
    """Body 2's bottom as its contact side: it faces away from body 1."""
    base = clamped_base([0.0, 1.0, -1.0, 0.0], 8).replace("contactLabel = 3", "contactLabel = 1").replace(
        "label = 1\n", "label = 3\n")
    message = refused(tmp_path, "away", pressed_block([0.0, 1.0, 0.0, 1.0], 6, 1, "-0.01*t"), base)
    assert "does not face body 1" in message and "label 1" in message


def test_a_contact_boundary_of_two_labels_is_the_boundary_of_their_union(tmp_path):
    """The punch's face (label 1) and rounded corners (label 4 with split = 1: the same mesh, other
    tags) named together give, to the bit, what the one label of the whole curve gives."""
    punch = REPO / "scenes" / "punch.toml"
    coarse = {"output.images": False, "body1.mesh.n": 30, "body2.mesh.n": 12, "time.N": 24, "output.fields": ["contact", "state"]}
    one = run(punch, tmp_path / "one", coarse)
    two = run(punch, tmp_path / "two", {**coarse, "body2.mesh.parameters": {"split": 1}, "body2.mesh.contactLabel": [1, 4]})
    for column in one.history:
        if column != "stepSeconds":
            assert np.array_equal(one.history[column], two.history[column]), column
    a, b = final_state(one), final_state(two)
    assert all(np.array_equal(a[name], b[name]) for name in ("u1", "u2", "zeta1", "s", "beta"))
    assert one.history["contactLength"][-1] > 1.5, "the contact reaches the corners (label 4)"


def test_a_traction_on_the_contact_boundary_acts_where_the_bodies_are_apart(tmp_path):
    """Body 1's contact side (its bottom) pulled by the traction (0, −q), the body on rollers at its
    top and left, body 2 far below (no contact): the elastic limit (the viscous response damped by
    (1 + kE/η)⁻¹ ≈ 1/101 a step) is uniaxial tension, u = (−ν q x/E, −q (1 − y)/E), which P1 holds
    exactly."""
    q, E, nu = 10.0, 1000.0, 0.3
    body1 = ("[body1.mesh]\nrectangle = [0.0, 1.0, 0.0, 1.0]\nn = 5\ncontactLabel = 1\n"
             f"[body1.material]\nE = {E}\nnu = {nu}\nmu = 0.0\neta = 1.0\n"
             "[body1.damage]\nlambdaD = 0.0\nlambdaU = 0.0\n"
             '[[body1.boundary]]\ntype = "roller"\nlabel = 3\ncomponent = "y"\n'
             '[[body1.boundary]]\ntype = "roller"\nlabel = 4\ncomponent = "x"\n'
             f'[[body1.boundary]]\ntype = "traction"\nlabel = 1\nfy = "{-q}"\n')
    result = run(scene(tmp_path, "pulled", body1, clamped_base([0.0, 1.0, -1.5, -0.5], 4), steps=10), tmp_path / "run")
    assert np.all(result.history["contactForce"] == 0)
    nodes = meshio.read(result.folder / "body1.msh").points
    u = final_state(result)["u1"]
    assert np.allclose(u[0::2], -nu * q * nodes[:, 0] / E, rtol=0, atol=1e-13)
    assert np.allclose(u[1::2], -q * (1 - nodes[:, 1]) / E, rtol=0, atol=1e-13)


def test_body_1_contact_labels_that_do_not_meet_end_to_end_are_refused(tmp_path):
    """meshes/base.geo's label 5 is its top left and right of the middle (label 1): two pieces,
    refused by the driver's check of Γ_C (edp/lib/mortar.idp), named by the scene's key."""
    base = ('[body1.mesh]\ngeo = "meshes/base.geo"\nn = 8\ncontactLabel = 5\n'
            '[[body1.boundary]]\ntype = "clamped"\nlabel = 3\n')
    block = pressed_block([-3.0, 3.0, 0.0, 1.0], 12, 1, "-0.01*t").replace("body1", "body2")
    with pytest.raises(SolverError, match=r"exit 3 .*: body 1's potential contact boundary \(label 5, body1\.mesh\."
                                          r"contactLabel\) is not one segment"):
        run(scene(tmp_path, "pieces", base, block), tmp_path / "pieces")
    whole = run(scene(tmp_path, "whole", base.replace("contactLabel = 5", "contactLabel = [1, 5]"), block), tmp_path / "whole")
    assert whole.history["contactLength"][-1] == pytest.approx(6.0)


HERTZ = REPO / "scenes" / "hertz.toml"


@pytest.mark.parametrize("order", [1, 2])
def test_hertz_at_a_coarse_level_agrees_with_the_analytic_line_contact(tmp_path, order):
    """scenes/hertz.toml at n = 8 (results/hertz has the ladder), displacements of degree 1 and 2:
    the half-width and the peak pressure within 3 % of a = 2√(FR/(πE*)), p0 = 2F/(πa) at the
    computed F, each segment's pressure within 5 % of p0 from the elliptical law's mean over it
    where |x| < 0.9a; no penetration, forces balanced, complementarity."""
    result = run(HERTZ, tmp_path / "hertz", {"body1.mesh.n": 8, "body2.mesh.n": 8, "space.order": order})
    row = measure(result, radius=8.0)
    assert row["F"] > 0
    assert row["errorA"] <= 0.03 and row["errorP0"] <= 0.03 and row["errorProfile"] <= 0.05
    h, p = result.history, result.params
    assert h["gapMax"].max() <= p["contactTol"] and h["lambdaMin"].min() >= 0
    assert h["complementarity"].max() <= p["contactTol"] * h["contactForce"].max()
    assert h["forceBalance"].max() <= 1e-10 * h["contactForce"].max()
    x, nodal, _, _, _ = contact_line(result)
    outside = np.abs(x) > 1.2 * row["a"]
    assert np.all(nodal[outside] == 0), "no force where the arc stays apart"
    assert np.all(result.fields("contact").point_data["initialGap"] >= 0)


def hertz_refused(tmp_path, name: str, overrides: dict) -> str:
    with pytest.raises(SolverError) as error:
        run(HERTZ, tmp_path / name, {"body1.mesh.n": 4, "body2.mesh.n": 4, **overrides})
    assert error.value.returncode == 3
    return error.value.message


def test_a_curved_mortar_side_is_refused(tmp_path):
    """The arc as body 1's contact boundary: body 1's must be straight."""
    swap = {"body1.mesh.geo": "meshes/hertz_cylinder.geo", "body2.mesh.geo": "meshes/hertz_block.geo",
            "body2.boundary": [{"type": "clamped", "label": 3}],
            "body1.boundary": [{"type": "clamped", "label": 2}]}
    message = hertz_refused(tmp_path, "curved", swap)
    assert "body 1's potential contact boundary (label 1, body1.mesh.contactLabel) is not straight" in message


def test_an_arc_that_folds_over_its_projection_is_refused(tmp_path):
    """A 240° arc passes its equator: lines normal to the block cross it twice."""
    message = hertz_refused(tmp_path, "folded", {"body2.mesh.parameters": {"angle": 240}})
    assert "does not project one-to-one" in message and "label 1" in message


def test_the_hertz_study_writes_its_ladder(tmp_path):
    """`study hertz` at a small size: the three cases, the mesh distances to the finest level, the
    force-controlled runs at the force of the displacement-controlled ones, files."""
    rows = hertz(tmp_path, levels=2, coarsest=4)
    assert [(row["case"], row["n"]) for row in rows] == [("same", 4), ("same", 8), ("dissimilar", 4), ("dissimilar", 8),
                                                         ("force", 4), ("force", 8)]
    assert all(0 < row["errorA"] < 0.05 and 0 < row["errorP0"] < 0.05 for row in rows)
    for pressed, loaded in zip(rows[:2], rows[4:]):
        assert loaded["F"] == pytest.approx(pressed["F"], rel=1e-12) and loaded["approach"] == pytest.approx(0.2, rel=0.05)
    assert "meshA" in rows[0] and "meshA" not in rows[1]
    assert {path.name for path in tmp_path.iterdir()} >= {"README.md", "hertz.csv", "pressure.png", "vonmises.png"}


def test_the_hertz_study_at_both_degrees_with_a_setting(tmp_path):
    """--orders runs every case at each degree, its nodes the displacement's (at degree 2 more
    than the mesh's vertices), --set reaches every run but the force case's boundary conditions,
    and the README's command reproduces both; a key the study sets per run is refused."""
    with pytest.raises(InputError, match="--set space.order: the study sets it"):
        hertz(tmp_path / "refused", levels=1, coarsest=4, settings={"space.order": 2})
    approach = "-0.1*min(t, 1)"
    rows = hertz(tmp_path / "both", levels=1, coarsest=4, orders=(1, 2), settings={"body2.boundary.1.value": approach})
    assert [(row["case"], row["order"]) for row in rows] == [("same", 1), ("dissimilar", 1), ("force", 1),
                                                             ("same", 2), ("dissimilar", 2), ("force", 2)]
    same = {row["order"]: row for row in rows if row["case"] == "same"}
    assert same[2]["nodes1"] > 2 * same[1]["nodes1"]  # the edges' middles too
    assert all(row["F"] > 0 and 0 < row["errorA"] < 0.05 for row in rows)
    forced = [row for row in rows if row["case"] == "force"]
    assert all(row["approach"] == pytest.approx(0.1, rel=0.1) for row in forced)  # pressed by the F of the 0.1 approach
    readme = (tmp_path / "both" / "README.md").read_text()
    assert "--orders 1,2 --set 'body2.boundary.1.value=\"-0.1*min(t, 1)\"'" in readme


def test_the_hertz_study_on_adapted_meshes(tmp_path):
    """--adapt-targets: an adapt loop per case from the scene's meshes at n = pilot, whose pilot is
    the graded ladder's run at that n (the same run: the same a, p0 and nodes); the estimate falls
    to the target and p0 comes closer to Hertz's (at the approach 0.05, whose gap floor, 0.075 %, is
    below the pilot's error); the report's tables and command say so."""
    rows = hertz(tmp_path, levels=1, coarsest=4, orders=(2,), adapt_targets=(0.01,), pilot=4,
                 settings={"body2.boundary.1.value": "-0.05*min(t, 1)"})
    graded = {row["case"]: row for row in rows if row["mesh"] == "graded"}
    for case in ("same", "dissimilar"):
        loop = [row for row in rows if (row["mesh"], row["case"]) == ("adapted", case)]
        pilot, last = loop[0], loop[-1]
        assert pilot["cycle"] == 0 and len(loop) >= 2
        for key in ("nodes1", "nodes2", "F", "aMoment", "p0Computed"):
            assert pilot[key] == graded[case][key]
        assert last["estimate"] <= 0.01 < pilot["estimate"]
        assert last["errorP0"] < pilot["errorP0"] / 4
    readme = (tmp_path / "README.md").read_text()
    assert "--adapt-targets 0.01 --pilot 4" in readme and "## Adapted meshes" in readme
    assert "| force | none | not run |" in readme  # its one run, n = 4, is the pilot's mesh


@pytest.mark.unit
def test_the_fewest_nodes_table_counts_designs_not_pilots():
    """The table's cell of a family is its run with the fewest nodes of both bodies among those
    whose a and p0 are both within 0.2 %; an adapt loop's pilot (the scene's own mesh) is none of
    its designs; P2 / P1 divides the best of each degree over both families."""
    from orchestrate.studies.hertz import fewest_nodes

    def row(order, mesh, nodes, a, p0, cycle=None):
        return {"case": "same", "order": order, "mesh": mesh, "nodes1": nodes, "nodes2": nodes, "errorA": a,
                "errorP0": p0, **({} if cycle is None else {"cycle": cycle})}

    rows = [row(1, "graded", 100, 0.001, 0.001), row(1, "graded", 50, 0.001, 0.003),
            row(1, "adapted", 10, 0.001, 0.001, cycle=0), row(1, "adapted", 80, 0.0015, 0.0005, cycle=1),
            row(2, "graded", 120, 0.001, 0.001), row(2, "adapted", 20, 0.002, 0.001, cycle=1)]
    line = fewest_nodes(rows, (1, 2))[-1]
    assert line == ("| same | 200 (a 0.100 %, p0 0.100 %) | 160 (a 0.150 %, p0 0.050 %) | 240 (a 0.100 %, p0 0.100 %) "
                    "| 40 (a 0.200 %, p0 0.100 %) | 0.25 |")
