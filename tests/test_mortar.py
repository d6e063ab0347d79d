"""The mortar projection π1 (docs/model.md §6, §13) against exact facts of L² projections, for
displacements of degree 1 and 2."""
import pytest

from conftest import gmsh_mesh
from orchestrate.freefem import REPO, run_script

pytestmark = pytest.mark.solver


def mortar_facts(upper, lower, contactLabel1=1, contactLabel2=3, order=1):
    done = run_script(REPO / "tests" / "edp" / "mortar_check.edp",
                      ["-mesh1", upper, "-mesh2", lower, "-contactLabel1", contactLabel1, "-contactLabel2", contactLabel2,
                       "-order", order], defines={"ORDER": str(order)})
    assert done.returncode == 0, done.stdout + done.stderr
    return {line.split()[0]: float(line.split()[1]) for line in done.stdout.splitlines() if len(line.split()) == 2}


@pytest.fixture(scope="module")
def blocks(tmp_path_factory):
    """Two unstructured blocks sharing the side y = 0 of length 2, with 7 and 11 trace segments, and
    a lower block on (0.35, 1.62) whose ends cut segments of the upper one's trace."""
    folder = tmp_path_factory.mktemp("mortar")
    upper = gmsh_mesh("meshes/rectangle.geo", folder / "upper.msh", x1=2, y0=0, y1=1, n=7)
    lower = gmsh_mesh("meshes/rectangle.geo", folder / "lower.msh", x1=2, y0=-1, y1=0, n=11)
    lower_matching = gmsh_mesh("meshes/rectangle.geo", folder / "lower7.msh", x1=2, y0=-1, y1=0, n=7)
    shorter = gmsh_mesh("meshes/rectangle.geo", folder / "shorter.msh", x0=0.35, x1=1.62, y0=-1, y1=0, n=5)
    return upper, lower, lower_matching, shorter


@pytest.mark.parametrize("order", [1, 2])
def test_coupling_matrices_sum_to_the_contact_length(blocks, order):
    upper, lower, _, shorter = blocks
    facts = mortar_facts(upper, lower, order=order)
    assert facts["sumM12"] == pytest.approx(2.0, abs=1e-13)
    assert facts["sumM11"] == pytest.approx(2.0, abs=1e-13)
    cut = mortar_facts(upper, shorter, order=order)
    assert cut["lengthC"] == pytest.approx(1.27, abs=1e-13)
    assert cut["sumM12"] == pytest.approx(1.27, abs=1e-13)


@pytest.mark.parametrize("order", [1, 2])
def test_projection_reproduces_polynomials_of_the_displacements_degree(blocks, order):
    upper, lower, _, shorter = blocks
    assert mortar_facts(upper, lower, order=order)["polynomialError"] < 1e-13
    assert mortar_facts(upper, shorter, order=order)["polynomialError"] < 1e-13


@pytest.mark.parametrize("order", [1, 2])
def test_projection_is_the_identity_on_matching_traces(blocks, order):
    upper, _, lower_matching, _ = blocks
    # gmsh places the "same" transfinite nodes of two curves up to ~1e-12 apart; π1 − I is of
    # the order of that mismatch over the segment length, far above round-off but far below 1e-9.
    assert 0 <= mortar_facts(upper, lower_matching, order=order)["identityError"] < 1e-9


@pytest.mark.parametrize("order", [1, 2])
def test_nodal_weights_are_the_trapezoid_and_simpson_weights(blocks, order):
    """∫ψ_j: (h_left + h_right)/2 at order 1; at order 2 Simpson's, (h_left + h_right)/6 at a
    segment's end and 2h/3 at its middle, all positive (docs/model.md §13): also with cut segments."""
    upper, lower, _, shorter = blocks
    facts, cut = mortar_facts(upper, lower, order=order), mortar_facts(upper, shorter, order=order)
    assert facts["weightError"] < 1e-14 and cut["weightError"] < 1e-14
    assert facts["nodesA"] == 7*order + 1


@pytest.mark.parametrize("order", [1, 2])
def test_jumps_are_exact_for_fields_of_the_displacements_degree(blocks, order):
    """g_h and s_h of two fields of degree k, one per body, equal their exact jumps at every node
    of θ1_h: the operators read the right dofs (FreeFEM's P2 numbering) with the right weights,
    also at the nodes inside a segment of body 1 that an end of Γ_C cuts."""
    upper, lower, _, shorter = blocks
    assert mortar_facts(upper, lower, order=order)["jumpError"] < 1e-13
    assert mortar_facts(upper, shorter, order=order)["jumpError"] < 1e-13


def test_paper_meshes_couple_along_the_whole_contact_line():
    facts = mortar_facts(REPO / "meshes" / "paper_body1-n24.msh", REPO / "meshes" / "paper_body2-n32.msh",
                         contactLabel1=1, contactLabel2=1)
    assert facts["lengthC"] == pytest.approx(6.0, abs=1e-12)
    assert facts["sumM12"] == pytest.approx(6.0, abs=1e-12)
    assert facts["polynomialError"] < 1e-12


@pytest.mark.parametrize("order", [1, 2])
def test_the_glues_segment_integrals_are_exact(blocks, order):
    """β's segment integrals on θ1_h (edp/lib/bonding.idp, glue.idp, contact.idp) against three-point
    Gauss on each segment, with random weights per segment and random nodal values, where an end
    of Γ_C cuts a segment: ∫ c f_h ψ_a, its band matrix, the segment means of f_h², and the closed
    length as the nodes' weights ∫ψ_j add it up."""
    upper, _, _, shorter = blocks
    done = run_script(REPO / "tests" / "edp" / "interface_check.edp",
                      ["-mesh1", upper, "-mesh2", shorter, "-contactLabel1", 1, "-contactLabel2", 3, "-order", order],
                      defines={"ORDER": str(order)})
    assert done.returncode == 0, done.stdout + done.stderr
    facts = {line.split()[0]: float(line.split()[1]) for line in done.stdout.splitlines() if len(line.split()) == 2}
    assert set(facts) == {"loadError", "bandError", "meanSquareError", "closedError"}
    assert max(facts.values()) < 1e-14
