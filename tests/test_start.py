"""A start in substeps (time.startSteps, time.startSubsteps; docs/model-choices.md, "A start in
substeps"), on the gallery's joint at a coarser mesh: a viscous layer on a glue spring, pulled
up at its end from rest. Its force rises like a fractional power of t at first (the bent length
grows with t), which steps of k do not resolve:

- one step of k reads the force at t = k about 10 % low (the mean rate over [0, k] for the rate at
  k), however small k is (the transient has every time scale below it);
- the substeps are the scheme's own steps: the first p rows of a run with a start are, to the
  bit, the rows m, 2m, …, pm of a run of steps k/m over [0, pk];
- with a start of two steps of four substeps (bdf2) or three of sixteen (semi-implicit), every
  step's force is within 1 % of a run of steps a thousand times shorter (the issue's clean start),
  also the steps of k after the start (the levels it leaves are those steps of k read);
- a start that covers the whole run is the fine run."""
import numpy as np
import pytest

from orchestrate.freefem import REPO
from orchestrate.runner import run

pytestmark = pytest.mark.physics

JOINT = REPO / "scenes" / "joint.toml"
K = 1 / 30  # the joint's step, T = 10 s over N = 300
COARSE = {"body1.mesh.n": 60, "body2.mesh.n": 30, "output.images": False,
          "output.times": "final", "output.fields": []}


def history(tmp_path, name, T, N, scheme="bdf2", start=0, substeps=4):
    """The history of the coarse joint, every column but the measured stepSeconds."""
    result = run(JOINT, tmp_path / name, {**COARSE, "time.T": T, "time.N": N, "time.scheme": scheme,
                                          "time.startSteps": start, "time.startSubsteps": substeps},
                 progress=False)
    return {column: np.asarray(values) for column, values in result.history.items() if column != "stepSeconds"}


def force(tmp_path, name, T, N, scheme="bdf2", start=0, substeps=4):
    """The history's times and the force that lifts the layer (reactionY1_2) of the coarse joint."""
    rows = history(tmp_path, name, T, N, scheme, start, substeps)
    return rows["t"], rows["reactionY1_2"]


@pytest.fixture(scope="module")
def converged(tmp_path_factory):
    """Steps of k/1000 over [0, 6k], the first 16 steps as 64 substeps each."""
    return force(tmp_path_factory.mktemp("fine"), "fine", 6 * K, 6000, start=16, substeps=64)


def relative_errors(times, values, reference):
    return values / np.interp(times, *reference) - 1


def test_one_step_of_k_from_rest_reads_the_force_too_low(tmp_path, converged):
    times, values = force(tmp_path, "plain", 6 * K, 6)
    error = relative_errors(times, values, converged)
    assert error[0] < -0.05 and abs(error[1]) > 0.005


@pytest.mark.parametrize("scheme, start, substeps", [("bdf2", 2, 4), ("semi-implicit", 3, 16)])
def test_a_start_in_substeps_puts_every_step_within_one_percent(tmp_path, converged, scheme, start, substeps):
    times, values = force(tmp_path, scheme, 6 * K, 6, scheme, start, substeps)
    assert times == pytest.approx(K * np.arange(1, 7), rel=1e-12)
    assert np.abs(relative_errors(times, values, converged)).max() < 0.01


@pytest.mark.parametrize("scheme", ["bdf2", "semi-implicit"])
def test_the_substeps_are_the_scheme_s_steps(tmp_path, scheme):
    """Every column of the start's rows (the energies summed over the substeps, the reactions, the
    front) is the fine run's at the same time, to the bit; n counts the run's steps."""
    start = history(tmp_path, "start", 3 * K, 3, scheme, start=2, substeps=4)
    fine = history(tmp_path, "uniform", 2 * K, 8, scheme)
    assert start["n"].tolist() == [1, 2, 3]
    assert start["t"] == pytest.approx(K * np.arange(1, 4), rel=1e-12)
    for column in set(start) - {"n", "t"}:
        assert start[column][:2].tolist() == fine[column][[3, 7]].tolist(), column


def test_a_start_over_the_whole_run_is_the_fine_run(tmp_path):
    start = history(tmp_path, "start", 2 * K, 2, start=5, substeps=3)
    fine = history(tmp_path, "uniform", 2 * K, 6)
    for column in set(start) - {"n", "t"}:
        assert start[column].tolist() == fine[column][[2, 5]].tolist(), column
