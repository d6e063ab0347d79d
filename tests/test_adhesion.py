"""The debonding law with a mobility and an adhesion energy (docs/model.md §4: Frémond's law,
β̇ = −m_d (β γ_ν R(g)² + s ½ p_τ R*(s_h)² − ε_a)₊ + rebonding):

- the driver's step is that recursion, written out here (the defaults, the paper's law, are
  tests/test_verification.py's and the golden record's);
- below the threshold nothing debonds: with β⁰ γ_ν max R(g)² < ε_a, β keeps β⁰ exactly;
- its results do not depend on the unit of stress: a pre-cracked joint pulled open, run in a unit
  1000 times smaller (every stiffness, viscosity, γ_ν, p_τ and ε_a × 1000, m_d ÷ 1000), gives the same
  u, ζ and β to round-off, its front moving; the paper's law (m_d = 1 in every unit) does not (in
  kN, 1000 times larger);
- the debonding front (history.csv debondFront) starts at the pre-crack's tip, only recedes while the
  joint opens without rebonding, and is where β crosses ½ in the run's final state."""
import math
import tomllib

import numpy as np
import pytest

from orchestrate.freefem import REPO, run_script
from orchestrate.manifest import read_state
from orchestrate.runner import run

pytestmark = pytest.mark.physics


def printed(done) -> dict[str, list[float]]:
    assert done.returncode == 0, done.stdout + done.stderr
    return {line.split()[0]: [float(v) for v in line.split()[1:]] for line in done.stdout.splitlines()
            if line.split() and line.split()[0] in ("s", "beta")}


def bonding(tmp_path, steps, *args):
    facts = printed(run_script(REPO / "tests" / "edp" / "bonding_check.edp", ["-N", steps, "-out", tmp_path, *args]))
    return np.array(facts["s"]), np.array(facts["beta"])


def debonding_recursion(s, steps, T, gamma_nu, mobility, energy, L, beta0):
    """β += k[−m_d (β γ_ν P_B(R(g)²) − ε_a)₊], g(s, t) = −(0.2 + 0.5 s) sin(3t) + 0.1 at t_{n−1}."""
    k = T / steps
    beta = np.full(len(s) - 1, beta0)
    for n in range(1, steps + 1):
        gap = np.clip(-(0.2 + 0.5 * s) * math.sin(3 * (n - 1) * k) + 0.1, -L, L)
        a, b = gap[:-1], gap[1:]
        mean_square = (a * a + a * b + b * b) / 3
        beta = beta - k * mobility * np.maximum(beta * gamma_nu * mean_square - energy, 0)
    return beta


def test_the_bonding_step_is_the_law_with_a_mobility_and_a_threshold(tmp_path):
    s, beta = bonding(tmp_path, 80, "-gammaNu", 3, "-gammaR", 0, "-L", 0.3, "-beta0", 0.8,
                      "-debondMobility", 2.5, "-adhesionEnergy", 0.02)
    expected = debonding_recursion(s, 80, 1.0, 3.0, 2.5, 0.02, 0.3, 0.8)
    np.testing.assert_allclose(beta, expected, rtol=1e-13)
    assert expected.min() < 0.79 and expected.max() > expected.min() + 0.05  # some segments debond, unevenly
    assert (expected > 0.02 / (3.0 * 0.3 ** 2) - 1e-12).all()  # never below ε_a/(γ_ν L²): the threshold holds


def test_below_the_adhesion_energy_nothing_debonds(tmp_path):
    # max R(g)² = 0.3² (L = 0.3), β⁰ γ_ν 0.09 = 0.216 < ε_a = 0.25
    _, beta = bonding(tmp_path, 40, "-gammaNu", 3, "-gammaR", 0, "-L", 0.3, "-beta0", 0.8, "-adhesionEnergy", 0.25)
    assert (beta == 0.8).all()


