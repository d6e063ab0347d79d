"""The gallery scenes (scenes/, docs/gallery.md) at a coarse level, each against what its
physics says must happen (the Hertz scene's, against the analytic line contact, is in
tests/test_geometry.py). The gallery resolution runs through `python -m orchestrate gallery`."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from orchestrate.studies.gallery import SCENES as GALLERY
from orchestrate.freefem import REPO
from orchestrate.results import Result, cell_field, load_result
from orchestrate.runner import run

pytestmark = pytest.mark.physics

SCENES = REPO / "scenes"


def coarse(name: str, folder, **overrides) -> Result:
    """A gallery scene with its meshes coarsened, no images; run() raises if the solver failed
    (non-convergence, NaN, ζ or β outside [0, 1], g_h above tolerance)."""
    result = run(SCENES / f"{name}.toml", folder / name, {"output.images": False, **overrides})
    check_interface(result)
    return result


def check_interface(result: Result) -> None:
    """What every run must satisfy: the contact and glue forces on the two bodies cancel, no node
    penetrates beyond the contact tolerance (g_h − π1 g0 ≤ contactTol), the contact forces push
    (λ ≥ 0) and act only where the gap is closed (|λ_j (g_j − π1 g0_j)| ≤ contactTol·max λ)."""
    history = result.history
    scale = max(np.abs(history["forceX1"]).max(), np.abs(history["forceY1"]).max(), 1.0)
    assert history["forceBalance"].max() <= 1e-10 * scale, "the interface forces on the two bodies must cancel"
    assert history["gapMax"].max() <= result.params["contactTol"]
    assert history["lambdaMin"].min() >= 0
    assert history["complementarity"].max() <= result.params["contactTol"] * max(history["contactForce"].max(), 1.0)


def segment_midpoints(line) -> np.ndarray:
    ends = line.cells[0].data[:, :2]  # a line's two points, or a quadratic edge's first two (degree 2)
    return 0.5 * (line.points[ends[:, 0], 0] + line.points[ends[:, 1], 0])


def debonding(name: str, folder) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """A strip lifted off its block (peel, precrack) at the coarse level, with no rebonding
    (γ_r = 0): β only falls (β update of docs/model.md §6). Its β along x at four times."""
    times = [0.5, 1.0, 1.5, 2.0]
    result = coarse(name, folder, **{"body1.mesh.n": 40, "body2.mesh.n": 25, "output.times": times})
    assert np.all(np.diff(result.history["betaMean"]) <= 0)
    return [(time, *bonding_along_x(result, time)) for time in times]


def bonding_along_x(result: Result, time: float) -> tuple[np.ndarray, np.ndarray]:
    """The segment midpoints' x on Γ_C and their β at an output time, in x order."""
    line = result.fields("contact", time)
    x, beta = segment_midpoints(line), line.cell_data["beta"][0]
    order = np.argsort(x)
    return x[order], beta[order]


