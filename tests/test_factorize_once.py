"""Matrices that do not change are assembled and factorized once per run (docs/model.md §6): the
number of factorizations FreeFEM reports does not grow with the number of steps."""
import pytest

from conftest import solve

pytestmark = pytest.mark.solver

NO_DAMAGE = ["-lambdaD1", 0, "-lambdaU1", 0, "-lambdaD2", 0, "-lambdaU2", 0]


def cholesky_factorizations(tmp_path, steps, *args):
    done, _ = solve(tmp_path / f"run{steps}", "-N", steps, "-v", 3, *args)
    assert done.returncode == 0, done.error_line
    return done.stdout.count("fac_numeric CHOLMoD")


@pytest.mark.parametrize("steps", [20, 80])
def test_the_two_body_matrices_are_factorized_once(tmp_path, steps):
    # With damage switched off only A/k of each body is factorized (CHOLMOD, linearSolver default).
    assert cholesky_factorizations(tmp_path, steps, *NO_DAMAGE) == 2


def test_damage_matrices_are_factorized_when_their_active_set_changes_only(tmp_path):
    # The paper's damage never reaches a bound after the first step, so the two damage matrices
    # are factorized once each, however many steps.
    assert cholesky_factorizations(tmp_path, 20) == cholesky_factorizations(tmp_path, 80) == 4


def test_every_cholesky_factorization_is_made_in_the_set_up(tmp_path):
    # FreeFEM factorizes at a matrix's first solve; the driver makes that solve in the set-up, so
    # the "set-up:" line comes after every factorization of a run whose active sets do not change.
    done, _ = solve(tmp_path / "run", "-N", 20, "-v", 3)
    assert done.returncode == 0, done.error_line
    before, after = done.stdout.split("\nset-up:", 1)
    assert before.count("fac_numeric CHOLMoD") == 4 and after.count("fac_numeric CHOLMoD") == 0
