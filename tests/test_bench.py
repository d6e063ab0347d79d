"""The benchmark command on two levels at each degree (speeds are its output, never asserted
here): it writes its table, report and plot, what it measures is consistent, and its steps are
balanced — the schemes, each at the N chosen for a time error of a quarter of the space error,
land within that margin of one another at every level."""
import csv

import pytest

from orchestrate.adapt import CYCLES
from orchestrate.studies.bench import (CHECK, DEGREES, N1_STEP, REFERENCE, SCHEMES, SEARCH_RUNS, bench, predicted_n1,
                                       wall_at)

pytestmark = pytest.mark.physics

# Between the errors of levels 0 and 1 (h1 = 6/6, 6/12) of both families at P1, and of the uniform
# family at P2: against this run's reference (graded P2, h1 = 6/48) they measured 13.9–14.0 % and
# 7.7–7.9 % (uniform P1), 9.5–9.8 % and 4.9–5.0 % (graded P1), 3.9–4.0 % and 2.3–2.4 % (uniform P2).
TARGETS = {0.09: {("uniform", 1), ("graded", 1)}, 0.03: {("uniform", 2)}}  # each with the variants it must search
ADAPT_TARGETS = {1: 0.03, 2: 0.01}  # below the uniform pilots' estimates (P1 n = 24, P2 n = 12): a cycle at least


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    return out, bench(out, levels=2, fraction=0.25, targets=tuple(TARGETS),
                      adapt_targets={degree: (target,) for degree, target in ADAPT_TARGETS.items()})


def test_bench_writes_its_table_report_and_plot(quick):
    out, _ = quick
    with open(out / "bench.csv") as handle:
        rows = list(csv.DictReader(handle))
    variants = [f"{scheme}, {family}, P{degree}" for degree in DEGREES for family in ("uniform", "graded")
                for scheme in SCHEMES]
    levels = [row for row in rows if row["level"].isdigit() or row["variant"] in (REFERENCE, CHECK)]
    assert sorted(row["variant"] for row in levels) == sorted([*variants * 2, REFERENCE, CHECK])
    # P2 ran: the structured uniform meshes of its level l have the nodes of P1's level l + 1, those of the
    # displacement (the vertices of a mesh with n1 = 6·2^l, 2 n1 + 1 a side, and its edges' middles)
    nodes = {(row["variant"], row["level"]): int(row["nodes1"]) for row in levels}
    assert nodes[("bdf2, uniform, P2", "0")] == nodes[("bdf2, uniform, P1", "1")] == 13 ** 2
    assert {row["degree"] for row in rows if row["variant"] in (REFERENCE, CHECK)} == {"2"}
    report = (out / "README.md").read_text()
    assert ("python -m orchestrate bench --levels 2 --uniform-levels 2 --time-fraction 0.25 --targets 9,3 "
            "--degrees 1,2 --adapt-targets 3 --adapt-targets-p2 1") in report
    assert all(f"| {variant} | {100 * target:g} % |" in report for variant in variants for target in TARGETS)
    assert "CHOLMOD" in report and "MUMPS_seq" in report and "Time error models" in report
    assert (out / "workprecision.png").stat().st_size > 20000


@pytest.mark.parametrize("degree", DEGREES)
def test_the_adapted_meshes_are_a_variant_of_their_own(quick, degree):
    """bdf2 on the meshes adapt designed from the uniform pilot (P1 n = 24, P2 n = 12: the same
    nodes) for an estimate below the pilot's: at least one cycle, more accurate than the uniform
    level 1 of the degree; its run timed as the others and its whole loop beside it; in the
    report's table of adapted meshes."""
    out, rows = quick
    target = ADAPT_TARGETS[degree]
    adapted = [row for row in rows if row["family"] == "adapted" and row["degree"] == degree]
    assert [row["variant"] for row in adapted] == [f"bdf2, adapted, P{degree}"] and adapted[0]["adaptCycles"] >= 1
    uniform = next(row for row in rows if row["variant"] == f"bdf2, uniform, P{degree}" and row["level"] == 1)
    assert adapted[0]["errorToReference"] < uniform["errorToReference"]
    assert adapted[0]["adaptSeconds"] > adapted[0]["wall"]
    report = (out / "README.md").read_text()
    assert "Adapted meshes (bdf2)" in report
    assert adapted[0]["adaptTarget"] == target
    line = next(line for line in report.split("Adapted meshes (bdf2)")[1].splitlines()
                if line.startswith(f"| P{degree} | {100 * target:g} % |"))
    assert f"| {100 * adapted[0]['adaptEstimate']:.3f} %" in line
    assert ("NOT REACHED" in line) == (adapted[0]["adaptEstimate"] > target)
    if adapted[0]["adaptCycles"] < CYCLES:  # adapt stops before its last cycle only on reaching the target
        assert adapted[0]["adaptEstimate"] <= target and "NOT REACHED" not in line


def test_measurements_are_consistent(quick):
    _, rows = quick
    for row in rows:
        # a step does at least the back-substitutions it cannot avoid, the first and every later one
        assert row["overheadRatio"] > 1 and row["laterOverheadRatio"] > 1
        assert row["wall"] > row["loop"] + row["output"] and row["loop"] > 0 and row["startup"] > 0
        # VmHWM, read twice: the kernel's RSS counters are approximate (per-CPU and per-thread
        # batches, and the implicit glue's LAPACK runs threads), so the later reading can fall below
        # the earlier one (measured: 8 kB, 84 kB, 289 kB)
        assert 0 < row["setupMemoryMB"] <= row["peakMemoryMB"] + 1 and row["columns"] >= 0
    for degree in DEGREES:
        for family in ("uniform", "graded"):
            for scheme in SCHEMES:
                errors = [row["errorToReference"] for row in rows if row["variant"] == f"{scheme}, {family}, P{degree}"]
                assert errors[0] > errors[1] > 0