@pytest.mark.parametrize("scheme, order", [("euler", 1), ("semi-implicit", 1), ("bdf2", 1), ("euler", 2), ("bdf2", 2)])
def test_the_tilted_patch_carries_its_uniform_stress_exactly(tmp_path, scheme, order):
    """u = −0.01 t (x, y): ε(u) = −0.01 t I, isotropic, so a frictionless interface of any
    slope carries it. With A τ = μ tr(τ) I + η τ and plane-stress G (docs/model.md §2), ζ uniform:
    σⁿ = −(2μ + η)·0.01 − ζⁿ E/(1 − ν)·0.01 tₙ in every triangle; the contact pressure balances
    step n's equation (docs/model.md §6, §9), whose rate is exact on this u for every scheme and
    whose elastic part is, with e = 0.01 E/(1 − ν): euler e ζⁿ⁻¹ tₙ₋₁ (explicit in ζⁿ⁻¹, uⁿ⁻¹);
    semi-implicit e (tₙ − (1 − ζⁿ⁻¹) tₙ₋₁) (G implicit, its weakening explicit); bdf2 e ζ* tₙ
    (ζ* = 2ζⁿ⁻¹ − ζⁿ⁻², and u* = 2uⁿ⁻¹ − uⁿ⁻² is uⁿ for a u linear in t). Displacements of degree
    2 (space.order) hold it as well, on the bodies' meshes split in four in their .vtu."""
    result = coarse("tilted_patch", tmp_path, **{"body1.mesh.n": 6, "body2.mesh.n": 9, "output.times": "final",
                                                 "time.scheme": scheme, "space.order": order})
    assert json.loads((result.folder / "run.json").read_text())["order"] == order
    p, h = result.params, result.history
    E, nu, mu, eta, T, N = p["E1"], p["nu1"], p["mu1"], p["eta1"], p["T"], p["N"]
    k = T / N
    zeta = h["zetaMin1"]
    assert np.allclose([h["zetaMax1"], h["zetaMin2"], h["zetaMax2"]], zeta, rtol=0, atol=1e-14)
    viscous, elastic = (2 * mu + eta) * 0.01, E / (1 - nu) * 0.01
    stress = viscous + elastic * zeta[-1] * T
    pressure = viscous + elastic * {"euler": zeta[-2] * (T - k), "semi-implicit": T - (1 - zeta[-2]) * (T - k),
                                     "bdf2": min(max(2 * zeta[-2] - zeta[-3], 0), 1) * T}[scheme]
    for body in ("body1", "body2"):
        mesh = result.fields(body)
        assert np.allclose(cell_field(mesh, "vonMises"), stress, rtol=1e-12)
        assert np.allclose(cell_field(mesh, "sigma12"), 0, atol=1e-12 * stress)
        # the .vtu points are Float32 (docs/freefem-facts.md): u is exact to their rounding
        assert np.allclose(mesh.point_data["u"][:, :2], -0.01 * T * mesh.points[:, :2], rtol=0, atol=1e-7 * 0.02 * 2)
    line = result.fields("contact")
    assert np.allclose(line.point_data["pressure"], pressure, rtol=1e-12)
    assert np.abs(line.point_data["gap"]).max() <= 1e-14


def test_the_tilted_patch_as_pyvista_datasets(tmp_path):
    """Result.grid hands pyvista the body's triangles and fields: sampled along a line across each
    body, the von Mises stress is the patch's exact uniform value at every point the line meets,
    and warped by u the body is the uniform compression of its points (u = −0.01 t (x, y))."""
    result = coarse("tilted_patch", tmp_path, **{"body1.mesh.n": 6, "body2.mesh.n": 9, "output.times": "final"})
    p, h = result.params, result.history
    stress = (2 * p["mu1"] + p["eta1"]) * 0.01 + p["E1"] / (1 - p["nu1"]) * 0.01 * h["zetaMin1"][-1] * p["T"]
    for body in ("body1", "body2"):
        grid = result.grid(body)
        assert grid.n_cells == len(cell_field(result.fields(body), "vonMises"))  # triangles only
        (x0, x1, y0, y1, _, _) = grid.bounds
        line = grid.sample_over_line((x0, y0, 0), (x1, y1, 0), resolution=50)
        met = line["vtkValidPointMask"].astype(bool)
        assert met.sum() > 10 and np.allclose(line["vonMises"][met], stress, rtol=1e-12)
        warped = grid.warp_by_vector("u", factor=1.0)
        assert np.allclose(warped.points[:, :2], (1 - 0.01 * p["T"]) * grid.points[:, :2], rtol=0, atol=1e-6)
    assert result.grid("contact").n_cells == len(result.fields("contact").cells[0].data)


