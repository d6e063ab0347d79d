"""The constitutive law of edp/lib/material.idp (docs/model.md §2, §8) against the same law written
independently here, with 3 × 3 tensors: σ = A r + w G s for random strains s, rates r and weights
w per point, (Aτ) = μ tr(τ) I + η τ, (Gτ) = aG tr(τ) I + bG τ with aG, bG from E and ν, the
out-of-plane stress of plane strain (ε33 = 0), and the von Mises norm as √(3/2 s:s) of the
deviator s (the library expands it in the components). Two facts besides: a uniaxial elastic
state (ν = 0) has σ11 = E ε11 and von Mises norm |σ11|; a pure shear rate gives σ12 = η γ̇12/2 and
von Mises √3 |σ12|."""
import textwrap

import numpy as np
import pytest

from orchestrate.freefem import REPO, run_script

pytestmark = pytest.mark.solver

CHECK = textwrap.dedent("""
    include "REPO/edp/lib/material.idp"
    int n = 64, planeStrain = PLANESTRAIN;
    real E = 1.7e3, nu = 0.31, mu = 31.3, eta = 7.7;
    real aG = elasticTrace(E, nu, planeStrain), bG = elasticShear(E, nu);
    real[int] w(n), s11(n), s22(n), s12(n), r11(n), r22(n), r12(n);
    for (int t = 0; t < n; t++) {
      w[t] = randreal1(); s11[t] = randreal1() - 0.5; s22[t] = randreal1() - 0.5; s12[t] = randreal1() - 0.5;
      r11[t] = randreal1() - 0.5; r22[t] = randreal1() - 0.5; r12[t] = randreal1() - 0.5;
    }
    real[int] e11(n), e22(n), e12(n), e33(n), v11(n), v22(n), v12(n), v33(n), vm(n), w1(n), w2(n), w3(n);
    e33 = 0; v33 = 0;
    weakenedElastic(aG, bG, w, s11, s22, s12, e11, e22, e12, e33, planeStrain, w1, w2, w3)
    viscousStress(mu, eta, r11, r22, r12, v11, v22, v12, v33, planeStrain, w1)
    real[int] t11 = e11 + v11, t22 = e22 + v22, t12 = e12 + v12, t33 = e33 + v33;
    vonMisesSquared(t11, t22, t12, t33, planeStrain, vm, w1)
    cout.precision(17);
    for (int t = 0; t < n; t++)
      cout << "row " << w[t] << " " << s11[t] << " " << s22[t] << " " << s12[t] << " " << r11[t] << " " << r22[t] << " "
           << r12[t] << " " << t11[t] << " " << t22[t] << " " << t12[t] << " " << t33[t] << " " << vm[t] << endl;
    // one point: a uniaxial elastic state (ν = 0: aG = 0, bG = E), then a pure shear rate
    real[int] one = [1.], zero = [0.], strain = [0.002], shear = [0.004], a(1), b(1), c(1), d(1), q(1), x(1), y(1), z(1);
    weakenedElastic(elasticTrace(3000., 0., planeStrain), elasticShear(3000., 0.), one, strain, zero, zero, a, b, c, d,
                    planeStrain, x, y, z)
    vonMisesSquared(a, b, c, d, planeStrain, q, x)
    cout << "uniaxial " << (a[0] - 6.) << " " << (sqrt(q[0]) - 6.) << endl;
    viscousStress(0., eta, zero, zero, shear, a, b, c, d, planeStrain, x)
    vonMisesSquared(a, b, c, d, planeStrain, q, x)
    cout << "shear " << (c[0] - 0.5*eta*0.004) << " " << (sqrt(q[0]) - sqrt(3.)*abs(c[0]))/sqrt(q[0]) << endl;
""")


def law(row: np.ndarray, plane_strain: bool) -> tuple[np.ndarray, float]:
    """σ (3 × 3) and σ_vm of one point, from the model's definitions."""
    E, nu, mu, eta = 1.7e3, 0.31, 31.3, 7.7
    lame = E * nu / ((1 + nu) * (1 - 2 * nu)) if plane_strain else E * nu / (1 - nu ** 2)
    w, s11, s22, g12, r11, r22, rg12 = row[:7]
    s = np.array([[s11, g12 / 2, 0], [g12 / 2, s22, 0], [0, 0, 0]])  # ε33 = 0 (plane strain; unused in plane stress)
    r = np.array([[r11, rg12 / 2, 0], [rg12 / 2, r22, 0], [0, 0, 0]])
    plane = np.diag([1.0, 1.0, 1.0 if plane_strain else 0.0])  # δ_αβ, with the out-of-plane entry in plane strain
    sigma = (mu * np.trace(r) * plane + eta * r) + w * (lame * np.trace(s) * plane + E / (1 + nu) * s)
    deviator = sigma - np.trace(sigma) / 3 * np.eye(3)
    return sigma, float(np.sqrt(1.5 * np.sum(deviator * deviator)))


@pytest.mark.parametrize("plane_strain", [0, 1])
def test_the_law_is_the_models(tmp_path, plane_strain):
    script = tmp_path / "law.edp"
    script.write_text(CHECK.replace("REPO", str(REPO)).replace("PLANESTRAIN", str(plane_strain)))
    done = run_script(script)
    assert done.returncode == 0, done.stdout + done.stderr
    rows = np.array([[float(v) for v in line.split()[1:]] for line in done.stdout.splitlines() if line.startswith("row ")])
    assert rows.shape == (64, 12)
    for row in rows:
        sigma, von_mises = law(row, bool(plane_strain))
        assert np.allclose(row[7:11], [sigma[0, 0], sigma[1, 1], sigma[0, 1], sigma[2, 2]], rtol=1e-13, atol=1e-10)
        assert np.sqrt(row[11]) == pytest.approx(von_mises, rel=1e-12)
    facts = {line.split()[0]: [float(v) for v in line.split()[1:]] for line in done.stdout.splitlines()
             if line.split() and line.split()[0] in ("uniaxial", "shear")}
    assert max(map(abs, facts["uniaxial"])) <= 1e-12
    assert abs(facts["shear"][0]) <= 1e-12 and abs(facts["shear"][1]) <= 1e-15
