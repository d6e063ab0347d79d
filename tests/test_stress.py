"""Stress tests (coarse): every run ends with all invariants held and every loop converged, or,
where the input is truly unstable, with the clear error of the core issue; the explicit-step
bound k* of docs/model.md §7 is enforced."""
import re

import numpy as np
import pytest

from conftest import SCENES, gmsh_mesh, solve, solve_ok
from orchestrate.studies.stability import GLUE, GLUE_ALONE, GLUE_SCENE, threshold

pytestmark = pytest.mark.physics


def assert_invariants(result):
    h, tol = result.history, result.params["contactTol"]
    for column, values in h.items():
        assert np.all(np.isfinite(values)), column
    for low, high in (("zetaMin1", "zetaMax1"), ("zetaMin2", "zetaMax2"), ("betaMin", "betaMax")):
        assert np.all(h[low] >= -1e-10) and np.all(h[high] <= 1 + 1e-10), (low, high)
    assert np.all(h["gapMax"] <= tol)
    assert np.all(h["lambdaMin"] >= -10 * tol * result.params["omegaBM"])
    scale = np.maximum(np.hypot(h["forceX1"], h["forceY1"]), 1e-300)
    assert np.all(h["forceBalance"] <= 1e-10 * scale + 1e-14)
    assert np.all(h["contactIters"] < result.params["contactMaxIt"])
    assert len(h["t"]) == result.params["N"]


@pytest.mark.parametrize("n1, n2", [(8, 8), (6, 18), (4, 32), (32, 4)], ids=["1:1", "1:3", "1:8", "8:1"])
def test_mesh_size_ratios_between_the_bodies(tmp_path, n1, n2):
    assert_invariants(solve_ok(tmp_path / "run", "-n1", n1, "-n2", n2))


def test_loads_times_ten_and_damage_reaching_its_floor(tmp_path):
    done, result = solve(tmp_path / "run", "-lambdaU1", 100, "-lambdaU2", 100, scene=SCENES / "heavy.idp")
    assert done.returncode == 0, done.error_line
    assert_invariants(result)
    h = result.history
    assert max(h["zetaBelowMin1"].max(), h["zetaBelowMin2"].max()) > 0, "damage should reach zeta_min somewhere"
    assert "explicit damage source is unstable" in done.stdout  # the bound of docs/model.md §7 is reported


@pytest.fixture(scope="module")
def pulled_blocks(tmp_path_factory):
    folder = tmp_path_factory.mktemp("pull")
    upper = gmsh_mesh("meshes/rectangle.geo", folder / "upper.msh", x1=2, y0=0, y1=1, n=5)
    lower = gmsh_mesh("meshes/rectangle.geo", folder / "lower.msh", x1=2, y0=-1, y1=0, n=7)
    return folder, upper, lower


def test_glue_that_debonds_the_whole_interface_before_the_end(pulled_blocks):
    """N = 160: β(T) is 0.00182 here and 0.00184 at N = 320 (the explicit normal glue at N = 40
    chatters instead, next test)."""
    folder, upper, lower = pulled_blocks
    result = solve_ok(folder / "debond", "-mesh1", upper, "-mesh2", lower, "-gammaNu", 2000, "-N", 160,
                      scene=SCENES / "pull.idp")
    assert_invariants(result)
    h = result.history
    assert h["betaMax"][-2] < 0.01


def test_a_normal_glue_above_its_bound_is_refused_naming_the_steps(pulled_blocks):
    """γ_ν = 1e4 on the pulled blocks at N = 40: kρ_ν = 15.6, refused before the first step with the
    smallest N of the explicit normal glue's bound (docs/model.md §7); allowed anyway, the run
    diverges at once and says which terms are over their bounds."""
    folder, upper, lower = pulled_blocks
    done, _ = solve(folder / "refused", "-mesh1", upper, "-mesh2", lower, "-gammaNu", 1e4, scene=SCENES / "pull.idp")
    assert done.returncode == 3 and "exceeds the explicit normal glue bound 2/rho_nu" in done.error_line
    assert "use N >= 313" in done.error_line
    done, result = solve(folder / "allowed", "-mesh1", upper, "-mesh2", lower, "-gammaNu", 1e4, "-allowUnstable", 1,
                         scene=SCENES / "pull.idp")
    assert done.returncode == 5 and "the explicit terms diverge" in done.error_line
    assert "normal glue k rho_nu = 15.6" in done.error_line and "each bound holds from N >= 313" in done.error_line


def test_glue_between_its_bound_and_the_sum_chatters_and_the_stop_names_the_steps(pulled_blocks):
    """γ_ν = 1e3 at N = 40: kρ_ν = 1.56 is within the normal glue's own bound, but with the elastic
    term (kρ = 0.96) it is not, and where Γ_C opens uniformly the two share their mode: the glue pulls
    Γ_C shut, contact stops it, the glue pulls again. The chatter check stops the run, naming the
    terms and the N for which they are stable together (51); that N runs."""
    folder, upper, lower = pulled_blocks
    done, result = solve(folder / "chatter", "-mesh1", upper, "-mesh2", lower, "-gammaNu", 1e3,
                         scene=SCENES / "pull.idp")
    assert done.returncode == 5 and "alternated in sign" in done.error_line, done.error_line
    assert "normal glue k rho_nu = 1.56" in done.error_line
    assert "all of them together for certain from N >= 51" in done.error_line
    assert len(result.history["t"]) < 40
    solve_ok(folder / "stable", "-mesh1", upper, "-mesh2", lower, "-gammaNu", 1e3, "-N", 51, scene=SCENES / "pull.idp")


