"""The per-triangle stresses of edp/plugins/stresses.cpp (edp/lib/body.idp, bodyFigures) against the
same formulas written as FreeFEM vector operations (the script the plugin replaced): equal to the
bit for the Euler and the BDF2 rate, in plane stress and plane strain. And two facts of the
formulas themselves: a uniaxial elastic state σ11 = E ε11 (ν = 0, ζ̄ = 1, no rate) has von Mises
norm |σ11|, and a pure shear rate gives σ12 = η/k · ½γ̇12, von Mises √3 |σ12|. The largest von
Mises norm is FreeFEM's max of the array, also where a stress is not a number."""
import textwrap

import pytest

from orchestrate.freefem import run_script

pytestmark = pytest.mark.solver

CHECK = textwrap.dedent("""
    load "stresses"
    int n = 257;
    real aG = 1.7e3, bG = 2.9e3, mu = 31.3, eta = 7.7, k = 0.013;
    int planeStrain = PLANESTRAIN, bdf2Rate = BDF2;
    real[int] zetaBar(n), e11(n), e22(n), g12(n), o11(n), o22(n), og12(n), p11(n), p22(n), pg12(n);
    for (int t = 0; t < n; t++) {
      zetaBar[t] = randreal1(); e11[t] = randreal1() - 0.5; e22[t] = randreal1() - 0.5; g12[t] = randreal1() - 0.5;
      o11[t] = randreal1() - 0.5; o22[t] = randreal1() - 0.5; og12[t] = randreal1() - 0.5;
      p11[t] = randreal1() - 0.5; p22[t] = randreal1() - 0.5; pg12[t] = randreal1() - 0.5;
    }
    real[int] s11(n), s22(n), s12(n), s33(n), vm(n), el11(n), el22(n), el12(n);
    s33 = 0;
    real[int] material = [aG, bG, mu, eta, k, planeStrain, bdf2Rate, 1.];
    real largest = stresses(material, zetaBar, e11, e22, g12, o11, o22, og12, p11, p22, pg12, s11, s22, s12, s33, vm,
                            el11, el22, el12);
    // the script's formulas
    real[int] d11 = e11 - o11, d22 = e22 - o22, dg12 = g12 - og12;
    if (bdf2Rate) {
      d11 = 1.5*e11 + (-2.)*o11; d11 += 0.5*p11;
      d22 = 1.5*e22 + (-2.)*o22; d22 += 0.5*p22;
      dg12 = 1.5*g12 + (-2.)*og12; dg12 += 0.5*pg12;
    }
    real[int] trace = e11 + e22, ze11 = zetaBar .* e11, ze22 = zetaBar .* e22, zg12 = zetaBar .* g12;
    real[int] zeTrace = zetaBar .* trace;
    real[int] r11 = aG*zeTrace + bG*ze11, r22 = aG*zeTrace + bG*ze22, r12 = (0.5*bG)*zg12;
    real[int] rateTrace = d11 + d22, viscous11 = (mu/k)*rateTrace + (eta/k)*d11;
    real[int] viscous22 = (mu/k)*rateTrace + (eta/k)*d22;
    real[int] t11 = viscous11 + r11, t22 = viscous22 + r22, t12 = r12 + (0.5*eta/k)*dg12, t33(n);
    t33 = 0;
    real[int] square11 = t11 .* t11, square22 = t22 .* t22, cross = t11 .* t22, square12 = t12 .* t12;
    real[int] tvm = square11 + square22;
    tvm -= cross;
    tvm = tvm + 3*square12;
    if (planeStrain) {
      t33 = (mu/k)*rateTrace + aG*zeTrace;
      real[int] inPlane = t11 + t22, square33 = t33 .* t33, cross33 = t33 .* inPlane;
      tvm += square33;
      tvm -= cross33;
    }
    real apart = abs(largest - sqrt(tvm.max));
    s11 -= t11; s22 -= t22; s12 -= t12; s33 -= t33; vm -= tvm; el11 -= r11; el22 -= r22; el12 -= r12;
    real[int] each = [s11.linfty, s22.linfty, s12.linfty, s33.linfty, vm.linfty, el11.linfty, el22.linfty, el12.linfty];
    apart = max(apart, each.max);
    cout << "apart " << apart << endl;
    // one triangle: a uniaxial elastic state (ν = 0: aG = 0, bG = E), then a pure shear rate
    real[int] one = [1.], zero = [0.], strain = [0.002], shear = [0.004], t1(1), t2(1), t3(1), t4(1), t5(1), f1(1), f2(1), f3(1);
    t4 = 0;
    real[int] elastic = [0., 3000., mu, eta, k, planeStrain, 0., 1.];
    real uniaxial = stresses(elastic, one, strain, zero, zero, strain, zero, zero, zero, zero, zero, t1, t2, t3, t4, t5, f1, f2, f3);
    cout << "uniaxial " << (uniaxial - 6.) << " " << t1[0] - 6. << endl;
    real[int] viscous = [0., 3000., 0., eta, k, planeStrain, 0., 1.];
    real pure = stresses(viscous, one, zero, zero, shear, zero, zero, zero, zero, zero, zero, t1, t2, t3, t4, t5, f1, f2, f3);
    cout << "shear " << (t3[0] - 0.5*eta/k*0.004 - 0.5*3000*0.004) << " " << (pure - sqrt(3.)*abs(t3[0]))/pure << endl;
    // a NaN among the stresses: the largest is FreeFEM's max of the array, NaN and all
    real nan = sqrt(-1.);
    real[int] nanFirst = [nan, 1., 0.1], nanMiddle = [1., nan, 0.1], z3(3), o3(3), r1(3), r2(3), r3(3), r4(3), r5(3);
    real[int] q1(3), q2(3), q3(3);
    z3 = 0; o3 = 1; r4 = 0;
    real[int] plain = [0., 1., 0., 0., k, planeStrain, 0., 1.];
    real first = stresses(plain, o3, nanFirst, z3, z3, z3, z3, z3, z3, z3, z3, r1, r2, r3, r4, r5, q1, q2, q3);
    cout << "nanfirst " << first << " " << sqrt(r5.max) << endl;
    real middle = stresses(plain, o3, nanMiddle, z3, z3, z3, z3, z3, z3, z3, z3, r1, r2, r3, r4, r5, q1, q2, q3);
    cout << "nanmiddle " << middle << " " << sqrt(r5.max) << endl;
""")