def test_the_tilted_patch_in_plane_strain_has_its_out_of_plane_stress(tmp_path):
    """The same uniform compression ε = e I, e = −0.01 t, in plane strain (ε33 = 0): with
    λ = Eν/((1+ν)(1−2ν)) and 2G = E/(1+ν) (docs/model.md §2), σ11 = σ22 = (2μ + η)ė + ζ(2λ + 2G)e and
    σ33 = 2μė + 2ζλe, so the von Mises stress of the 3D state is |σ11 − σ33| = |ηė + 2Gζe|:
    the out-of-plane stress enters it, and run.json says the bodies are in plane strain."""
    strain = {f"body{b}.material.planeStrain": True for b in (1, 2)}
    result = coarse("tilted_patch", tmp_path, **{"body1.mesh.n": 6, "body2.mesh.n": 9, "output.times": "final",
                                                 "output.fields": ["bodies", "stress", "contact"], **strain})
    p, h = result.params, result.history
    E, nu, mu, eta, T = p["E1"], p["nu1"], p["mu1"], p["eta1"], p["T"]
    zeta = h["zetaMin1"][-1]
    lame, shear2 = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (1 + nu)
    rate, e = -0.01, -0.01 * T
    in_plane = (2 * mu + eta) * rate + zeta * (2 * lame + shear2) * e
    out_of_plane = 2 * mu * rate + 2 * zeta * lame * e
    for body in ("body1", "body2"):
        mesh = result.fields(body)
        assert np.allclose(cell_field(mesh, "sigma11"), in_plane, rtol=1e-12)
        assert np.allclose(cell_field(mesh, "sigma33"), out_of_plane, rtol=1e-12)
        assert np.allclose(cell_field(mesh, "vonMises"), abs(eta * rate + shear2 * zeta * e), rtol=1e-12)
    facts = json.loads((result.folder / "run.json").read_text())
    assert facts["stressState1"] == facts["stressState2"] == "plane strain"


def test_the_peel_front_travels_from_the_lifted_end(tmp_path):
    """The lifted right end debonds first and the front (β = ½) moves left while the far end stays
    bonded."""
    fronts = []
    for time, x, beta in debonding("peel", tmp_path):
        assert beta[:10].min() > 0.99, f"the far end must stay bonded at t = {time}"
        fronts.append(x[beta < 0.5].min())
        if time >= 1.0:
            assert beta[-1] < 1e-3, f"the lifted end must be debonded at t = {time}"
    assert np.all(np.diff(fronts) < 0), f"the front must move towards the far end: {fronts}"
    assert fronts[-1] < 6 - 1.5, "by T the front has travelled more than a quarter of the strip"


def test_indentation_damages_the_base_under_the_punch_edges(tmp_path):
    """The punch does not damage (λ_D = λ_u = 0, ζ⁰ = 1): ζ ≡ 1 there. The stress of a flat
    punch is singular at its edges x = ±0.5 on Γ_C, so the base's damage is lowest there."""
    result = coarse("indentation", tmp_path, **{"body1.mesh.n": 8, "body2.mesh.n": 12})
    h = result.history
    assert h["zetaMin1"].min() == 1.0 and h["zetaMax1"].max() == 1.0
    base = result.fields("body2")
    zeta = base.point_data["zeta"]
    weakest = base.points[np.argmin(zeta), :2]
    assert abs(abs(weakest[0]) - 0.5) < 1e-9 and abs(weakest[1]) < 1e-9, f"damage peaks at {weakest}"
    assert zeta.min() < 0.9
    # the punch presses down (the contact force on it points up) and the load grows with t
    assert np.all(np.diff(h["contactForce"]) > 0) and h["forceY1"][-1] > 0


def test_the_shear_load_is_held_by_the_glue_until_it_debonds(tmp_path):
    """Frictionless contact: only the tangential glue p_τ β R*(slip) carries the shear, and the
    opening (γ_ν term) debonds it, so the shear force rises, peaks, and falls with β."""
    result = coarse("shear", tmp_path, **{"body1.mesh.n": 8, "body2.mesh.n": 11})
    h = result.history
    shear = np.abs(h["forceX1"])
    peak = int(np.argmax(shear))
    assert 0 < peak < len(shear) - 1
    assert shear[-1] < 0.1 * shear[peak]
    assert h["betaMean"][-1] < 0.05 and np.all(np.diff(h["betaMean"]) <= 0)
    assert h["contactLength"].max() == 0, "the opening load never closes the interface"


