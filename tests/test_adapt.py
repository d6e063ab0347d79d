"""Meshes designed from an error estimate (orchestrate/adapt.py, mesh.sizes, edp/tools/estimate.edp).

- a size field (a gmsh view) sets a body's element sizes, from the body's own .geo with its
  labels; the .geo's constant adapted drops its Transfinite lines, so Γ_C follows the field too,
  and without a field the committed and cached meshes are the ones they were;
- on the paper's scene the loop from a coarse pilot reaches its target in a few designs, every run
  a complete run folder, and the adapted mesh is closer to a fine run than a uniform mesh with more
  nodes (the point of adapting)."""
from __future__ import annotations

import meshio
import numpy as np
import pytest

from orchestrate import compare, run
from orchestrate.freefem import REPO
from orchestrate.manifest import facts
from orchestrate.mesh import MeshError, body_mesh, cache_key

RECTANGLE = REPO / "meshes" / "rectangle.geo"


def size_view(path, sizes):
    """A view over the unit square: the sizes at its corners (0,0), (1,0), (1,1), (0,1)."""
    a, b, c, d = sizes
    path.write_text('View "sizes" {\n'
                    f"ST(0,0,0,1,0,0,1,1,0){{{a},{b},{c}}};\n"
                    f"ST(0,0,0,1,1,0,0,1,0){{{a},{c},{d}}};\n}};\n")
    return path


@pytest.mark.solver
def test_a_size_field_grades_a_body_from_its_own_geo(tmp_path):
    view = size_view(tmp_path / "sizes.pos", (0.02, 0.3, 0.3, 0.3))
    graded = meshio.read(body_mesh(RECTANGLE, {"n": 4, "adapted": 1}, cache=tmp_path, sizes=view))
    points = graded.points[:, :2]
    near, far = (np.hypot(*points.T) < 0.2).sum(), (np.hypot(*(points - 1).T) < 0.2).sum()
    assert near > 10 * max(far, 1), (near, far)
    bottom = np.sort(points[np.abs(points[:, 1]) < 1e-12, 0])
    steps = np.diff(bottom)
    assert steps.min() < 0.05 and steps.max() > 0.15  # Γ_C (label 1) graded: no Transfinite line
    assert set(graded.cell_data_dict["gmsh:physical"]["line"]) == {1, 2, 3, 4}
    uniform = meshio.read(body_mesh(RECTANGLE, {"n": 4}, cache=tmp_path)).points  # no field: Γ_C's n segments
    np.testing.assert_allclose(np.sort(uniform[np.abs(uniform[:, 1]) < 1e-12, 0]), np.linspace(0, 1, 5), atol=1e-12)
    assert cache_key(RECTANGLE, {"n": 4, "adapted": 1}, sizes=view) != cache_key(RECTANGLE, {"n": 4, "adapted": 1})
    # gmsh parses a view with its .geo language: a file of any other form than adapt's is refused
    lines = view.read_text().splitlines()
    for name, text, words in (("merge", "Merge 'elsewhere.msh';\n", "not a gmsh view"),
                              ("command", "\n".join([*lines[:2], 'SystemCall "touch x";', *lines[2:]]) + "\n", "line 3"),
                              ("negative", view.read_text().replace("{0.02,", "{-0.02,"), "not a positive number")):
        (tmp_path / f"{name}.pos").write_text(text)
        with pytest.raises(MeshError, match=words):
            body_mesh(RECTANGLE, {"n": 4, "adapted": 1}, cache=tmp_path, sizes=tmp_path / f"{name}.pos")


