"""When a run folder is complete, and proof that it still is.

FreeFEM's streams report no write error: on a full disk or past a file-size limit a run can exit 0
with files cut short. So a run is complete only when every file it lists in run.json (written as
its last act) has been read back whole: history.csv with a row per step, every .vtu parsed with
the node and triangle counts the run reported, every state file with its arrays' lengths, the
.pvd naming only files of the run. Then `manifest.json`, written last and atomically, records the
size and SHA-256 of every file in the folder (images aside: `render` remakes them) and the run's
inputs. `load_result`, `render`, `compare` and `sweep` trust a folder only through it, and only
what it lists: the manifest must name exactly the folder's files (images aside), those run.json
lists and the runner's own, each by one of the fixed names of a run's files. A folder FreeFem++
wrote by hand (run.json, no manifest) is checked file by file each time it is loaded.
"""
from __future__ import annotations

import base64
import json
import os
import re
import xml.etree.ElementTree as ElementTree
from pathlib import Path
from typing import TYPE_CHECKING

from orchestrate.formats import STATE_ARRAYS, state_lengths
from orchestrate.identity import sha256_of as digest

if TYPE_CHECKING:  # the readers import numpy: the runner imports this module before FreeFem++ starts
    import numpy as np

MANIFEST = "manifest.json"
FACTS = "run.json"
# The names of a run's files, and no other: the driver's (edp/lib/output.idp: NNNN is the step)
# and the runner's (orchestrate/runner.py); a name read from a data file is used only when it is one.
DRIVER_FILE = re.compile(r"(history\.csv|params_used\.json|solution\.pvd|run\.json"
                         r"|(body1|body2|contact)_[0-9]{4,}\.vtu|state_[0-9]{4,}\.txt)")
RUNNER_FILES = ("inputs.json", "scene.toml", "scene.idp", "run.log", "body1.msh", "body2.msh", "summary.json",
                "steps.json")
HAND_RUN_FILE = re.compile(r"checkpoint-[ab]\.txt|checkpoint-[a-z]+\.tmp|body[12]-n[0-9]+\.msh|gmsh-body[12]\.log")
IMAGE = re.compile(r"[a-z0-9_-]{1,64}\.(png|pdf|svg)")  # render's, made anew from the data: outside the manifest
PARTS = ("body1", "body2", "contact")
BODY_ARRAYS = ("u", "zeta")  # point data every body file holds (vonMises is cell data)


def read_state(path: str | Path) -> dict[str, np.ndarray | float]:
    """A state_NNNN.txt file (edp/lib/formats.toml, docs/formats.md): t, then each array as its
    length and values."""
    return parse_state(Path(path).read_bytes())


def parse_state(data: bytes) -> dict[str, np.ndarray | float]:
    """A state file's bytes as read_state reads them."""
    import numpy as np

    tokens = data.split()
    state: dict[str, np.ndarray | float] = {"t": float(tokens[0])}
    position = 1
    for name in STATE_ARRAYS:
        length = int(tokens[position])
        state[name] = np.array(tokens[position + 1: position + 1 + length], dtype=float)
        position += 1 + length
    return state


def write_state(path: Path, state: dict[str, np.ndarray | float]) -> None:
    """A state file as edp/lib/stateFile.idp writes one (read_state reads it): t, then each array
    as its length and values, every value written back exactly (repr)."""
    lines = [repr(float(state["t"]))]
    lines += [f"{len(state[name])}\n" + " ".join(repr(float(value)) for value in state[name]) for name in STATE_ARRAYS]
    Path(path).write_text("\n".join(lines) + "\n")


class IncompleteRun(RuntimeError):
    """A run folder whose files are missing, cut short or changed since the run finished (a full
    disk or a file-size limit cuts files short without FreeFEM noticing)."""


class StrayFiles(IncompleteRun):
    """A folder holding files no run writes (a manifest lists a run's files only)."""


def read_json(path: Path) -> dict:
    """A JSON object of a run's file; IncompleteRun for anything else (a reader never meets a
    KeyError or an AttributeError of a file someone changed)."""
    try:
        data = json.loads(path.read_bytes())
    except FileNotFoundError:
        raise IncompleteRun(f"{path.parent}: no {path.name}") from None
    except (ValueError, UnicodeDecodeError) as error:
        raise IncompleteRun(f"{path}: not valid JSON ({error}); the file is cut short or damaged") from None
    if not isinstance(data, dict):
        raise IncompleteRun(f"{path}: not a run's file (a JSON object was expected)")
    return data


