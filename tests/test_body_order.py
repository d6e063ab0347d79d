"""A body's forms at the displacements' degree 1 and 2 (docs/model.md §13; edp/lib/body.idp)
against FreeFEM's own assembly and exact facts: the strain points are the triangles' centroids
(k = 1) or edge middles (k = 2) with weights |T| or |T|/3; the strains of a field of degree k are
its exact strains there; the force of the viscous stress is FreeFEM's assembled (Aε(u), ε(v)),
exact for both degrees (the points' rule is exact for the product of two strains); the weakened
elastic force with ζ at the points is FreeFEM's assembly of (ζ Gε(u), ε(v)) by the same rule
(qf1pT, qf2pT), a P1 ζ being random; and the damage source's loads integrate a field of degree
k − 1 exactly."""
import pytest

from conftest import gmsh_mesh
from orchestrate.freefem import REPO, run_script

pytestmark = pytest.mark.solver


def body_facts(mesh, order):
    done = run_script(REPO / "tests" / "edp" / "body_check.edp", ["-mesh1", mesh, "-order", order],
                      defines={"ORDER": str(order)})
    assert done.returncode == 0, done.stdout + done.stderr
    return {line.split()[0]: float(line.split()[1]) for line in done.stdout.splitlines() if len(line.split()) == 2}


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    """An unstructured block (0, 2) × (0, 1), its side 4 (x = 0) clamped by the check."""
    return gmsh_mesh("meshes/rectangle.geo", tmp_path_factory.mktemp("body") / "block.msh", x1=2, y0=0, y1=1, n=7)


@pytest.mark.parametrize("order", [1, 2])
def test_strain_points_are_the_rule_exact_for_products_of_strains(block, order):
    facts = body_facts(block, order)
    triangles = body_facts(block, 1)["points"]
    assert facts["points"] == triangles*(1 if order == 1 else 3)
    assert facts["pointError"] < 1e-13
    assert facts["weightError"] < 1e-15


@pytest.mark.parametrize("order", [1, 2])
def test_forces_at_the_points_are_freefems_assembly(block, order):
    facts = body_facts(block, order)
    assert facts["strainError"] < 1e-12
    assert facts["viscousError"] < 1e-12
    assert facts["weakenedError"] < 1e-12
    assert facts["loadError"] < 1e-12


def test_the_paper_body_at_order_two():
    """On the paper's body 1 (6 × 1.5, a quadratic field of size 30 there: round-off in the strains of
    order 1e-16 · 30 / h relative to strains of order 10)."""
    facts = body_facts(REPO / "meshes" / "paper_body1-n24.msh", 2)
    assert max(facts[name] for name in ("pointError", "viscousError", "weakenedError", "loadError")) < 1e-11
    assert facts["strainError"] < 1e-10
