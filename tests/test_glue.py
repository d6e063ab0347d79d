"""The glue implicit (docs/model.md §11(b)): in the semi-implicit and bdf2 schemes the glue acts on uⁿ
inside step 1's contact problem.

Two blocks glued and pulled apart in uniaxial strain (tests/scenes/glued.idp): each block's strain is
uniform, so the discrete problem is the scalar one of a spring in series with two Kelvin–Voigt
bars, which `glued_pull` solves here from the model's equations alone, with the scheme's rate
weights. The opening passes the truncation L mid-run, where the glue's traction stops growing; the
run must follow the recursion to round-off at every step, on non-matching meshes. With debonding
(docs/model.md §9, the bonding implicit in β), the recursion adds the closed form of each step's
βⁿ, with a finite mobility and in the rate-independent limit m_d = inf, where β γ_ν o² stays at the
adhesion energy ε_a once the opening has passed sqrt(ε_a/γ_ν)."""
import numpy as np
import pytest

from conftest import SCENES, gmsh_mesh, solve, solve_ok

pytestmark = pytest.mark.physics

T, PULL_RATE, WIDTH = 1.0, 0.05, 2.0  # the top of body 1 lifted by PULL_RATE·t (tests/scenes/glued.idp)
HEIGHT = (1.0, 1.0)
# (E, nu, mu, eta, plane strain) of the two blocks; no damage (λ = 0)
BODIES = ((50.0, 0.3, 3.0, 20.0, 0), (30.0, 0.25, 1.0, 15.0, 1))
GAMMA_NU, L = 40.0, 0.01
RATE_WEIGHTS = {"semi-implicit": (1.0, -1.0, 0.0), "bdf2": (1.5, -2.0, 0.5)}


def uniaxial(body):
    """(viscous, elastic) coefficients of σyy in uniaxial strain: (Aτ)yy = (μ + η) τyy, (Gτ)yy = (a + b) τyy."""
    E, nu, mu, eta, plane_strain = body
    a = E * nu / ((1 + nu) * (1 - 2 * nu)) if plane_strain else E * nu / (1 - nu ** 2)
    return mu + eta, a + E / (1 + nu)


def glued_pull(steps, weights, mobility=0.0, energy=0.0, coupled=False):
    """Per step n the traction σⁿ, the opening oⁿ, the strains εᵢⁿ of the blocks and the bonding βⁿ, from
      cᵢ (w₀εᵢⁿ + w₁εᵢⁿ⁻¹ + w₂εᵢⁿ⁻²)/k + eᵢ εᵢⁿ = σⁿ = γ_ν β*² min(max(oⁿ, 0), L)   (each block),
      oⁿ = δⁿ − H₁ε₁ⁿ − H₂ε₂ⁿ   (the opening of Γ_C, δⁿ = PULL_RATE tⁿ),
      w₀βⁿ + w₁βⁿ⁻¹ + w₂βⁿ⁻² = −k m_d (βⁿ Y − ε_a)₊,   Y = γ_ν min(oⁿ, L)²,
    β* = βⁿ⁻¹ (after a two-level step 2βⁿ⁻¹ − βⁿ⁻², clipped to [0, 1]), the first step with the
    one-level weights (1, −1, 0) in every scheme; m_d = inf: βⁿ = min(βⁿ⁻¹, ε_a/Y) in every scheme.
    coupled (glue.bondingCoupled): β* = βⁿ, the two equations solved together (a fixed point on β,
    iterated here until it stops moving)."""
    k = T / steps
    coefficients = [uniaxial(body) for body in BODIES]
    heights = np.array(HEIGHT)
    past = np.zeros((2, 2))  # εᵢⁿ⁻¹, εᵢⁿ⁻²
    beta = [1.0, 1.0]  # βⁿ⁻¹, βⁿ⁻²
    history = []
    for n in range(1, steps + 1):
        w = (1.0, -1.0, 0.0) if n == 1 else weights
        d = np.array([c * w[0] / k + e for c, e in coefficients])
        q = np.array([-c * (w[1] * p[0] + w[2] * p[1]) / k for (c, _), p in zip(coefficients, past)])
        delta = PULL_RATE * n * k

        def step(star):
            spring = GAMMA_NU * star ** 2
            sigma = spring * (delta - heights @ (q / d)) / (1 + spring * np.sum(heights / d))  # the spring
            strain = (sigma + q) / d
            if delta - heights @ strain > L:  # past the truncation: the constant traction
                sigma = spring * L
                strain = (sigma + q) / d
            opening = delta - heights @ strain
            drive = GAMMA_NU * min(opening, L) ** 2
            start = beta[0] if mobility == "inf" else (-w[1] * beta[0] - w[2] * beta[1]) / w[0]
            if start * drive > energy:
                start = energy / drive if mobility == "inf" else \
                    (start + k * mobility / w[0] * energy) / (1 + k * mobility / w[0] * drive)
            return sigma, opening, strain, min(max(start, 0.0), 1.0)

        star = beta[0] if n == 1 or w[2] == 0 else min(max(2 * beta[0] - beta[1], 0.0), 1.0)
        sigma, opening, strain, new = step(star)
        for _ in range(1000 if coupled else 0):
            if new == star:
                break
            star = new
            sigma, opening, strain, new = step(star)
        beta = [new, beta[0]]
        past = np.column_stack([strain, past[:, 0]])
        history.append((sigma, opening, strain, beta[0]))
    return history


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    folder = tmp_path_factory.mktemp("glued")
    return (gmsh_mesh("meshes/rectangle.geo", folder / "upper.msh", x1=2, y0=0, y1=1, n=5),
            gmsh_mesh("meshes/rectangle.geo", folder / "lower.msh", x1=2, y0=-1, y1=0, n=7))


