"""Contact patch test and uniform creep on two stacked blocks (tests/scenes/blocks.idp).

The upper block (body 1, (0,2)×(0,1)) is pushed down through its top by 0.05·t and sits on the
lower block (body 2, (0,2)×(−1,0)); rollers elsewhere, no glue, non-matching unstructured meshes.
The exact discrete solution is then uniform in each body: σxx = σxy = 0, σyy = −p, the contact
closed everywhere with the pressure p. A P1 mortar discretization must reproduce it to round-off
(patch test), and its history must follow the scalar recursion of the scheme (docs/model.md §6), which
`creep_recursion` computes here from the model's equations alone; so must the P2 discretization
(docs/model.md §13: uniform stress is in the space; the exact discrete solution is the same).
"""
import subprocess
from dataclasses import dataclass

import numpy as np
import pytest

from conftest import SCENES, gmsh_mesh, solve, solve_ok
from orchestrate.compare import compare
from orchestrate.estimate import estimate
from orchestrate.results import cell_field

pytestmark = pytest.mark.solver

T, N = 1.0, 25
PUSH_RATE = 0.05                 # top of body 1 displaced by −PUSH_RATE·t (tests/scenes/blocks.idp)
HEIGHT, WIDTH = (1.0, 1.0), 2.0  # body 1, body 2


@dataclass
class Body:
    E: float
    nu: float
    mu: float
    eta: float
    plane_strain: int
    lambdaD: float
    lambdaU: float
    lambdaW: float

    @property
    def lame(self):
        """(a, b) of (Gτ) = a tr(τ) I + b τ (docs/model.md §2)."""
        a = self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu)) if self.plane_strain \
            else self.E * self.nu / (1 - self.nu ** 2)
        return a, self.E / (1 + self.nu)

    def flags(self, i):
        names = dict(E="E", nu="nu", mu="mu", eta="eta", plane_strain="planeStrain",
                     lambdaD="lambdaD", lambdaU="lambdaU", lambdaW="lambdaW")
        return [item for field, flag in names.items() for item in (f"-{flag}{i}", getattr(self, field))]


# Damage strong enough to halve ζ in body 2; λ_w > 0 makes ζ ≤ 1 active in body 1 at the first steps.
BODIES = (Body(1000, 0.3, 30, 20, 0, 0.01, 2000, 0.002), Body(600, 0.25, 10, 15, 1, 0.02, 3000, 0.0))