@pytest.mark.parametrize("plane_strain", [0, 1])
@pytest.mark.parametrize("bdf2", [0, 1])
def test_the_plugins_stresses_are_the_scripts_to_the_bit_and_obey_their_formulas(tmp_path, plane_strain, bdf2):
    script = tmp_path / "stresses.edp"
    script.write_text(CHECK.replace("PLANESTRAIN", str(plane_strain)).replace("BDF2", str(bdf2)))
    done = run_script(script)
    assert done.returncode == 0, done.stdout + done.stderr
    printed = {line.split()[0]: line.split()[1:] for line in done.stdout.splitlines() if line.split()}
    facts = {name: [float(v) for v in printed[name]] for name in ("apart", "uniaxial", "shear")}
    for name in ("nanfirst", "nanmiddle"):  # as printed: the same number, or nan both
        assert printed[name][0] == printed[name][1], printed[name]
    assert facts["apart"] == [0]
    assert max(abs(v) for v in facts["uniaxial"]) <= 1e-12
    assert abs(facts["shear"][0]) <= 1e-12 and abs(facts["shear"][1]) <= 1e-15


BDF2_EXPLICIT = textwrap.dedent("""
    load "stresses"
    int n = 263;
    real aG = 1.7e3, bG = 2.9e3, mu = 31.3, eta = 7.7, k = 0.013;
    real[int] zs(n), e11(n), e22(n), g12(n), o11(n), o22(n), og12(n);
    for (int t = 0; t < n; t++) {
      zs[t] = randreal1(); e11[t] = randreal1() - 0.5; e22[t] = randreal1() - 0.5; g12[t] = randreal1() - 0.5;
      o11[t] = randreal1() - 0.5; o22[t] = randreal1() - 0.5; og12[t] = randreal1() - 0.5;
    }
    real[int] material = [aG, bG, mu, eta, k], x11(n), x22(n), x12(n), density(n);
    bdf2Explicit(material, zs, e11, e22, g12, o11, o22, og12, x11, x22, x12, density);
    // the script it replaced: the viscous force of A ε(4uⁿ − uⁿ⁻¹)/(2k), plus the weakened one of (1 − ζ̄*) G ε(u*)
    real[int] r11 = (2/k)*e11 + (-0.5/k)*o11, r22 = (2/k)*e22 + (-0.5/k)*o22, r12 = (2/k)*g12 + (-0.5/k)*og12;
    real[int] rTrace = r11 + r22;
    real[int] v11 = mu*rTrace + eta*r11, v22 = mu*rTrace + eta*r22, v12 = (0.5*eta)*r12;
    real[int] s11 = 2*e11 + (-1.)*o11, s22 = 2*e22 + (-1.)*o22, s12 = 2*g12 + (-1.)*og12;
    real[int] w = -zs;
    w += 1;
    real[int] sTrace = s11 + s22, ws11 = w .* s11, ws22 = w .* s22, ws12 = w .* s12, wTrace = w .* sTrace;
    real[int] w11 = aG*wTrace + bG*ws11, w22 = aG*wTrace + bG*ws22, w12 = (0.5*bG)*ws12;
    real[int] t11 = v11 + w11, t22 = v22 + w22, t12 = v12 + w12;
    real[int] q11 = s11 .* s11, q22 = s22 .* s22, q12 = s12 .* s12, tdensity = q11 + q22;  /* ε:ε, the script's grouping */
    tdensity = tdensity + 0.5*q12;
    t11 -= x11; t22 -= x22; t12 -= x12; tdensity -= density;
    real[int] each = [t11.linfty, t22.linfty, t12.linfty, tdensity.linfty];
    cout << "apart " << each.max << endl;
    // a state at rest (uⁿ⁻¹ = uⁿ, ζ* = ζ̄): σ* + ζ̄ G ε(u) = (3/(2k)) A ε(u) + G ε(u), the BDF2 matrix's stress
    bdf2Explicit(material, zs, e11, e22, g12, e11, e22, g12, x11, x22, x12, density);
    real[int] trace = e11 + e22, a11 = mu*trace + eta*e11, a22 = mu*trace + eta*e22, a12 = (0.5*eta)*g12;
    real[int] k11 = aG*trace + bG*e11, k22 = aG*trace + bG*e22, k12 = (0.5*bG)*g12;
    k11 += (1.5/k)*a11; k22 += (1.5/k)*a22; k12 += (1.5/k)*a12;
    real[int] zt = zs .* trace, z11 = zs .* e11, z22 = zs .* e22, z12 = zs .* g12;
    x11 += aG*zt + bG*z11; x22 += aG*zt + bG*z22; x12 += (0.5*bG)*z12;
    x11 -= k11; x22 -= k22; x12 -= k12;
    real[int] rest = [x11.linfty/k11.linfty, x22.linfty/k22.linfty, x12.linfty/k12.linfty];
    cout << "rest " << rest.max << endl;
""")