def test_the_tangential_glue_s_energy_drives_debonding_when_asked(tmp_path):
    """s = 1 with γ_ν = 0: the driving force is ½ p_τ R*(s_h)² − ε_a, the same at every step, so β
    falls linearly, β(t) = β⁰ − t m_d (½ p_τ s² − ε_a), and stops at 0; without it, nothing happens."""
    common = ["-uniform", 1, "-gammaNu", 0, "-gammaR", 0, "-beta0", 0.9, "-pTau", 4, "-slip", 0.5, "-L", 1,
              "-debondMobility", 3, "-adhesionEnergy", 0.1]
    rate = 3 * (0.5 * 4 * 0.25 - 0.1)  # 1.2 per unit time
    _, falling = bonding(tmp_path, 20, *common, "-shearDebonding", 1)
    np.testing.assert_allclose(falling, 0.0, atol=1e-15)  # 0.9 − 1.2 < 0: held at 0
    _, half = bonding(tmp_path, 20, *common, "-shearDebonding", 1, "-T", 0.5)
    np.testing.assert_allclose(half, 0.9 - 0.5 * rate, rtol=1e-13)
    _, still = bonding(tmp_path, 20, *common)
    assert (still == 0.9).all()


QUIET = {"body1.mesh.n": 30, "body2.mesh.n": 12, "time.N": 60, "output.times": "final", "output.fields": ["state"],
         "output.images": False}
STRESS_LIKE = ("body1.material.E", "body1.material.mu", "body1.material.eta", "body2.material.E", "body2.material.mu",
               "body2.material.eta", "glue.gammaNu", "glue.pTau")


def scene_value(data: dict, key: str):
    for part in key.split("."):
        data = data[part]
    return data


def joint(tmp_path, name, scale, law):
    """scenes/precrack.toml (prescribed displacement, no tractions: no load to scale) with its
    stresses in a unit 1/scale; law: m_d = 2 and ε_a = 0.5 in N/m, else the paper's law."""
    scene = REPO / "scenes" / "precrack.toml"
    data = tomllib.loads(scene.read_text())
    values = {key: scale * scene_value(data, key) for key in STRESS_LIKE}
    if law:
        values |= {"glue.adhesionEnergy": 0.5 * scale, "glue.debondMobility": 2.0 / scale}
    result = run(scene, tmp_path / name, {**QUIET, **values})
    state = read_state(result.folder / "state_0060.txt")
    return result.history, state


def test_the_law_does_not_depend_on_the_unit_of_stress(tmp_path):
    history, state = joint(tmp_path, "N-m", 1.0, True)
    scaled_history, scaled_state = joint(tmp_path, "mN-m", 1000.0, True)
    assert history["betaMean"][-1] < history["betaMean"][0] - 0.05  # the front moved
    for name in ("u1", "u2", "zeta1", "zeta2", "beta"):
        scale = np.abs(state[name]).max()
        assert np.abs(scaled_state[name] - state[name]).max() <= 1e-9 * scale, name
    np.testing.assert_allclose(scaled_history["contactForce"], 1000 * history["contactForce"], rtol=1e-8, atol=1e-9)
    _, paper = joint(tmp_path, "paper", 1.0, False)
    _, paper_scaled = joint(tmp_path, "paper-kN", 0.001, False)  # (in mN, its explicit bonding step overshoots)
    assert np.abs(paper_scaled["beta"] - paper["beta"]).max() > 0.05  # the paper's law: γ_ν is also the rate


def crossing(s: np.ndarray, beta: np.ndarray) -> float:
    """Where β (one value a segment of the nodes s, at the segments' midpoints, linear between)
    first crosses ½, from s[0]."""
    middle = 0.5 * (s[:-1] + s[1:]) - s[0]
    side = beta >= 0.5
    change = np.flatnonzero(side != side[0])
    if not change.size:
        return s[-1] - s[0] if side[0] else 0.0
    e = change[0]
    return float(np.interp(0.5, sorted([beta[e - 1], beta[e]]),
                           [middle[e - 1], middle[e]] if beta[e - 1] < beta[e] else [middle[e], middle[e - 1]]))


def test_the_debonding_front_is_where_beta_crosses_one_half(tmp_path):
    history, state = joint(tmp_path, "front", 1.0, False)
    front = history["debondFront"]
    # scenes/precrack.toml: bonded where x < 4.5; after step 1, whose implicit bonding acts on u¹, the
    # tip's segment has lost a little of its β, which moves the front by a fraction of a segment (0.075)
    assert front[0] == pytest.approx(4.5, abs=1e-3)
    assert (np.diff(front) <= 1e-12).all() and front[-1] < 4.0  # it recedes, and far
    assert front[-1] == pytest.approx(crossing(state["s"], state["beta"]), rel=1e-12)


