"""The damage step's right-hand side in the plugin edp/plugins/damagesource.cpp (edp/lib/damage.idp)
is the script it replaced, to the bit, in each of its branches: ζ below ζ_min somewhere (clamped,
the nodes counted) or not, ε:ε above L somewhere (truncated) or not, λ_D = 0 or λ_u = 0. And a fact
of its own: with λ_D = λ_u = 0 the source is M(inertia + λ_w), whose sum over the nodes is
(inertia + λ_w) times the area when the inertia is constant."""
import textwrap

import pytest

from orchestrate.freefem import REPO, run_script

pytestmark = pytest.mark.solver

CHECK = textwrap.dedent("""
    load "damagesource"
    include "REPO/edp/lib/arrays.idp"
    real zetaMin = 1e-3, L = 0.7;
    mesh Th = square(9, 7, [3*x, 2*y]);
    fespace Sh(Th, P1);
    fespace Ph(Th, P0);
    varf vMass(z, w) = int2d(Th)(z*w);
    varf vCellLoad(q, w) = int2d(Th)(q*w);
    matrix Md = vMass(Sh, Sh), Q = vCellLoad(Ph, Sh);
    int ops = damageOperators(Md, Q);
    // the script the plugin replaced (damage.idp before it)
    func int damageSourceScript(matrix & Md, matrix & Q, real lambdaD, real lambdaU, real lambdaW, real[int] & inertia,
                                real[int] & zeta, real[int] & density, real[int] & b) {
      int below = 0;
      real[int] nodal = inertia;
      if (lambdaD != 0) {
        real[int] inverse(zeta.n);
        inverse = 1;
        if (zeta.min < zetaMin) {
          real[int] gap = -zeta;
          gap += zetaMin;
          below = lrint(positivePart01(gap).sum);
          inverse = inverse ./ maxWith(zeta, zetaMin);
        } else inverse = inverse ./ zeta;
        nodal += lambdaD*inverse;
      }
      nodal += lambdaW - lambdaD;
      b = Md*nodal;
      if (lambdaU != 0) {
        real[int] cellLoad(b.n);
        if (density.max <= L) cellLoad = Q*density;
        else cellLoad = Q*minWith(density, L);
        b -= (0.5*lambdaU)*cellLoad;
      }
      return below;
    }
    real[int] inertia(Sh.ndof), zeta(Sh.ndof), density(Ph.ndof), b(Sh.ndof), bScript(Sh.ndof);
    for (int j = 0; j < Sh.ndof; j++) { inertia[j] = 10*randreal1(); zeta[j] = 0.05 + 0.95*randreal1(); }
    for (int t = 0; t < Ph.ndof; t++) density[t] = 0.6*randreal1();
    real[int,int] cases = [[0.01, 1, 0], [0.01, 1, 0.2], [0, 1, 0.1], [0.02, 0, 0.3]];
    real nan = sqrt(-1.);
    /* ζ and ε:ε inside, ζ below ζ_min, ε:ε above L, both; then a NaN after a value out of range
       (FreeFEM's min and max pass over the values before a NaN: no clamp, no truncation) */
    for (int variant = 0; variant < 6; variant++)
      for (int c = 0; c < cases.n; c++) {
        real[int] z = zeta, d = density;
        if (variant % 2 == 1 && variant < 4) { z[3] = 0; z[17] = 1e-5; z[40] = -1e-9; }
        if (variant == 2 || variant == 3) { d[5] = 2.5; d[11] = 0.71; }
        if (variant == 4) { z[0] = 0; z[1] = nan; }
        if (variant == 5) { d[0] = 5; d[1] = nan; }
        real[int] data = [cases(c, 0), cases(c, 1), cases(c, 2), zetaMin, L];
        int below = damageSource(ops, data, inertia, z, d, b);
        int belowScript = damageSourceScript(Md, Q, cases(c, 0), cases(c, 1), cases(c, 2), inertia, z, d, bScript);
        int same = 1;  /* to the bit, a NaN or an infinity in the same places */
        for (int j = 0; j < b.n; j++) same = same && (b[j] == bScript[j] || (isNaN(b[j]) && isNaN(bScript[j])));
        cout << "case " << variant << " " << c << " " << (1 - same) << " " << below << " " << belowScript << endl;
      }
    real[int] one(Sh.ndof), data = [0, 0, 0.25, zetaMin, L];
    one = 2;
    damageSource(ops, data, one, zeta, density, b);
    cout << "mass " << abs(b.sum - 2.25*6)/(2.25*6) << endl;
""")


def test_the_plugins_damage_source_is_the_scripts_to_the_bit_in_every_branch(tmp_path):
    script = tmp_path / "source.edp"
    script.write_text(CHECK.replace("REPO", str(REPO)))
    done = run_script(script)
    assert done.returncode == 0, done.stdout + done.stderr
    cases = [line.split()[1:] for line in done.stdout.splitlines() if line.startswith("case ")]
    assert len(cases) == 24
    for variant, case, apart, below, below_script in cases:
        assert float(apart) == 0 and below == below_script, (variant, case)
        assert int(below) == (3 if variant in ("1", "3") and case != "2" else 0), (variant, case)
    mass = [float(line.split()[1]) for line in done.stdout.splitlines() if line.startswith("mass ")]
    assert mass and mass[0] <= 1e-14


def test_a_number_that_is_no_damage_operators_is_named(tmp_path):
    script = tmp_path / "wrong.edp"
    script.write_text('load "damagesource"\nreal[int] d = [0, 0, 0, 0, 1], a(3), b(3), c(3), e(3);\n'
                      'damageSource(2, d, a, b, c, e);\n')
    done = run_script(script)
    assert done.returncode != 0 and "not a number damageOperators gave" in done.stdout + done.stderr
