"""A file is trusted only once this program checked it (issue "Trust no file ...", items 3, 6, 7):
the solver's identity is derived from its sources, so no change of code is a "same run"; a run
folder is read only through a manifest that names exactly its files; a checkpoint is taken only
when its seal matches, and only by a run of its identity."""
import json
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from orchestrate import load_result, run
from orchestrate.cli import main
from orchestrate.compare import compare
from orchestrate.freefem import MAIN, REPO, run_script
from orchestrate.identity import program_files, solver_identity
from orchestrate.manifest import IncompleteRun
from orchestrate.results import Result
from orchestrate.runner import RunError, checkpoint_step, inputs_of, sealed_checkpoint
from orchestrate.scene import Scene

pytestmark = pytest.mark.runs

PAPER = REPO / "scenes" / "paper.toml"
STATES = {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.N": 20, "output.images": False,
          "output.times": [0.25, 0.5, 1.0], "output.fields": ["bodies", "contact", "state"]}


# --- 3. the solver's identity is derived ---------------------------------------------------------

@pytest.fixture
def edp_copy(tmp_path):
    copy = tmp_path / "edp"
    shutil.copytree(REPO / "edp", copy, ignore=shutil.ignore_patterns("*.o", "*.log"))
    return copy


@pytest.mark.parametrize("change", [
    lambda edp: (edp / "plugins" / "strainoperators.cpp").write_text(
        (edp / "plugins" / "strainoperators.cpp").read_text().replace("gy*ux + gx*uy", "gx*ux + gy*uy", 1)),
    lambda edp: (edp / "plugins" / "strainoperators.so").write_bytes(
        (edp / "plugins" / "strainoperators.so").read_bytes() + b"\0"),
    lambda edp: (edp / "lib" / "parameterTable.idp").write_text(
        (edp / "lib" / "parameterTable.idp").read_text().replace('"1e-10"', '"1e-9"', 1)),
    lambda edp: (edp / "lib" / "damage.idp").write_text((edp / "lib" / "damage.idp").read_text() + "// a comment\n"),
], ids=["plugin source", "built plugin", "parameter table", "library"])
@pytest.mark.unit
def test_every_change_of_the_solver_s_files_changes_its_identity(edp_copy, change):
    before = solver_identity(edp_copy / "main.edp")
    change(edp_copy)
    assert solver_identity(edp_copy / "main.edp") != before


@pytest.mark.unit
def test_a_new_library_or_plugin_enters_the_identity_with_no_edit(edp_copy):
    """A library included from the driver and the plugin it loads are in the identity as soon as
    the driver names them; a tool script beside the libraries is not part of the program."""
    before = solver_identity(edp_copy / "main.edp")
    (edp_copy / "tools" / "solvers.edp").write_text("// a tool, not included by the driver\n")
    assert solver_identity(edp_copy / "main.edp") == before
    (edp_copy / "lib" / "glue.idp").write_text('load "gluesource"\n')
    (edp_copy / "plugins" / "gluesource.cpp").write_text("// a plugin\n")
    assert solver_identity(edp_copy / "main.edp") != before  # lib/ is read: a data file beside the libraries
    main = edp_copy / "main.edp"
    main.write_text(main.read_text().replace('include "lib/checkpoint.idp"\n',
                                             'include "lib/checkpoint.idp"\ninclude "lib/glue.idp"\n'))
    files = program_files(main)
    assert edp_copy.resolve() / "lib" / "glue.idp" in files
    assert edp_copy.resolve() / "plugins" / "gluesource.cpp" in files and \
        edp_copy.resolve() / "plugins" / "gluesource.so" in files


@pytest.mark.unit
def test_a_run_s_inputs_hold_the_solver_s_identity():
    assert inputs_of(Scene.load(PAPER))["solver"] == solver_identity()