@pytest.mark.unit
def test_a_size_field_needs_a_geo_that_can_drop_its_transfinite_lines(tmp_path):
    from orchestrate.scene import Scene, SceneError

    view = size_view(tmp_path / "sizes.pos", (0.1, 0.1, 0.1, 0.1))
    own = tmp_path / "own.geo"  # a user's .geo, with Transfinite lines adapt cannot drop
    own.write_text((REPO / "meshes" / "paper_body2.geo").read_text().replace(", adapted = 0", "")
                   .replace("If (!adapted)", "If (1)").replace("structured && !adapted", "structured"))
    with pytest.raises(SceneError, match="body2.mesh: sizes: own.geo has no constant adapted"):
        Scene.load(REPO / "scenes" / "paper.toml", {"body2.mesh.geo": str(own), "body2.mesh.sizes": str(view)})
    scene = Scene.load(REPO / "scenes" / "paper.toml", {"body1.mesh.sizes": str(view)})
    assert scene.body1.mesh.numbers()["adapted"] == 1 and "adapted" not in scene.body2.mesh.numbers()


@pytest.mark.unit
@pytest.mark.parametrize("overrides, words", [
    ({"output.fields": ["bodies", "contact"]}, "output.fields = ['bodies', 'contact']: adapt estimates each run from "
                                               'the states it saves: add "state"'),
    ({"output.times": "none"}, 'output.times = "none": adapt estimates each run from the states')])
def test_a_scene_whose_runs_save_no_state_is_refused_before_the_pilot_runs(tmp_path, overrides, words):
    """The estimate reads the states a run saves: without them the pilot ran, then the loop failed."""
    from orchestrate.adapt import adapt
    from orchestrate.freefem import InputError

    with pytest.raises(InputError) as error:
        adapt(REPO / "scenes" / "paper.toml", tmp_path / "adapt", 0.01, overrides=overrides)
    assert words in str(error.value) and not any(tmp_path.iterdir())


@pytest.mark.unit
def test_a_mesh_key_adapt_cannot_honour_is_refused_before_anything_runs(tmp_path, capsys):
    """mesh.refine splits every triangle of a mesh, a design's too: the loop ran its designs 4^refine
    times finer than they were designed, without a word. Refused, naming the key and what to give."""
    from orchestrate.adapt import adapt
    from orchestrate.cli import main
    from orchestrate.freefem import InputError

    with pytest.raises(InputError, match=r"body2.mesh.refine = 1: .* 4 times the triangles designed: give the "
                                         r"pilot's fineness by body2.mesh.n, with --set body2.mesh.refine=0"):
        adapt(REPO / "scenes" / "paper.toml", tmp_path / "adapt", 0.01, overrides={"body2.mesh.refine": 1})
    scene = tmp_path / "refined.toml"
    scene.write_text((REPO / "scenes" / "paper.toml").read_text().replace('"meshes/', f'"{REPO}/meshes/')
                     .replace("n = 24\n", "n = 24\nrefine = 2\n", 1))
    assert main(["adapt", str(scene), "--target", "0.01", "--out", str(tmp_path / "cli")]) == 2
    assert "body1.mesh.refine = 2" in capsys.readouterr().err
    assert not any(tmp_path.glob("adapt*")) and not (tmp_path / "cli").exists()