def creep_recursion(zeta_min=1e-3, L=1.0, steps=N):
    """Per step n: uniform strains (exx, eyy) per body, pressure p, damage ζ per body, and the
    output stress σⁿ = A(εⁿ − εⁿ⁻¹)/k + ζⁿ G εⁿ, from the scheme's equations:
      σxx = [μ tr Δ + η Δxx]/k + ζⁿ⁻¹ (a tr ε + b exx)ⁿ⁻¹ = 0,
      σyy = [μ tr Δ + η Δyy]/k + ζⁿ⁻¹ (a tr ε + b eyy)ⁿ⁻¹ = −p  (each body),
      H1 eyy1 + H2 eyy2 = −PUSH_RATE tⁿ  (contact closed: the interface moves as one),
      ζⁿ = clip(ζⁿ⁻¹ + k φ(εⁿ⁻¹, ζⁿ⁻¹), 0, 1).
    """
    k = T / steps
    strain = np.zeros((2, 2))
    zeta = np.ones(2)
    history = []
    for n in range(1, steps + 1):
        matrix, rhs = np.zeros((5, 5)), np.zeros(5)
        for i, body in enumerate(BODIES):
            a, b = body.lame
            exx, eyy = strain[i]
            matrix[2 * i, 2 * i: 2 * i + 2] = ((body.mu + body.eta) / k, body.mu / k)
            matrix[2 * i + 1, 2 * i: 2 * i + 2] = (body.mu / k, (body.mu + body.eta) / k)
            matrix[2 * i + 1, 4] = 1.0
            rhs[2 * i] = -zeta[i] * (a * (exx + eyy) + b * exx)
            rhs[2 * i + 1] = -zeta[i] * (a * (exx + eyy) + b * eyy)
        matrix[4, 1], matrix[4, 3] = HEIGHT
        rhs[4] = -PUSH_RATE * n * k - HEIGHT[0] * strain[0, 1] - HEIGHT[1] * strain[1, 1]
        solution = np.linalg.solve(matrix, rhs)
        increment, pressure = solution[:4].reshape(2, 2), solution[4]
        new_zeta = np.empty(2)
        for i, body in enumerate(BODIES):
            zc = max(zeta[i], zeta_min)
            phi = body.lambdaD * (1 - zc) / zc - 0.5 * body.lambdaU * min(np.sum(strain[i] ** 2), L) + body.lambdaW
            new_zeta[i] = np.clip(zeta[i] + k * phi, 0.0, 1.0)
        strain = strain + increment
        stress = []
        for i, body in enumerate(BODIES):
            a, b = body.lame
            dxx, dyy = increment[i]
            exx, eyy = strain[i]
            stress.append(((body.mu * (dxx + dyy) + body.eta * dxx) / k + new_zeta[i] * (a * (exx + eyy) + b * exx),
                           (body.mu * (dxx + dyy) + body.eta * dyy) / k + new_zeta[i] * (a * (exx + eyy) + b * eyy)))
        zeta = new_zeta
        norm_v = np.sqrt(sum(HEIGHT[i] * WIDTH * np.sum(strain[i] ** 2) for i in range(2)))
        history.append(dict(pressure=pressure, zeta=zeta.copy(), stress=np.array(stress), normV=norm_v,
                            strain=strain.copy()))
    return history


@pytest.fixture(scope="module")
def blocks(tmp_path_factory):
    return blocks_run(tmp_path_factory.mktemp("blocks"), n=(7, 11), steps=N)


@pytest.fixture(scope="module")
def blocks_p2(tmp_path_factory):
    return blocks_run(tmp_path_factory.mktemp("blocks2"), n=(7, 11), steps=N, order=2)


@pytest.fixture(scope="module", params=[1, 2], ids=["P1", "P2"])
def ordered(request):
    """The blocks with displacements of degree 1 and 2: (order, result)."""
    return request.param, request.getfixturevalue("blocks" if request.param == 1 else "blocks_p2")


def blocks_run(folder, n, steps, split=False, order=1):
    """The blocks on gmsh meshes with n elements per side, each triangle split in four with `split`,
    displacements of degree `order`."""
    upper = gmsh_mesh("meshes/rectangle.geo", folder / "upper.msh", x1=2, y0=0, y1=1, n=n[0])
    lower = gmsh_mesh("meshes/rectangle.geo", folder / "lower.msh", x1=2, y0=-1, y1=0, n=n[1])
    for mesh in (upper, lower) if split else ():
        subprocess.run(["gmsh", "-refine", str(mesh), "-o", str(mesh), "-format", "msh22"], check=True, capture_output=True)
    return solve_ok(folder / "run", "-mesh1", upper, "-mesh2", lower, "-T", T, "-N", steps,
                    "-outTimes", "all", "-outFields", "bodies,stress,contact,state", "-contactTol", 1e-14,
                    *BODIES[0].flags(1), *BODIES[1].flags(2), scene=SCENES / "blocks.idp", order=order)


def test_meshes_do_not_match(ordered):
    order, blocks = ordered
    assert len(blocks.fields("contact").points) == 7*order + 1  # body 1's trace; body 2 has 11·order + 1 nodes there


