"""Every FreeFEM script compiles (FreeFem++ -jc: parse, types, includes, loads).

Libraries (edp/lib/*.idp) and scene files are compiled through the scripts that include them."""
from pathlib import Path

import pytest

from orchestrate.freefem import MAIN, REPO, run_script

pytestmark = pytest.mark.solver

SCENES = sorted((REPO / "edp" / "scenes").glob("*.idp")) + sorted((REPO / "tests" / "scenes").glob("*.idp"))
SCRIPTS = sorted((REPO / "edp").rglob("*.edp")) + sorted((REPO / "tests").rglob("*.edp"))


def label(path):
    return str(Path(path).relative_to(REPO))


@pytest.mark.parametrize("script", SCRIPTS, ids=label)
def test_script_compiles(script):
    done = run_script(script, ["-jc"])
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]


@pytest.mark.parametrize("scene", SCENES, ids=label)
def test_scene_compiles_with_the_driver(scene):
    done = run_script(MAIN, ["-jc"], defines={"SCENE": scene.name}, cwd=scene.parent)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]


def test_libraries_do_nothing_when_included(tmp_path):
    """tests/edp/libraries.edp includes every library after the parameters are read: they define
    functions and macros only, so it prints nothing and writes nothing."""
    done = run_script(REPO / "tests" / "edp" / "libraries.edp", [], cwd=tmp_path)
    assert done.returncode == 0 and done.stdout.strip() == "" and done.stderr.strip() == ""
    assert not any(tmp_path.iterdir())
    included = set((REPO / "tests" / "edp" / "libraries.edp").read_text().split('lib/')[1:])
    assert {name.split('"')[0] for name in included} == {path.name for path in (REPO / "edp" / "lib").glob("*.idp")}


@pytest.mark.unit
def test_the_driver_declares_no_state_and_its_loop_is_the_scheme():
    """Per-body state lives in edp/lib/state.idp; the loop of edp/main.edp is docs/model.md §6's
    steps, in order, as its macro stepSolve (which a start in substeps, lib/start.idp, runs too)."""
    text = (REPO / "edp" / "main.edp").read_text()
    assert "real[int]" not in text and "Vh1" not in text
    solve = text[text.index("macro stepSolve\n"):]
    solve = [line.split()[0] for line in solve[:solve.index("\n//\n")].splitlines()[1:]]
    assert solve == ["glueLoads", "explicitRhs(1)", "explicitRhs(2)", "contactStep", "damageStep(1)", "damageStep(2)",
                     "bondingStep", "stepFigures"]
    loop = text[text.index("for (int n = firstStep; n <= nSteps; n++) {"):]
    loop = loop[:loop.index("\n}\n")].splitlines()[1:]
    assert len(loop) <= 16, loop
    for step in ("stepSolve", "historyRow(n)", "advanceState"):
        assert any(line.strip().startswith(step) for line in loop), step