def steps_of(folder: Path) -> int:
    steps = read_json(folder / "params_used.json").get("N")
    if not isinstance(steps, int) or isinstance(steps, bool) or steps < 1:
        raise IncompleteRun(f"{folder / 'params_used.json'}: no number of steps N")
    return steps


def facts(folder: Path) -> dict:
    """run.json of a run folder: what the run established, and the files it wrote."""
    data = read_json(Path(folder) / FACTS)
    if data.get("finished") is not True:
        raise IncompleteRun(f"{folder}: the run did not finish (run.json says finished = {data.get('finished')})")
    return data


def check_files(folder: Path) -> dict:
    """Read back every file the run lists; raise IncompleteRun naming the first that is not whole.
    Returns the run's facts."""
    folder = Path(folder)
    run = facts(folder)
    files = run.get("files", [])
    for name in files:
        if not isinstance(name, str) or not DRIVER_FILE.fullmatch(name) or not regular_file(folder / name):
            raise IncompleteRun(f"{folder}: the run lists {name!r}, which is not a file of the folder by a run's name")
    _check_digests(folder, files, run.get("fileDigests"))
    _check_history(folder / "history.csv", steps_of(folder))
    for name in files:
        path = folder / name
        if name.endswith(".vtu"):
            _check_vtu(path, run)
        elif name.startswith("state_"):
            _check_state(path, run)
        elif name.endswith(".pvd"):
            _check_pvd(path, files)
    return run


def _check_digests(folder: Path, files: list, digests) -> None:
    """Every file the run lists but run.json has the SHA-256 the driver wrote at its end: a file
    copied in from another run (of the same mesh, so that it reads back whole) is refused."""
    if not isinstance(digests, dict) or sorted(digests) != sorted(name for name in files if name != FACTS):
        raise IncompleteRun(f"{folder}: run.json holds no SHA-256 of each file it lists (fileDigests): a run of an older "
                            "driver, or changed since; run it again")
    for name, expected in digests.items():
        if digest(folder / name) != expected:
            raise IncompleteRun(f"{folder / name}: changed since the run finished (its SHA-256 is not run.json's)")


def _check_history(path: Path, steps: int) -> None:
    import numpy as np

    lines = path.read_bytes().split(b"\n")
    if lines and lines[-1] == b"":
        lines.pop()
    columns = lines[0].count(b",") if lines else -1
    if len(lines) != steps + 1 or any(line.count(b",") != columns for line in lines):
        raise IncompleteRun(f"{path}: {max(len(lines) - 1, 0)} rows of {steps} steps, or a row cut short")
    try:
        np.array(b",".join(lines[1:]).split(b","), dtype=float)
    except ValueError:
        raise IncompleteRun(f"{path}: a value that is not a number (the file is damaged)") from None


# The VTK types the driver writes, as numpy's little-endian types.
VTK_TYPES = {"Float32": "<f4", "Float64": "<f8", "Int32": "<i4", "Int64": "<i8", "UInt8": "u1", "UInt32": "<u4",
             "UInt64": "<u8", "Int8": "i1"}


VTK_TRIANGLE = 5  # VTK's cell type of a 3-node triangle


