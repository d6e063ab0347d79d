"""The benchmark command on two levels (speeds are its output, never asserted here): it writes
its table, report and plot, what it measures is consistent, and its steps are balanced — the
schemes, each at the N chosen for a time error of a quarter of the space error, land within that
margin of one another at every level."""
import csv

import pytest

from orchestrate.bench import CHECK, REFERENCE, SCHEMES, bench, wall_at


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    return out, bench(out, levels=2, fraction=0.25)


def test_bench_writes_its_table_report_and_plot(quick):
    out, _ = quick
    with open(out / "bench.csv") as handle:
        rows = list(csv.DictReader(handle))
    variants = [f"{scheme}, {family}" for family in ("uniform", "graded") for scheme in SCHEMES]
    assert sorted(row["variant"] for row in rows) == sorted([*variants * 2, REFERENCE, CHECK])
    report = (out / "README.md").read_text()
    assert "python -m orchestrate bench --levels 2 --uniform-levels 2 --time-fraction 0.25" in report
    assert "CHOLMOD" in report and "MUMPS_seq" in report and "Time error models" in report
    assert (out / "workprecision.png").stat().st_size > 20000


def test_measurements_are_consistent(quick):
    _, rows = quick
    for row in rows:
        assert row["overheadRatio"] > 1  # a step does at least the back-substitutions it cannot avoid
        assert row["wall"] > row["loop"] > 0 and row["startup"] > 0
        assert 0 < row["setupMemoryMB"] <= row["peakMemoryMB"] and row["columns"] >= 0
    for family in ("uniform", "graded"):
        for scheme in SCHEMES:
            errors = [row["errorToReference"] for row in rows if row["variant"] == f"{scheme}, {family}"]
            assert errors[0] > errors[1] > 0


def test_the_steps_balance_time_against_space_error(quick):
    """Time error ≤ a quarter of the space error in every scheme's run: the three schemes' total
    errors at a level then differ by less than 1.25/0.75 (measured against the reference)."""
    _, rows = quick
    for family in ("uniform", "graded"):
        for level in (0, 1):
            errors = [row["errorToReference"] for row in rows if row["family"] == family and row["level"] == level]
            assert len(errors) == 3 and max(errors) / min(errors) < 1.25 / 0.75, (family, level, errors)


def test_wall_at_reads_a_curve_in_log_log():
    # wall = error^-2 is a straight line in log–log: the interpolation is exact inside, None outside
    points = [(e, e ** -2) for e in (0.025, 0.05, 0.1)]
    assert wall_at(points, 0.04) == pytest.approx(0.04 ** -2, rel=1e-12)
    assert wall_at(points, 0.2) is None and wall_at(points, 0.01) is None