def glued_flags(scheme, steps):
    flags = ["-scheme", scheme, "-T", T, "-N", steps, "-outTimes", "none", "-gammaNu", GAMMA_NU, "-L", L,
             "-pTau", 5.0, "-contactTol", 1e-14]
    for i, (E, nu, mu, eta, plane_strain) in enumerate(BODIES, 1):
        flags += [f"-E{i}", E, f"-nu{i}", nu, f"-mu{i}", mu, f"-eta{i}", eta, f"-planeStrain{i}", plane_strain,
                  f"-lambdaD{i}", 0, f"-lambdaU{i}", 0, f"-lambdaW{i}", 0]
    return flags


@pytest.mark.parametrize("scheme", ["semi-implicit", "bdf2"])
@pytest.mark.parametrize("mobility, energy, coupled", [(0.0, 0.0, 0), (500.0, 5e-4, 0), ("inf", 1e-3, 0),
                                                       (500.0, 5e-4, 1), ("inf", 1e-3, 1)],
                         ids=["bonded", "debonding", "rate-independent", "debonding-coupled",
                              "rate-independent-coupled"])
def test_a_glued_pull_follows_the_spring_in_series_at_every_step(tmp_path, meshes, scheme, mobility, energy, coupled):
    upper, lower = meshes
    steps = 20
    result = solve_ok(tmp_path / "run", "-mesh1", upper, "-mesh2", lower, *glued_flags(scheme, steps),
                      "-debondMobility", mobility, "-adhesionEnergy", energy, "-bondingCoupled", coupled,
                      scene=SCENES / "glued.idp")
    expected = glued_pull(steps, RATE_WEIGHTS[scheme], mobility, energy, coupled)
    sigma = np.array([step[0] for step in expected])
    opening = np.array([step[1] for step in expected])
    beta = np.array([step[3] for step in expected])
    assert opening[0] < L < opening[-1], "the run should pass the truncation"
    h = result.history
    np.testing.assert_allclose(h["forceY2"], sigma * WIDTH, rtol=1e-10)
    np.testing.assert_allclose(h["forceY1"], -sigma * WIDTH, rtol=1e-10)
    norm_v = [np.sqrt(WIDTH * np.sum(np.array(HEIGHT) * step[2] ** 2)) for step in expected]
    np.testing.assert_allclose(h["normV"], norm_v, rtol=1e-10)
    np.testing.assert_allclose(h["betaMin"], beta, rtol=1e-10)
    np.testing.assert_allclose(h["betaMax"], beta, rtol=1e-10)
    assert np.all(h["contactForce"] == 0)
    # the reactions (docs/model.md §11(d)): the lifted top carries the pull, the held bottom gives it back,
    # and the rollers hold the lateral stress σxx = μ k·ε̇ + a ε of uniaxial strain, per unit height
    np.testing.assert_allclose(h["reactionY1_3"], sigma * WIDTH, rtol=1e-10)
    np.testing.assert_allclose(h["reactionY2_1"], -sigma * WIDTH, rtol=1e-10)
    strains = np.array([step[2] for step in expected])  # step, body
    padded = np.vstack([np.zeros((2, 2)), strains])
    for i, body in enumerate(BODIES, 1):
        E, nu, mu, eta, plane_strain = body
        a = E * nu / ((1 + nu) * (1 - 2 * nu)) if plane_strain else E * nu / (1 - nu ** 2)
        weights = np.array([RATE_WEIGHTS[scheme]] * steps)
        weights[0] = (1.0, -1.0, 0.0)
        rate = (weights[:, 0] * padded[2:, i - 1] + weights[:, 1] * padded[1:-1, i - 1]
                + weights[:, 2] * padded[:-2, i - 1]) / (T / steps)
        lateral = (mu * rate + a * strains[:, i - 1]) * HEIGHT[i - 1]
        np.testing.assert_allclose(h[f"reactionX{i}_2"], lateral, rtol=1e-9)
        np.testing.assert_allclose(h[f"reactionX{i}_4"], -lateral, rtol=1e-9)
    # the stored energies (energy.idp): ½(Gε, ε) of uniaxial strain, the glue's ½ γ_ν β² R(o)², ε_a(1 − β)
    elastic = sum(0.5 * uniaxial(body)[1] * strains[:, i] ** 2 * HEIGHT[i] * WIDTH for i, body in enumerate(BODIES))
    np.testing.assert_allclose(h["elasticEnergy"], elastic, rtol=1e-10)
    np.testing.assert_allclose(h["glueEnergy"], 0.5 * GAMMA_NU * beta ** 2 * np.minimum(opening, L) ** 2 * WIDTH,
                               rtol=1e-10)
    np.testing.assert_allclose(h["surfaceEnergy"], energy * (1 - beta) * WIDTH, rtol=1e-10, atol=1e-16)
    if mobility == "inf":  # past sqrt(ε_a/γ_ν) = 0.005 the bonds hold β γ_ν o² at ε_a exactly
        held = opening > np.sqrt(energy / GAMMA_NU)
        assert held.sum() > 5
        np.testing.assert_allclose(beta[held] * GAMMA_NU * np.minimum(opening[held], L) ** 2, energy, rtol=1e-12)
    if mobility != 0.0:
        assert beta[-1] < 0.5, "the bonds should let go"


