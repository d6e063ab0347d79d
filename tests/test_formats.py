"""One specification per file format the program reads back (issue 47, item 2): edp/lib/formats.toml.
The files generated from it are in step with it; the files real runs write hold to it (history.csv's
header, run.json's facts and their types, the state files' arrays and lengths, a checkpoint's
lines in order, the manifest); and the largest and strangest legal output (a long Unicode title,
an infinite mobility, huge, tiny and subnormal numbers, text with commas, quotes and line breaks)
reads back as it was written."""
import csv
import json
import math
import signal
import subprocess
import time

import numpy as np
import pytest

from orchestrate import formats, run
from orchestrate.freefem import MAIN, REPO, freefem_command, freefem_env
from orchestrate.manifest import read_state, verify_manifest, write_manifest, write_state
from orchestrate.plot import read_sweep
from orchestrate.results import load_result
from orchestrate.runner import sealed_checkpoint
from orchestrate.sweep import write_table

PAPER = REPO / "scenes" / "paper.toml"
TITLE = ("Ünïcødé ✓ 试验 שָׁלוֹם 🧪 \"quoted\", commas, and a \\ backslash " * 12)[:500]
STRANGE = {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.N": 30, "time.scheme": "bdf2", "glue.debondMobility": "inf",
           "output.times": "all", "output.fields": ["bodies", "stress", "contact", "state"], "output.images": False,
           "title": TITLE}


@pytest.mark.unit
@pytest.mark.parametrize("path", list(formats.generated()), ids=lambda path: path.name)
def test_the_generated_files_are_the_specification_s(path):
    assert path.read_text() == formats.generated()[path], f"{path} is stale: run python -m orchestrate reference --force"


@pytest.fixture(scope="module")
def strange(tmp_path_factory):
    return run(PAPER, tmp_path_factory.mktemp("strange") / "run", STRANGE)


@pytest.mark.runs
def test_history_csv_holds_the_specified_columns_in_order(strange):
    header = (strange.folder / "history.csv").read_text().splitlines()[0].split(",")
    named = [formats.FIRST_COLUMN, *(column["name"] for column in formats.HISTORY_COLUMNS)]
    assert header[:len(named)] == named and header[-1] == formats.LAST_COLUMN
    reactions = header[len(named):-1]
    assert reactions and all(formats.REACTION.fullmatch(name) for name in reactions)


@pytest.mark.runs
def test_run_json_holds_the_specified_facts_of_their_types(strange):
    facts = json.loads((strange.folder / "run.json").read_text())
    kinds = {"int": int, "real": (int, float), "text": str, "bool": bool, "names": list, "digests": dict}
    assert set(facts) <= set(formats.FACTS), set(facts) - set(formats.FACTS)
    always = {name for name, fact in formats.FACTS.items() if "when" not in fact or fact["when"] in ("finished",)}
    assert always - {"factorColumnNonzeros1", "factorColumnNonzeros2"} <= set(facts), always - set(facts)
    for name, value in facts.items():
        kind = formats.FACTS[name]["type"]
        assert value is None and kind == "real" or isinstance(value, kinds[kind]), (name, value, kind)
        assert not (kind == "int" and isinstance(value, bool)), name


@pytest.mark.runs
def test_every_state_file_has_the_specified_arrays_and_lengths(strange):
    facts = json.loads((strange.folder / "run.json").read_text())
    lengths = formats.state_lengths(facts)
    states = sorted(strange.folder.glob("state_*.txt"))
    assert len(states) == STRANGE["time.N"]
    for path in states:
        state = read_state(path)
        assert {name: len(state[name]) for name in formats.STATE_ARRAYS} == lengths
        tokens = path.read_text().split()  # the file itself: t, then each array's length and values
        assert len(tokens) == 1 + sum(1 + length for length in lengths.values())


@pytest.mark.runs
def test_a_strange_run_reads_back_as_written(strange):
    summary = json.loads((strange.folder / "summary.json").read_text())
    assert summary["title"] == TITLE and summary["scene"]["glue"]["debondMobility"] == "inf"
    assert json.loads((strange.folder / "params_used.json").read_text())["debondMobility"] == "inf"
    rows = list(csv.reader((strange.folder / "history.csv").read_text().splitlines()))
    cells = np.array([[float(cell) for cell in row] for row in rows[1:]])
    history = load_result(strange.folder).history
    for j, name in enumerate(rows[0]):  # numpy's reader and a plain parse of each cell agree to the bit
        assert np.array_equal(history[name], cells[:, j]), name
    assert verify_manifest(strange.folder)["inputs"]["digest"]


