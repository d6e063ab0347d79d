"""Readers that snapshot (issue 47, item 3): a run folder is read through its manifest, each file's
SHA-256 checked against it when the file is read, so a folder replaced or changed while it is read
is refused, never read half from one run and half from another; compare names every difference
between the problems two runs solve (every scene key: loads, boundary conditions, initial data;
the meshes by content), and says when there is none."""
import os
import shutil

import pytest

from orchestrate import run
from orchestrate.compare import compare, scene_differences
from orchestrate.freefem import REPO, run_script
from orchestrate.manifest import IncompleteRun
from orchestrate.results import load_result

pytestmark = pytest.mark.runs

PAPER = REPO / "scenes" / "paper.toml"
COARSE = {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.N": 20, "output.images": False,
          "output.fields": ["bodies", "contact", "state"], "output.times": [0.5, 1.0]}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("runs")
    changes = {"same": {}, "load": {"body1.boundary[label=4].fy": "-20*t"}, "zeta0": {"body2.damage.zeta0": "1 - 0.1*x/6"},
               "condition": {"body1.boundary[label=5].type": "roller", "body1.boundary[label=5].component": "x"},
               "mesh": {"body1.mesh.structured": False}}
    return {name: run(PAPER, folder / name, {**COARSE, **change}).folder for name, change in changes.items()}


@pytest.mark.parametrize("reader", [
    lambda result: result.history, lambda result: result.params,
    lambda result: result.fields("body1", 1.0), lambda result: compare(result, load_result(result.folder)),
])
def test_a_folder_replaced_after_it_was_loaded_is_refused_not_mixed(tmp_path, runs, reader):
    folder = tmp_path / "run"
    shutil.copytree(runs["same"], folder)
    result = load_result(folder)
    replaced = tmp_path / "other"
    shutil.copytree(runs["load"], replaced)
    os.rename(folder, tmp_path / "old")
    os.rename(replaced, folder)  # a run published over it, as runner.publish swaps one in
    with pytest.raises(IncompleteRun, match="not the file its manifest records"):
        reader(result)


def test_a_file_changed_in_place_after_loading_is_refused(tmp_path, runs):
    folder = tmp_path / "run"
    shutil.copytree(runs["same"], folder)
    result = load_result(folder)
    state = folder / "state_0020.txt"
    state.write_text(state.read_text().replace("1", "2", 1))
    with pytest.raises(IncompleteRun, match="state_0020.txt: not the file its manifest records"):
        compare(result, load_result(runs["same"]))


@pytest.mark.parametrize("other, named", [
    ("same", []),
    ("load", ["body1.boundary[label=4].fy"]),
    ("zeta0", ["body2.damage.zeta0"]),
    ("condition", ["body1.boundary[label=5].type", "body1.boundary[label=5].component"]),
    ("mesh", ["body1.mesh.structured", "body 1's mesh (by content)"]),
])
def test_compare_names_every_difference_of_the_problems(runs, other, named):
    first, second = load_result(runs["same"]), load_result(runs[other])
    assert sorted(scene_differences(first, second)) == sorted(named)
    report = compare(first, second).report() if other != "mesh" else ""
    if other == "same":
        assert "the same problem" in report
    elif report:
        assert all(f"  {name}:" in report for name in named)


def test_runs_of_the_driver_by_hand_are_told_apart_by_their_scene_file_s_code(tmp_path, runs, monkeypatch):
    """Without scene.toml, the scene file's code (run.json sceneCode) stands for the loads."""
    monkeypatch.chdir(runs["same"])  # where the driver found body1.msh and body2.msh (the same in both runs)
    folders = {}
    for name in ("same", "load"):
        folders[name] = tmp_path / name
        done = run_script(REPO / "edp" / "main.edp", ["-out", str(folders[name])], cwd=runs[name], defines={"SCENE": "scene.idp"})
        assert done.returncode == 0, done.error_line
    differences = scene_differences(load_result(folders["same"]), load_result(folders["load"]))
    assert list(differences) == ["scene file's code (loads, conditions, initial data)"]
    assert not scene_differences(load_result(folders["same"]), load_result(folders["same"]))


def test_what_a_run_writes_and_the_order_of_its_conditions_are_no_difference_of_the_problem(tmp_path, runs):
    """Found by an adversarial pass: the title, the output times and fields are not the problem, and
    the same conditions listed in another order solve the same one (named by label, not by index)."""
    scene = (PAPER.read_text().replace('title = "', 'title = "another title, ')
             .replace('[[body1.boundary]]\ntype = "traction"\nlabel = 4\nfx = "0"\nfy = "-10*t"\n\n', ""))
    scene = scene.replace('label = 2\nfx = "10*y*t"\nfy = "0"\n',
                          'label = 2\nfx = "10*y*t"\nfy = "0"\n\n[[body1.boundary]]\ntype = "traction"\nlabel = 4\n'
                          'fx = "0"\nfy = "-10*t"\n')
    assert scene.index("label = 2") < scene.index("label = 4")  # body 1's tractions in the other order
    (tmp_path / "reordered.toml").write_text(scene)
    other = run(tmp_path / "reordered.toml", tmp_path / "reordered", {**COARSE, "output.times": [1.0]})
    assert scene_differences(load_result(runs["same"]), load_result(other.folder)) == {}
