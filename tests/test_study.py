"""The convergence study command on a quick ladder (three levels of each kind); the full ladder
is `python -m orchestrate study convergence scenes/paper.toml` (results/convergence)."""
import csv
import json
import shlex

import pytest

from orchestrate.arguments import parse_assignments
from orchestrate.freefem import REPO
from orchestrate.studies.convergence import convergence, rates

pytestmark = pytest.mark.physics


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("study")
    return out, convergence(REPO / "scenes" / "paper.toml", out, count=3, time_mesh_level=1, space_steps_level=1)


def test_study_writes_its_table_report_and_plot(quick):
    out, _ = quick
    with open(out / "convergence.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert [row["ladder"] for row in rows] == ["lockstep"] * 3 + ["time"] * 3 + ["space"] * 3
    report = (out / "README.md").read_text()
    assert "python -m orchestrate study convergence" in report and "Observed rates" in report
    assert (out / "convergence.png").stat().st_size > 10000


def test_errors_fall_at_least_at_the_theorems_rates(quick):
    # Theorem 2.1: c(h^{3/4} + k). Successive differences are free of the reference's own error.
    _, table = quick
    for ladder in ("lockstep", "time", "space"):
        rows = [row for row in table if row["ladder"] == ladder and "errorV" in row]
        for quantity in ("errorV", "errorZeta", "errorBeta"):
            assert rows[0][quantity] > rows[1][quantity] > 0, (ladder, quantity)
    observed = {ladder: rates(table, ladder)["errorV"]["successive"] for ladder in ("lockstep", "time", "space")}
    assert observed["lockstep"] >= 0.75 and observed["space"] >= 0.75 and observed["time"] >= 1.0, observed


def test_time_ladders_per_scheme_share_one_reference_and_say_which_levels_could_not_run(tmp_path):
    """A time ladder per scheme on one mesh, N = 10 … 160, against bdf2 at N = 320: euler's N = 10
    exceeds k* = 0.052 (N >= 20, docs/model.md §7) and is reported as refused, not dropped silently;
    bdf2's successive differences over the finest levels fall as k²."""
    table = convergence(REPO / "scenes" / "paper.toml", tmp_path, count=2, kinds=("time",), schemes=("euler", "bdf2"),
                        time_steps=10, time_count=5, time_mesh_level=1)
    euler = [row for row in table if row["ladder"] == "time euler"]
    assert "exceeds the explicit elastic bound" in euler[0]["status"] and "errorV" not in euler[0]
    assert [row["status"] for row in euler[1:]] == ["ran"] * 4
    report = (tmp_path / "README.md").read_text()
    assert "| 10 | did not run: time step k = T/N = 0.1 exceeds" in report and "Reference: bdf2 with N = 320" in report
    bdf2 = rates(table, "time bdf2")
    assert 1.8 < bdf2["errorV"]["successive"] < 2.3, bdf2
    assert 0.9 < rates(table, "time euler")["errorV"]["reference"] < 1.1


def test_a_space_ladder_on_graded_meshes_takes_the_scheme_it_is_given(tmp_path):
    """--set reaches every run of the study (a graded space ladder in bdf2, as
    results/convergence-graded) and its reproduce line, which gives back the same values (a
    boolean too); its meshes are not nested, and its error in ‖·‖_V still falls at least at the
    theorem's h^(3/4)."""
    table = convergence(REPO / "scenes" / "paper_graded.toml", tmp_path, count=3, n1=12, n2=6, steps=10,
                        kinds=("space",), space_steps_level=0,
                        settings={"time.scheme": "bdf2", "glue.shearDebonding": False})
    assert {row["scheme"] for row in table} == {"bdf2"}
    used = {json.loads(path.read_text())["scheme"] for path in (tmp_path / "runs").rglob("params_used.json")}
    assert used == {"bdf2"}  # what the runs themselves ran
    line = next(line for line in (tmp_path / "README.md").read_text().splitlines() if "--set" in line)
    given = [shlex.split(part)[0] for part in line.split(" --set ")[1:]]  # as a shell passes them
    assert parse_assignments(given, "--set") == {"time.scheme": "bdf2", "glue.shearDebonding": False}
    assert rates(table, "space")["errorV"]["successive"] >= 0.75


@pytest.mark.unit
def test_a_study_refuses_a_setting_its_ladders_make(tmp_path):
    from orchestrate.freefem import InputError

    with pytest.raises(InputError, match=r"--set time.N: the study sets it for each run"):
        convergence(REPO / "scenes" / "paper.toml", tmp_path / "study", settings={"time.N": 5})
    assert not (tmp_path / "study").exists()


@pytest.mark.unit
def test_every_option_of_every_command_says_its_default():
    """`--help` of each command and study: an option with a default names it (argparse's own,
    or the option's text)."""
    import argparse

    from orchestrate.cli import parser

    def commands(top):
        for action in top._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    yield name, sub
                    yield from commands(sub)

    for name, sub in commands(parser()):
        text = sub.format_help().split("\noptions:", 1)[-1]  # past the usage lines
        for action in sub._actions:
            if action.option_strings and action.default not in (None, False, [], (), argparse.SUPPRESS) \
                    and action.dest != "help":
                line = next((i for i, row in enumerate(text.splitlines()) if row.lstrip().startswith(action.option_strings[-1])),
                            None)
                block = " ".join(text.splitlines()[line:line + 4]) if line is not None else ""
                assert "default" in block, (name, action.option_strings)


@pytest.mark.unit
def test_the_time_ladders_never_run_on_meshes_finer_than_the_space_ladder():
    from orchestrate.studies.convergence import time_mesh_level
    from orchestrate.freefem import InputError

    assert time_mesh_level(6, None) == 3 and time_mesh_level(3, None) == 2 and time_mesh_level(2, None) == 1
    assert time_mesh_level(3, 0) == 0
    with pytest.raises(InputError, match=r"--time-mesh-level 3: give a level in \[0, 2\]"):
        time_mesh_level(3, 3)


def test_compare_of_two_levels_gives_the_time_ladders_distances(quick, tmp_path, capsys):
    """`compare` of the time ladder's coarsest level with the next level and with the ladder's
    reference run measures what the study measured between them (at the same instants: the
    coarsest level's steps); a run compared with itself is at distance 0, to round-off."""
    from orchestrate.cli import main
    from orchestrate.compare import compare
    from orchestrate.results import load_result

    out, table = quick
    rows = [row for row in table if row["ladder"] == "time"]
    by_steps = {load_result(folder).params["N"]: folder for folder in (out / "runs" / "time").iterdir()}
    coarse, middle = by_steps[rows[0]["N"]], by_steps[rows[1]["N"]]
    [reference] = (out / "runs" / "time-reference").iterdir()
    to_next, to_reference = compare(coarse, middle), compare(coarse, reference)
    assert to_next.nested and to_next.reference == "b" and to_next.differences["time.N"] == (rows[0]["N"], rows[1]["N"])
    for quantity, column in (("errorV", "nextV"), ("errorZeta", "nextZeta"), ("errorBeta", "nextBeta")):
        assert to_next.maximum(quantity) == pytest.approx(rows[0][column], rel=1e-12)
        assert to_reference.maximum(quantity) == pytest.approx(rows[0][quantity], rel=1e-12)
    assert to_reference.relative("errorV") == pytest.approx(rows[0]["relativeErrorV"], rel=1e-12)
    itself = compare(middle, middle)  # its strains and ζ taken at its own quadrature points: round-off
    assert all(row["errorV"] <= 1e-13 * row["normV"] and row["errorZeta"] <= 1e-13 * row["normZeta"]
               and row["errorBeta"] == 0 for row in itself.rows)
    assert compare(middle, coarse).reference == "a"  # the same meshes: the run with more steps
    assert main(["compare", str(coarse), str(middle), "--out", str(coarse)]) == 2  # a run folder: refused
    assert main(["compare", str(coarse), str(middle), "--out", str(tmp_path)]) == 0
    report = capsys.readouterr().out
    assert "the figures are exact" in report
    assert all(f"body {body} mesh: the same, " in report for body in (1, 2))  # a time ladder keeps its meshes
    assert (tmp_path / "history.png").stat().st_size > 10000 and (tmp_path / "comparison.csv").read_text().count("\n") == 1 + rows[0]["N"]


def test_compare_lists_how_the_meshes_differ(quick):
    """Two levels of the space ladder: the report gives each body's node and triangle counts, as
    the mesh files hold them (read here by meshio, another reader)."""
    import meshio

    from orchestrate.compare import compare
    from orchestrate.results import load_result

    out, _ = quick
    def nodes(folder):
        return len(meshio.read(load_result(folder).mesh_file(1)).points)

    coarse, fine = sorted((out / "runs" / "space").iterdir(), key=nodes)[:2]
    comparison = compare(coarse, fine)
    for body, mesh in enumerate(comparison.meshes, 1):
        counts = [(len(read.points), len(read.cells_dict["triangle"]))
                  for read in (meshio.read(load_result(run).mesh_file(body)) for run in (coarse, fine))]
        assert mesh["nodes"] == (counts[0][0], counts[1][0]) and mesh["triangles"] == (counts[0][1], counts[1][1])
        assert not mesh["same"] and mesh["nodes"][0] < mesh["nodes"][1]
        assert (f"body {body} mesh: {counts[0][0]} nodes, {counts[0][1]} triangles (A); {counts[1][0]} nodes, "
                f"{counts[1][1]} triangles (B)") in comparison.report()