def test_the_search_finds_the_coarsest_mesh_that_reaches_the_target(quick):
    """Between levels 0 and 1, for each variant they bracket: every search run lies between them
    (n1 = 12 itself rerun at the search's steps), and the coarsest search run that reaches the
    target has, one n1 step below it, a run above the target — so no coarser mesh between the
    levels reaches it — unless the search ran out of runs; the report says which n1 it found."""
    out, rows = quick
    report = (out / "README.md").read_text()
    for target, wanted in TARGETS.items():
        bracketed = set()
        for degree, family, scheme in ((d, f, s) for d in DEGREES for f in ("uniform", "graded") for s in SCHEMES):
            step, name = N1_STEP[family], f"{scheme}, {family}, P{degree}"
            runs = [row for row in rows if row["variant"] == name]
            levels = [row for row in runs if isinstance(row["level"], int)]
            if not levels[0]["errorToReference"] > target >= levels[1]["errorToReference"]:
                continue
            bracketed.add((family, degree))
            searched = [row for row in runs if row["level"] == f"search {100 * target:g} %"]
            assert all(6 < row["n1"] <= 12 and row["n1"] % step == 0 for row in searched)
            fine = min((row["n1"] for row in searched if row["errorToReference"] <= target), default=None)
            neighbours = [row for row in searched + levels[:1] if fine and row["n1"] == fine - step]
            if not (neighbours and all(row["errorToReference"] > target for row in neighbours)):
                assert len(searched) == SEARCH_RUNS, (family, scheme, degree)
                continue
            line = next(line for line in report.splitlines() if line.startswith(f"| {name} | {100 * target:g} % |"))
            assert line.endswith(f"| n1 = {fine} reaches it, {fine - step} does not |")
        assert wanted <= bracketed, (target, bracketed)


@pytest.mark.unit
def test_predicted_n1_follows_a_power_law():
    # error = 3·n1^-0.8 is a straight line in log–log: the prediction is exact, then rounded up to the step
    runs = [{"n1": n1, "errorToReference": 3 * n1 ** -0.8} for n1 in (6, 12)]
    assert predicted_n1(*runs, 3 * 9 ** -0.8, 1) == 9
    assert predicted_n1(*runs, 3 * 9 ** -0.8, 2) == 10
    assert predicted_n1(*runs, 3 * 8.5 ** -0.8, 1) == 9


def test_the_steps_balance_time_against_space_error(quick):
    """Time error ≤ a quarter of the space error in every scheme's run: the three schemes' total
    errors at a level then differ by less than 1.25/0.75 (measured against the reference)."""
    _, rows = quick
    for degree, family, level in ((d, f, l) for d in DEGREES for f in ("uniform", "graded") for l in (0, 1)):
        errors = [row["errorToReference"] for row in rows
                  if (row["degree"], row["family"], row["level"]) == (degree, family, level)]
        assert len(errors) == 3 and max(errors) / min(errors) < 1.25 / 0.75, (degree, family, level, errors)


@pytest.mark.unit
def test_wall_at_reads_a_curve_in_log_log():
    # wall = error^-2 is a straight line in log–log: the interpolation is exact inside, None outside
    points = [(e, e ** -2) for e in (0.025, 0.05, 0.1)]
    assert wall_at(points, 0.04) == pytest.approx(0.04 ** -2, rel=1e-12)
    assert wall_at(points, 0.2) is None and wall_at(points, 0.01) is None


@pytest.mark.parametrize("steps", [1, 7])
def test_the_timed_back_substitutions_change_no_result(tmp_path, steps):
    """The bench's -measureSolves sets are timed inside the loop (steps 2 … N) or after it (N = 1),
    on copies: the files are those of a run without them, and every set asked for is timed."""
    import json
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from conftest import solve_ok

    flags = ["-N", steps, "-scheme", "semi-implicit", "-outTimes", 1, "-outFields", "state"]  # no elastic bound
    plain = solve_ok(tmp_path / "plain", *flags)
    timed = solve_ok(tmp_path / "timed", *flags, "-measureSolves", 5)
    for name in (f"state_{steps:04d}.txt",):
        assert (plain.folder / name).read_bytes() == (timed.folder / name).read_bytes()
    strip = lambda path: [line.rsplit(",", 1)[0] for line in path.read_text().splitlines()]  # stepSeconds aside
    assert strip(plain.folder / "history.csv") == strip(timed.folder / "history.csv")
    facts = json.loads((timed.folder / "run.json").read_text())
    assert facts["backsubSecondsPerStep"] > 0 and facts["backsubSets"] == 5
    # a step followed by sets is paired with them (none after a loop of one step); a step does at
    # least its own back-substitutions
    assert facts["overheadPairs"] == (0 if steps == 1 else 5)
    if steps > 1:
        assert 1 < facts["overheadPairedLow"] <= facts["overheadPairedMedian"] <= facts["overheadPairedHigh"]
    assert json.loads((plain.folder / "run.json").read_text())["backsubSecondsPerStep"] == 0