PILOT = {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.scheme": "bdf2", "time.N": 10, "output.images": False}


@pytest.mark.runs
def test_the_adapt_loop_reaches_its_target_with_fewer_nodes_than_a_uniform_mesh(tmp_path):
    from orchestrate.adapt import adapt
    from orchestrate.results import load_result

    rows = adapt(REPO / "scenes" / "paper.toml", tmp_path / "adapt", 0.03, overrides=PILOT, progress=False)
    assert rows[0]["relative"] > 0.1 and rows[-1]["relative"] <= 0.03 and len(rows) <= 4
    assert all(later["relative"] < earlier["relative"] for earlier, later in zip(rows, rows[1:]))
    for row in rows:
        load_result(tmp_path / "adapt" / row["folder"])  # each a whole run folder, through its manifest
    assert (tmp_path / "adapt" / "sizes" / "cycle1" / "body1.pos").is_file()
    assert "Reached at cycle" in (tmp_path / "adapt" / "README.md").read_text()
    fine = run(REPO / "scenes" / "paper.toml", tmp_path / "n96", {**PILOT, "body1.mesh.n": 96, "body2.mesh.n": 128})
    uniform = run(REPO / "scenes" / "paper.toml", tmp_path / "n24", {**PILOT, "body1.mesh.n": 24, "body2.mesh.n": 32})
    adapted = load_result(tmp_path / "adapt" / rows[-1]["folder"])
    nodes = rows[-1]["nodes1"] + rows[-1]["nodes2"]
    assert nodes < 625 + 1089  # uniform n = 24: 25² + 33² nodes
    assert compare(adapted, fine).rows[-1]["errorV"] < 0.8 * compare(uniform, fine).rows[-1]["errorV"]


@pytest.mark.runs
def test_the_designs_keep_body_2_no_coarser_than_body_1_on_the_contact(tmp_path):
    """The mortar's rule (estimate.edp): body 1's trace carries the multipliers, and a trace finer
    than body 2's facing side lets the pressure swing between segments. Hertz with a stiffer
    cylinder at degree 2, whose estimate alone leaves the cylinder coarser than the block there:
    the design's cylinder steps along Γ_C are at most the block's (gmsh's meshing to a size within
    a fifth), and the pressure follows Hertz's law (before the rule: p0 0.47 % and the profile
    3.4 % off on the same loop)."""
    from orchestrate.adapt import adapt
    from orchestrate.results import load_result
    from orchestrate.studies.hertz import RADIUS, contact_line, measure

    stiffer = {"body2.material.E": 600.0, "body2.material.nu": 0.2, "body2.material.eta": 3.0,
               "body2.boundary.1.value": "-0.05*min(t, 1)", "space.order": 2, "body1.mesh.n": 4, "body2.mesh.n": 4}
    rows = adapt(REPO / "scenes" / "hertz.toml", tmp_path / "adapt", 0.01, overrides=stiffer, progress=False)
    result = load_result(tmp_path / "adapt" / rows[-1]["folder"])
    row = measure(result, RADIUS)
    _, _, middle, length, _ = contact_line(result)
    block = np.median(length[np.abs(middle) < row["a"]])
    cylinder = meshio.read(result.mesh_file(2))
    points = cylinder.points[np.unique(cylinder.cells_dict["line"][cylinder.cell_data_dict["gmsh:physical"]["line"] == 1])]
    arc = np.sort(points[np.abs(points[:, 0]) < row["a"], 0])
    assert np.median(np.diff(arc)) <= 1.2 * block, (np.diff(arc), block)
    assert row["errorP0"] < 0.002 and row["errorProfile"] < 0.005, row


@pytest.mark.runs
def test_the_adapt_loop_at_degree_two_spends_fewer_nodes_than_the_uniform_mesh_for_less_error(tmp_path):
    """At degree 2 (the estimate's recovery into P2, its sizes for η_T ~ h³): the loop reaches its
    target, and its last design is closer to a fine P2 run than the uniform P2 mesh n = 24, with
    fewer displacement nodes."""
    from orchestrate.adapt import adapt
    from orchestrate.results import load_result

    two = {**PILOT, "space.order": 2}
    rows = adapt(REPO / "scenes" / "paper.toml", tmp_path / "adapt", 0.005, overrides=two, progress=False)
    assert rows[-1]["relative"] <= 0.005 and all(later["relative"] < earlier["relative"] for earlier, later in zip(rows, rows[1:]))
    fine = run(REPO / "scenes" / "paper.toml", tmp_path / "n96", {**two, "body1.mesh.n": 96, "body2.mesh.n": 128})
    uniform = run(REPO / "scenes" / "paper.toml", tmp_path / "n24", {**two, "body1.mesh.n": 24, "body2.mesh.n": 32})
    adapted = load_result(tmp_path / "adapt" / rows[-1]["folder"])
    nodes = {result: sum(facts(result.folder)[f"displacementNodes{body}"] for body in (1, 2)) for result in (adapted, uniform)}
    assert nodes[adapted] < nodes[uniform]
    assert compare(adapted, fine).rows[-1]["errorV"] < compare(uniform, fine).rows[-1]["errorV"]


@pytest.mark.runs
def test_the_adaptivity_study_reports_estimate_and_error_per_cycle(tmp_path):
    """`study adaptivity` at a small size (results/adaptivity holds targets down to 0.2 % against the
    benchmark's graded reference): one design from the uniform pilot; the true error falls with it,
    and the estimate stays within a factor of 2.5 of the error against a reference that is itself
    about 1 % off at this size."""
    from orchestrate.studies.adaptivity import SMALL, adaptivity

    rows = adaptivity(tmp_path / "study", SMALL, progress=False)
    assert [row["cycle"] for row in rows] == [0, 1] and rows[1]["error"] < rows[0]["error"]
    assert all(0.4 < row["effectivity"] < 2.5 for row in rows)
    assert (tmp_path / "study" / "adaptivity.png").stat().st_size > 10_000
    assert (tmp_path / "study" / "adaptivity.csv").read_text().startswith("target,cycle,nodes,estimate,error")


@pytest.mark.unit
def test_the_adapted_family_s_rates_are_the_slopes_of_its_designs():
    """The rates come from the run that met each target, and only where its error is well above
    the reference's own: on errors that follow N^-0.5, N^-1 and N^-0.25 exactly, the rates are
    those exponents; a design near the reference's accuracy, a loop that missed its target, and
    the earlier cycles, are left out."""
    from orchestrate.studies.adaptivity import FULL, adapted_rates, designs

    def row(target, cycle, nodes, scale=1.0, missed=False):
        return {"target": target, "cycle": cycle, "nodes": nodes, "error": scale * nodes ** -0.5,
                "estimate": 2 * target if missed else target, "errorZeta": nodes ** -1.0, "errorBeta": nodes ** -0.25}

    rows = [row(0.02, 0, 1000, 5.0), row(0.02, 1, 2000), row(0.01, 0, 1000, 5.0), row(0.01, 1, 8000),
            row(0.005, 0, 1000, 5.0), row(0.005, 4, 30000, missed=True),  # its loop spent its cycles above 0.5 %
            row(0.002, 0, 1000, 5.0), row(0.002, 1, 9 * 10 ** 6)]  # the last: 0.033 %, near the reference
    used = designs(rows, FULL)
    assert [r["nodes"] for r in used] == [2000, 8000]
    assert adapted_rates(used) == pytest.approx({"‖u − u_ref‖_V": 0.5, "‖ζ − ζ_ref‖_L2": 1.0,
                                                 "‖β − β_ref‖_L2(Γ_C)": 0.25})


@pytest.mark.unit
def test_the_adaptivity_report_of_degree_two_gives_its_command_and_its_pilot():
    """`study adaptivity --order 2` runs its own targets from a coarser pilot: its README says so,
    in the command that reproduces it and in the adapt command of every loop."""
    from orchestrate.studies.adaptivity import FULL_ORDER2, SIZES, report

    assert SIZES[2] is FULL_ORDER2 and FULL_ORDER2.pilot == (12, 16) and max(FULL_ORDER2.targets) < 0.01
    rows = [{"target": 0.005, "cycle": 0, "nodes": 1714, "estimate": 0.0136, "error": 0.023, "effectivity": 0.59,
             "errorZeta": 1e-6, "errorBeta": 1e-6, "seconds": 0.3, "loopSeconds": 1.2}]
    text = report(rows, FULL_ORDER2, 2)
    assert "python -m orchestrate study adaptivity --order 2\n" in text
    assert "--set space.order=2 --set body1.mesh.n=12 --set body2.mesh.n=16` from the uniform pilot" in text
