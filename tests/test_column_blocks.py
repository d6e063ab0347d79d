"""Blocks of contact columns (solver.condensation = "columns", solver.columnBlock,
edp/plugins/blocksolve.cpp): blockSolve solves
many right-hand sides exactly; a run with blocks is the run one column at a time up to round-off,
with the same contact iterations; a column's bits do not depend on when it is made, so a run
with blocks killed and restarted continues to the bit."""
import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from conftest import resealed  # noqa: E402
from test_restart import DRIVER, killed_driver, rows, same_results  # noqa: E402

from orchestrate.freefem import MAIN, REPO, run_script  # noqa: E402
from orchestrate.results import STATE_ARRAYS, read_state  # noqa: E402
from orchestrate.runner import run  # noqa: E402

pytestmark = pytest.mark.solver

# A P1 field w is reproduced exactly by solving A x = A w: the columns of B are A w_j for
# fields w_j of different shapes, so blockSolve(A, B) must give the w_j to round-off.
BLOCK_CHECK = textwrap.dedent("""
    load "blocksolve"
    mesh Th = square(12, 9);
    fespace Vh(Th, [P1, P1]);
    varf a([u1, u2], [v1, v2]) = int2d(Th)(dx(u1)*dx(v1) + dy(u1)*dy(v1) + dx(u2)*dx(v2) + dy(u2)*dy(v2)
        + 0.3*(dx(u1)*dy(v2) + dy(u2)*dx(v1)) + u1*v1 + u2*v2) + on(4, u1 = 0, u2 = 0);
    matrix full = a(Vh, Vh), half = a(Vh, Vh, sym = 1);
    set(half, solver = SOLVER);
    int m = COLUMNS;
    real[int,int] B(Vh.ndof, m), W(Vh.ndof, m);
    for (int j = 0; j < m; j++) {
      Vh [w1, w2] = [x^(j % 3)*(1 + j*y), y*y - j*x];
      real[int] b = full*w1[];
      B(:, j) = b; W(:, j) = w1[];
    }
    cout << "columns " << blockSolve(half, B) << endl;
    real worst = 0;
    for (int j = 0; j < m; j++) { real[int] d = B(:, j); real[int] w = W(:, j); d -= w; worst = max(worst, d.linfty); }
    cout.precision(17);
    cout << "error " << worst << endl;
""")


@pytest.mark.parametrize("solver", ["CHOLMOD", "UMFPACK"])
@pytest.mark.parametrize("columns", [1, 2, 3, 7, 32])
def test_block_solve_reproduces_p1_fields_exactly(tmp_path, solver, columns):
    script = tmp_path / "block.edp"
    script.write_text(BLOCK_CHECK.replace("SOLVER", f'"{solver}"').replace("COLUMNS", str(columns)))
    done = run_script(script)
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"columns {columns}\n" in done.stdout
    assert float(done.stdout.split("error ")[1].split()[0]) < 1e-12


def test_block_solve_refuses_columns_of_another_size(tmp_path):
    script = tmp_path / "wrong.edp"
    script.write_text(BLOCK_CHECK.replace("SOLVER", '"CHOLMOD"').replace("COLUMNS", "2")
                      .replace("blockSolve(half, B)", "blockSolve(half, C)")
                      .replace("int m = 2;", "int m = 2;\nreal[int,int] C(Vh.ndof - 1, m);\nC = 1;"))
    done = run_script(script)
    assert done.returncode != 0 and "different number of rows" in done.stdout + done.stderr


def column_runs(tmp_path, scene: str, overrides: dict, blocks=(1, 4, 32)):
    folders = {}
    for block in blocks:
        folders[block] = tmp_path / f"block{block}"
        run(REPO / "scenes" / f"{scene}.toml", folders[block],
            {**overrides, "solver.condensation": "columns", "solver.columnBlock": block, "output.fields": ["state"],
             "output.images": False})
    return folders