@pytest.mark.parametrize("omega", [0.1, 1, 10, 100])
def test_bermudez_moreno_over_three_decades_of_its_penalty(tmp_path, omega):
    result = solve_ok(tmp_path / "bm", "-contactSolver", "bm", "-bmOmega", omega)
    assert_invariants(result)
    reference = solve_ok(tmp_path / "pdas").history["normV"]
    # Bermúdez–Moreno stops within contactTol = 1e-10 of the exact (active-set) solution
    np.testing.assert_allclose(result.history["normV"], reference, rtol=0, atol=10 * result.params["contactTol"])


def test_long_horizon(tmp_path):
    result = solve_ok(tmp_path / "run", "-T", 10, "-N", 400)
    assert_invariants(result)
    assert result.history["zetaMin1"][-1] < 0.5  # ten times the load, ten times as long: real damage


def test_a_step_above_the_explicit_bound_is_refused_with_the_smallest_stable_n(tmp_path):
    # Paper data: rho = (E/(1+nu))/eta = 38.46, k* = 0.052 (docs/model.md §7)
    done, _ = solve(tmp_path / "n19", "-N", 19)
    assert done.returncode == 3
    assert "k* = 2/rho = 0.052" in done.error_line and "N >= 20" in done.error_line and "-allowUnstable" in done.error_line
    assert "smallest stable N = 20" in solve(tmp_path / "n20", "-N", 20)[0].stdout


def test_an_allowed_unstable_run_is_stopped_when_it_diverges(tmp_path):
    done, result = solve(tmp_path / "run", "-N", 2, "-T", 0.2, "-allowUnstable", 1)
    assert "warning: k = 0.1 > k* = 0.052" in done.stdout
    done, result = solve(tmp_path / "run", "-N", 8, "-T", 2, "-allowUnstable", 1, "-divergenceFactor", 2)
    assert done.returncode == 5 and "normV grew from" in done.error_line and "diverge" in done.error_line
    assert len(result.history["t"]) < 8  # the steps before stay on disk


# Two soft blocks (E = 10, so the elastic bound k* = 5.2 is far) bonded by a stiff tangential glue
# (p_τ = 1000, γ_ν = 0: the glue is a linear spring on the slip) and sheared open, loads held after
# t = 1 (GLUE_ALONE). The bound 2/ρ_τ comes from the operator (power iteration, edp/lib/stability.idp); the
# threshold observed here comes from the dynamics of the run.
SLIDING = {**GLUE_ALONE, "glue.pTau": 1000.0, "time.T": 5.0, "output.times": "none", "output.images": False}


def test_the_tangential_glue_bound_is_sharp(tmp_path):
    from orchestrate import SolverError, run

    with pytest.raises(SolverError) as refused:
        run(GLUE_SCENE, tmp_path / "refused", {**SLIDING, "time.N": 200})
    assert refused.value.returncode == 3 and "tangential glue bound" in refused.value.message
    smallest = int(re.search(r"N >= (\d+)", refused.value.message).group(1))
    assert 100 < smallest < 5000  # p_τ dominates: far above the elastic N >= 1
    below = {**SLIDING, "time.N": int(0.99 * smallest), "solver.allowUnstable": True}
    with pytest.raises(SolverError) as diverged:
        run(GLUE_SCENE, tmp_path / "below", below)
    assert diverged.value.returncode == 5 and "diverge" in diverged.value.message
    stable = run(GLUE_SCENE, tmp_path / "above", {**SLIDING, "time.N": int(1.01 * smallest) + 1})
    normV = stable.history["normV"]
    assert np.all(np.isfinite(normV)) and normV[-1] < 10 * normV[np.argmin(np.abs(stable.history["t"] - 1))]


def test_the_stability_study_finds_the_glue_threshold(tmp_path):
    """The study's bisection (orchestrate/studies/stability.py, results/stability) on a soft glue: the
    threshold it observes brackets the predicted 2/ρ_τ within 5 % (docs/model.md §7, issue target)."""
    row = threshold(GLUE_SCENE, {**GLUE_ALONE, "glue.pTau": 100.0}, tmp_path / "run", GLUE)
    assert row["stableK"] < row["unstableK"]
    assert abs(row["difference"]) < 0.05, row


def test_an_instability_capped_by_the_glue_truncation_is_still_stopped(tmp_path):
    """p_τ = 10⁴ at k ρ_τ ≈ 5.3: the slip mode grows until R* caps it (|s| > L), then cycles with
    period two, bounded; ‖u‖_V never grows tenfold in a step. The chatter check stops it."""
    from orchestrate import SolverError, run

    with pytest.raises(SolverError) as stopped:
        run(GLUE_SCENE, tmp_path / "run", {**SLIDING, "glue.pTau": 1e4, "time.N": 1336, "solver.allowUnstable": True})
    assert stopped.value.returncode == 5 and "alternated in sign" in stopped.value.message
    assert int(re.search(r"step (\d+)/", stopped.value.message).group(1)) < 30
