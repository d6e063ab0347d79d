"""The damage step's right-hand side (edp/lib/damage.idp, damageSourceOf; docs/model.md §3, §6),
b = M(inertia + λ_D (1 − ζc)/ζc + λ_w) − ½ λ_u Q R(ε:ε), ζc = max(ζ, ζ_min), R(s) = min(s, L), against
its value for fields constant on the mesh, where every integral is the area times the constant:
Σ_j b_j = |Ω| (inertia + λ_D (1 − ζc)/ζc + λ_w − ½ λ_u R(ε:ε)), in each branch (ζ below ζ_min: clamped
and its nodes counted; ε:ε above L: truncated; λ_D = 0; λ_u = 0). And for fields that vary, the
part each term adds is linear in it: b(λ_D, λ_u, λ_w) = b(0, 0, 0) + the three parts apart."""
import textwrap

import pytest

from orchestrate.freefem import REPO, run_script

pytestmark = pytest.mark.solver

CHECK = textwrap.dedent("""
    include "REPO/edp/lib/arrays.idp"
    real zetaMin = 1e-3, L = 0.7;
    string linearSolver = "CHOLMOD";
    include "REPO/edp/lib/damage.idp"
    mesh Th = square(9, 7, [3*x, 2*y]);  /* |Ω| = 6 */
    fespace Sh(Th, P1);
    fespace Ph(Th, P0);
    varf vMass(z, w) = int2d(Th)(z*w);
    varf vCellLoad(q, w) = int2d(Th)(q*w);
    matrix Md = vMass(Sh, Sh), Q = vCellLoad(Ph, Sh);
    real[int] inertia(Sh.ndof), zeta(Sh.ndof), density(Ph.ndof), b(Sh.ndof);
    real[int,int] cases = [[0.01, 1, 0], [0.01, 1, 0.2], [0, 1, 0.1], [0.02, 0, 0.3]];
    real[int] zetas = [0.4, 1e-5, 0.], densities = [0.3, 2.5];
    cout.precision(17);
    for (int c = 0; c < cases.n; c++) for (int z = 0; z < zetas.n; z++) for (int d = 0; d < densities.n; d++) {
      inertia = 7.5; zeta = zetas[z]; density = densities[d];
      int below = damageSourceOf(Md, Q, cases(c, 0), cases(c, 1), cases(c, 2), inertia, zeta, density, b);
      cout << "constant " << cases(c, 0) << " " << cases(c, 1) << " " << cases(c, 2) << " " << zetas[z] << " "
           << densities[d] << " " << below << " " << b.sum << " " << Sh.ndof << endl;
    }
    for (int j = 0; j < Sh.ndof; j++) { inertia[j] = 10*randreal1(); zeta[j] = 0.05 + 0.95*randreal1(); }
    for (int t = 0; t < Ph.ndof; t++) density[t] = 0.6*randreal1();
    real[int] none(Sh.ndof), withD(Sh.ndof), withU(Sh.ndof), withW(Sh.ndof), all(Sh.ndof);
    damageSourceOf(Md, Q, 0, 0, 0, inertia, zeta, density, none);
    damageSourceOf(Md, Q, 0.01, 0, 0, inertia, zeta, density, withD);
    damageSourceOf(Md, Q, 0, 1, 0, inertia, zeta, density, withU);
    damageSourceOf(Md, Q, 0, 0, 0.2, inertia, zeta, density, withW);
    damageSourceOf(Md, Q, 0.01, 1, 0.2, inertia, zeta, density, all);
    real[int] sum = withD + withU;
    sum += withW;
    sum -= 2*none;
    sum -= all;
    cout << "parts " << sum.linfty/all.linfty << endl;
""")


def test_the_damage_source_integrates_its_terms(tmp_path):
    script = tmp_path / "source.edp"
    script.write_text(CHECK.replace("REPO", str(REPO)))
    done = run_script(script)
    assert done.returncode == 0, done.stdout + done.stderr
    rows = [[float(v) for v in line.split()[1:]] for line in done.stdout.splitlines() if line.startswith("constant ")]
    assert len(rows) == 24
    for lambda_d, lambda_u, lambda_w, zeta, density, below, total, nodes in rows:
        clamped = max(zeta, 1e-3)
        expected = 6 * (7.5 + lambda_d * (1 - clamped) / clamped + lambda_w - 0.5 * lambda_u * min(density, 0.7))
        assert total == pytest.approx(expected, rel=1e-12), (lambda_d, lambda_u, lambda_w, zeta, density)
        assert below == (nodes if lambda_d != 0 and zeta < 1e-3 else 0)
    parts = [float(line.split()[1]) for line in done.stdout.splitlines() if line.startswith("parts ")]
    assert parts and parts[0] <= 1e-14