# The paper's scene over 15 s (the contact set and the glue change) and the peel scene (the
# bonded zone opens node by node), with the paper's scheme (its glue explicit: the contact's
# columns are made as nodes become active; the peel's normal glue is above euler's bound, allowed
# here: the runs compared share their data): one column at a time, in groups of 4 and of 32.
# In the paper's scene two of the 12 constrained nodes are never active: one group of 32 makes their
# columns too.
@pytest.mark.parametrize("scene, overrides, never_active", [
    ("paper", {"body1.mesh.n": 12, "body2.mesh.n": 16, "time.T": 15.0, "time.N": 300, "time.scheme": "euler"}, 2),
    ("peel", {"body1.mesh.n": 20, "body2.mesh.n": 27, "time.scheme": "euler", "solver.allowUnstable": True}, 0),
])
def test_blocks_change_only_the_last_bits(tmp_path, scene, overrides, never_active):
    folders = column_runs(tmp_path, scene, overrides)
    facts = {block: json.loads((folder / "run.json").read_text()) for block, folder in folders.items()}
    one = facts[1]
    for block, fact in facts.items():
        # the same active sets: every step needs the same contact iterations
        history = [line.split(",") for line in (folders[block] / "history.csv").read_text().splitlines()]
        iterations = [row[history[0].index("contactIters")] for row in history[1:]]
        if block == 1:
            reference_iterations = iterations
        assert iterations == reference_iterations
        assert fact["contactSolves"] == one["contactSolves"]
        # a group is made whole: at least the columns of the nodes ever active, at most all
        assert one["contactColumns"] <= fact["contactColumns"] <= fact["constraints"]
        reference = read_state(sorted(folders[1].glob("state_*.txt"))[-1])
        produced = read_state(sorted(folders[block].glob("state_*.txt"))[-1])
        for name in STATE_ARRAYS:  # each field against its own largest value
            assert produced[name].shape == reference[name].shape, name
            scale = np.abs(reference[name]).max()
            assert np.abs(produced[name] - reference[name]).max() <= 1e-11*scale, name
    assert one["contactColumns"] == one["constraints"] - never_active
    assert facts[32]["contactColumns"] == one["constraints"] <= 32  # one group holds every node


def test_the_implicit_glue_s_compliance_in_blocks_changes_only_the_last_bits(tmp_path):
    """The peel scene with the semi-implicit scheme: the interface's compliance S_B (glue.idp) is
    made in groups of columnBlock back-substitutions as well; one at a time or 32 together give
    the same run but for the last bits, which the dense interface solve carries to about 1e-12."""
    folders = column_runs(tmp_path, "peel", {"body1.mesh.n": 20, "body2.mesh.n": 27, "time.scheme": "semi-implicit"},
                          blocks=(1, 32))
    reference = read_state(sorted(folders[1].glob("state_*.txt"))[-1])
    produced = read_state(sorted(folders[32].glob("state_*.txt"))[-1])
    for name in STATE_ARRAYS:
        scale = np.abs(reference[name]).max()
        assert np.abs(produced[name] - reference[name]).max() <= 1e-10*scale, name
    assert json.loads((folders[1] / "run.json").read_text())["contactColumns"] == 0  # no contact column: S_B holds all


@pytest.fixture(scope="module")
def hertz_scene(tmp_path_factory) -> Path:
    """The Hertz scene's run folder: its scene.idp reruns it by hand."""
    folder = tmp_path_factory.mktemp("hertz") / "run"
    run(REPO / "scenes" / "hertz.toml", folder, {"output.fields": ["state"], "output.images": False})
    return folder / "scene.idp"


@pytest.mark.parametrize("kill_at", [30, 100])
def test_a_run_with_blocks_continues_to_the_bit_after_a_restart(tmp_path, hertz_scene, kill_at):
    # Hertz's contact zone grows with the load: the uninterrupted run makes its columns in groups
    # of 3 over its first 60 steps (9 nodes at step 1, 31 by step 60), the restarted one those of
    # its active set at the checkpoint at once and the rest later. A group of 3 leaves a column to
    # the BLAS's single-column kernels, whose last bits differ from those of the others.
    extra = ("-condensation", "columns", "-columnBlock", "3")
    whole = tmp_path / "whole"
    done = run_script(MAIN, [*DRIVER, *extra, "-out", whole], cwd=hertz_scene.parent, defines={"SCENE": hertz_scene.name})
    assert done.returncode == 0, done.error_line
    assert json.loads((whole / "run.json").read_text())["contactColumns"] > 9
    folder = tmp_path / "run"
    killed_driver(folder, kill_at, extra, scene=hertz_scene)
    killed_at = rows(folder)  # a few rows past kill_at: a Hertz step takes milliseconds
    done = run_script(MAIN, [*DRIVER, *extra, "-out", folder, "-restart", folder],
                      cwd=hertz_scene.parent, defines={"SCENE": hertz_scene.name})
    assert done.returncode == 0, done.error_line
    assert 0 < json.loads((folder / "run.json").read_text())["restartedFrom"] <= killed_at
    same_results(whole, folder)