def test_patch_stress_is_uniform_in_every_element_at_every_step(ordered):
    _, blocks = ordered
    assert len(blocks.outputs) == N
    for time, _ in blocks.outputs:
        for body in ("body1", "body2"):
            mesh = blocks.fields(body, time)
            stress = np.stack([cell_field(mesh, f"sigma{c}") for c in ("11", "22", "12")])
            scale = np.abs(stress).max()
            assert scale > 0
            spread = np.abs(stress - stress.mean(axis=1, keepdims=True)).max()
            assert spread <= 1e-8 * scale, f"{body} at t={time}: stress varies by {spread / scale:.2e} (relative)"


def test_patch_pressure_is_uniform_at_every_contact_node(ordered):
    """And at degree 2 each segment's pressure (its force over its length) is the same."""
    order, blocks = ordered
    for time, _ in blocks.outputs:
        line = blocks.fields("contact", time)
        pressure = line.point_data["pressure"]
        assert pressure.min() > 0, f"contact not closed everywhere at t={time}"
        assert np.ptp(pressure) <= 1e-8 * pressure.mean(), f"pressure varies at t={time}"
        assert ("segmentPressure" in line.cell_data) == (order == 2)
        if order == 2:
            assert np.allclose(line.cell_data["segmentPressure"][0], pressure.mean(), rtol=1e-8)


def test_creep_follows_the_scalar_recursion(ordered):
    _, blocks = ordered
    expected = creep_recursion()
    history = blocks.history
    pressure = np.array([step["pressure"] for step in expected])
    np.testing.assert_allclose(history["contactForce"], pressure * WIDTH, rtol=1e-10)
    # the reactions of the paper's scheme (explicit elasticity): the pushed top and the held bottom
    np.testing.assert_allclose(history["reactionY1_3"], -pressure * WIDTH, rtol=1e-10)
    np.testing.assert_allclose(history["reactionY2_1"], pressure * WIDTH, rtol=1e-10)
    np.testing.assert_allclose(history["normV"], [step["normV"] for step in expected], rtol=1e-10)
    np.testing.assert_allclose(history["zetaMin1"], [step["zeta"][0] for step in expected], rtol=0, atol=1e-10)
    np.testing.assert_allclose(history["zetaMin2"], [step["zeta"][1] for step in expected], rtol=0, atol=1e-10)
    assert expected[-1]["zeta"].min() < 0.5, "the test should exercise damage"
    for (time, _), step in zip(blocks.outputs, expected):
        for i, body in enumerate(("body1", "body2")):
            mesh = blocks.fields(body, time)
            sxx, syy = step["stress"][i]
            scale = abs(syy)
            np.testing.assert_allclose(cell_field(mesh, "sigma22"), syy, rtol=1e-10)
            np.testing.assert_allclose(cell_field(mesh, "sigma11"), sxx, rtol=0, atol=1e-10 * scale)
            np.testing.assert_allclose(cell_field(mesh, "sigma12"), 0.0, rtol=0, atol=1e-10 * scale)


def test_a_damage_step_past_its_active_set_iterations_is_finished_by_projected_gauss_seidel(tmp_path):
    """damageMaxIt = 1: a damage step whose active sets change (ζ ≤ 1 leaves body 1's nodes as the
    damage grows) needs a second iteration, so the driver finishes it by projected Gauss–Seidel
    (the path a cycling active set takes), says so, and still follows the creep recursion."""
    from orchestrate.manifest import facts

    upper = gmsh_mesh("meshes/rectangle.geo", tmp_path / "upper.msh", x1=2, y0=0, y1=1, n=7)
    lower = gmsh_mesh("meshes/rectangle.geo", tmp_path / "lower.msh", x1=2, y0=-1, y1=0, n=11)
    done, result = solve(tmp_path / "run", "-mesh1", upper, "-mesh2", lower, "-T", T, "-N", N, "-outTimes", "none",
                         "-contactTol", 1e-14, "-damageMaxIt", 1, *BODIES[0].flags(1), *BODIES[1].flags(2),
                         scene=SCENES / "blocks.idp")
    assert done.returncode == 0, done.error_line
    assert facts(result.folder)["damageFallbacks"] >= 1
    assert "solved by projected Gauss-Seidel" in done.stdout
    expected = creep_recursion()
    np.testing.assert_allclose(result.history["normV"], [step["normV"] for step in expected], rtol=1e-10)
    np.testing.assert_allclose(result.history["zetaMin1"], [step["zeta"][0] for step in expected], rtol=0, atol=1e-10)


