"""The fast paths give the results of the slow ones: the active-set contact solver agrees with
Bermúdez–Moreno (the paper's algorithm) to its tolerance, and skipping work no result depends
on (damage where ζ cannot change, glue where β ≡ 0, contact solves where every node is open)
changes nothing but the time."""
import numpy as np
import pytest

from conftest import SCENES, solve_ok

pytestmark = pytest.mark.solver

SAME = ("normV", "vmMax1", "vmMax2", "zetaMin1", "zetaMin2", "betaMin", "betaMean", "contactLength",
        "contactForce", "forceX1", "forceY1")


def test_active_set_and_bermudez_moreno_agree_on_the_paper_scene(tmp_path):
    pdas = solve_ok(tmp_path / "pdas", "-contactSolver", "pdas")
    bm = solve_ok(tmp_path / "bm", "-contactSolver", "bm")
    tol, omega = bm.params["contactTol"], bm.params["omegaBM"]
    # BM stops when no node penetrates by more than tol and λ moves by less than tol·ω
    np.testing.assert_allclose(pdas.history["normV"], bm.history["normV"], rtol=1e-8)
    np.testing.assert_allclose(pdas.history["contactForce"], bm.history["contactForce"], rtol=0,
                               atol=10 * tol * omega * len(pdas.fields("contact").points))
    np.testing.assert_array_equal(pdas.history["contactLength"], bm.history["contactLength"])
    pressure = [r.fields("contact").point_data["pressure"] for r in (pdas, bm)]
    np.testing.assert_allclose(pressure[0], pressure[1], rtol=0, atol=1e-7 * pressure[1].max())
    # the active set reaches exact complementarity, in about one iteration per step
    assert np.all(pdas.history["lambdaMin"] >= 0) and np.all(pdas.history["gapMax"] <= 1e-14)
    assert pdas.history["contactIters"].mean() < 1.5 < 40 < bm.history["contactIters"].mean()


@pytest.mark.parametrize("scene, args, skipped_work", [
    (None, ["-beta0", 0, "-lambdaD1", 0, "-lambdaU1", 0, "-lambdaD2", 0, "-lambdaU2", 0], "damageIters1"),
    (SCENES / "lift.idp", [], "contactIters"),
])
def test_skipped_and_full_paths_give_the_same_results(tmp_path, scene, args, skipped_work):
    skipped = solve_ok(tmp_path / "skipped", *args, scene=scene)
    full = solve_ok(tmp_path / "full", *args, "-skipIdle", 0, scene=scene)
    for column in SAME:
        np.testing.assert_allclose(skipped.history[column], full.history[column], rtol=1e-12, atol=1e-14,
                                   err_msg=column)
    assert np.all(skipped.history[skipped_work] == 0) and np.all(full.history[skipped_work] >= 1)


def test_a_run_without_bonds_or_rebonding_runs_its_idle_glue_too(tmp_path):
    """β⁰ = 0 and γ_r = 0: β stays 0, the glue is idle. With skipIdle = 0 its forces and its bound
    are computed anyway; the bound's power iteration has no glue to measure (once a division by 0)."""
    args = ["-beta0", 0, "-gammaR", 0]
    skipped = solve_ok(tmp_path / "skipped", *args)
    full = solve_ok(tmp_path / "full", *args, "-skipIdle", 0)
    for column in SAME:
        np.testing.assert_allclose(skipped.history[column], full.history[column], rtol=1e-12, atol=1e-14, err_msg=column)
    assert np.all(full.history["betaMax"] == 0)
