"""Facts about this machine's FreeFEM that the solver relies on, checked against exact answers."""
import os
import subprocess
import textwrap

import pytest

from orchestrate.freefem import REPO, freefem_command, freefem_env, run_script

pytestmark = pytest.mark.solver

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


# Large enough for CHOLMOD's supernodal factorization, the one that runs OpenMP regions.
SUPERNODAL_SOLVE = SOLVE_CHECK.replace("square(6, 6)", "square(150, 150)").replace(
    'getARGV("-solver", "CHOLMOD")', '"CHOLMOD"').replace(
    'cout << "error " << x.linfty << endl;', 'cout << "error " << x.linfty << endl;\nx += w1[];\ncout << x << endl;')


def test_cholmod_gives_the_same_bits_with_openmp_limited_to_one_thread(tmp_path):
    # orchestrate and bin/ff set OMP_THREAD_LIMIT=1 for speed (docs/freefem-facts.md): the results
    # must not change with it. Each run is also checked against the exact field.
    script = tmp_path / "supernodal.edp"
    script.write_text(SUPERNODAL_SOLVE)
    outputs = []
    for limit in (None, "1"):
        env = {key: value for key, value in freefem_env().items() if key != "OMP_THREAD_LIMIT"}
        if limit:
            env["OMP_THREAD_LIMIT"] = limit
        done = subprocess.run(freefem_command(script), env=env, capture_output=True, text=True, cwd=REPO)
        assert done.returncode == 0, done.stdout + done.stderr
        assert float(done.stdout.split("error ")[1].split()[0]) < 1e-10
        outputs.append(done.stdout)
    assert outputs[0] == outputs[1]


GET_LIMIT = 'load "shell"\ncout << "limit [" << getenv("OMP_THREAD_LIMIT") << "]" << endl;\n'


def test_launchers_limit_openmp_to_one_thread_unless_the_caller_chose(tmp_path, monkeypatch):
    script = tmp_path / "limit.edp"
    script.write_text(GET_LIMIT)
    monkeypatch.delenv("OMP_THREAD_LIMIT", raising=False)
    by_hand = subprocess.run(["bash", REPO / "bin" / "ff", script], capture_output=True, text=True,
                             env={**os.environ})
    assert "limit [1]" in by_hand.stdout, by_hand.stdout + by_hand.stderr
    assert "limit [1]" in run_script(script).stdout
    monkeypatch.setenv("OMP_THREAD_LIMIT", "2")
    assert "limit [2]" in run_script(script).stdout
