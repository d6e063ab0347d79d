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


def test_a_mesh_does_not_inherit_the_constants_of_an_earlier_one(tmp_path):
    """gmsh keeps -setnumber values for the life of a process: a tilted box meshed after a
    rectangle given y0 = −1 must still start at its own default y0 = 0.6 (meshes/tilted_box.geo)."""
    from pathlib import Path

    from orchestrate.mesh import body_mesh

    body_mesh(Path(REPO / "meshes/rectangle.geo"), {"n": 4, "y0": -1.0, "y1": 0.0}, cache=tmp_path)
    box = meshio.read(body_mesh(Path(REPO / "meshes/tilted_box.geo"), {"n": 6, "side": 1.0}, cache=tmp_path))
    assert box.points[:, 1].min() == pytest.approx(0.6, abs=1e-12)
    assert box.points[:, 1].max() == pytest.approx(2.0, abs=1e-12)
