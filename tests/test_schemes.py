"""The time schemes (-scheme euler | semi-implicit | bdf2, docs/model.md §9) against exact solutions:
uniform creep of two stacked blocks against the continuous Kelvin–Voigt solution (orders 1, 1 and
2), a manufactured damage solution with the obstacle inactive (bdf2: order 2), the time order of
‖u(T)‖_V on the paper's scene, and each scheme's stability rules."""
import json

import numpy as np
import pytest

from conftest import SCENES, gmsh_mesh, solve, solve_ok
from orchestrate.freefem import REPO, run_script

pytestmark = pytest.mark.physics

T = 1.0
PUSH_RATE = 0.05                 # top of body 1 displaced by −PUSH_RATE·t (tests/scenes/blocks.idp)
HEIGHT, WIDTH = (1.0, 1.0), 2.0  # body 1, body 2
# (E, nu, mu, eta, plane strain) of the two blocks; no damage (λ = 0), no glue (blocks.idp). Soft
# enough that the creep time η/E is about T: the solution is no straight line in t, which every
# scheme would follow exactly once the start has died out.
BODIES = ((50.0, 0.3, 3.0, 20.0, 0), (30.0, 0.25, 1.0, 15.0, 1))


def expm(matrix: np.ndarray) -> np.ndarray:
    """exp of a small matrix by scaling and squaring a Taylor series (error about 1e-16)."""
    scale = max(0, int(np.ceil(np.log2(max(np.abs(matrix).sum(axis=1).max(), 1e-300)))) + 1)
    reduced = matrix / 2 ** scale
    term, total = np.eye(len(matrix)), np.eye(len(matrix))
    for order in range(1, 25):
        term = term @ reduced / order
        total = total + term
    for _ in range(scale):
        total = total @ total
    return total


def exact_pressure(t: float) -> float:
    """The contact pressure of the continuous problem: uniform strains x = (exx1, eyy1, exx2, eyy2)
    with, per body, σxx = μ tr ε̇ + η ε̇xx + a tr ε + b εxx = 0, σyy = … = −p, and the contact closed,
    H1 eyy1 + H2 eyy2 = −PUSH_RATE t. Differentiating the constraint makes ẋ = Fx + h; with x(0) = 0,
    x(t) is read off exp(t [[F, h], [0, 0]]), and p from the same linear system."""
    viscous, elastic, pressure_column = np.zeros((4, 4)), np.zeros((4, 4)), np.zeros(4)
    for i, (E, nu, mu, eta, plane_strain) in enumerate(BODIES):
        a = E * nu / ((1 + nu) * (1 - 2 * nu)) if plane_strain else E * nu / (1 - nu ** 2)
        b = E / (1 + nu)
        rows = slice(2 * i, 2 * i + 2)
        viscous[rows, rows] = [[mu + eta, mu], [mu, mu + eta]]
        elastic[rows, rows] = [[a + b, a], [a, a + b]]
        pressure_column[2 * i + 1] = 1.0
    system = np.zeros((5, 5))
    system[:4, :4], system[:4, 4] = viscous, pressure_column
    system[4, [1, 3]] = HEIGHT
    inverse = np.linalg.inv(system)
    drift = -inverse[:4, :4] @ elastic            # ẋ = drift x + push
    push = inverse[:4, 4] * (-PUSH_RATE)
    augmented = np.zeros((5, 5))
    augmented[:4, :4], augmented[:4, 4] = drift, push
    x = expm(t * augmented)[:4, 4]
    return float((inverse[4, :4] @ (-elastic @ x)) + inverse[4, 4] * (-PUSH_RATE))


@pytest.fixture(scope="module")
def blocks_meshes(tmp_path_factory):
    folder = tmp_path_factory.mktemp("blocks")
    return (gmsh_mesh("meshes/rectangle.geo", folder / "upper.msh", x1=2, y0=0, y1=1, n=7),
            gmsh_mesh("meshes/rectangle.geo", folder / "lower.msh", x1=2, y0=-1, y1=0, n=11))


def creep_flags(scheme: str, steps: int) -> list:
    flags = ["-scheme", scheme, "-T", T, "-N", steps, "-outTimes", "none", "-contactTol", 1e-14]
    for i, (E, nu, mu, eta, plane_strain) in enumerate(BODIES, 1):
        flags += [f"-E{i}", E, f"-nu{i}", nu, f"-mu{i}", mu, f"-eta{i}", eta, f"-planeStrain{i}", plane_strain,
                  f"-lambdaD{i}", 0, f"-lambdaU{i}", 0, f"-lambdaW{i}", 0]
    return flags


