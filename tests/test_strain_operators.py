"""A body's strain operators in the compact form of edp/plugins/strainoperators.cpp (edp/lib/body.idp,
bodyForms) give what FreeFEM's own matrices give, to round-off: the strains Dx u, Dy u and G12 u (G12
= two more interpolates, summed), their square ε:ε = ε11² + ε22² + ½γ12², and the force (Dxᵀ diag|T|) s11 + (Dyᵀ diag|T|) s22 + (G12ᵀ diag|T|)
s12, on a structured mesh (whose zero derivatives interpolate leaves out) and on a graded one. Two
facts besides: the strains of a linear field are its constant strains, and the force of a stress
is the work it does on the strains of a field, Σ_T |T| σ_T : ε_T(w) = forceᵀ w. The operator may
hold any number of nodes per point (nothing assumes P1), and arrays that are no operator, or name
a node outside the displacement, are refused by name."""
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
    fespace Ph(Th, P0);
    int[int] xc = [0], yc = [1];
    matrix Dx = interpolate(Ph, Vh, U2Vc = xc, op = 1), Dy = interpolate(Ph, Vh, U2Vc = yc, op = 2);
    matrix dyux = interpolate(Ph, Vh, U2Vc = xc, op = 2), dxuy = interpolate(Ph, Vh, U2Vc = yc, op = 1);
    matrix G12 = dyux + dxuy;
    varf vArea(unused, q) = int2d(Th)(q);
    real[int] area = vArea(0, Ph);
    int[int] start(0), node(0);
    real[int] gradient(0);
    int points = strainOperators(Dx, Dy, start, node, gradient);
    cout << "points " << points << " " << Th.nt << " " << node.n << endl;
    real apart = 0;
    for (int r = 0; r < 4; r++) {
      real[int] u(Vh.ndof), p(Ph.ndof), q(Ph.ndof), s(Ph.ndof);
      for (int j = 0; j < u.n; j++) u[j] = randreal1() - 0.5;
      for (int j = 0; j < p.n; j++) { p[j] = randreal1() - 0.5; q[j] = randreal1() - 0.5; s[j] = randreal1() - 0.5; }
      real[int] e11(Ph.ndof), e22(Ph.ndof), g12(Ph.ndof), density(Ph.ndof), force(Vh.ndof);
      strainsOf(start, node, gradient, u, e11, e22, g12, density);
      stressForce(start, node, gradient, area, p, q, s, force);
      real[int] a = Dx*u, b = Dy*u, c = G12*u;
      real[int] d = a .* a;  /* ε:ε = ε11² + ε22² + ½γ12² */
      d += b .* b;
      real[int] shear = c .* c;
      d += 0.5*shear;
      real[int] wp = area .* p, wq = area .* q, ws = area .* s;
      real[int] f = Dx'*wp;
      f += Dy'*wq;
      f += G12'*ws;
      real[int] scale = [a.linfty, b.linfty, c.linfty, f.linfty];
      real dScale = d.linfty;
      a -= e11; b -= e22; c -= g12; f -= force; d -= density;
      real[int] each = [a.linfty, b.linfty, c.linfty, f.linfty];
      apart = max(apart, max(each.max/scale.max, d.linfty/dScale));
    }
    cout << "apart " << apart << endl;
    Vh [ux, uy] = [0.3*x - 1.7*y, 2.9*x + 0.4*y];
    real[int] e11(Ph.ndof), e22(Ph.ndof), g12(Ph.ndof), density(Ph.ndof);
    strainsOf(start, node, gradient, ux[], e11, e22, g12, density);
    e11 -= 0.3; e22 -= 0.4; g12 -= 1.2;
    real[int] linear = [e11.linfty, e22.linfty, g12.linfty];
    cout << "linear " << linear.max/(G12.linfty*ux[].linfty) << endl;  /* relative to the largest term */
    Vh [wx, wy] = [sin(x + 2*y), x*x - y];
    real[int] w11(Ph.ndof), w22(Ph.ndof), w12(Ph.ndof), force(Vh.ndof), s11(Ph.ndof), s22(Ph.ndof), s12(Ph.ndof);
    strainsOf(start, node, gradient, wx[], w11, w22, w12, density);
    for (int t = 0; t < Ph.ndof; t++) { s11[t] = randreal1(); s22[t] = randreal1(); s12[t] = randreal1(); }
    stressForce(start, node, gradient, area, s11, s22, s12, force);
    real work = 0;  /* σ : ε with the engineering shear γ12 = 2ε12: s12 γ12 */
    for (int t = 0; t < Ph.ndof; t++) work += area[t]*(s11[t]*w11[t] + s22[t]*w22[t] + s12[t]*w12[t]);
    cout << "work " << abs(force'*wx[] - work)/abs(work) << endl;
""")


@pytest.mark.parametrize("graded", [False, True])
def test_the_compact_strain_operators_are_freefems_matrices(tmp_path, graded):
    script = tmp_path / "check.edp"
    if graded:  # in FreeFEM's format, for readmesh (as the runner hands a graded mesh over)
        write_freefem(body_mesh(REPO / "meshes" / "paper_body1_graded.geo", {"n": 40}, cache=tmp_path / "cache"),
                      tmp_path / "mesh.msh")
    script.write_text(CHECK.replace("MESH", f'"{tmp_path / "mesh.msh"}"' if graded else '""'))
    done = run_script(script)
    assert done.returncode == 0, done.stdout + done.stderr
    facts = {line.split()[0]: [float(v) for v in line.split()[1:]] for line in done.stdout.splitlines() if line.split()}
    points, triangles, entries = facts["points"]
    assert points == triangles and entries == 3 * triangles  # a P1 triangle's three nodes at its centroid
    assert facts["apart"][0] <= 1e-14
    assert facts["linear"][0] <= 1e-14
    assert facts["work"][0] <= 1e-13


def test_points_with_more_nodes_than_a_triangle_has(tmp_path):
    """P2 displacements at each triangle's centroid: six nodes a point. The strains of a quadratic
    field there are its exact derivatives, and the force is still the work it does."""
    script = tmp_path / "p2.edp"
    script.write_text(textwrap.dedent("""
        load "strainoperators"
        mesh Th = square(6, 4, [2*x, y]);
        fespace Vh(Th, [P2, P2]);
        fespace Ph(Th, P0);
        int[int] xc = [0], yc = [1];
        matrix Dx = interpolate(Ph, Vh, U2Vc = xc, op = 1), Dy = interpolate(Ph, Vh, U2Vc = yc, op = 2);
        int[int] start(0), node(0);
        real[int] gradient(0);
        int points = strainOperators(Dx, Dy, start, node, gradient);
        Vh [ux, uy] = [x*x + 0.5*x*y, y*y - 2*x*y];
        Ph cx = x, cy = y;  /* the centroids */
        real[int] e11(points), e22(points), g12(points), density(points);
        strainsOf(start, node, gradient, ux[], e11, e22, g12, density);
        real worst = 0;
        for (int t = 0; t < points; t++) {
          real X = cx[][t], Y = cy[][t];
          worst = max(worst, abs(e11[t] - (2*X + 0.5*Y)));
          worst = max(worst, abs(e22[t] - (2*Y - 2*X)));
          worst = max(worst, abs(g12[t] - (0.5*X - 2*Y)));
        }
        cout << "entries " << (1.*node.n/points) << endl;
        cout << "exact " << worst << endl;
    """))
    done = run_script(script)
    assert done.returncode == 0, done.stdout + done.stderr
    facts = {line.split()[0]: float(line.split()[1]) for line in done.stdout.splitlines() if len(line.split()) == 2}
    assert facts["entries"] == 6
    assert facts["exact"] <= 1e-12


@pytest.mark.parametrize("call, message", [
    ("strainsOf(start, node, gradient, u, a, b, c, w);", "not an operator strainOperators made"),
    ("strainsOf(good, far, wide, u, a, b, c, w);", "a node lies outside the displacement's dofs"),
    ("stressForce(good, far, wide, w, a, b, c, u);", "a node lies outside the displacement's dofs"),
])
def test_arrays_that_are_no_operator_are_named(tmp_path, call, message):
    script = tmp_path / "wrong.edp"
    script.write_text('load "strainoperators"\nint[int] start = [0, 3], node = [0, 2], good = [0, 1], far = [8];\n'
                      'real[int] gradient(4), wide = [1., 1.], u(4), a(1), b(1), c(1), w(1);\n' + call + "\n")
    done = run_script(script)
    assert done.returncode != 0 and message in done.stdout + done.stderr
