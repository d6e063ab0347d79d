"""A body's shear operator G12 and the elastic force's operators Dᵀdiag(|T|), built by the plugin
edp/plugins/strainoperators.cpp from the interpolated Dx and Dy (edp/lib/body.idp, bodyForms), are
the matrices FreeFEM's own operations make (two more interpolates and their sum; a transpose and a
product): the same entries, and products with them equal to the bit, on a structured mesh (whose
zero derivatives interpolate leaves out) and on a graded one. G12 of a linear field is its
2ε12, exactly up to round-off."""
import textwrap

import pytest

from orchestrate.freefem import REPO, run_script
from orchestrate.mesh import body_mesh, write_freefem

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
    matrix weight = area;
    matrix DxT = Dx', DyT = Dy', G12T = G12';
    matrix DxArea = DxT*weight, DyArea = DyT*weight, G12Area = G12T*weight;
    matrix G12p, DxAreap, DyAreap, G12Areap;
    shearOperator(Dx, Dy, G12p);
    weightedTranspose(Dx, area, DxAreap); weightedTranspose(Dy, area, DyAreap); weightedTranspose(G12p, area, G12Areap);
    cout << "entries " << (G12p.nnz - G12.nnz) << " " << (DxAreap.nnz - DxArea.nnz) << " "
         << (DyAreap.nnz - DyArea.nnz) << " " << (G12Areap.nnz - G12Area.nnz) << endl;
    real apart = 0;
    for (int r = 0; r < 4; r++) {
      real[int] u(Vh.ndof), p(Ph.ndof);
      for (int j = 0; j < u.n; j++) u[j] = randreal1() - 0.5;
      for (int j = 0; j < p.n; j++) p[j] = randreal1() - 0.5;
      real[int] a = G12*u, b = G12p*u; b -= a; apart = max(apart, b.linfty);
      real[int] c = DxArea*p, d = DxAreap*p; d -= c; apart = max(apart, d.linfty);
      real[int] e = DyArea*p, f = DyAreap*p; f -= e; apart = max(apart, f.linfty);
      real[int] g = G12Area*p, h = G12Areap*p; h -= g; apart = max(apart, h.linfty);
    }
    cout << "apart " << apart << endl;
    Vh [ux, uy] = [0.3*x - 1.7*y, 2.9*x + 0.4*y];
    real[int] shear = G12p*ux[];
    shear -= 1.2;
    cout << "linear " << shear.linfty/(G12p.linfty*ux[].linfty) << endl;  /* relative to the largest term */
""")


@pytest.mark.parametrize("graded", [False, True])
def test_the_plugins_strain_operators_are_freefems_to_the_bit(tmp_path, graded):
    script = tmp_path / "check.edp"
    if graded:  # in FreeFEM's format, for readmesh (as the runner hands a graded mesh over)
        write_freefem(body_mesh(REPO / "meshes" / "paper_body1_graded.geo", {"n": 40}, cache=tmp_path / "cache"),
                      tmp_path / "mesh.msh")
    script.write_text(CHECK.replace("MESH", f'"{tmp_path / "mesh.msh"}"' if graded else '""'))
    done = run_script(script)
    assert done.returncode == 0, done.stdout + done.stderr
    facts = {line.split()[0]: [float(v) for v in line.split()[1:]] for line in done.stdout.splitlines() if line.split()}
    assert facts["entries"] == [0, 0, 0, 0]
    assert facts["apart"] == [0]
    assert facts["linear"][0] <= 1e-14
