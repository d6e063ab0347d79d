"""The committed default meshes are what their gmsh sources give (a stale .msh would silently
replace the geometry), and they do not match on Γ_C (body 2 about 4/3 as fine as body 1); graded
meshes follow their size law and refinement nests."""
import meshio
import numpy as np
import pytest

from conftest import gmsh_mesh
from orchestrate.freefem import REPO
from orchestrate.mesh import MeshError, body_mesh, cache_key


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
    body_mesh(REPO / "meshes/rectangle.geo", {"n": 4, "y0": -1.0, "y1": 0.0}, cache=tmp_path)
    box = meshio.read(body_mesh(REPO / "meshes/tilted_box.geo", {"n": 6, "side": 1.0}, cache=tmp_path))
    assert box.points[:, 1].min() == pytest.approx(0.6, abs=1e-12)
    assert box.points[:, 1].max() == pytest.approx(2.0, abs=1e-12)


def _edges(mesh):
    triangles = mesh.cells_dict["triangle"]
    pairs = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    return pairs, np.linalg.norm(mesh.points[pairs[:, 0], :2] - mesh.points[pairs[:, 1], :2], axis=1)


def test_graded_mesh_follows_its_size_law(tmp_path):
    """meshes/paper_body1_graded.geo: size h·(r/radius)^grade between hmin = h·(h/radius)^(grade/(1−grade))
    and h. At grade ½ the elements at a singular point shrink as h² while the node count still
    grows as n² (∫ r dr / size² is finite), the property that gives P1 its optimal rate there."""
    nodes = []
    for n in (24, 48):
        mesh = meshio.read(body_mesh(REPO / "meshes/paper_body1_graded.geo", {"n": n}, cache=tmp_path))
        h = 6 / n
        hmin = h * (h / 3)
        pairs, lengths = _edges(mesh)
        corner = np.flatnonzero(np.linalg.norm(mesh.points[:, :2], axis=1) < 1e-12)[0]  # the clamped corner (0,0)
        at_corner = lengths[(pairs == corner).any(axis=1)]
        assert 0.5 * hmin < at_corner.min() and at_corner.max() < 2.5 * hmin
        assert lengths.max() < 1.6 * h
        nodes.append(len(mesh.points))
    assert 3.5 < nodes[1] / nodes[0] < 4.5


def test_a_grading_exponent_outside_its_range_is_refused(tmp_path):
    with pytest.raises(MeshError, match=r"grade = 1\.5: the grading exponent must lie in \(0, 1\)"):
        body_mesh(REPO / "meshes/paper_body2_graded.geo", {"n": 8, "grade": 1.5}, cache=tmp_path)


def test_refinement_splits_every_triangle_in_four(tmp_path):
    """mesh.refine: each triangle becomes four through its edge midpoints, so the refined mesh has
    one new node per edge (V + E nodes, 4T triangles) and keeps every old node (nested meshes)."""
    source = REPO / "meshes/paper_body2_graded.geo"
    coarse = meshio.read(body_mesh(source, {"n": 8}, cache=tmp_path))
    fine = meshio.read(body_mesh(source, {"n": 8}, refine=1, cache=tmp_path))
    pairs, _ = _edges(coarse)
    edges = len({tuple(sorted(pair)) for pair in pairs.tolist()})
    assert len(fine.points) == len(coarse.points) + edges
    assert len(fine.cells_dict["triangle"]) == 4 * len(coarse.cells_dict["triangle"])
    old = {tuple(np.round(point[:2], 12)) for point in coarse.points}
    assert old <= {tuple(np.round(point[:2], 12)) for point in fine.points}


def test_the_cache_key_follows_included_files(tmp_path):
    """A graded mesh's size law lives in an included file: editing it must give a new mesh."""
    for name in ("paper_body2_graded.geo", "graded_size.geo"):
        (tmp_path / name).write_text((REPO / "meshes" / name).read_text())
    source = tmp_path / "paper_body2_graded.geo"
    before = cache_key(source, {"n": 8})
    (tmp_path / "graded_size.geo").write_text((REPO / "meshes/graded_size.geo").read_text() + "// edited\n")
    assert cache_key(source, {"n": 8}) != before