def test_the_error_estimate_is_zero_where_the_strain_is_uniform(ordered):
    """The creep's u is linear in each body: the recovered strains are the computed ones, so the
    Zienkiewicz–Zhu estimate (orchestrate/estimate.py) vanishes at every saved state, while its
    ‖u_h‖_V is the run's normV there; at degree 2 as at degree 1 (the recovery into P2)."""
    _, blocks = ordered
    rows = estimate(blocks)
    assert len(rows) == N
    for row, norm in zip(rows, blocks.history["normV"]):
        assert row["estimate"] <= 1e-10 * norm
        assert row["normV"] == pytest.approx(norm, rel=1e-10)


@pytest.mark.parametrize("n, split", [((5, 8), False), ((7, 11), True)], ids=["not-nested", "nested"])
def test_compare_gives_the_distances_of_the_creep_recursions(blocks, tmp_path, n, split):
    """The creep's u is linear and ζ constant in each body, so interpolating the coarser run onto the
    finer run's meshes loses nothing, whether they nest (the blocks' meshes split in four) or not.
    compare measures at every output of either run (every step of N = 50 from the first of N = 25):
    where N = 25 saved no state, its state is the mean of its two neighbours (linear in time), so
    the distances are those of the two recursions' uniform strains and damage (averaged there),
    times the bodies' areas."""
    from orchestrate.compare import compare

    other = blocks_run(tmp_path, n=n, steps=2 * N, split=split)
    comparison = compare(blocks, other)
    assert comparison.reference == ("b" if split else "a") and comparison.nested == split
    at_n, at_2n = creep_recursion(steps=N), creep_recursion(steps=2 * N)
    steps = range(2, 2 * N + 1)  # of N = 50
    np.testing.assert_allclose([row["t"] for row in comparison.rows], np.array(steps) * T / (2 * N), rtol=1e-12)
    areas = np.array(HEIGHT) * WIDTH
    for j, row in zip(steps, comparison.rows):
        neighbours = (at_n[(j - 1) // 2 - 1], at_n[(j + 1) // 2 - 1])
        a = {key: (neighbours[0][key] + neighbours[1][key]) / 2 for key in ("strain", "zeta")} if j % 2 else at_n[j // 2 - 1]
        b = at_2n[j - 1]
        assert row["interpolated"] == ("A" if j % 2 else "")
        strain_distance = np.sqrt(np.sum(areas[:, None] * (a["strain"] - b["strain"]) ** 2))
        assert row["errorV"] == pytest.approx(strain_distance, rel=1e-8)
        assert row["errorZeta"] == pytest.approx(np.sqrt(np.sum(areas * (a["zeta"] - b["zeta"]) ** 2)), rel=1e-8)
        reference = (b if split else a)["strain"]
        assert row["normV"] == pytest.approx(np.sqrt(np.sum(areas[:, None] * reference ** 2)), rel=1e-10)
        assert row["errorBeta"] == 0  # no glue: β⁰ = 1 in both
    assert comparison.maximum("errorV") > 1e-3 * comparison.rows[-1]["normV"], "the runs should differ"
    report = comparison.report()
    assert "interpolation in time" in report and "max, common" in report
    common = [row for row in comparison.rows if not row["interpolated"]]
    assert comparison.maximum("errorV", common=True) == max(row["errorV"] for row in common)


def test_compare_refuses_other_bodies_and_runs_without_states(blocks, tmp_path):
    from orchestrate.compare import covers_one_body, nests, paired_states, triangulation
    from orchestrate.results import Result

    square = gmsh_mesh("meshes/rectangle.geo", tmp_path / "square.msh", x1=2, y0=0, y1=1, n=4)
    taller = gmsh_mesh("meshes/rectangle.geo", tmp_path / "taller.msh", x1=2, y0=0, y1=1.5, n=4)
    shifted = gmsh_mesh("meshes/rectangle.geo", tmp_path / "shifted.msh", x0=1, x1=3, y0=0, y1=1, n=4)
    for other in (taller, shifted):  # another area; the same area elsewhere
        with pytest.raises(RuntimeError, match="not meshes of the same body"):
            covers_one_body(triangulation(square), triangulation(other), (square, other))
    covers_one_body(triangulation(square), triangulation(square), (square, square))
    assert nests(triangulation(square), triangulation(square))
    (tmp_path / "empty").mkdir()
    with pytest.raises(RuntimeError, match='saved no state.*output.fields including "state"'):
        paired_states(blocks, Result(tmp_path / "empty"), tmp_path)


def test_the_command_refuses_to_compare_a_run_with_itself_before_anything_is_written(blocks, tmp_path, capsys):
    """Its distances would all be 0, a report that reads as two runs agreeing (compare() takes one:
    the distance to itself is a check of errors.edp, tests/test_study.py)."""
    from orchestrate.cli import main

    assert main(["compare", str(blocks.folder), str(blocks.folder / "."), "--out", str(tmp_path / "same")]) == 2
    assert "RUN_A and RUN_B are both" in capsys.readouterr().err and not (tmp_path / "same").exists()


def test_compare_reads_a_run_s_mesh_in_freefem_s_format_as_in_gmsh_s(tmp_path):
    """A run holds a mesh with triangles below gmshload's area limit in FreeFEM's format
    (orchestrate/mesh.py, write_freefem): compare reads it as the same nodes and triangles."""
    from orchestrate.compare import triangulation
    from orchestrate.mesh import write_freefem

    source = gmsh_mesh("meshes/rectangle.geo", tmp_path / "gmsh.msh", x1=2, y0=0, y1=1, n=7)
    write_freefem(source, tmp_path / "freefem.msh")
    (points, triangles), (same_points, same_triangles) = (triangulation(path) for path in (source, tmp_path / "freefem.msh"))
    np.testing.assert_array_equal(points, same_points)
    np.testing.assert_array_equal(triangles, same_triangles)


def test_compare_writes_a_new_folder_and_replaces_only_its_own_files_never_through_a_link(blocks, tmp_path):
    """A second comparison into one folder asks for --force; --force replaces its own three files
    (a link among them unlinked, its target kept); a folder of the user's files is refused."""
    from orchestrate.compare import compare, write
    from orchestrate.outputs import OutputError

    comparison = compare(blocks, blocks)
    out, victim = tmp_path / "c", tmp_path / "victim.png"
    write(comparison, out)
    with pytest.raises(OutputError, match="exists .*: pass --force to replace its files"):
        write(comparison, out)
    victim.write_bytes(b"the user's")
    (out / "history.png").unlink()
    (out / "history.png").symlink_to(victim)
    write(comparison, out, force=True)
    assert victim.read_bytes() == b"the user's"
    assert not (out / "history.png").is_symlink() and (out / "history.png").stat().st_size > 10000
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "report.txt").write_text("the user's")
    with pytest.raises(OutputError, match="holds files no orchestrate command recorded writing"):
        write(comparison, mine, force=True)
    assert (mine / "report.txt").read_text() == "the user's"


@pytest.mark.unit
def test_compare_pairs_the_states_of_the_same_instants_however_short_the_steps(tmp_path):
    """T = 1e-9 with N = 4 and N = 2: each state of the coarser run is paired with the state at its
    own instant, never with a neighbour that lies within an absolute tolerance; at the finer run's
    instant between two of the coarser run's, the coarser state is their mean; before the coarser
    run's first state there is nothing to compare."""
    import hashlib
    import json

    from orchestrate.compare import paired_states
    from orchestrate.manifest import STATE_ARRAYS, read_state
    from orchestrate.results import Result

    def fake(name, steps):
        folder = tmp_path / name
        folder.mkdir()
        (folder / "params_used.json").write_text(json.dumps({"k": 1e-9 / steps}))
        names = [f"state_{j:04d}.txt" for j in range(1, steps + 1)]
        for j, name in enumerate(names, 1):  # every array [j, 10 j], the trace coordinates [0, 1]
            arrays = ["2\n0 1" if array == "s" else f"2\n{j} {10 * j}" for array in STATE_ARRAYS]
            (folder / name).write_text(f"{j * 1e-9 / steps!r}\n" + "\n".join(arrays) + "\n")
        digests = {name: hashlib.sha256((folder / name).read_bytes()).hexdigest() for name in names}
        (folder / "run.json").write_text(json.dumps({"files": names, "fileDigests": digests}))  # what compare reads
        return Result(folder)

    fine, coarse = fake("fine", 4), fake("coarse", 2)
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    pairs = paired_states(fine, coarse, scratch)
    steps = 1e-9 / 4
    assert [(read_state(a)["t"], read_state(b)["t"], which) for a, b, which in pairs] == [
        (2 * steps, 2 * steps, ""), (3 * steps, pytest.approx(3 * steps, rel=1e-15), "B"), (4 * steps, 4 * steps, "")]
    assert pairs[0][0].read_bytes() == (tmp_path / "fine" / "state_0002.txt").read_bytes()  # a saved state as it is
    middle = read_state(pairs[1][1])
    assert middle["t"] == pytest.approx(0.75e-9, rel=1e-15)
    np.testing.assert_allclose(middle["u1"], [1.5, 15.0], rtol=1e-15)
    np.testing.assert_array_equal(middle["s"], [0.0, 1.0])


def test_compare_measures_the_distance_between_the_degrees(blocks, blocks_p2):
    """The blocks' exact discrete solution is the same uniform state at both degrees (the patch
    test), so compare finds them at round-off distance from each other, the P1 run's field taken
    into the P2 reference's space on the same meshes (nested: exact)."""
    comparison = compare(blocks, blocks_p2)
    assert comparison.reference == "b" and comparison.nested
    for row in comparison.rows:
        assert row["errorV"] <= 1e-10 * row["normV"] and row["errorZeta"] <= 1e-10 * row["normZeta"]
        assert row["errorBeta"] == 0


def test_compare_takes_the_higher_degree_for_reference_between_equal_node_counts(blocks_p2, tmp_path):
    """P1 on the blocks' meshes split in four has as many displacement nodes as P2 on them: the P2
    run is the reference whichever comes first, and the P1 run's field is not in its space (its
    mesh does not nest in the reference's), so the figures are not called exact; both hold the
    patch's uniform state, at round-off distance."""
    split = blocks_run(tmp_path, n=(7, 11), steps=N, split=True)
    for first, second, reference in ((split, blocks_p2, "b"), (blocks_p2, split, "a")):
        comparison = compare(first, second)
        assert comparison.reference == reference and not comparison.nested
        for body, mesh in enumerate(comparison.meshes, 1):  # the report says why: the nodes of the displacements
            p1, p2 = (0, 1) if first is split else (1, 0)
            assert mesh["displacementNodes"][p2] == mesh["displacementNodes"][p1] == mesh["nodes"][p1]
            assert (f"{mesh['nodes'][p2]} nodes, {mesh['triangles'][p2]} triangles, {mesh['nodes'][p1]} nodes of its "
                    f"P2 displacement ({'AB'[p2]})") in comparison.report()
        for row in comparison.rows:
            assert row["errorV"] <= 1e-10 * row["normV"]
