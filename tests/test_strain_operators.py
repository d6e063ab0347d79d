"""A body's strain operators, kept per triangle by the plugin edp/plugins/strainoperators.cpp
(edp/lib/body.idp, bodyForms), give what FreeFEM's own matrices give, to the bit: the strains Dx u,
Dy u and G12 u (G12 = two more interpolates, summed), ε:ε in the script's grouping, the force
(Dxᵀ diag|T|) s11 + (Dyᵀ diag|T|) s22 + (G12ᵀ diag|T|) s12 (FreeFEM's transposes and products,
summed in that order) and the triangle means Avg z; on a structured mesh (whose zero derivatives
interpolate leaves out) and on a graded one. And two facts: the strains of a linear field are its
constant strains, and the force of a stress is the work it does on the strains of a field,
Σ_T |T| σ_T : ε_T(w) = forceᵀ w."""
import textwrap

import pytest

from orchestrate.freefem import REPO, run_script
from orchestrate.mesh import body_mesh, write_freefem

pytestmark = pytest.mark.solver

CHECK = textwrap.dedent("""
    load "strainoperators"
    mesh Th = square(7, 5);
    if (MESH != "") Th = readmesh(MESH);
    fespace Vh(Th, [P1, P1]);
    fespace Sh(Th, P1);
    fespace Ph(Th, P0);
    int[int] xc = [0], yc = [1];
    matrix Dx = interpolate(Ph, Vh, U2Vc = xc, op = 1), Dy = interpolate(Ph, Vh, U2Vc = yc, op = 2);
    matrix dyux = interpolate(Ph, Vh, U2Vc = xc, op = 2), dxuy = interpolate(Ph, Vh, U2Vc = yc, op = 1);
    matrix G12 = dyux + dxuy, Avg = interpolate(Ph, Sh);
    varf vArea(unused, q) = int2d(Th)(q);
    real[int] area = vArea(0, Ph);
    matrix weight = area;
    matrix DxT = Dx', DyT = Dy', G12T = G12';
    matrix DxArea = DxT*weight, DyArea = DyT*weight, G12Area = G12T*weight;
    int ops = strainOperators(Dx, Dy, Avg, area);
    real apart = 0;
    for (int r = 0; r < 4; r++) {
      real[int] u(Vh.ndof), p(Ph.ndof), q(Ph.ndof), s(Ph.ndof), z(Sh.ndof);
      for (int j = 0; j < u.n; j++) u[j] = randreal1() - 0.5;
      for (int j = 0; j < p.n; j++) { p[j] = randreal1() - 0.5; q[j] = randreal1() - 0.5; s[j] = randreal1() - 0.5; }
      for (int j = 0; j < z.n; j++) z[j] = randreal1();
      real[int] e11(Ph.ndof), e22(Ph.ndof), g12(Ph.ndof), density(Ph.ndof), force(Vh.ndof), zBar(Ph.ndof);
      strainsOf(ops, u, e11, e22, g12, density);
      stressForce(ops, p, q, s, force);
      triangleMeans(ops, z, zBar);
      real[int] a = Dx*u, b = Dy*u, c = G12*u;
      real[int] q11 = a .* a, q22 = b .* b, q12 = c .* c, d = q11 + q22;
      d = d + 0.5*q12;
      real[int] f = DxArea*p, part = DyArea*q;
      f += part;
      part = G12Area*s;
      f += part;
      real[int] m = Avg*z;
      a -= e11; b -= e22; c -= g12; d -= density; f -= force; m -= zBar;
      real[int] each = [a.linfty, b.linfty, c.linfty, d.linfty, f.linfty, m.linfty];
      apart = max(apart, each.max);
    }
    cout << "apart " << apart << endl;
    Vh [ux, uy] = [0.3*x - 1.7*y, 2.9*x + 0.4*y];
    real[int] e11(Ph.ndof), e22(Ph.ndof), g12(Ph.ndof), density(Ph.ndof);
    strainsOf(ops, ux[], e11, e22, g12, density);
    e11 -= 0.3; e22 -= 0.4; g12 -= 1.2;
    real[int] linear = [e11.linfty, e22.linfty, g12.linfty];
    cout << "linear " << linear.max/(G12.linfty*ux[].linfty) << endl;  /* relative to the largest term */
    Vh [wx, wy] = [sin(x + 2*y), x*x - y];
    real[int] w11(Ph.ndof), w22(Ph.ndof), w12(Ph.ndof), force(Vh.ndof), s11(Ph.ndof), s22(Ph.ndof), s12(Ph.ndof);
    strainsOf(ops, wx[], w11, w22, w12, density);
    for (int t = 0; t < Ph.ndof; t++) { s11[t] = randreal1(); s22[t] = randreal1(); s12[t] = randreal1(); }
    stressForce(ops, s11, s22, s12, force);
    real work = 0;  /* σ : ε with the engineering shear γ12 = 2ε12: s12 γ12 */
    for (int t = 0; t < Ph.ndof; t++) work += area[t]*(s11[t]*w11[t] + s22[t]*w22[t] + s12[t]*w12[t]);
    cout << "work " << abs(force'*wx[] - work)/abs(work) << endl;
""")


@pytest.mark.parametrize("graded", [False, True])
def test_the_plugins_strain_operators_are_freefems_matrices_to_the_bit(tmp_path, graded):
    script = tmp_path / "check.edp"
    if graded:  # in FreeFEM's format, for readmesh (as the runner hands a graded mesh over)
        write_freefem(body_mesh(REPO / "meshes" / "paper_body1_graded.geo", {"n": 40}, cache=tmp_path / "cache"),
                      tmp_path / "mesh.msh")
    script.write_text(CHECK.replace("MESH", f'"{tmp_path / "mesh.msh"}"' if graded else '""'))
    done = run_script(script)
    assert done.returncode == 0, done.stdout + done.stderr
    facts = {line.split()[0]: [float(v) for v in line.split()[1:]] for line in done.stdout.splitlines() if line.split()}
    assert facts["apart"] == [0]
    assert facts["linear"][0] <= 1e-14
    assert facts["work"][0] <= 1e-13


def test_a_number_that_is_no_operators_is_named(tmp_path):
    script = tmp_path / "wrong.edp"
    script.write_text('load "strainoperators"\nreal[int] u(4), a(2), b(2), c(2), d(2);\nstrainsOf(3, u, a, b, c, d);\n')
    done = run_script(script)
    assert done.returncode != 0 and "not a number strainOperators gave" in done.stdout + done.stderr