@pytest.mark.solver
def test_bin_ff_checks_its_plugins_and_gives_the_identity_from_one_python_process(tmp_path):
    """bin/ff's two checks, the plugins' stamps and the solver's identity, cost a python3 start each
    (two of them were 0.27–0.32 s of a 0.7 s run of a 6 × 8 scene): one isolated process (-I -S:
    without the site packages' start-up) makes both, and gives the driver the identity orchestrate
    computes in-process."""
    calls = tmp_path / "calls"
    wrapper = tmp_path / "bin" / "python3"
    wrapper.parent.mkdir()
    wrapper.write_text(f'#!/bin/sh\necho "$*" >> {calls}\nexec {shutil.which("python3")} "$@"\n')
    wrapper.chmod(0o755)
    done = subprocess.run([REPO / "bin" / "ff", "edp/main.edp", "-T", "0.05", "-N", "1", "-out", tmp_path / "run"],
                          cwd=REPO, capture_output=True, text=True,
                          env={**os.environ, "PATH": f"{wrapper.parent}:{os.environ['PATH']}"})
    assert done.returncode == 0, done.stderr
    started = calls.read_text().splitlines()
    assert len(started) == 1 and started[0].startswith("-I -S "), started
    assert json.loads((tmp_path / "run" / "params_used.json").read_text())["solverIdentity"] == solver_identity()


@pytest.mark.unit
def test_a_fact_kept_by_this_process_is_taken_only_for_the_file_as_it_was(tmp_path):
    """Within a process as between processes: a change that keeps the size and puts the
    modification time back (`touch -r`, a careful copy) still changes the change time, and the fact
    is computed anew (the process's memory once left the change time out)."""
    from orchestrate import identity

    facts = identity.StampedFacts(tmp_path / "store", lambda path: path.read_text())
    file = tmp_path / "data.txt"
    file.write_text("first")
    assert facts.of(file) == "first"
    before = file.stat()
    time.sleep(0.05)  # change times move by the kernel's clock tick
    file.write_text("other")
    os.utime(file, ns=(before.st_atime_ns, before.st_mtime_ns))
    assert facts.of(file) == "other"


@pytest.mark.unit
def test_a_kept_fact_is_taken_only_for_the_file_as_it_was(tmp_path, monkeypatch):
    """StampedFacts (FreeFem++'s digests, the meshes read whole): a fact is taken from the store by
    another process only while the file keeps its stamp; a change that keeps the size and puts the
    modification time back still changes it (the change time), a file changed within SETTLED
    seconds of its reading is not kept for others, and an entry that is damaged, of another path,
    without a stamp, of another version of the code or whose fact its check refuses is computed
    anew, never believed."""
    from orchestrate import identity

    computed = []

    def facts(store: Path, version: str = "1") -> identity.StampedFacts:  # a fresh process's view of the store
        return identity.StampedFacts(store, lambda path: computed.append(path) or path.read_text(), version,
                                     lambda fact: fact != "refused")

    store, file = tmp_path / "store", tmp_path / "data.txt"
    file.write_text("first")
    assert facts(store).of(file) == "first" and len(computed) == 1
    assert facts(store).of(file) == "first" and len(computed) == 2  # changed just now: kept by no one else
    monkeypatch.setattr(identity, "SETTLED", -1.0)
    facts(store).of(file)
    assert facts(store).of(file) == "first" and len(computed) == 3  # settled: the second process computed nothing
    before = file.stat()
    file.write_text("other")  # the same size, and the modification time put back
    os.utime(file, ns=(before.st_atime_ns, before.st_mtime_ns))
    assert facts(store).of(file) == "other" and len(computed) == 4
    entry = facts(store).entry_file(str(file))
    record = json.loads(entry.read_text())
    for damaged in ("{not json", json.dumps({**record, "path": str(tmp_path / "another.txt"), "fact": "forged"}),
                    json.dumps({key: value for key, value in record.items() if key != "stamp"}),
                    json.dumps({**record, "fact": "refused"})):
        entry.write_text(damaged)
        computed.clear()
        assert facts(store).of(file) == "other" and len(computed) == 1, damaged
    computed.clear()
    assert facts(store, "2").of(file) == "other" and len(computed) == 1  # another version of the code
    assert not list(store.glob("*.partial"))


# --- 6, 7. readers take only what the manifest lists ---------------------------------------------

