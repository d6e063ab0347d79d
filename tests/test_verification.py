"""Verification against independent facts (issue 4): a manufactured solution for the damage
obstacle problem, the bonding update against its recursion and against the exact ODE solution,
matching and non-matching meshes reaching the same limit, and the invariants of every step."""
import math

import numpy as np
import pytest

from conftest import solve_ok
from orchestrate.freefem import REPO, run_script

pytestmark = pytest.mark.physics


def printed(done) -> dict[str, list[float]]:
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr
    return {line.split()[0]: [float(v) for v in line.split()[1:]] for line in done.stdout.splitlines() if line.split()}


def test_damage_obstacle_problem_converges_to_a_manufactured_solution(tmp_path):
    # k ∝ h² makes the expected L² error O(h²): each halving of h divides it by 4.
    errors = []
    for n in (16, 32, 64):
        facts = printed(run_script(REPO / "tests" / "edp" / "damage_mms.edp",
                                   ["-n1", n, "-N", n * n // 4, "-kappa1", 0.01, "-out", tmp_path]))
        assert facts["zetaMax"][0] <= 1 + 1e-12 and facts["zetaMin"][0] >= 0
        assert facts["active"][0] > 0.2 * facts["active"][1], "the upper bound must be active on a region"
        errors.append(facts["error"][0])
    rates = [math.log2(a / b) for a, b in zip(errors, errors[1:])]
    assert all(rate > 1.9 for rate in rates), rates
    assert errors[-1] < 2e-4


def test_projected_gauss_seidel_solves_the_obstacle_problem_the_active_sets_solve(tmp_path):
    """The damage solver's fallback (for active sets that cycle) and the active-set method are two
    independent exact solvers of the same bound-constrained problem: the same ζ, to round-off,
    at both bounds, and both satisfy its KKT conditions."""
    facts = printed(run_script(REPO / "tests" / "edp" / "obstacle_check.edp",
                               ["-n1", 30, "-N", 10000, "-kappa1", 0.001, "-damageMaxIt", 1000, "-out", tmp_path]))
    assert facts["sets"][0] > 0 and facts["sweeps"][0] > 0
    assert facts["bounds"] == [0.0, 1.0]
    assert facts["difference"][0] < 1e-12
    assert facts["kktSets"][0] < 1e-13 and facts["kktSweeps"][0] < 1e-13


def bonding(tmp_path, steps, *args):
    facts = printed(run_script(REPO / "tests" / "edp" / "bonding_check.edp", ["-N", steps, "-out", tmp_path, *args]))
    return np.array(facts["s"]), np.array(facts["beta"])


def bonding_recursion(s, steps, T, gamma_nu, gamma_r, L, beta0):
    """docs/model.md §6 step 3, written out: β += k[−γ_ν β₊ P_B(R(g)²) + γ_r β₊(1 − β)₊/(1 + (Σ kβ)²)]."""
    k = T / steps
    beta, integral = np.full(len(s) - 1, beta0), np.zeros(len(s) - 1)
    for n in range(1, steps + 1):
        gap = np.clip(-(0.2 + 0.5 * s) * math.sin(3 * (n - 1) * k) + 0.1, -L, L)
        a, b = gap[:-1], gap[1:]
        mean_square = (a * a + a * b + b * b) / 3  # mean over a segment of the square of a linear function
        integral += k * beta
        plus = np.maximum(beta, 0)
        beta = beta + k * (-gamma_nu * plus * mean_square + gamma_r * plus * np.maximum(1 - beta, 0) / (1 + integral ** 2))
    return beta


def test_bonding_update_is_the_discrete_recursion(tmp_path):
    s, beta = bonding(tmp_path, 50, "-gammaNu", 3, "-gammaR", 2, "-L", 0.3, "-beta0", 0.8)
    np.testing.assert_allclose(beta, bonding_recursion(s, 50, 1.0, 3.0, 2.0, 0.3, 0.8), rtol=1e-13)


def test_bonding_update_converges_to_the_exact_ode_solution(tmp_path):
    # Without rebonding and with g = −0.25 sin(3t) everywhere, β' = −γ_ν β g² gives
    # β(T) = β0 exp(−γ_ν ∫₀ᵀ g²); explicit Euler is first order in k.
    gamma_nu, beta0 = 4.0, 0.9
    integral = 0.0625 * (1 / 2 - math.sin(6) / 12)
    exact = beta0 * math.exp(-gamma_nu * integral)
    errors = []
    for steps in (25, 50, 100, 200):
        _, beta = bonding(tmp_path, steps, "-uniform", 1, "-gammaNu", gamma_nu, "-gammaR", 0, "-beta0", beta0)
        assert np.ptp(beta) < 1e-15
        errors.append(abs(beta[0] - exact))
    rates = [math.log2(a / b) for a, b in zip(errors, errors[1:])]
    assert all(0.9 < rate < 1.1 for rate in rates), rates
    assert errors[-1] < 1e-3 * exact


def test_matching_and_non_matching_meshes_reach_the_same_limit(tmp_path):
    differences, changes, previous = [], [], None
    for n in (6, 12, 24, 48):
        matching = solve_ok(tmp_path / f"m{n}", "-n1", n, "-n2", n, "-outTimes", "none").history
        other = solve_ok(tmp_path / f"o{n}", "-n1", n, "-n2", n * 4 // 3, "-outTimes", "none").history
        differences.append(abs(matching["normV"][-1] - other["normV"][-1]))
        if previous is not None:
            changes.append(abs(matching["normV"][-1] - previous))
        previous = matching["normV"][-1]
    assert all(b < a / 2 for a, b in zip(differences, differences[1:])), differences
    assert all(d < c / 10 for d, c in zip(differences[1:], changes)), (differences, changes)


@pytest.fixture(scope="module")
def paper(tmp_path_factory):
    return solve_ok(tmp_path_factory.mktemp("invariants") / "run")


def test_complementarity_holds_at_every_step(paper):
    h, tol, omega = paper.history, paper.params["contactTol"], paper.params["omegaBM"]
    assert np.all(h["gapMax"] <= tol)
    assert np.all(h["lambdaMin"] >= -10 * tol * omega)
    # |λ_j g_j| ≤ (largest nodal force) × (gap tolerance) where the contact is closed, and
    # ≤ (multiplier tolerance) × (largest gap) where it is open
    assert np.all(h["complementarity"] <= 10 * tol * (h["contactForce"] + omega))


def test_interface_forces_on_the_two_bodies_are_equal_and_opposite(paper):
    h = paper.history
    scale = np.hypot(h["forceX1"], h["forceY1"])
    assert np.all(scale > 0)
    assert np.all(h["forceBalance"] <= 1e-12 * scale)
    # the normal part is the contact force minus the glue's pull on the open part
    assert np.all(h["forceY1"] <= h["contactForce"] + 1e-12)


def test_damage_and_bonding_stay_in_the_unit_interval(paper):
    h = paper.history
    for low, high in (("zetaMin1", "zetaMax1"), ("zetaMin2", "zetaMax2"), ("betaMin", "betaMax")):
        assert np.all(h[low] >= 0) and np.all(h[high] <= 1 + 1e-12)
