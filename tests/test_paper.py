"""The paper's scene (docs/model.md §8) at the default, coarse resolution (h1 = 0.25, h2 = 0.1875,
N = 40): it runs to T with every invariant holding and the contact closed on part of Γ_C and
open, with the glue pulling, on the rest."""
import numpy as np
import pytest

from conftest import solve_ok

pytestmark = pytest.mark.physics

N = 40


@pytest.fixture(scope="module")
def paper(tmp_path_factory):
    return solve_ok(tmp_path_factory.mktemp("paper") / "run")


def test_runs_to_the_final_time_with_a_row_per_step(paper):
    history = paper.history
    assert len(history["t"]) == N
    np.testing.assert_allclose(history["t"], np.arange(1, N + 1) / N, rtol=0, atol=1e-14)
    for column in ("normV", "vmMax1", "vmMax2", "contactForce", "stepSeconds"):
        assert np.all(np.isfinite(history[column])), column


def test_invariants_hold_at_every_step(paper):
    history, tol = paper.history, paper.params["contactTol"]
    for column in ("zetaMin1", "zetaMin2", "betaMin", "betaMean"):
        assert np.all((history[column] >= 0) & (history[column] <= 1)), column
    assert np.all(history["gapMax"] <= tol)
    # The contact loop stops when λ moves by less than tol·ω/2 per iteration (ω: the penalty, in
    # force per length); at linear convergence the multiplier is then within a few tol·ω of its limit.
    assert np.all(history["lambdaMin"] >= -10 * tol * paper.params["omegaBM"])
    assert np.all(history["contactIters"] < paper.params["contactMaxIt"])


def test_contact_closed_on_the_right_and_open_with_glue_on_the_left(paper):
    line = paper.fields("contact")
    x, gap, pressure = line.points[:, 0], line.point_data["gap"], line.point_data["pressure"]
    tol = paper.params["contactTol"]
    closed = gap >= -tol
    assert closed[x > 4.5].all() and (pressure[x > 4.5] > 0).all()
    assert not closed[(x > 0.5) & (x < 3)].any()
    assert np.all(np.abs(pressure[~closed]) <= 1e-6 * pressure.max())
    assert 1.0 < paper.history["contactLength"][-1] < 5.0
    beta = line.cell_data["beta"][0]
    assert beta.min() < 1.0 and beta.min() > 0.9, "the glue debonds a little where the bodies separate"


def test_displacement_norm_near_an_independent_implementation(paper):
    # An independent implementation of the same scheme gives ‖u(T)‖_V ≈ 0.214 (on its own
    # meshes); at this coarse level the discretization error is a few percent.
    assert paper.history["normV"][-1] == pytest.approx(0.214, rel=0.05)


def test_files_of_a_run(paper):
    names = {path.name for path in paper.folder.iterdir()}
    assert {"params_used.json", "history.csv", "solution.pvd", "body1_0040.vtu", "body2_0040.vtu",
            "contact_0040.vtu"} <= names
    assert [time for time, _ in paper.outputs] == [1.0]
    body = paper.fields("body1")
    assert body.point_data["u"].shape[1] == 3 and "zeta" in body.point_data
    assert {"vonMises", "sigma11", "sigma22", "sigma12"} <= set(body.cell_data)


def test_params_used_are_the_paper_values(paper):
    params = paper.params
    expected = dict(T=1, N=40, n1=24, n2=32, E1=1000, E2=1000, nu1=0.3, mu1=30, eta1=20, kappa1=1,
                    lambdaD1=0.01, lambdaU1=1, lambdaW1=0, gammaNu=1, pTau=1, L=1, zetaMin=1e-3)
    for name, value in expected.items():
        assert params[name] == pytest.approx(value), name
    assert params["meshFile1"].endswith("paper_body1-n24.msh")


def test_other_resolutions_are_meshed_by_gmsh_and_output_times_chosen(tmp_path):
    result = solve_ok(tmp_path / "run", "-n1", 12, "-n2", 16, "-N", 20, "-outTimes", "0.25,1")
    assert result.params["meshFile1"] == str(tmp_path / "run" / "body1-n12.msh")
    assert len(result.fields("contact").points) == 13
    assert [time for time, _ in result.outputs] == [0.25, 1.0]