@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    parent = tmp_path_factory.mktemp("runs")
    first = run(PAPER, parent / "a", STATES, progress=False)
    second = run(PAPER, parent / "b", {**STATES, "time.N": 40}, progress=False)
    return first.folder, second.folder


@pytest.fixture
def copy_of(tmp_path, two_runs):
    def copied(index: int) -> Path:
        target = tmp_path / f"run{index}"
        shutil.copytree(two_runs[index], target)
        return target
    return copied


def test_a_state_file_the_manifest_does_not_list_is_not_read(copy_of, two_runs):
    """An extra state file from another run (was: a row more in compare, another maximum
    ‖β_A − β_B‖, and load_result passed)."""
    folder = copy_of(0)
    shutil.copy(two_runs[1] / "state_0010.txt", folder / "state_0015.txt")
    with pytest.raises(IncompleteRun, match="not in the manifest: state_0015.txt"):
        load_result(folder)
    assert "state_0015.txt" not in Result(folder).files
    rows = compare(Result(folder), Result(two_runs[1])).rows
    assert [row["t"] for row in rows] == pytest.approx([0.25, 0.5, 1.0])


def test_an_emptied_manifest_and_a_cut_history_are_refused(copy_of):
    folder = copy_of(0)
    history = folder / "history.csv"
    history.write_text("\n".join(history.read_text().splitlines()[:5]) + "\n")
    (folder / "manifest.json").write_text('{"files": {}}')
    with pytest.raises(IncompleteRun, match="not a run's manifest"):
        load_result(folder)


def forged(folder: Path, change) -> None:
    """The manifest made to match the folder after `change(entries)`: what a forger writes."""
    from orchestrate.manifest import digest

    manifest = json.loads((folder / "manifest.json").read_text())
    change(manifest["files"])
    for name in manifest["files"]:
        if (folder / name).is_file():
            manifest["files"][name] = {"bytes": (folder / name).stat().st_size, "sha256": digest(folder / name)}
    (folder / "manifest.json").write_text(json.dumps(manifest))


def test_a_manifest_forged_to_match_a_cut_history_is_refused_by_the_row_count(copy_of):
    folder = copy_of(0)
    history = folder / "history.csv"
    history.write_text("\n".join(history.read_text().splitlines()[:5]) + "\n")
    forged(folder, lambda entries: None)
    with pytest.raises(IncompleteRun, match="4 rows of 20 steps"):
        load_result(folder)


def test_a_manifest_without_a_file_run_json_names_is_refused(copy_of):
    folder = copy_of(0)
    (folder / "state_0010.txt").unlink()
    forged(folder, lambda entries: entries.pop("state_0010.txt"))
    with pytest.raises(IncompleteRun, match="files run.json names"):
        load_result(folder)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(edit=st.sampled_from(["drop", "add", "bytes", "sha", "rename", "link", "folder"]), pick=st.integers(0, 10**6),
       name=st.sampled_from(["state_0005.txt", "../x", "body3_0010.vtu", "run.log.1", "extra.csv", "a/b"]))
def test_a_folder_that_differs_from_its_manifest_in_any_way_is_refused(two_runs, tmp_path, edit, pick, name):
    """Entries removed, added, renamed or with other numbers, a file a link, a folder inside:
    each is refused, never loaded as the run."""
    folder = Path(tempfile.mkdtemp(dir=tmp_path)) / "run"  # a new folder each example, failed or not
    shutil.copytree(two_runs[0], folder)
    manifest = json.loads((folder / "manifest.json").read_text())
    entries = manifest["files"]
    chosen = sorted(entries)[pick % len(entries)]
    assume(not (edit in ("add", "rename") and name == chosen))  # the entry as it was: no edit at all
    if edit == "drop":
        entries.pop(chosen)
    elif edit == "add":
        entries[name] = dict(entries[chosen])
    elif edit == "bytes":
        entries[chosen]["bytes"] += 1 + pick % 7
    elif edit == "sha":
        entries[chosen]["sha256"] = f"{pick:064x}"[-64:]
    elif edit == "rename":
        entries[name] = entries.pop(chosen)
    elif edit == "link":
        target = folder.parent / f"target{pick}"
        shutil.copy(folder / chosen, target)
        (folder / chosen).unlink()
        (folder / chosen).symlink_to(target)
    elif edit == "folder":
        (folder / "pilots").mkdir()
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(IncompleteRun):
        load_result(folder)
    shutil.rmtree(folder.parent)


