"""The committed default meshes are what their gmsh sources give (a stale .msh would silently
replace the geometry), and they do not match on Γ_C (body 2 about 4/3 as fine as body 1); graded
meshes follow their size law and refinement nests; a .geo is meshed within limits of time,
memory and size, and what the solver cannot take is refused naming the field (issue 32)."""
import os
import subprocess
import time

import meshio
import numpy as np
import pytest

from conftest import gmsh_mesh
from orchestrate import mesh
from orchestrate.freefem import REPO
from orchestrate.mesh import MeshError, MeshLimits, TooLarge, body_mesh, cache_key

pytestmark = pytest.mark.solver


@pytest.mark.parametrize("body, n", [(1, 24), (2, 32)])
def test_committed_mesh_matches_its_source(tmp_path, body, n):
    fresh = meshio.read(gmsh_mesh(f"meshes/paper_body{body}.geo", tmp_path / "fresh.msh", n=n))
    committed = meshio.read(REPO / "meshes" / f"paper_body{body}-n{n}.msh")
    np.testing.assert_allclose(fresh.points, committed.points, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(fresh.cells_dict["triangle"], committed.cells_dict["triangle"])


@pytest.mark.parametrize("body, n", [(1, 24), (2, 32)])
@pytest.mark.unit
def test_a_committed_mesh_s_record_holds_its_geo_and_itself_as_they_are(body, n):
    """Each committed mesh carries the SHA-256 of the .geo it was made from and its own, as sha256sum
    gives them, after a comment saying how gmsh made it."""
    record = (REPO / "meshes" / f"paper_body{body}-n{n}.msh.sha256").read_text().splitlines()
    names = [f"paper_body{body}.geo", f"paper_body{body}-n{n}.msh"]
    digests = subprocess.run(["sha256sum", "--", *names], cwd=REPO / "meshes", capture_output=True, text=True, check=True)
    assert record[0].startswith("# made by gmsh ") and f"-setnumber n {n} " in record[0]
    assert record[1:] == digests.stdout.splitlines()


@pytest.fixture
def own_meshes(tmp_path, monkeypatch):
    """A copy of the paper's body 1 sources, committed mesh and record, taken as the project's meshes/."""
    folder = tmp_path / "meshes"
    folder.mkdir()
    for name in ("paper_body1.geo", "paper_body1-n24.msh", "paper_body1-n24.msh.sha256"):
        (folder / name).write_bytes((REPO / "meshes" / name).read_bytes())
    monkeypatch.setattr(mesh, "REPO", tmp_path)
    return folder


@pytest.mark.parametrize("edit, words", [
    ("paper_body1.geo", "paper_body1.geo changed since its record paper_body1-n24.msh.sha256 was written"),
    ("paper_body1-n24.msh", "paper_body1-n24.msh changed since its record"),
    ("paper_body1-n24.msh.sha256", "it has no record paper_body1-n24.msh.sha256 of what it was made from"),
])
@pytest.mark.unit
def test_a_committed_mesh_is_refused_once_its_geo_or_itself_changed(own_meshes, edit, words):
    """A body given only by n ran the committed <geo>-n<n>.msh whatever its .geo had become: an edited
    paper_body1.geo still ran the old mesh. Now the mesh's record must hold both as they are."""
    assert mesh.committed_mesh(own_meshes / "paper_body1.geo", {"n": 24}, 0) == own_meshes / "paper_body1-n24.msh"
    changed = own_meshes / edit
    if edit.endswith(".sha256"):
        changed.unlink()
    else:
        moved = changed.read_bytes().replace(b"{6, 0, 0, h}", b"{6.5, 0, 0, h}")  # the corner (6, 0), in either file
        changed.write_bytes(moved.replace(b"\n2 6 0 0\n", b"\n2 6.5 0 0\n"))
    with pytest.raises(MeshError) as error:
        mesh.committed_mesh(own_meshes / "paper_body1.geo", {"n": 24}, 0)
    message = str(error.value)
    assert words in message and "with n = 24" in message, message
    assert f"`python -m orchestrate commit-mesh {own_meshes / 'paper_body1.geo'} --n 24`" in message


def test_the_driver_run_by_hand_refuses_a_committed_mesh_whose_geo_changed(tmp_path):
    """The driver follows the same rule by hand (edp/lib/meshes.idp: -geo1 with n1 takes the
    <geo>-n<n1>.msh beside it): the record must hold the .geo's and the mesh's SHA-256 as they are."""
    from orchestrate.freefem import MAIN, run_script

    for name in ("paper_body1.geo", "paper_body1-n24.msh", "paper_body1-n24.msh.sha256"):
        (tmp_path / name).write_bytes((REPO / "meshes" / name).read_bytes())
    flags = ["-geo1", tmp_path / "paper_body1.geo", "-T", 0.05, "-N", 1]
    assert run_script(MAIN, [*flags, "-out", tmp_path / "same"]).returncode == 0
    geo = tmp_path / "paper_body1.geo"
    geo.write_text(geo.read_text().replace("Point(4) = {3, 6, 0, h};", "Point(4) = {3.5, 6, 0, h};"))
    done = run_script(MAIN, [*flags, "-out", tmp_path / "edited"])
    assert done.returncode == 3, done.stdout[-500:]
    assert f"the committed mesh '{tmp_path}/paper_body1-n24.msh' of body 1 is not the mesh of" in done.error_line
    assert f"python -m orchestrate commit-mesh {geo} --n 24" in done.error_line


@pytest.mark.unit
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
    """meshes/paper_body1_graded.geo: size h·(r/radius)^g between hmin = h·(h/radius)^(g/(1−g)) and h,
    g = grade (0.3) toward the clamped corner (0,0), g = loadedCornerGrade (0.6) toward (0,6), radius
    2. The elements at a singular point shrink faster than h (as h^(1/(1−g))) while the node count
    still grows as n² (∫ r dr / size² is finite for g < 1), the property that gives P1 its optimal
    rate there."""
    nodes = []
    for n in (24, 48):
        mesh = meshio.read(body_mesh(REPO / "meshes/paper_body1_graded.geo", {"n": n}, cache=tmp_path))
        h = 6 / n
        pairs, lengths = _edges(mesh)
        for corner, grade in (((0, 0), 0.3), ((0, 6), 0.6)):
            hmin = h * (h / 2) ** (grade / (1 - grade))
            node = np.flatnonzero(np.linalg.norm(mesh.points[:, :2] - corner, axis=1) < 1e-12)[0]
            at_corner = lengths[(pairs == node).any(axis=1)]
            assert 0.5 * hmin < at_corner.min() and at_corner.max() < 2.5 * hmin, (n, corner)
        assert lengths.max() < 1.6 * h
        nodes.append(len(mesh.points))
    assert 3.5 < nodes[1] / nodes[0] < 4.5


def test_body_2_is_graded_toward_one_end_of_its_contact_side(tmp_path):
    """meshes/paper_body2_graded.geo: toward (6,0) at grade 0.4, radius 6 (hmin = h·(h/6)^(2/3));
    its other end (0,0) is farther than the radius from it, so its elements there are of size h."""
    h = 6 / 24
    mesh = meshio.read(body_mesh(REPO / "meshes/paper_body2_graded.geo", {"n": 24}, cache=tmp_path))
    pairs, lengths = _edges(mesh)
    for corner, size in (((6, 0), h * (h / 6) ** (2 / 3)), ((0, 0), h)):
        node = np.flatnonzero(np.linalg.norm(mesh.points[:, :2] - corner, axis=1) < 1e-12)[0]
        at_corner = lengths[(pairs == node).any(axis=1)]
        assert 0.5 * size < at_corner.min() and at_corner.max() < 2.5 * size, corner


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


@pytest.mark.unit
def test_the_cache_key_follows_included_files(tmp_path):
    """A graded mesh's size law lives in an included file: editing it must give a new mesh."""
    for name in ("paper_body2_graded.geo", "graded_size.geo"):
        (tmp_path / name).write_text((REPO / "meshes" / name).read_text())
    source = tmp_path / "paper_body2_graded.geo"
    before = cache_key(source, {"n": 8})
    (tmp_path / "graded_size.geo").write_text((REPO / "meshes/graded_size.geo").read_text() + "// edited\n")
    assert cache_key(source, {"n": 8}) != before


def test_a_mesh_in_freefems_format_is_the_same_mesh_to_the_bit(tmp_path):
    """What the runner hands over when a triangle is below gmshload's area limit: the paper's run
    on the meshes in FreeFEM's format is its run on the gmsh files, every byte of its results."""
    from orchestrate.freefem import MAIN, run_script
    from orchestrate.mesh import write_freefem

    meshes = {}
    for body, n in ((1, 24), (2, 32)):
        meshes[body] = tmp_path / f"body{body}.msh"
        write_freefem(REPO / "meshes" / f"paper_body{body}-n{n}.msh", meshes[body])
    runs = {}
    for kind, flags in (("gmsh", []), ("freefem", ["-mesh1", meshes[1], "-mesh2", meshes[2]])):
        runs[kind] = tmp_path / kind
        done = run_script(MAIN, [*flags, "-N", 20, "-outFields", "bodies,state", "-out", runs[kind]])
        assert done.returncode == 0, done.error_line
    for name in ("body1_0020.vtu", "body2_0020.vtu", "state_0020.txt"):
        assert (runs["gmsh"] / name).read_bytes() == (runs["freefem"] / name).read_bytes()
    history = [[line.rsplit(",", 1)[0] for line in (runs[kind] / "history.csv").read_text().splitlines()]
               for kind in runs]
    assert history[0] == history[1]


def test_a_scene_in_si_units_with_millimetre_elements_runs_as_in_millimetres(tmp_path):
    """gmshload refuses triangles below 1e-8 in area (1e-4 m sides): the polymer pad in metres and
    pascals has 5e-9 m² triangles. Pressed onto its block, it runs, and gives the pad in
    millimetres and megapascals scaled: u by 1e-3, so ‖u‖_V (unit-free strains over an area scaled
    by 1e-6) by 1e-3, the contact force per unit thickness (MPa·mm = kN/m) by 1e3. Neither damage
    nor glue here: docs/model.md's R truncates ε·ε by the glue's length L, and γ_ν is both a stiffness
    and a debonding rate, so neither is unit-free."""
    from orchestrate import run

    pad = REPO / "scenes" / "polymer_pad.toml"
    common = {"time.N": 20, "output.images": False, "body1.damage.lambdaU": 0.0, "body1.damage.lambdaD": 0.0,
              "glue.gammaNu": 0.0, "glue.pTau": 0.0,  # structured: gmsh's unstructured meshes are not scale-free
              "body1.mesh.structured": True, "body2.mesh.structured": True}
    millimetres = run(pad, tmp_path / "mm", {**common, "body1.boundary.0.value": "0",
                                             "body1.boundary.1.value": "-0.01*t"})
    si = {**common, "body1.mesh.rectangle": [0.0, 0.01, 0.0, 0.002], "body2.mesh.rectangle": [0.0, 0.01, -0.004, 0.0],
          "body1.boundary.0.value": "0", "body1.boundary.1.value": "-1e-5*t"}
    for body in ("body1", "body2"):
        for key in ("E", "mu", "eta"):
            si[f"{body}.material.{key}"] = scene_number(pad, f"{body}.material.{key}") * 1e6
    metres = run(pad, tmp_path / "m", si)
    assert (metres.folder / "body1.msh").read_bytes()[:1] != b"$"  # handed over in FreeFEM's format
    assert millimetres.history["contactLength"][-1] > 9  # pressed: Γ_C closed nearly everywhere
    np.testing.assert_allclose(metres.history["normV"], 1e-3 * millimetres.history["normV"], rtol=1e-7)
    np.testing.assert_allclose(metres.history["contactForce"], 1e3 * millimetres.history["contactForce"], rtol=1e-7)
    np.testing.assert_allclose(metres.history["contactLength"], 1e-3 * millimetres.history["contactLength"], rtol=1e-9)


def scene_number(path, dotted: str) -> float:
    from orchestrate.parameters import scene_value
    from orchestrate.scene import Scene

    return scene_value(Scene.load(path).model_dump(mode="json"), dotted)


def test_a_mesh_below_gmshloads_area_limit_goes_to_the_driver_in_freefems_format_made_once(tmp_path):
    """Where a triangle is below gmshload's area limit the run folder gets the mesh in FreeFEM's
    format: byte for byte what write_freefem makes of the gmsh file (whose equivalence to it is
    tested above), made once per cache entry and copied by later runs; a twin cut short is made
    again, and another gmsh file (an entry rebuilt) never gets an older file's twin."""
    from orchestrate.mesh import GMSHLOAD_SMALLEST_AREA, hand_over, read_msh, write_freefem

    source, numbers, cache = REPO / "meshes/paper_body1_graded.geo", {"n": 24, "loadedCornerGrade": 0.8}, tmp_path / "c"
    path = body_mesh(source, numbers, cache=cache)
    info = read_msh(path)
    assert info.smallest_area < GMSHLOAD_SMALLEST_AREA
    write_freefem(path, tmp_path / "direct.msh")
    direct = (tmp_path / "direct.msh").read_bytes()
    hand_over(path, info, tmp_path / "first.msh")
    [twin] = cache.glob("*.mesh")
    made = twin.stat().st_mtime_ns
    hand_over(path, info, tmp_path / "second.msh")
    assert twin.stat().st_mtime_ns == made
    twin.write_bytes(twin.read_bytes()[:-100])
    hand_over(path, info, tmp_path / "third.msh")
    for run in ("first", "second", "third"):
        assert (tmp_path / f"{run}.msh").read_bytes() == direct
    lines = path.read_text().splitlines()  # the same mesh with its first node moved a little
    first = lines.index("$Nodes") + 2
    node = lines[first].split()
    lines[first] = " ".join([node[0], repr(float(node[1]) + 1e-9), *node[2:]])
    path.write_text("\n".join(lines) + "\n")
    hand_over(path, read_msh(path), tmp_path / "moved.msh")
    assert len(list(cache.glob("*.mesh"))) == 2 and (tmp_path / "moved.msh").read_bytes() != direct


def meshio_facts(path):
    """Node and triangle counts, boundary segments per physical tag and the smallest triangle area,
    as meshio (another reader of the format) sees the file."""
    read = meshio.read(path, file_format="gmsh")
    segments = {}
    for block, tags in zip(read.cells, read.cell_data["gmsh:physical"]):
        if block.type == "line":
            for tag, count in zip(*np.unique(tags, return_counts=True)):
                segments[int(tag)] = segments.get(int(tag), 0) + int(count)
    a, b, c = (read.points[read.cells_dict["triangle"][:, j], :2] for j in range(3))
    areas = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    return len(read.points), len(areas), segments, areas.min()


@pytest.mark.parametrize("name", ["paper_body1-n24.msh", "paper_body2-n32.msh"])
@pytest.mark.unit
def test_a_mesh_file_is_read_as_another_reader_reads_it_whatever_its_blanks(tmp_path, name):
    """read_msh parses whole sections at once: its counts must be meshio's, also for the same file
    written with tabs, runs of spaces and CRLF line ends, which the format allows."""
    from orchestrate.mesh import parse_msh

    source = REPO / "meshes" / name
    nodes, triangles, segments, smallest = meshio_facts(source)
    spaced = tmp_path / "spaced.msh"
    spaced.write_bytes(source.read_bytes().replace(b" ", b" \t  ").replace(b"\n", b"  \r\n"))
    for path in (source, spaced):
        info = parse_msh(path)
        assert (info.nodes, info.triangles, info.segments) == (nodes, triangles, segments)
        assert info.smallest_area == pytest.approx(smallest, rel=1e-12)


@pytest.mark.parametrize("fault, damage", [
    ("not integers", lambda fields: fields[:2] + ["x"] + fields[3:]),
    ("not integers", lambda fields: fields[:-1] + ["-", fields[-1]]),  # numpy alone would read "- 7" as -7
    ("cut short", lambda fields: fields[:3]),
    ("not numbers of the \\$Nodes section", lambda fields: fields[:-1] + ["999999"]),
])
@pytest.mark.unit
def test_a_malformed_element_line_is_named(tmp_path, fault, damage):
    from orchestrate.mesh import parse_msh

    lines = (REPO / "meshes" / "paper_body1-n24.msh").read_text().splitlines()
    at = lines.index("$Elements") + 2
    at = next(i for i in range(at, len(lines)) if lines[i].split()[1] == "2")  # a triangle
    lines[at] = " ".join(damage(lines[at].split()))
    damaged = tmp_path / "damaged.msh"
    damaged.write_text("\n".join(lines) + "\n")
    with pytest.raises(MeshError, match=fault):
        parse_msh(damaged)


@pytest.mark.unit
def test_a_mesh_file_without_elements_reads_as_no_triangles(tmp_path):
    from orchestrate.mesh import parse_msh

    text = (REPO / "meshes" / "paper_body1-n24.msh").read_text()
    head, _, _ = text.partition("$Elements")
    empty = tmp_path / "empty.msh"
    empty.write_text(head + "$Elements\n0\n$EndElements\n")
    info = parse_msh(empty)
    assert (info.triangles, info.segments) == (0, {}) and info.nodes == meshio_facts(REPO / "meshes" / "paper_body1-n24.msh")[0]


# --- bounded meshing (issue 32, item 8) ---------------------------------------------------------

RECTANGLE = (REPO / "meshes" / "rectangle.geo").read_text()


def user_geo(folder, extra: str):
    source = folder / "block.geo"
    source.write_text(RECTANGLE + extra + "\n")
    return source


def meshers_running(folder) -> list[str]:
    """Command lines of mesher processes meshing copies made under `folder`."""
    found = subprocess.run(["ps", "-eo", "args"], capture_output=True, text=True).stdout.splitlines()
    return [line for line in found if "gmsh_mesher" in line and str(folder) in line]


@pytest.mark.parametrize("code", ["Sleep 30;", "For i In {1:1e12}\n  x = i;\nEndFor"], ids=["sleep", "endless loop"])
def test_a_geo_that_never_finishes_is_stopped_at_its_time_limit(tmp_path, code):
    started = time.monotonic()
    # the CPU-time limit or the wall clock, whichever strikes first (an endless loop spends both alike)
    with pytest.raises(MeshError, match=r"^body1\.mesh\.timeLimit = 2 s: gmsh (did not finish meshing|used that much CPU "
                                        r"time without finishing meshing) body1's \.geo \(block\.geo .*\).*; raise it "
                                        r"or coarsen the mesh"):
        body_mesh(user_geo(tmp_path, code), {"n": 4.0}, cache=tmp_path / "cache", limits=MeshLimits("body1", 2))
    assert time.monotonic() - started < 5
    assert not meshers_running(tmp_path) and not list((tmp_path / "cache").iterdir())


def test_a_mesh_size_far_too_small_is_refused_before_the_surface_is_meshed(tmp_path):
    """Mesh.MeshSizeMax = 1e-4 on the 6 × 6 square asks for about 2/√3 · 36/1e-8 = 4.2e9 nodes,
    33 TB at 8 kB each; its boundary alone is 240 000 segments, meshed in well under a second."""
    source = user_geo(tmp_path, "Mesh.MeshSizeMax = 1e-4;")
    started = time.monotonic()
    with pytest.raises(TooLarge) as error:
        body_mesh(source, {"n": 4.0, "x1": 6.0, "y1": 6.0}, cache=tmp_path, limits=MeshLimits("body2", 60))
    assert time.monotonic() - started < 10
    message = str(error.value)
    nodes = int(message.split("about ")[1].split(" nodes")[0].replace(",", ""))
    assert 0.5 * 4.2e9 < nodes < 1.5 * 4.2e9, message
    assert "an area of 36 " in message and "body2.mesh.n or body2.mesh.refine" in message and "Mesh.MeshSizeMax" in message


def test_the_node_estimate_is_close_for_the_project_meshes(tmp_path, monkeypatch):
    """The estimate gmsh's boundary mesh gives, against the nodes of the mesh made: within a factor
    2 either way for uniform, graded and structured meshes (read from the refusal at a limit of 1 node)."""
    cases = [("paper_body1.geo", {"n": 24}), ("paper_body1_graded.geo", {"n": 24}), ("base.geo", {"n": 16}),
             ("rectangle.geo", {"n": 8, "structured": 1}), ("hertz_cylinder.geo", {"n": 8})]
    for name, numbers in cases:
        made = mesh.read_msh(body_mesh(REPO / "meshes" / name, numbers, cache=tmp_path)).nodes
        with monkeypatch.context() as patch:
            patch.setattr(mesh, "memory_available", lambda: mesh.BYTES_PER_NODE)
            with pytest.raises(TooLarge) as error:
                body_mesh(REPO / "meshes" / name, numbers, 1, cache=tmp_path)
        estimated = int(str(error.value).split("about ")[1].split(" nodes")[0].replace(",", "")) / 4
        assert 0.5 < estimated / made < 2, (name, estimated, made)


def test_a_geo_that_fills_the_memory_it_may_use_is_refused_naming_it(tmp_path, monkeypatch):
    """On a machine with 64 MiB free (as told to the mesher) its address space is 576 MiB."""
    monkeypatch.setattr(mesh, "memory_available", lambda: 64 * 2 ** 20)
    monkeypatch.setattr(mesh, "GMSH_ADDRESS_SPACE", 512 * 2 ** 20)
    with pytest.raises(MeshError, match=r"gmsh ran out of the 0\.6 GiB it may use .* meshing body1's \.geo"):
        body_mesh(user_geo(tmp_path, "x() = {1:1e9};"), {"n": 4.0}, cache=tmp_path, limits=MeshLimits("body1", 30))


def test_a_mesh_file_beyond_its_size_limit_is_refused_naming_it(tmp_path, monkeypatch):
    """A size field fine inside and coarse on the boundary (684 nodes and 62 kB made by gmsh, 18
    nodes by the boundary's estimate), on a machine with room for 100 nodes: its file passes
    2 × 100 × 120 bytes."""
    monkeypatch.setattr(mesh, "memory_available", lambda: 100 * mesh.BYTES_PER_NODE)
    field = 'Field[1] = MathEval;\nField[1].F = "0.003 + 2*((x-0.5)^2+(y-0.5)^2)";\nBackground Field = 1;'
    with pytest.raises(MeshError, match=r"gmsh's mesh of body1's \.geo .* grew beyond 0\.024 MB"):
        body_mesh(user_geo(tmp_path, field), {"n": 4.0}, cache=tmp_path / "cache", limits=MeshLimits("body1", 30))
    assert not list((tmp_path / "cache").iterdir())


@pytest.mark.parametrize("option, words", [
    ("Mesh.ElementOrder = 2;", ["Line 3, Triangle 6 elements", "(Mesh.ElementOrder = 2)"]),
    ("Mesh.RecombineAll = 1;", ["Quadrilateral 4 elements", "(Mesh.RecombineAll = 1)"]),
])
def test_elements_the_solver_cannot_take_are_refused_naming_the_option(tmp_path, option, words):
    with pytest.raises(MeshError) as error:
        body_mesh(user_geo(tmp_path, option), {"n": 4.0}, cache=tmp_path, limits=MeshLimits("body2"))
    message = str(error.value)
    assert message.startswith("body2.mesh.geo (block.geo with {'n': 4.0}): its mesh has ")
    for word in [*words, "the solver takes 3-node triangles only (Mesh.ElementOrder = 1"]:
        assert word in message, message


def test_control_characters_in_gmsh_s_text_are_shown_escaped(tmp_path):
    source = user_geo(tmp_path, 'Error("\x1b[2J\x1b]0;owned\x07 \u202etxt.exe");\nAbort;')
    with pytest.raises(MeshError) as error:
        body_mesh(source, {"n": 4.0}, cache=tmp_path)
    message = str(error.value)
    assert message.endswith(r"Error: \x1b[2J\x1b]0;owned\x07 \u202etxt.exe")
    assert message.isprintable()


# --- mesh inputs within what gmsh meshes faithfully (issue 47, item 5) ------------------------------

from orchestrate import gmsh_mesher  # noqa: E402  (the bounds the refusals name)

FAR = [("extent", {"x1": 1e300}, r"the body's extent \(the larger side of its box\) 1e\+300 is outside \[1e-06, 1e\+15\]"),
       ("offset", {"x0": 1e8, "x1": 1e8 + 1}, r"the body's coordinate 1e\+08 is outside \[-10000, 10000\], 10000 times "
                                               r"its extent 1 "),
       ("flat", {"x1": 1e6, "y1": 1e-3}, r"the shorter side of the body's box 0\.001 is below 1, 1e-06 times its "
                                         r"extent 1e\+06")]


@pytest.mark.parametrize("case, numbers, words", FAR, ids=[case for case, _, _ in FAR])
@pytest.mark.unit
def test_a_rectangle_gmsh_would_not_mesh_faithfully_is_refused_naming_the_key(case, numbers, words):
    """mesh.rectangle = [0, 1e300, 0, 1] sent gmsh to 7 GB; a body 1e8 of its extents from the origin
    came back with a quarter of its nodes, one flatter than 1e-6 with its points merged."""
    from orchestrate.scene import Scene, SceneError

    box = {"x0": 0.0, "x1": 1.0, "y0": 0.0, "y1": 1.0, **numbers}
    rectangle = [box["x0"], box["x1"], box["y0"], box["y1"]]
    with pytest.raises(SceneError, match=rf"body2\.mesh: rectangle \[.*\]: {words}"):
        Scene.load(REPO / "scenes" / "paper.toml", {"body2.mesh.geo": None, "body2.mesh.rectangle": rectangle})
    assert gmsh_mesher.EXTENT == (1e-6, 1e15) and gmsh_mesher.OFFSET == 1e4 and gmsh_mesher.FLAT == 1e-6


@pytest.mark.parametrize("case, numbers, words", FAR, ids=[case for case, _, _ in FAR])
def test_a_geo_whose_parameters_put_it_beyond_what_gmsh_meshes_faithfully_is_refused(tmp_path, monkeypatch, case,
                                                                                      numbers, words):
    """The same bounds for any .geo, whatever sets its coordinates (its parameters here): the mesher
    checks the geometry gmsh read before it meshes anything. (At 1e300 gmsh took all the memory it
    was given, here 1 GiB, and failed with the bare word "Exception".)"""
    monkeypatch.setattr(mesh, "memory_available", lambda: 2 ** 30)
    started = time.monotonic()
    with pytest.raises(MeshError, match=rf"^body1\.mesh\.geo \(block\.geo with .*\): {words}"):
        body_mesh(user_geo(tmp_path, ""), {"n": 10.0, **numbers}, cache=tmp_path / "cache", limits=MeshLimits("body1", 30))
    assert time.monotonic() - started < 10


SQUARE_FIELD = "ST(0,0,0,1,0,0,1,1,0){0.25,0.25,0.25};\nST(0,0,0,1,1,0,0,1,0){0.25,0.25,%s};\n"
BAD_FIELDS = [
    ("size 1e-300", SQUARE_FIELD % "1e-300", r"size 1e-300 at line 3 is below the sizes allowed \(the allowed range "
                                             r"is \[1e-08, 100\], 1e-08 to 100 times the extent 1 of this body\)"),
    ("size 1e-320", SQUARE_FIELD % "1e-320", r"size 9\.99989e-321 at line 3 is below the sizes allowed"),
    ("size 1e300", SQUARE_FIELD % "1e300", r"size 1e\+300 at line 3 is above the sizes allowed"),
    ("far point", SQUARE_FIELD % "0.25" + "ST(1e300,0,0,1e300,1,0,1e300,0,1){0.25,0.25,0.25};\n",
     r"point \(1e\+300, 0, 0\) at line 4 lies outside \[-1, 2\] × \[-1, 2\] × \[-1, 1\], the body's box widened by its "
     r"extent 1"),
]


@pytest.mark.parametrize("case, body, words", BAD_FIELDS, ids=[case for case, _, _ in BAD_FIELDS])
def test_a_size_field_beyond_what_gmsh_follows_is_refused_naming_the_line_and_the_range(tmp_path, case, body, words):
    """gmsh ignored a 1e-300 size without a word (the mesh was made as if the field were not
    there), and meshed a 6 × 6 body whose field held 1e-320 until its time limit. Sizes lie within
    [1e-8, 1e2] times the body's extent, the field's points within its box widened by the extent."""
    view = tmp_path / "sizes.pos"
    view.write_text('View "sizes" {\n' + body + "};\n")
    started = time.monotonic()
    with pytest.raises(MeshError, match=rf"^body1\.mesh\.sizes: {words}"):
        body_mesh(REPO / "meshes" / "rectangle.geo", {"n": 4, "adapted": 1}, cache=tmp_path / "cache",
                  limits=MeshLimits("body1", 20), sizes=view)
    assert time.monotonic() - started < 10
    assert gmsh_mesher.SIZES == (1e-8, 1e2)


def test_a_size_field_finer_inside_than_on_the_boundary_is_counted_before_meshing(tmp_path, monkeypatch):
    """The boundary's spacing misses a field that is fine inside only: the nodes its sizes ask for,
    2/√3 ∫ h⁻², are counted from the field itself. A unit square whose field is 0.3 at the corners
    and 0.0003 at the centre (sizes linear on four triangles) asks for about 150 nodes (checked by
    quadrature below; gmsh makes 203), on a machine with room for 100: refused before meshing (the
    boundary's estimate, 13 nodes, let gmsh make it)."""
    monkeypatch.setattr(mesh, "memory_available", lambda: 100 * mesh.BYTES_PER_NODE)
    corners = [(0, 0), (1, 0), (1, 1), (0, 1)]
    view = tmp_path / "sizes.pos"
    view.write_text('View "sizes" {\n' + "".join(f"ST(0.5,0.5,0,{a[0]},{a[1]},0,{b[0]},{b[1]},0){{0.0003,0.3,0.3}};\n"
                                                 for a, b in zip(corners, corners[1:] + corners[:1])) + "};\n")
    with pytest.raises(TooLarge) as error:
        body_mesh(REPO / "meshes" / "rectangle.geo", {"n": 4, "adapted": 1}, cache=tmp_path / "cache",
                  limits=MeshLimits("body1", 20), sizes=view)
    message = str(error.value)
    assert message.startswith("body1.mesh.sizes: the size field would give body1's .geo (rectangle.geo"), message
    nodes = int(message.split("about ")[1].split(" nodes")[0].replace(",", ""))
    s, t = np.meshgrid((np.arange(2000) + 0.5) / 2000, (np.arange(2000) + 0.5) / 2000, indexing="ij")
    s = s ** 4  # graded toward the centre, where h⁻² peaks; a point (1 − s)·centre + s·(edge point t)
    weight = 4 * s * np.gradient(s, axis=0) / 2000 * 0.5  # four triangles, Jacobian s·2|T| with |T| = 1/4
    quadrature = (2 / 3 ** 0.5) * np.sum(weight / (0.0003 * (1 - s) + 0.3 * s) ** 2)
    assert abs(nodes - quadrature) < 0.01 * quadrature + 1, (nodes, quadrature)