def test_the_rounded_punch_closes_its_gap_then_spreads_its_contact(tmp_path):
    """The punch starts 0.02 above the block and its top moves down by 0.12 t: nothing touches
    before t = 1/6 (no force, no closed length); after it the contact closes over the flat face
    and spreads into the rounded corners, never shrinking, and the force grows. The stiff punch
    does not damage; the block's damage is lowest under the face's ends (x = ±0.75), where the
    rounded corners begin."""
    result = coarse("punch", tmp_path, **{"body1.mesh.n": 30, "body2.mesh.n": 12, "time.N": 24,
                                          "output.times": "final"})
    h = result.history
    apart = h["t"] < 0.02 / 0.12 - 1e-9
    assert np.all(h["contactForce"][apart] == 0) and np.all(h["contactLength"][apart] == 0)
    assert np.all(h["contactForce"][~apart] > 0)
    assert np.all(np.diff(h["contactLength"][~apart]) >= 0) and np.all(np.diff(h["contactForce"][~apart]) > 0)
    assert h["contactLength"][-1] > 1.5 + 0.1, "the contact spreads beyond the flat face"
    assert h["zetaMin2"].min() == 1.0
    block = result.fields("body1")
    zeta = block.point_data["zeta"]
    weakest = block.points[np.argmin(zeta), :2]
    assert 0.6 < abs(weakest[0]) < 1.0 and weakest[1] > -0.3, f"damage peaks at {weakest}"
    assert zeta.min() < 0.95
    # the bodies start apart: drawn magnified, the closed gap would look like an overlap
    from orchestrate.render import render_fields

    assert render_fields(result, tmp_path / "fields.png")["magnification"] == 1


def test_the_precrack_stays_open_and_the_front_starts_at_its_tip(tmp_path):
    """β⁰ = (x < 4.5): β stays 0 on the crack at every time (β₊ in both terms of its update); the
    bonded part loses bonds from the crack tip on (its lowest β is at the tip at every output), and
    the front moves left while the far end stays bonded."""
    fronts = []
    for time, x, beta in debonding("precrack", tmp_path):
        assert np.all(beta[x > 4.5] == 0), f"the crack must stay open at t = {time}"
        bonded = x < 4.5
        assert beta[bonded][-1] == beta[bonded].min() < 1, f"the tip must debond first (t = {time})"
        assert beta[x < 1].min() > 0.99, f"the far end must stay bonded at t = {time}"
        fronts.append(x[bonded & (beta < 0.5)].min() if np.any(bonded & (beta < 0.5)) else 4.5)
    assert np.all(np.diff(fronts) <= 0) and fronts[-1] < 4.5 - 0.5, f"the front must move left: {fronts}"


@pytest.mark.parametrize("order", [1, 2])
def test_the_joint_peels_from_its_tip_and_its_reaction_is_the_glue_s_pull(tmp_path, order):
    """The polymer layer peeled off aluminium (scenes/joint.toml), coarser: the layer is held only at
    its peeled end, so that end's reaction balances the glue's pull across Γ_C at every step; the
    crack runs left from the pre-crack's tip (x = 27) once the force has risen, only left, while the
    far end stays bonded; and the energies balance to the time error (no damage, no rebonding, the
    openings below L). So with displacements of degree 2 (its glue's band matrices, β on segments
    of three nodes)."""
    result = coarse("joint", tmp_path, **{"body1.mesh.n": 60, "body2.mesh.n": 30, "time.N": 100, "space.order": order})
    h = result.history
    np.testing.assert_allclose(h["reactionX1_2"] + h["forceX1"], 0, atol=1e-9 * np.abs(h["reactionY1_2"]).max())
    np.testing.assert_allclose(h["reactionY1_2"] + h["forceY1"], 0, atol=1e-9 * np.abs(h["reactionY1_2"]).max())
    front = h["debondFront"]
    assert front[0] == pytest.approx(27, abs=0.05) and np.all(np.diff(front) <= 1e-12) and front[-1] < 24
    started = np.argmax(front < 26.9)
    assert h["reactionY1_2"][started] > 0.5 * h["reactionY1_2"].max()  # the force had risen first
    assert h["betaMax"][-1] == 1 and h["surfaceEnergy"][-1] > 0
    assert np.abs(h["energyBalance"][10:]).max() < 1e-2