def test_the_bdf2_explicit_stress_is_the_scripts_to_the_bit_and_keeps_a_state_at_rest(tmp_path):
    """bdf2Explicit (σ* and ε(u*):ε(u*) of the next BDF2 step) against the script's vector operations it
    replaced, to the bit; and the scheme's consistency: from a state at rest the explicit stress plus
    the implicit ζ̄ G ε(u) is the stress of the BDF2 matrix 3A/(2k) + G, so the state stays at rest."""
    script = tmp_path / "bdf2explicit.edp"
    script.write_text(BDF2_EXPLICIT)
    done = run_script(script)
    assert done.returncode == 0, done.stdout + done.stderr
    printed = {line.split()[0]: float(line.split()[1]) for line in done.stdout.splitlines() if len(line.split()) == 2}
    assert printed["apart"] == 0
    assert printed["rest"] <= 1e-13


def test_without_fields_the_stresses_are_not_written_and_the_largest_norm_is_the_same(tmp_path):
    """A step whose files do not hold the stresses (fields = 0) gets the same largest von Mises norm
    (the history's) and the same next explicit stress, and leaves the stress arrays as they were."""
    script = tmp_path / "fields.edp"
    script.write_text(textwrap.dedent("""
        load "stresses"
        int n = 101;
        real[int] z(n), e(n), f(n), g(n), s11(n), s22(n), s12(n), s33(n), vm(n), x11(n), x22(n), x12(n), y11(n), y22(n), y12(n);
        for (int t = 0; t < n; t++) { z[t] = randreal1(); e[t] = randreal1() - 0.5; f[t] = randreal1() - 0.5; g[t] = randreal1() - 0.5; }
        real[int] with = [1.7e3, 2.9e3, 31.3, 7.7, 0.013, 1., 0., 1.], without = [1.7e3, 2.9e3, 31.3, 7.7, 0.013, 1., 0., 0.];
        real written = stresses(with, z, e, f, g, f, g, e, e, e, e, s11, s22, s12, s33, vm, x11, x22, x12);
        s11 = 7; s22 = 7; s12 = 7; s33 = 7; vm = 7;
        real kept = stresses(without, z, e, f, g, f, g, e, e, e, e, s11, s22, s12, s33, vm, y11, y22, y12);
        real[int] untouched = [s11.max, s11.min, s22.max, s22.min, s12.max, s12.min, s33.max, s33.min, vm.max, vm.min];
        y11 -= x11; y22 -= x22; y12 -= x12;
        cout << "largest " << (kept - written) << endl;
        cout << "untouched " << untouched.max << " " << untouched.min << endl;
        cout << "explicit " << max(y11.linfty, max(y22.linfty, y12.linfty)) << endl;
    """))
    done = run_script(script)
    assert done.returncode == 0, done.stdout + done.stderr
    printed = {line.split()[0]: [float(v) for v in line.split()[1:]] for line in done.stdout.splitlines()
               if line.split() and line.split()[0] in ("largest", "untouched", "explicit")}
    assert printed == {"largest": [0.0], "untouched": [7.0, 7.0], "explicit": [0.0]}