# --- checkpoints as the runner reads them ---------------------------------------------------------

def sealed(lines: list[str], step: int, identity: str = "f" * 64) -> bytes:
    import hashlib

    body = "".join(line + "\n" for line in [f"checkpoint {step}", f"solver {'e' * 64}", f"run {identity}", *lines])
    return (body + f"seal {hashlib.sha256(body.encode()).hexdigest()}\nend {step}\n").encode()


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(lines=st.lists(st.text(st.characters(blacklist_categories=["Cs", "Cc"]), max_size=20), min_size=1, max_size=8),
       step=st.integers(1, 10**6), cut=st.integers(0, 10**6), kind=st.sampled_from(["drop", "repeat", "cut", "step"]))
@pytest.mark.unit
def test_a_checkpoint_is_whole_exactly_when_its_seal_matches(tmp_path, lines, step, cut, kind):
    path = tmp_path / "checkpoint-a.txt"
    data = sealed(lines, step)
    path.write_bytes(data)
    assert sealed_checkpoint(path) == (step, "f" * 64) and checkpoint_step(tmp_path) == step
    rows = data.decode().split("\n")[:-1]
    j = cut % len(rows)
    changed = {"drop": rows[:j] + rows[j + 1:], "repeat": rows[:j + 1] + rows[j:],
               "step": [f"checkpoint {step + 1}", *rows[1:-1], f"end {step + 1}"]}.get(kind)
    damaged = data[:cut % len(data)] if kind == "cut" else ("\n".join(changed) + "\n").encode()
    path.write_bytes(damaged)
    assert sealed_checkpoint(path) is None and checkpoint_step(tmp_path) == 0


@pytest.mark.unit
def test_resume_refuses_a_checkpoint_of_another_run_identity(tmp_path):
    """inputs.json says these inputs, the checkpoint another run's: refused, not continued."""
    scene = Scene.load(PAPER, STATES)
    inputs = inputs_of(scene)
    partial = tmp_path / "run.partial"
    partial.mkdir()
    (partial / "inputs.json").write_text(json.dumps(inputs))
    (partial / "checkpoint-a.txt").write_bytes(sealed(["parameters 0"], 7, "0" * 64))
    with pytest.raises(RunError, match="a checkpoint of a run of other inputs"):
        run(scene, tmp_path / "run", resume=True, progress=False)


def test_a_manifest_whose_inputs_were_changed_is_refused(copy_of):
    """The completion key of a sweep is read from the manifest's inputs: they must be those of
    inputs.json, which the manifest hashes."""
    folder = copy_of(0)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["inputs"]["digest"] = "deadbeef"
    (folder / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(IncompleteRun, match="its inputs are not those of inputs.json"):
        load_result(folder)


def test_a_run_of_orchestrate_without_its_manifest_is_not_taken_for_a_hand_run(copy_of, two_runs):
    """Deleting manifest.json would otherwise leave only the hand-run check of run.json's files."""
    folder = copy_of(0)
    (folder / "manifest.json").unlink()
    with pytest.raises(IncompleteRun, match="without its manifest.json"):
        load_result(folder)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(["manifest.json", "run.json", "params_used.json", "inputs.json"]),
       value=st.recursive(st.none() | st.booleans() | st.integers() | st.text(max_size=5),
                          lambda children: st.lists(children, max_size=3) | st.dictionaries(st.text(max_size=5), children,
                                                                                            max_size=3), max_leaves=6))
def test_a_run_s_json_file_replaced_by_any_json_is_refused_with_incomplete_run(two_runs, tmp_path, name, value):
    """Never a KeyError or AttributeError from a reader (a sweep would stop with a traceback)."""
    folder = Path(tempfile.mkdtemp(dir=tmp_path)) / "run"
    shutil.copytree(two_runs[0], folder)
    (folder / name).write_text(json.dumps(value))
    with pytest.raises(IncompleteRun):
        load_result(folder)
    shutil.rmtree(folder.parent)