def test_the_gallery_command_runs_every_scene_at_its_own_resolution(tmp_path):
    """`python -m orchestrate gallery` as a user runs it: every scene of docs/gallery.md, its
    images and its invariants."""
    done = subprocess.run([sys.executable, "-m", "orchestrate", "gallery", "--out", str(tmp_path)],
                          cwd=REPO, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    for name in GALLERY:
        result = load_result(tmp_path / name)
        check_interface(result)
        assert result.history["t"][-1] == pytest.approx(result.params["T"])
        for image in ("fields.png", "contact_line.png", "history.png"):
            assert (tmp_path / name / image).stat().st_size > 10_000
    assert (tmp_path / "peel" / "beta_xt.png").exists() and (tmp_path / "precrack" / "beta_xt.png").exists()
    assert not (tmp_path / "punch" / "beta_xt.png").exists()  # no glue (β⁰ = 0, no rebonding): no β to show
    for image in ("pressure.png", "vonmises.png"):  # Hertz against the analytic solution
        assert (tmp_path / "hertz" / image).stat().st_size > 10_000
    for image in ("joint-reactionY1_2-vs-t.png", "joint-debondFront-vs-t.png"):  # the joint's curves
        assert (tmp_path / image).stat().st_size > 10_000


def test_the_polymer_pad_runs_stiff_materials_in_few_steps_to_its_target(tmp_path):
    """E/η = 2000 and 7000 s⁻¹ over 4 s: the paper's scheme would need N ≥ T ρ/2 (its elastic
    bound, about 10⁴ steps); bdf2 with time.N = "auto" takes a few hundred and reaches the target
    against bdf2 with eight times its steps on the same meshes. The glue only lets go (γ_r = 0),
    the lifted pad never touches the block, the block (λ = 0) never damages."""
    from orchestrate.manifest import facts
    from orchestrate.steps import relative_distance

    sizes = {"body1.mesh.n": 50, "body2.mesh.n": 40, "output.times": "final", "output.fields": ["state"]}
    result = coarse("polymer_pad", tmp_path, **sizes, **{"time.targetError": 1e-3})
    h, steps = result.history, len(result.history["t"])
    rho = facts(result.folder)["rho"]
    assert steps < 0.05 * result.params["T"] * rho / 2
    reference = run(SCENES / "polymer_pad.toml", tmp_path / "reference",
                    {**sizes, "output.images": False, "time.N": 8 * steps})
    assert relative_distance(result.folder, reference.folder, steps, 8 * steps) <= 1.2e-3
    assert np.all(np.diff(h["betaMax"]) <= 1e-15) and h["betaMin"][-1] < 0.3
    assert np.all(h["contactLength"] == 0) and np.all(h["zetaMin2"] == 1)
    assert h["zetaMin1"].min() < 0.8
    with pytest.raises(Exception, match="exceeds the explicit elastic bound"):
        run(SCENES / "polymer_pad.toml", tmp_path / "euler", {**sizes, "output.images": False, "time.N": steps,
                                                                "time.scheme": "euler"})


@pytest.mark.unit
def test_the_committed_gallery_can_be_made_again_in_place():
    """`make gallery` (orchestrate gallery --force) replaces the committed folders of a clean clone:
    each holds a run's summary and images this package drew (their mark), nothing a user made."""
    from orchestrate.runner import refuse_existing

    for name in GALLERY:
        refuse_existing(REPO / "results" / "gallery" / name, force=True)
