"""Every FreeFEM script compiles (FreeFem++ -jc: parse, types, includes, loads).

Libraries (edp/lib/*.idp) and scene files are compiled through the scripts that include them."""
from pathlib import Path

import pytest

from orchestrate.freefem import MAIN, REPO, run_script

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