# --- a second round as an attacker: the driver writes no file through a planted link ------------

DRIVER_RUN = ["-n1", "6", "-n2", "8", "-N", "20", "-outTimes", "0.5,1"]


def test_a_fresh_run_writes_nothing_through_links_planted_by_its_files_names(tmp_path):
    """Was: a driver run into a folder whose history.csv was a symbolic link, and whose run.json a
    hard link, to a user's files wrote the run into them. Now every entry named as a run's file is
    removed before the run writes (a link removed, never followed): the user's files are as they
    were, the run's own files are whole, and an earlier run's files are gone."""
    out = tmp_path / "out"
    out.mkdir()
    linked, hard = tmp_path / "linked.txt", tmp_path / "hard.txt"
    linked.write_text("the user's\n")
    hard.write_text("the user's too\n")
    (out / "history.csv").symlink_to(linked)
    os.link(hard, out / "run.json")
    (out / "state_0600.txt").write_text("another run's\n")
    (out / "notes.txt").write_text("not a run's name: kept\n")
    done = run_script(MAIN, [*DRIVER_RUN, "-out", out])
    assert done.returncode == 0, done.error_line
    assert linked.read_text() == "the user's\n" and hard.read_text() == "the user's too\n"
    assert not (out / "history.csv").is_symlink() and not (out / "state_0600.txt").exists()
    assert (out / "notes.txt").read_text() == "not a run's name: kept\n"
    assert len(load_result(out).history["t"]) == 20


def test_a_file_of_another_run_copied_into_a_hand_run_folder_is_refused(tmp_path):
    """Was: a hand run's folder has no manifest, and a state file copied from another run of the
    same meshes read back whole: compare reported its numbers. run.json now holds each file's
    SHA-256."""
    for name, extra in (("a", []), ("b", ["-gammaNu", "0.5"])):
        assert run_script(MAIN, [*DRIVER_RUN, *extra, "-out", tmp_path / name]).returncode == 0
    load_result(tmp_path / "a")
    shutil.copy(tmp_path / "b" / "state_0010.txt", tmp_path / "a" / "state_0010.txt")
    with pytest.raises(IncompleteRun, match="state_0010.txt: changed since the run finished"):
        load_result(tmp_path / "a")


def test_a_scene_path_the_macro_reader_would_cut_is_refused_by_bin_ff_with_a_message(tmp_path):
    """Was: `Error opening file .../x in:` from FreeFEM, with no word of the '#' that cut the path."""
    folder = tmp_path / "x#y"
    folder.mkdir()
    shutil.copy(REPO / "edp" / "scenes" / "paper.idp", folder / "scene.idp")
    done = subprocess.run([REPO / "bin" / "ff", REPO / "edp" / "main.edp", f"-DSCENE={folder}/scene.idp", "-out",
                           tmp_path / "o"], capture_output=True, text=True)
    assert done.returncode == 3 and "holds a '#'" in done.stderr and not (tmp_path / "o").exists(), done.stderr


@pytest.mark.parametrize("content", ["not json", "[1, 2]", '{"final": 3}'])
def test_check_against_a_file_that_is_no_summary_is_refused_before_the_run(tmp_path, content):
    """Was: a KeyError or TypeError traceback, after the whole run."""
    expected = tmp_path / "expected.json"
    expected.write_text(content)
    assert main(["run", str(PAPER), "--out", str(tmp_path / "run"), "--check-against", str(expected)]) == 2
    assert not (tmp_path / "run").exists()