@pytest.mark.runs
def test_a_checkpoint_holds_the_specified_lines_in_order(tmp_path):
    folder = tmp_path / "run"
    process = subprocess.Popen(freefem_command(MAIN, ["-N", "400", "-n1", "6", "-n2", "8", "-checkpointEvery", "50", "-scheme", "bdf2",
                                                       "-debondMobility", "inf", "-out", str(folder)]),
                               cwd=REPO, env=freefem_env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    checkpoint = folder / "checkpoint-a.txt"
    deadline = time.time() + 60
    while process.poll() is None and time.time() < deadline and not sealed_checkpoint(checkpoint):
        time.sleep(0.005)
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert sealed_checkpoint(checkpoint)
    lines = checkpoint.read_text().splitlines()
    position = 0
    for entry in formats.CHECKPOINT_LINES:  # each word starts a line, in order; the lines between belong to it
        found = next((j for j in range(position, len(lines)) if lines[j].startswith(entry["word"])), None)
        assert found is not None or entry.get("optional"), entry["word"]
        position = found + 1 if found is not None else position
    assert lines[-1].startswith("end ") and lines[-2].startswith("seal ")
    assert f"{formats.CHECKPOINT_LAYOUT}" in lines
    assert "debondMobility inf" in {" ".join(line.split()) for line in lines}  # a number as a word: inf


EXTREMES = [0.0, -0.0, 5e-324, -2.2250738585072014e-308, 1e-300, 1.7976931348623157e308, -1e300, 0.1 + 0.2, math.pi]


@pytest.mark.unit
def test_a_state_file_round_trips_every_double(tmp_path):
    state = {"t": 1e-310, **{name: np.array(EXTREMES[j:] + EXTREMES[:j]) for j, name in enumerate(formats.STATE_ARRAYS)}}
    write_state(tmp_path / "state_0001.txt", state)
    again = read_state(tmp_path / "state_0001.txt")
    assert again["t"] == state["t"]
    for name in formats.STATE_ARRAYS:
        assert again[name].tobytes() == state[name].tobytes(), name  # to the bit, the sign of zero included


@pytest.mark.unit
def test_a_sweep_table_round_trips_strange_text_and_numbers(tmp_path):
    keys = ["glue.gammaNu", "title"]
    rows = [{"glue.gammaNu": value, "title": TITLE, "folder": f"run-{j}", "status": "failed",
             "error": 'SolverError: "quoted", a comma\nand a line break', "warnings": "", "wallSeconds": 1e-300,
             "contactItersPerStep": float("inf"), **{name: value for name in formats.SWEEP_FIGURES}}
            for j, value in enumerate(EXTREMES)]
    write_table(tmp_path / "sweep.csv", rows, keys)
    swept, read = read_sweep(tmp_path)
    assert swept == keys
    for row, back in zip(rows, read):
        assert back["title"] == TITLE and back["error"] == row["error"]
        assert float(back["glue.gammaNu"]) == row["glue.gammaNu"] and float(back["contactItersPerStep"]) == math.inf
        assert all(float(back[name]) == row[name] for name in formats.SWEEP_FIGURES)
    assert list(read[0]) == [*keys, *formats.SWEEP_COLUMNS, *formats.SWEEP_FIGURES]


@pytest.mark.unit
def test_a_manifest_round_trips_unicode_inputs(tmp_path):
    inputs = {"digest": "f" * 64, "scene": TITLE, "meshes": ["committed:" + "0" * 64, "generated:abc"]}
    for name in ("inputs.json", "history.csv", "run.json"):
        (tmp_path / name).write_text(json.dumps(inputs) if name == "inputs.json" else "x\n")
    write_manifest(tmp_path, inputs)
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["inputs"] == inputs and set(manifest["files"]) == {"inputs.json", "history.csv", "run.json"}