@pytest.mark.parametrize("scheme, ladder, order", [
    ("euler", (10, 20, 40, 80), (0.95, 1.05)),
    ("semi-implicit", (10, 20, 40, 80), (0.95, 1.05)),
    ("bdf2", (10, 20, 40, 80), (1.9, 2.1)),
])
def test_uniform_creep_converges_to_the_continuous_solution_at_the_scheme_s_order(tmp_path, blocks_meshes, scheme,
                                                                                  ladder, order):
    upper, lower = blocks_meshes
    exact = exact_pressure(T)
    errors = []
    for steps in ladder:
        result = solve_ok(tmp_path / f"run{steps}", "-mesh1", upper, "-mesh2", lower, *creep_flags(scheme, steps),
                          scene=SCENES / "blocks.idp")
        errors.append(abs(result.history["contactForce"][-1] / WIDTH - exact) / abs(exact))
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert errors[0] < 0.1 and order[0] <= rates[-1] <= order[1], (errors, rates)
    assert np.all(rates > order[0] - 0.15), (errors, rates)


@pytest.mark.unit
def test_the_exact_creep_pressure_is_the_elastic_limit_after_long_times():
    """A check of the exact solution itself: at a constant strain rate the viscous stress tends to a
    constant and the pressure grows linearly; its long-time slope is the elastic one."""
    slope = (exact_pressure(60.0) - exact_pressure(50.0)) / 10.0
    compliance = 0.0
    for E, nu, mu, eta, plane_strain in BODIES:
        a = E * nu / ((1 + nu) * (1 - 2 * nu)) if plane_strain else E * nu / (1 - nu ** 2)
        b = E / (1 + nu)
        compliance += 1.0 / ((a + b) - a * a / (a + b))  # σyy/εyy with σxx = 0: the uniaxial modulus
    # H1 eyy1 + H2 eyy2 = −R t with eyy_i = −p/modulus_i: p = R t / Σ 1/modulus_i (H = 1)
    assert slope == pytest.approx(PUSH_RATE / compliance, rel=1e-6)


def run_mms(scheme: str, steps: int) -> np.ndarray:
    done = run_script(REPO / "tests" / "edp" / "damage_schemes.edp", ["-scheme", scheme, "-N", steps, "-n1", 64])
    assert done.returncode == 0, done.stdout[-2000:]
    return np.array([float(v) for v in done.stdout.split("zeta ")[1].split()])


@pytest.mark.parametrize("scheme, order", [("euler", 1.0), ("bdf2", 2.0)])
def test_the_damage_step_converges_at_the_scheme_s_order(scheme, order):
    """ζ(x, t) = 0.5 + 0.25 cos(πx) e^{−t} on (0,1)×(0,¼) (∂ζ/∂ν = 0, the obstacle inactive) with its
    source ζ_t − κΔζ: the differences between runs of N and 2N steps on one mesh (the space error
    cancels) shrink as k^order."""
    fields = {steps: run_mms(scheme, steps) for steps in (20, 40, 80, 160)}
    differences = [np.abs(fields[n] - fields[2 * n]).max() for n in (20, 40, 80)]
    rates = np.log2(np.array(differences[:-1]) / np.array(differences[1:]))
    assert np.all(np.abs(rates - order) < 0.1), (differences, rates)


@pytest.mark.parametrize("scheme, ladder, order", [("semi-implicit", (40, 80, 160, 320), 1.0),
                                                     ("bdf2", (20, 40, 80, 160), 2.0)])
def test_the_paper_scene_converges_in_time_at_the_scheme_s_order(tmp_path, scheme, ladder, order):
    """‖u(T)‖_V, min ζ(T) (the damage step of the library) and mean β(T) (the bonding update) of
    successive N: their differences shrink as k^order."""
    runs = [solve_ok(tmp_path / f"{steps}", "-scheme", scheme, "-N", steps, "-outTimes", "none").history
            for steps in ladder]
    for column in ("normV", "zetaMin1", "betaMean"):
        differences = np.abs(np.diff([history[column][-1] for history in runs]))
        rates = np.log2(differences[:-1] / differences[1:])
        assert np.all(np.abs(rates - order) < 0.2), (column, differences, rates)


def test_the_implicit_schemes_take_steps_far_above_the_explicit_bound(tmp_path):
    stiff = ["-E1", 25000, "-E2", 25000, "-N", 10, "-outTimes", "none"]
    done, _ = solve(tmp_path / "euler", *stiff)
    assert done.returncode == 3 and "use N >= 481" in done.error_line
    for scheme in ("semi-implicit", "bdf2"):
        result = solve_ok(tmp_path / scheme, *stiff, "-scheme", scheme)
        facts = json.loads((result.folder / "run.json").read_text())
        assert facts["kStar"] is None and facts["scheme"] == scheme  # no elastic bound (infinite)
        assert np.all(np.isfinite(result.history["normV"]))


def test_bdf2_s_damage_source_level_is_its_own(tmp_path):
    euler = json.loads((solve_ok(tmp_path / "e", "-outTimes", "none").folder / "run.json").read_text())
    bdf2 = json.loads((solve_ok(tmp_path / "b", "-scheme", "bdf2", "-outTimes", "none").folder / "run.json").read_text())
    k, lambda_d = 1.0 / 40, 0.01
    assert euler["zetaCritical1"] == pytest.approx(np.sqrt(k * lambda_d / 2), rel=1e-14)
    assert bdf2["zetaCritical1"] == pytest.approx(np.sqrt(3 * k * lambda_d / 4), rel=1e-14)