def test_the_rate_independent_limit_needs_the_bonding_implicit(tmp_path, meshes):
    upper, lower = meshes
    done, _ = solve(tmp_path / "run", "-mesh1", upper, "-mesh2", lower, *glued_flags("euler", 20),
                    "-debondMobility", "inf", scene=SCENES / "glued.idp")
    assert done.returncode == 3
    assert "debondMobility = inf (the rate-independent limit) needs the bonding step implicit in beta" in done.error_line


def test_the_glue_and_the_bonding_together_need_the_glue_implicit(tmp_path, meshes):
    upper, lower = meshes
    done, _ = solve(tmp_path / "run", "-mesh1", upper, "-mesh2", lower, *glued_flags("euler", 20),
                    "-bondingCoupled", 1, scene=SCENES / "glued.idp")
    assert done.returncode == 3
    assert "parameter bondingCoupled = 1" in done.error_line and "scheme = semi-implicit or bdf2" in done.error_line


@pytest.mark.parametrize("scheme, order", [("semi-implicit", 1), ("bdf2", 2)])
def test_the_energy_balance_closes_at_the_scheme_s_order(tmp_path, meshes, scheme, order):
    """The glued pull debonding (m_d = 100, ε_a = 5e-4: β falls to 0.26) below the truncation (L = 10):
    the work of the loads and supports against the elastic, glue and surface energies, the viscous
    and the debonding dissipation (docs/model.md §11(d)). Its relative misfit at T falls with k at
    least at the scheme's order (trapezoid rules in time: energy.idp)."""
    upper, lower = meshes
    misfits = []
    for steps in (20, 40, 80):
        flags = glued_flags(scheme, steps)
        flags[flags.index("-L") + 1] = 10.0
        h = solve_ok(tmp_path / f"run{steps}", "-mesh1", upper, "-mesh2", lower, *flags, "-debondMobility", 100,
                     "-adhesionEnergy", 5e-4, scene=SCENES / "glued.idp").history
        assert h["betaMin"][-1] < 0.3 and h["debondDissipation"][-1] > 0 and h["surfaceEnergy"][-1] > 0
        misfits.append(abs(h["energyBalance"][-1]))
    rates = np.log2(np.array(misfits[:-1]) / np.array(misfits[1:]))
    assert misfits[-1] < 0.1 and np.all(rates > order - 0.2), (misfits, rates)
