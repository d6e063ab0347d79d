"""The glue implicit (docs/model.md §11(b)): in the semi-implicit and bdf2 schemes the glue acts on uⁿ
inside step 1's contact problem.

Two blocks glued and pulled apart in uniaxial strain (tests/scenes/glued.idp): each block's strain is
uniform, so the discrete problem is the scalar one of a spring in series with two Kelvin–Voigt
bars, which `glued_pull` solves here from the model's equations alone, with the scheme's rate
weights. The opening passes the truncation L mid-run, where the glue's traction stops growing; the
run must follow the recursion to round-off at every step, on non-matching meshes."""
import numpy as np
import pytest

from conftest import SCENES, gmsh_mesh, solve_ok

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


def glued_pull(steps, weights):
    """Per step n the traction σⁿ and the strains εᵢⁿ of the blocks, from
      cᵢ (w₀εᵢⁿ + w₁εᵢⁿ⁻¹ + w₂εᵢⁿ⁻²)/k + eᵢ εᵢⁿ = σⁿ = γ_ν min(max(oⁿ, 0), L)   (each block),
      oⁿ = δⁿ − H₁ε₁ⁿ − H₂ε₂ⁿ   (the opening of Γ_C, δⁿ = PULL_RATE tⁿ),
    the first step with the one-level weights (1, −1, 0) in every scheme."""
    k = T / steps
    coefficients = [uniaxial(body) for body in BODIES]
    past = np.zeros((2, 2))  # εᵢⁿ⁻¹, εᵢⁿ⁻²
    history = []
    for n in range(1, steps + 1):
        w = (1.0, -1.0, 0.0) if n == 1 else weights
        delta = PULL_RATE * n * k
        d = np.array([c * w[0] / k + e for c, e in coefficients])
        q = np.array([-c * (w[1] * p[0] + w[2] * p[1]) / k for (c, _), p in zip(coefficients, past)])
        heights = np.array(HEIGHT)
        sigma = GAMMA_NU * (delta - heights @ (q / d)) / (1 + GAMMA_NU * np.sum(heights / d))  # the spring
        strain = (sigma + q) / d
        if delta - heights @ strain > L:  # past the truncation: the constant traction
            sigma = GAMMA_NU * L
            strain = (sigma + q) / d
        past = np.column_stack([strain, past[:, 0]])
        history.append((sigma, delta - heights @ strain, strain))
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
def test_a_glued_pull_follows_the_spring_in_series_at_every_step(tmp_path, meshes, scheme):
    upper, lower = meshes
    steps = 20
    result = solve_ok(tmp_path / "run", "-mesh1", upper, "-mesh2", lower, *glued_flags(scheme, steps),
                      scene=SCENES / "glued.idp")
    expected = glued_pull(steps, RATE_WEIGHTS[scheme])
    sigma = np.array([step[0] for step in expected])
    opening = np.array([step[1] for step in expected])
    assert opening[0] < L < opening[-1], "the run should pass the truncation"
    h = result.history
    np.testing.assert_allclose(h["forceY2"], sigma * WIDTH, rtol=1e-10)
    np.testing.assert_allclose(h["forceY1"], -sigma * WIDTH, rtol=1e-10)
    norm_v = [np.sqrt(WIDTH * np.sum(np.array(HEIGHT) * step[2] ** 2)) for step in expected]
    np.testing.assert_allclose(h["normV"], norm_v, rtol=1e-10)
    assert np.all(h["contactForce"] == 0) and np.all(h["betaMin"] == 1)
