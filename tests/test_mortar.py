"""The mortar projection π1 (docs/model.md §6) against exact facts of L² projections."""
import pytest

from conftest import gmsh_mesh
from orchestrate.freefem import REPO, run_script

pytestmark = pytest.mark.solver


def mortar_facts(upper, lower, contactLabel1=1, contactLabel2=3):
    done = run_script(REPO / "tests" / "edp" / "mortar_check.edp",
                      ["-mesh1", upper, "-mesh2", lower, "-contactLabel1", contactLabel1, "-contactLabel2", contactLabel2])
    assert done.returncode == 0, done.stdout + done.stderr
    return {line.split()[0]: float(line.split()[1]) for line in done.stdout.splitlines() if len(line.split()) == 2}


@pytest.fixture(scope="module")
def blocks(tmp_path_factory):
    """Two unstructured blocks sharing the side y = 0 of length 2, with 7 and 11 trace segments."""
    folder = tmp_path_factory.mktemp("mortar")
    upper = gmsh_mesh("meshes/rectangle.geo", folder / "upper.msh", x1=2, y0=0, y1=1, n=7)
    lower = gmsh_mesh("meshes/rectangle.geo", folder / "lower.msh", x1=2, y0=-1, y1=0, n=11)
    lower_matching = gmsh_mesh("meshes/rectangle.geo", folder / "lower7.msh", x1=2, y0=-1, y1=0, n=7)
    return upper, lower, lower_matching


def test_coupling_matrix_sums_to_the_contact_length(blocks):
    upper, lower, _ = blocks
    facts = mortar_facts(upper, lower)
    assert facts["sumM12"] == pytest.approx(2.0, abs=1e-13)
    assert facts["sumM11"] == pytest.approx(2.0, abs=1e-13)


def test_projection_reproduces_linear_functions(blocks):
    upper, lower, _ = blocks
    assert mortar_facts(upper, lower)["linearError"] < 1e-13


def test_projection_is_the_identity_on_matching_traces(blocks):
    upper, _, lower_matching = blocks
    # gmsh places the "same" transfinite nodes of two curves up to ~1e-12 apart; π1 − I is of
    # the order of that mismatch over the segment length, far above round-off but far below 1e-9.
    assert 0 <= mortar_facts(upper, lower_matching)["identityError"] < 1e-9


def test_paper_meshes_couple_along_the_whole_contact_line():
    facts = mortar_facts(REPO / "meshes" / "paper_body1-n24.msh", REPO / "meshes" / "paper_body2-n32.msh",
                         contactLabel1=1, contactLabel2=1)
    assert facts["lengthC"] == pytest.approx(6.0, abs=1e-12)
    assert facts["sumM12"] == pytest.approx(6.0, abs=1e-12)
    assert facts["linearError"] < 1e-12
