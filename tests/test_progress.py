"""Progress that tells the truth (issue 18, item 7): a bar where someone can see it and nowhere
else, the loop's rate and time left measured without the set-up, and each phase of a run named."""
import io
import re
import sys
import types

import pytest

from orchestrate import run
from orchestrate.freefem import REPO, InputError
from orchestrate.progress import loop_pace, pace_note, wanted
from orchestrate.studies.stability import stability

pytestmark = pytest.mark.runs

PAPER = REPO / "scenes" / "paper.toml"
COARSE = {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.N": 20}


def counts(stderr: str, total: int) -> list[int]:
    """The step counts a bar showed, in order."""
    return [int(n) for n in re.findall(rf"(\d+)/{total}\b", stderr)]


@pytest.mark.unit
def test_the_rate_and_time_left_leave_the_set_up_out():
    # 10 s of set-up, then a step every 0.1 s: at t = 12 s, 20 of 100 steps are done.
    assert loop_pace((10.0, 0), 12.0, 20, 100) == pytest.approx((10.0, 8.0))
    # From the launch it would have been 20 steps in 12 s and 48 s left: the misleading estimate.
    assert loop_pace((10.0, 0), 12.0, 20, 100)[1] != pytest.approx((100 - 20) / (20 / 12.0))
    # A restart whose set-up ended with 60 steps already done (its checkpoint): only its own count.
    assert loop_pace((5.0, 60), 7.0, 70, 100) == pytest.approx((5.0, 6.0))
    assert loop_pace(None, 12.0, 0, 100) is None  # set-up: no rate, no time left
    assert loop_pace((10.0, 0), 10.5, 0, 100) is None  # set-up over, no step of the loop yet


@pytest.mark.unit
def test_the_note_gives_a_rate_and_the_time_left_once_there_is_one():
    assert pace_note(None) == "first step"
    assert pace_note((10.0, 8.0)) == "10 step/s, 00:08 left"
    assert pace_note((1234.4, 65.0)) == "1234 step/s, 01:05 left"
    assert pace_note((0.25, 100.0)) == "4 s/step, 01:40 left"


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.mark.unit
def test_auto_shows_progress_on_a_terminal_or_in_a_notebook_and_nowhere_else(monkeypatch):
    monkeypatch.setattr(sys, "stderr", io.StringIO())  # a pipe, a CI log
    monkeypatch.delitem(sys.modules, "IPython", raising=False)
    assert wanted("auto") is False
    assert wanted(True) is True and wanted(False) is False
    monkeypatch.setattr(sys, "stderr", Terminal())
    assert wanted("auto") is True
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    ipython = types.ModuleType("IPython")
    shell = types.SimpleNamespace()  # a terminal IPython: its shell has no kernel
    ipython.get_ipython = lambda: shell
    monkeypatch.setitem(sys.modules, "IPython", ipython)
    assert wanted("auto") is False
    shell.kernel = object()  # a Jupyter kernel's shell
    assert wanted("auto") is True
    with pytest.raises(InputError, match=r"progress = 'yes': give True, False or 'auto'"):
        wanted("yes")


def test_a_run_with_progress_names_its_phases_and_ends_on_its_last_step(tmp_path, capsys):
    run(PAPER, tmp_path / "shown", COARSE, progress=True, mesh_cache=tmp_path / "cache")
    shown = capsys.readouterr().err
    for phase in ("meshing body 1 (gmsh)", "meshing body 2 (gmsh)", "set-up", "reading the files back",
                  "rendering fields.png", "rendering history.png"):
        assert phase in shown, phase
    steps = counts(shown, 20)
    assert steps[-1] == 20 and steps == sorted(steps)
    assert shown.index("meshing") < shown.index("set-up") < shown.index("rendering")


def test_a_run_without_progress_writes_nothing_to_stderr(tmp_path, capsys):
    run(PAPER, tmp_path / "quiet", {**COARSE, "output.images": False}, progress=False, mesh_cache=tmp_path / "cache")
    assert capsys.readouterr().err == ""
    with pytest.raises(InputError, match="progress = 1"):
        run(PAPER, tmp_path / "never", COARSE, progress=1)
    assert not (tmp_path / "never.partial").exists()


def test_the_stability_study_counts_its_cases(tmp_path, capsys):
    """Without Young's moduli or glue stiffnesses (its size flags --young '' --p-tau '') the study
    is its two damage-source cases, and its report's command says so."""
    from orchestrate.cli import parser

    options = parser().parse_args(["study", "stability", "--young", "", "--p-tau", ""])
    assert (options.young, options.p_tau) == ((), ())
    with pytest.raises(SystemExit):
        parser().parse_args(["study", "stability", "--young", "100,-1"])
    rows = stability(PAPER, tmp_path / "study", young=options.young, glue=options.p_tau, progress=True)
    shown = capsys.readouterr().err
    assert "every value must be > 0" in shown
    assert "--young '' --p-tau ''" in (tmp_path / "study" / "README.md").read_text()
    assert len(rows) == 2 and "2/2" in shown
    assert "damage source, euler" in shown and "damage source, bdf2" in shown
    assert "run: " in shown  # and each run's own bar