def _check_vtu(path: Path, run: dict) -> None:
    """A .vtu of the driver read back whole, without a reader of VTK (meshio reads the fields for
    users; here only completeness counts): its XML closed, every DataArray holding as many values
    as its Piece says (binary: the base64 payload as long as its UInt32 header, the header as long
    as the values; ascii: the values counted), the cells' connectivity as long as their last
    offset; a body's point and triangle counts those of run.json and u, ζ among its point data; the
    contact line's points the trace's nodes."""
    import numpy as np

    try:
        root = ElementTree.parse(path).getroot()
        if root.get("byte_order") != "LittleEndian":
            raise ValueError(f"byte order {root.get('byte_order')!r}, not the driver's LittleEndian")
        piece = root.find("UnstructuredGrid/Piece")
        points, cells = int(piece.get("NumberOfPoints")), int(piece.get("NumberOfCells"))
        coordinates = piece.findall("Points/DataArray")
        if len(coordinates) != 1 or coordinates[0].get("NumberOfComponents") != "3":
            raise ValueError("no single Points array of 3 components")
        for section, count in (("Points", points), ("PointData", points), ("CellData", cells)):
            for array in piece.findall(f"{section}/DataArray"):
                if len(_vtu_values(array)) != count * int(array.get("NumberOfComponents", "1")):
                    raise ValueError(f"{section} {array.get('Name') or ''} holds another number of values than "
                                     f"{count} × its components")
        arrays = {array.get("Name"): _vtu_values(array) for array in piece.findall("Cells/DataArray")}
        offsets = arrays["offsets"]
        if len(offsets) != cells or len(arrays["types"]) != cells or (cells and len(arrays["connectivity"]) != offsets[-1]):
            raise ValueError("its cells' connectivity, offsets and types disagree")
    except (ElementTree.ParseError, AttributeError, KeyError, IndexError, TypeError, ValueError,  # base64's too
            OverflowError) as error:
        raise IncompleteRun(f"{path}: cannot be read back ({type(error).__name__}: {error}); cut short?") from None
    part = path.name.rsplit("_", 1)[0]
    if part in ("body1", "body2"):
        body = part[-1]
        expected = (displacement_nodes(run, body), run[f"triangles{body}"] * (4 if run.get("order", 1) == 2 else 1))
        named = {array.get("Name") for array in piece.findall("PointData/DataArray")}
        missing = [name for name in BODY_ARRAYS if name not in named]
        triangles = int(np.count_nonzero(arrays["types"] == VTK_TRIANGLE))  # the boundary's edges are cells too
        if (points, triangles) != expected or missing:
            raise IncompleteRun(f"{path}: {points} points and {triangles} triangles (expected {expected[0]} "
                                f"and {expected[1]}){', no ' + ', '.join(missing) if missing else ''}")
    elif part == "contact" and points != run["traceNodes1"]:
        raise IncompleteRun(f"{path}: {points} points, expected {run['traceNodes1']}")


def _vtu_values(array) -> np.ndarray:
    """The values of one DataArray of a .vtu (little-endian, as the driver writes), checked whole."""
    import numpy as np

    kind = VTK_TYPES[array.get("type")]
    text = (array.text or "").strip()
    if array.get("format") == "ascii":
        return np.array(text.split(), dtype=kind)
    if array.get("format") != "binary":
        raise ValueError(f"a DataArray in format {array.get('format')!r}, not the driver's")
    raw = base64.b64decode(text, validate=True)
    if len(raw) < 4 or int.from_bytes(raw[:4], "little") != len(raw) - 4 or (len(raw) - 4) % np.dtype(kind).itemsize:
        raise ValueError("a binary DataArray shorter or longer than its header says")
    return np.frombuffer(raw[4:], dtype=kind)


def displacement_nodes(run: dict, body: str) -> int:
    """The nodes of a body's displacement (run.json): its mesh's vertices at degree 1, and its edges'
    middles too at degree 2 (the vertices of its mesh split in four, where its .vtu lies)."""
    return run.get(f"displacementNodes{body}", run[f"nodes{body}"])


def _check_state(path: Path, run: dict) -> None:
    try:
        state = read_state(path)
    except (ValueError, IndexError):
        raise IncompleteRun(f"{path}: cannot be read back; cut short?") from None
    try:
        expected = state_lengths(run)
    except KeyError as missing:
        raise IncompleteRun(f"{path.parent / FACTS}: no fact {missing}, which a state file's lengths need: a run of an "
                            "older driver; run it again") from None
    wrong = [name for name, length in expected.items() if len(state[name]) != length]
    if wrong:
        raise IncompleteRun(f"{path}: arrays {', '.join(wrong)} have the wrong length")


def _check_pvd(path: Path, files: list[str]) -> None:
    try:
        datasets = list(ElementTree.parse(path).getroot().iter("DataSet"))
        for dataset in datasets:
            float(dataset.get("timestep"))
            if dataset.get("part") not in ("0", "1", "2") or dataset.get("file") not in files:
                raise ValueError(f"entry {dataset.attrib} names no file of the run")
    except (ElementTree.ParseError, ValueError, TypeError) as error:
        raise IncompleteRun(f"{path}: not the run's collection ({error})") from None


