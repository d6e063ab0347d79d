"""Facts about this machine's FreeFEM that the solver relies on, checked against exact answers."""
import textwrap

from orchestrate.freefem import run_script

# A P1 vector field is reproduced exactly by solving A x = A w, whatever A's (SPD) form.
SOLVE_CHECK = textwrap.dedent("""
    mesh Th = square(6, 6);
    fespace Vh(Th, [P1, P1]);
    Vh [w1, w2] = [x*x, x*y];
    varf a([u1, u2], [v1, v2]) = int2d(Th)(dx(u1)*dx(v1) + dy(u1)*dy(v1) + dx(u2)*dx(v2) + dy(u2)*dy(v2)
        + 0.3*(dx(u1)*dy(v2) + dy(u2)*dx(v1)) + u1*v1 + u2*v2) + on(4, u1 = 0, u2 = 0);
    matrix full = a(Vh, Vh), half = a(Vh, Vh, sym = 1);
    real[int] b = full*w1[];
    set(half, solver = getARGV("-solver", "CHOLMOD"));
    real[int] x = half^-1*b;
    x -= w1[];
    cout.precision(17);
    cout << "error " << x.linfty << endl;
""")


def solve_error(tmp_path, solver):
    script = tmp_path / "solve.edp"
    script.write_text(SOLVE_CHECK.replace('getARGV("-solver", "CHOLMOD")', f'"{solver}"'))
    done = run_script(script)
    assert done.returncode == 0, done.stdout + done.stderr
    return float(done.stdout.split("error ")[1].split()[0])


def test_cholmod_solves_half_stored_matrices_exactly(tmp_path):
    # The solver assembles every matrix it factorizes with sym=1 because this build's CHOLMOD
    # solves a wrong system when given a fully stored matrix.
    assert solve_error(tmp_path, "CHOLMOD") < 1e-12


def test_umfpack_solves_half_stored_matrices_exactly(tmp_path):
    assert solve_error(tmp_path, "UMFPACK") < 1e-12
