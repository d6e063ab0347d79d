"""The committed default meshes are what their gmsh sources give (a stale .msh would silently
replace the geometry), and they do not match on Γ_C (body 2 about 4/3 as fine as body 1)."""
import meshio
import numpy as np
import pytest

from conftest import gmsh_mesh
from orchestrate.freefem import REPO


@pytest.mark.parametrize("body, n", [(1, 24), (2, 32)])
def test_committed_mesh_matches_its_source(tmp_path, body, n):
    fresh = meshio.read(gmsh_mesh(f"meshes/paper_body{body}.geo", tmp_path / "fresh.msh", n=n))
    committed = meshio.read(REPO / "meshes" / f"paper_body{body}-n{n}.msh")
    np.testing.assert_allclose(fresh.points, committed.points, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(fresh.cells_dict["triangle"], committed.cells_dict["triangle"])


def test_default_traces_do_not_match():
    counts = []
    for body, n in [(1, 24), (2, 32)]:
        mesh = meshio.read(REPO / "meshes" / f"paper_body{body}-n{n}.msh")
        counts.append(np.count_nonzero(np.abs(mesh.points[:, 1]) < 1e-12))
    assert counts == [25, 33]