def test_run_force_keeps_a_users_file_named_as_an_image(tmp_path, capsys):
    """Was: an image name was taken for a run's own image whatever the file held, and deleted."""
    folder = tmp_path / "run"
    assert main(["run", str(PAPER), "--out", str(folder), "--set", "body1.mesh.n=6", "--set", "body2.mesh.n=8",
                 "--set", "time.N=20", "--set", "output.images=false"]) == 0
    (folder / "figure_3.png").write_text("the user's figure")
    capsys.readouterr()
    assert main(["run", str(PAPER), "--out", str(folder), "--force", "--set", "time.N=20"]) == 1
    err = capsys.readouterr().err
    assert "figure_3.png, which no run writes" in err, err
    assert (folder / "figure_3.png").read_text() == "the user's figure"


def test_a_refused_restart_leaves_the_results_in_its_output_folder(tmp_path):
    """Was: -out was emptied of an earlier run's files before the checkpoint was checked, so a
    restart refused for want of a checkpoint had deleted that run's history and fields."""
    out, empty = tmp_path / "out", tmp_path / "empty"
    empty.mkdir()
    assert run_script(MAIN, [*DRIVER_RUN, "-out", out]).returncode == 0
    written = ("history.csv", "solution.pvd", "state_0010.txt", "state_0020.txt", "body1_0020.vtu", "contact_0010.vtu")
    before = {name: (out / name).read_bytes() for name in written}  # the set-up's files are written anew, as ever
    refused = run_script(MAIN, [*DRIVER_RUN, "-restart", empty, "-out", out])
    assert refused.returncode == 3 and "holds no whole checkpoint" in refused.error_line
    assert {name: (out / name).read_bytes() for name in before} == before


def vtu(points: str, u: str) -> str:
    """A body file as the driver writes one: 3 points, one triangle and one boundary edge (cells),
    u binary (UInt32 header, then the values) and zeta ascii."""
    return f"""<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" byte_order="LittleEndian">
<UnstructuredGrid>
<Piece NumberOfPoints="3" NumberOfCells="2">
<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">{points}</DataArray></Points>
<Cells>
<DataArray type="Int32" Name="connectivity" format="ascii">0 1 2 0 1</DataArray>
<DataArray type="Int32" Name="offsets" format="ascii">3 5</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">5 3</DataArray>
</Cells>
<PointData>
<DataArray type="Float64" Name="u" NumberOfComponents="3" format="binary">{u}</DataArray>
<DataArray type="Float64" Name="zeta" NumberOfComponents="1" format="ascii">1 1 1</DataArray>
</PointData>
</Piece>
</UnstructuredGrid>
</VTKFile>
"""


@pytest.mark.unit
def test_a_body_file_is_read_back_whole_value_by_value(tmp_path):
    """manifest.py checks a .vtu without a VTK reader: a file whose XML is whole but that holds a
    value less than its Piece says, or a binary block shorter than its header, is refused; the
    whole one passes, its boundary edges not counted as triangles."""
    import base64
    import struct

    from orchestrate.manifest import IncompleteRun, _check_vtu

    def binary(values, header=None):
        payload = struct.pack(f"<{len(values)}d", *values)
        return base64.b64encode(struct.pack("<I", len(payload) if header is None else header) + payload).decode()

    coordinates, facts = "0 0 0 1 0 0 0 1 0", {"nodes1": 3, "triangles1": 1}
    path = tmp_path / "body1_0001.vtu"
    path.write_text(vtu(coordinates, binary([0.0] * 9)))
    _check_vtu(path, facts)
    for points, u in ((coordinates, binary([0.0] * 8)), (coordinates, binary([0.0] * 9, header=80)),
                      ("0 0 0 1 0 0 0 1", binary([0.0] * 9))):
        path.write_text(vtu(points, u))
        with pytest.raises(IncompleteRun, match="cannot be read back"):
            _check_vtu(path, facts)
    path.write_text(vtu(coordinates, binary([0.0] * 9)).replace("<Points>", "<Nodes>").replace("</Points>", "</Nodes>"))
    with pytest.raises(IncompleteRun, match="no single Points array"):
        _check_vtu(path, facts)
    path.write_text(vtu(coordinates, binary([0.0] * 9)))
    with pytest.raises(IncompleteRun, match="3 points and 1 triangles \\(expected 3 and 2\\)"):
        _check_vtu(path, {"nodes1": 3, "triangles1": 2})
