"""The benchmark command on two levels (speeds are its output, never asserted here): it writes
its table, report and plot, and what it measures is consistent."""
import csv

import pytest

from orchestrate.bench import bench, graded_gains


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    return out, bench(out, levels=2, check_reference=True)


def test_bench_writes_its_table_report_and_plot(quick):
    out, _ = quick
    with open(out / "bench.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert [row["variant"] for row in rows] == (["uniform, pdas"] * 2 + ["uniform, bm"] * 2
                                                + ["graded, pdas", "reference", "reference check"])
    report = (out / "README.md").read_text()
    assert "python -m orchestrate bench --levels 2 --check-reference" in report
    assert "CHOLMOD" in report and "MUMPS_seq" in report
    assert (out / "workprecision.png").stat().st_size > 10000


def test_measurements_are_consistent(quick):
    _, rows = quick
    for row in rows:
        # a step does at least the back-substitutions it cannot avoid
        assert row["overheadRatio"] > 1
        assert row["wall"] > row["loop"] > 0 and row["startup"] > 0
    uniform = [row for row in rows if row["variant"] == "uniform, pdas"]
    bm = [row for row in rows if row["variant"] == "uniform, bm"]
    assert uniform[0]["errorToReference"] > uniform[1]["errorToReference"] > 0
    # the uniform ladder is nested in the check's mesh, so these errors are exact and converge
    assert uniform[0]["errorToCheck"] > uniform[1]["errorToCheck"] > 0
    for a, b in zip(uniform, bm):  # same meshes, the two contact solvers agree
        assert b["errorToReference"] == pytest.approx(a["errorToReference"], rel=1e-6)
        assert b["contactIters"] > 10 * a["contactIters"]


def test_graded_gain_reads_both_curves_at_equal_error():
    # wall = error^-2 (uniform) and error^-2/4 (graded) are straight lines in log–log, so the
    # interpolation is exact and the gain is 4 at every error both curves span
    uniform = [{"variant": "uniform, pdas", "errorToReference": e, "wall": e ** -2} for e in (0.1, 0.05, 0.025)]
    graded = [{"variant": "graded, pdas", "errorToReference": e, "wall": e ** -2 / 4} for e in (0.2, 0.04, 0.02)]
    for row in uniform + graded:  # the same curves read against another reference
        row["errorToCheck"] = row["errorToReference"]
    for key in ("errorToReference", "errorToCheck"):
        gains = graded_gains(uniform + graded, key)
        assert [error for error, _ in gains] == [0.025, 0.04, 0.05, 0.1]  # 0.2 and 0.02 lie outside the uniform range
        assert [gain for _, gain in gains] == pytest.approx([4.0] * 4, rel=1e-12)