def write_manifest(folder: Path, inputs: dict, verified: dict[str, str] | None = None) -> None:
    """Sizes and hashes of every file in the folder but the images (which `render` makes anew from
    the data), and the inputs, written last: a folder with a manifest was complete when it was
    written. A file by a name no run writes is refused, not listed. `verified`: SHA-256 of files
    this process has just checked against their content (check_files), not read again."""
    names = sorted(path.name for path in Path(folder).iterdir() if path.name != MANIFEST and not IMAGE.fullmatch(path.name))
    stray = [name for name in names if not is_run_file(name) or not regular_file(Path(folder) / name)]
    if stray:
        raise StrayFiles(f"{folder} holds {', '.join(stray)}, which no run writes (a manifest lists a run's files only)")
    verified = verified or {}
    entries = {name: {"bytes": (Path(folder) / name).stat().st_size,
                      "sha256": verified.get(name) or digest(Path(folder) / name)} for name in names}
    text = json.dumps({"inputs": inputs, "files": entries}, indent=1) + "\n"
    partial = Path(folder) / (MANIFEST + ".partial")
    with open(partial, "w") as handle:
        handle.write(text)
        handle.flush()
        os.fsync(handle.fileno())
    partial.replace(Path(folder) / MANIFEST)


def is_run_file(name: str) -> bool:
    return bool(DRIVER_FILE.fullmatch(name)) or name in RUNNER_FILES


def is_run_entry(name: str) -> bool:
    """A name a run folder may hold: its files, its manifest, its images, and what the driver
    leaves in a folder it writes by hand (checkpoints, meshes it generated and gmsh's logs:
    edp/lib/checkpoint.idp, runFileNames)."""
    return is_run_file(name) or name == MANIFEST or bool(IMAGE.fullmatch(name) or HAND_RUN_FILE.fullmatch(name))


def regular_file(path: Path) -> bool:
    return path.is_file() and not path.is_symlink()


def verify_manifest(folder: Path) -> dict:
    """The manifest of a run folder, after checking that it lists exactly the folder's files (by a
    run's names), those run.json lists and the runner's own, each unchanged, and that the history
    has its rows; raises IncompleteRun naming the first that is not so."""
    folder = Path(folder)
    manifest = read_json(folder / MANIFEST)
    entries = manifest.get("files")
    if not isinstance(entries, dict) or not isinstance(manifest.get("inputs"), dict):
        raise IncompleteRun(f"{folder / MANIFEST}: not a run's manifest (no inputs or no files)")
    listed = set(entries)
    present = {path.name for path in folder.iterdir() if path.name != MANIFEST and not
               (IMAGE.fullmatch(path.name) and regular_file(path))}
    if present != listed:
        extra, missing = sorted(present - listed), sorted(listed - present)
        raise IncompleteRun(f"{folder}: the folder and its manifest differ ("
                            + "; ".join(filter(None, [extra and f"not in the manifest: {', '.join(extra)}",
                                                      missing and f"missing: {', '.join(missing)}"])) + ")")
    for name, entry in entries.items():
        path = folder / name
        if not is_run_file(name) or not regular_file(path):
            raise IncompleteRun(f"{folder}: the manifest lists {name!r}, which is not a run's file")
        if not (isinstance(entry, dict) and entry.get("bytes") == path.stat().st_size
                and entry.get("sha256") == digest(path)):
            raise IncompleteRun(f"{path}: changed since the run finished (size or SHA-256 differ from the manifest)")
    if manifest["inputs"] != read_json(folder / "inputs.json"):  # what a sweep's completion key is read from
        raise IncompleteRun(f"{folder / MANIFEST}: its inputs are not those of inputs.json (the manifest was changed)")
    written = facts(folder).get("files")
    if not isinstance(written, list) or not {FACTS, *map(str, written)} <= listed \
            or not listed - set(map(str, written)) <= {FACTS, *RUNNER_FILES}:
        raise IncompleteRun(f"{folder}: the manifest does not list the files run.json names, and those only "
                            "(with the runner's own)")
    _check_history(folder / "history.csv", steps_of(folder))
    return manifest