@pytest.mark.parametrize("scheme", ["semi-implicit", "bdf2"])
def test_the_implicit_glue_takes_a_stiff_glue_with_no_bound(tmp_path, scheme):
    """The shear scene's glue alone at p_τ = 1e4 and N = 100: euler refuses the step (its explicit
    tangential glue bound); the schemes with the glue implicit (docs/model.md §11(b)) have no glue
    bound, run, and agree with N = 400 to within their time error (‖u(T)‖_V)."""
    from orchestrate import SolverError, run
    from orchestrate.manifest import facts
    from orchestrate.studies.stability import GLUE_ALONE, GLUE_SCENE

    stiff = {**GLUE_ALONE, "glue.pTau": 1e4, "time.N": 100, "output.times": "none", "output.images": False}
    with pytest.raises(SolverError, match=r"exceeds the explicit tangential glue bound 2/rho_tau"):
        run(GLUE_SCENE, tmp_path / "euler", stiff)
    coarse = run(GLUE_SCENE, tmp_path / "coarse", {**stiff, "time.scheme": scheme})
    fine = run(GLUE_SCENE, tmp_path / "fine", {**stiff, "time.scheme": scheme, "time.N": 400})
    assert facts(coarse.folder)["rhoTau"] == 0
    assert "no glue bound" in (coarse.folder / "run.log").read_text()
    difference = abs(coarse.history["normV"][-1] / fine.history["normV"][-1] - 1)
    assert difference < (2e-3 if scheme == "bdf2" else 2e-2), difference


def test_the_bonding_step_s_positivity_level_is_printed_and_its_breach_named(tmp_path):
    """The peel scene (γ_ν = 100, L = 0.5, T = 2) without tangential glue at N = 40 (k = 0.05): euler's
    explicit bonding step keeps β ≥ 0 only while the opening stays below 1/sqrt(kγ_ν) = 0.447; the
    lifted end opens past it and the run stops naming the step that would hold for any opening,
    N >= T γ_ν L² = 50. The semi-implicit scheme's bonding step is implicit in β (docs/model.md
    §11(c)): the same N keeps β in [0, 1], and the front still moves."""
    from orchestrate import SolverError, run

    peel = REPO / "scenes" / "peel.toml"
    quiet = {"glue.pTau": 0.0, "time.N": 40, "output.times": "none", "output.images": False}
    with pytest.raises(SolverError) as stopped:  # above the normal glue's own bound, allowed (test_stress.py)
        run(peel, tmp_path / "euler", {**quiet, "time.scheme": "euler", "solver.allowUnstable": True})
    assert stopped.value.returncode == 5
    assert "the explicit bonding step overshoots where the opening exceeds 0.447214" in stopped.value.message
    assert "N >= 50 keeps beta >= 0" in stopped.value.message
    facts = json.loads((tmp_path / "euler.failed" / "run.json").read_text())
    assert facts["openingCritical"] == pytest.approx(1 / np.sqrt(0.05 * 100), rel=1e-12)
    result = run(peel, tmp_path / "implicit", {**quiet, "time.scheme": "semi-implicit"})
    assert result.history["betaMin"].min() >= 0 and result.history["betaMax"].max() <= 1
    assert result.history["debondFront"][-1] < 0.9 * result.history["debondFront"][0]


@pytest.mark.parametrize("scheme, limit", [("euler", 2.0), ("bdf2", 4.0 / 3.0)])
def test_the_damage_source_bound_is_sharp_for_each_scheme(tmp_path, scheme, limit):
    """A uniform ζ near the equilibrium ζ_eq = 0.1 of ζ' = λ_D (1 − ζ)/ζ + λ_w (no loads, λ_u = 0):
    linearized, ζ − ζ_eq obeys the scheme's recursion for the rate λ_D/ζ_eq², stable up to
    k λ_D/ζ_eq² = 2 (euler) or 4/3 (bdf2's extrapolation, docs/model-choices.md). The bisection of
    the stability study observes the threshold within one step of that number."""
    from orchestrate.studies.stability import SOURCE, SOURCE_ALONE, ZETA_EQUILIBRIUM, threshold

    row = threshold(REPO / "scenes" / "paper.toml", {**SOURCE_ALONE, "time.scheme": scheme}, tmp_path / "run", SOURCE)
    exact = limit * ZETA_EQUILIBRIUM ** 2 / SOURCE_ALONE["body1.damage.lambdaD"]
    assert row["predicted"] == pytest.approx(exact, rel=1e-12)
    assert row["stableK"] <= exact * (1 + 1e-9) and row["unstableK"] >= exact * (1 - 1e-9), row