def test_one_interface_opened_in_mode_one_separates_with_its_fracture_energy(tmp_path):
    """`study mode-one` at a small size (results/mode-one holds the ladder): two stiff blocks glued
    and pulled apart in the rate-independent limit; the lifting force's work of separation per unit
    length approaches G(L) = ε_a (1 − δ₀²/(2L²)), the law's closed form, from above (the traction lags
    β by a step), within 1 % at N = 400, its error falling with k; what the debonding books beyond
    ε_a falls with it."""
    from orchestrate.studies.modeone import mode_one

    rows = mode_one(tmp_path / "study", steps=(200, 400), progress=False)
    coarse, fine = rows
    assert fine["theory"] == pytest.approx(1e-3 * (1 - 0.005 ** 2 / (2 * 0.1 ** 2)), rel=1e-12)
    assert 0 < fine["error"] < 0.01 and fine["error"] < coarse["error"] / 3
    assert fine["debondShare"] < coarse["debondShare"] / 3 and fine["stored"] < 1e-5
    assert "| 400 |" in (tmp_path / "study" / "README.md").read_text()
    assert (tmp_path / "study" / "traction.png").stat().st_size > 10_000


def test_a_cantilever_peel_follows_beam_theory(tmp_path):
    """`study cantilever` at a small size (results/cantilever holds a/h from 10 to 30): an arm bonded
    beyond a crack and lifted at its free end. With χ fitted on the initial elastic branch alone,
    the force where the front passes a/h = 10, 12, 14 is within 3 % of beam theory's
    √(2E′I G_c)/(a + χh), and the front starts (moves by h/8) within 3 % of δ_c; the root's
    compliance χh is that of a beam on the glue's Winkler foundation, 1/λ = (4E′I/γ_ν)^¼, within
    the 20 % that the shear glue and the arm's shear strain move it by."""
    from orchestrate.studies.cantilever import SMALL, cantilever

    peel = cantilever(tmp_path / "study", SMALL, progress=False)
    stiffness = 1000 / (1 - 0.3 ** 2) / 12  # E′I of scenes/cantilever.toml's arm, h = 1
    assert peel.beam.stiffness == pytest.approx(stiffness, rel=1e-12)
    assert peel.beam.root == pytest.approx((4 * stiffness / 100) ** 0.25, rel=0.2)
    assert [row["a_over_h"] for row in peel.rows] == [10, 12, 14]
    for row in peel.rows:
        theory = math.sqrt(2 * stiffness * 0.01 * (1 - 0.5e-4)) / (row["a_over_h"] + peel.beam.root)
        assert row["force_theory"] == pytest.approx(theory, rel=1e-12)
        assert abs(row["error"]) < 0.03
    started = peel.onset[0]
    assert started["moved_over_h"] == 0.125 and abs(started["error"]) < 0.03
    table = (tmp_path / "study" / "cantilever.csv").read_text().splitlines()
    assert table[0] == "a_over_h,force,force_theory,error" and len(table) == 4
    assert (tmp_path / "study" / "peel.png").stat().st_size > 10_000


def test_a_peeled_arm_keeps_its_gap_to_the_round_off_of_its_lift(tmp_path):
    """The cantilever (scenes/cantilever.toml) lifted by 6t with the default contactTol = 1e-10: its
    interface solves leave gaps of 1.5e-10 at the bonded nodes by step 23, round-off of a
    displacement of 0.46 (1e-9 of it allowed), not a penetration: the run goes on, and its forces are
    those of the scene's own contactTol = 1e-8 to 1e-9."""
    settings = {"time.T": 0.1, "time.N": 30, "output.images": False, "output.times": "final"}
    default = run(REPO / "scenes" / "cantilever.toml", tmp_path / "default", {**settings, "solver.contactTol": 1e-10},
                  progress=False).history
    tuned = run(REPO / "scenes" / "cantilever.toml", tmp_path / "tuned", settings, progress=False).history
    assert default["gapMax"].max() > 1e-10  # beyond contactTol: the check took the round-off allowance
    assert default["gapMax"].max() <= 1e-9 * 6 * 0.1
    assert np.abs(tuned["reactionY1_4"]).max() > 0  # the lifting force
    np.testing.assert_allclose(default["reactionY1_4"], tuned["reactionY1_4"], rtol=1e-9)