def plugin_copy(parent: Path) -> Path:
    """bin and edp of the repository, copied with their file times, and the stamps' reader."""
    copy = parent / "repo"
    for name in ("bin", "edp"):
        shutil.copytree(REPO / name, copy / name)
    (copy / "orchestrate").mkdir()
    shutil.copy2(REPO / "orchestrate" / "identity.py", copy / "orchestrate")
    return copy


@pytest.mark.unit
def test_a_missing_plugin_is_named_before_freefem_starts(tmp_path, monkeypatch):
    from orchestrate import freefem
    copy = plugin_copy(tmp_path)
    (copy / "edp" / "plugins" / "blocksolve.so").unlink()
    monkeypatch.setattr(freefem, "REPO", copy)
    with pytest.raises(FileNotFoundError, match=r"plugins/blocksolve.so is missing, or not built .* run `make setup`"):
        freefem.freefem_binary()


def test_bin_ff_names_a_plugin_not_built_from_its_source_as_it_is(tmp_path):
    copy = plugin_copy(tmp_path)
    source = copy / "edp" / "plugins" / "blocksolve.cpp"
    source.write_text(source.read_text() + "// edited\n")
    done = subprocess.run([copy / "bin" / "ff", "edp/main.edp"], cwd=copy, capture_output=True, text=True)
    assert done.returncode == 3
    assert "blocksolve.so is missing, or not built from its source for this FreeFem++: run `make setup`" in done.stderr


def test_bin_plugins_compiles_what_is_missing_and_fails_loudly(tmp_path):
    copy = plugin_copy(tmp_path)
    plugins = copy / "edp" / "plugins"
    (plugins / "blocksolve.so").unlink()
    done = subprocess.run([copy / "bin" / "plugins", "build"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    rebuilt = sorted(p.name for p in plugins.iterdir() if p.name.startswith("blocksolve."))
    assert rebuilt == ["blocksolve.built-for", "blocksolve.cpp", "blocksolve.so"]  # its .o and log cleared
    assert subprocess.run([copy / "bin" / "plugins", "check"]).returncode == 0
    (plugins / "blocksolve.cpp").write_text("this is not C++\n")
    done = subprocess.run([copy / "bin" / "plugins", "build"], capture_output=True, text=True)
    assert done.returncode == 1 and "ff-c++ did not build" in done.stderr
    assert not (plugins / "blocksolve.so").exists()
    assert subprocess.run([copy / "bin" / "plugins", "check"], capture_output=True).returncode == 3


def test_a_checkpoint_made_without_a_parameter_of_this_driver_is_refused(tmp_path):
    # A checkpoint of the code before solver.columnBlock: restarted with the default 32 it would not
    # continue the run it was made by (one column at a time) to the bit.
    folder = tmp_path / "run"
    killed_driver(folder, 100)
    edited = 0
    for checkpoint in folder.glob("checkpoint-*.txt"):
        lines = checkpoint.read_text().splitlines()
        at = [j for j, line in enumerate(lines) if line.startswith("parameters ")]
        kept = [line for line in lines if not line.startswith("columnBlock ")]
        if not at or len(kept) == len(lines):
            continue  # cut short by the kill: the restart passes it over
        kept[at[0]] = f"parameters {int(lines[at[0]].split()[1]) - 1}"
        resealed(checkpoint, lambda _: kept[:-2])
        edited += 1
    assert edited
    done = run_script(MAIN, [*DRIVER, "-out", folder, "-restart", folder])
    assert done.returncode == 3
    assert "was made by a driver without 1 of this driver's parameters" in done.error_line, done.error_line
