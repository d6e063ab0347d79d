"""gmsh 2.2 ASCII files parsed whole with numpy (a line at a time, a mesh of 10⁵ triangles took
0.3 s): what mesh.py checks a mesh by, what it converts one to FreeFEM's format with, and a size
field's numbers. mesh.py imports it only where a file is read for the first time (its WHOLE), so
a run whose files were all read before never loads numpy."""
from __future__ import annotations

import math

import numpy as np


class NotWhole(ValueError):
    """What is wrong with a file that is not a whole gmsh 2.2 mesh."""


def parse_msh(data: bytes) -> dict:
    """What mesh.read_msh checks and returns (a MeshInfo's record), parsed from a file's bytes;
    NotWhole names the first fault."""
    head = data[:256].split(b"\n", 2)
    if len(head) < 2 or head[0].strip() != b"$MeshFormat" or not head[1].startswith(b"2.2 "):
        raise NotWhole("it does not start with $MeshFormat 2.2")
    at = {}
    for section in (b"$Nodes", b"$EndNodes", b"$Elements", b"$EndElements"):
        at[section] = section_line(data, section)
        if at[section] is None:
            raise NotWhole(f"no {section.decode()} line")
    nodes, node_block = counted_block(data, at[b"$Nodes"], at[b"$EndNodes"])
    elements, element_block = counted_block(data, at[b"$Elements"], at[b"$EndElements"])
    node_lines, element_lines = node_block.count(b"\n"), element_block.count(b"\n")
    if node_lines != nodes or element_lines != elements:
        raise NotWhole(f"{node_lines} of {nodes} nodes and {element_lines} of {elements} elements")
    try:
        coordinates = np.fromstring(node_block, dtype=float, sep=" ") if nodes else np.zeros(0)
    except ValueError:
        raise NotWhole("a node line that is not numbers") from None
    if coordinates.size != 4 * nodes or not np.isfinite(coordinates).all():
        raise NotWhole("a node line without 3 finite coordinates")
    fields, start, counts = element_fields(element_block, elements)
    kind = fields[start + 1]
    line_tags = fields[start[kind == 1] + 3]
    tags, per_tag = np.unique(line_tags, return_counts=True)
    table = coordinates.reshape(nodes, 4)
    where = rows_of(table[:, 0], corner_nodes(fields, start, counts, kind == 2, 3))
    a, b, c = (table[where[:, j], 1:3] for j in range(3))
    areas = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    ends = rows_of(table[:, 0], corner_nodes(fields, start, counts, kind == 1, 2))
    in_triangle = np.zeros(nodes, dtype=bool)
    in_triangle[where.ravel()] = True
    curves, stray = {}, {}
    for tag in tags.tolist():
        mine = ends[line_tags == tag]
        curves[tag] = table[mine, 1:3].tolist()
        loose = mine[~in_triangle[mine]]
        if loose.size:
            stray[tag] = tuple(table[loose[0], 1:3].tolist())
    return {"nodes": nodes, "triangles": len(where), "segments": dict(zip(tags.tolist(), per_tag.tolist())),
            "smallestArea": float(areas.min()) if len(where) else math.inf, "curves": curves, "stray": stray}


def corner_nodes(fields: np.ndarray, start: np.ndarray, counts: np.ndarray, chosen: np.ndarray, corners: int) -> np.ndarray:
    """The node numbers of the chosen elements (each line's last `corners` fields), one row each."""
    end = (start + counts)[chosen]
    return np.stack([fields[end - corners + c] for c in range(corners)], axis=1).reshape(-1, corners)


def element_fields(block: bytes, elements: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every field of the $Elements lines as one integer array, and each line's first field and
    field count in it."""
    try:
        fields = np.fromstring(block, dtype=np.int64, sep=" ") if elements else np.zeros(0, dtype=np.int64)
    except ValueError:
        raise NotWhole("an element line that is not integers") from None
    counts = fields_per_line(block)
    if counts.size != elements or (counts < 4).any():
        raise NotWhole("an element line cut short")
    if fields.size != counts.sum():  # numpy read a lone sign with the next number, or stopped early
        raise NotWhole("an element line that is not integers")
    return fields, (np.cumsum(counts) - counts).astype(np.int64), counts


def rows_of(numbers: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """The rows of the $Nodes table (node numbers `numbers`) that hold the node numbers `wanted`."""
    if not wanted.size:
        return wanted
    missing = NotWhole("a triangle whose nodes are not numbers of the $Nodes section")
    if not numbers.size:
        raise missing
    order = np.argsort(numbers)
    rows = order[np.minimum(np.searchsorted(numbers[order], wanted), numbers.size - 1)]
    if (numbers[rows] != wanted).any():
        raise missing
    return rows


def section_line(data: bytes, name: bytes) -> tuple[int, int] | None:
    """Where the first line that holds only name (and blanks) starts and ends (its newline)."""
    at = data.find(b"\n" + name)
    while at >= 0:
        end = data.find(b"\n", at + 1)
        end = len(data) if end < 0 else end
        if not data[at + 1 + len(name): end].strip():
            return at + 1, end
        at = data.find(b"\n" + name, at + 1)
    return None


def counted_block(data: bytes, opening: tuple[int, int], closing: tuple[int, int]) -> tuple[int, bytes]:
    """A section's count (the line after its opening line) and the lines from there to its closing line."""
    count_end = data.find(b"\n", opening[1] + 1)
    if count_end < 0 or closing[0] <= count_end:
        raise NotWhole("a section closed before its lines")
    try:
        count = int(data[opening[1] + 1: count_end])
    except ValueError:
        raise NotWhole("a section count is not a number") from None
    return count, data[count_end + 1: closing[0]]


def fields_per_line(block: bytes) -> np.ndarray:
    """How many whitespace-separated fields each line of block (every line ended by a newline) holds."""
    text = np.frombuffer(block, dtype=np.uint8)
    if not text.size:
        return np.zeros(0, dtype=np.int64)
    blank = text <= 32
    starts = np.flatnonzero(blank[:-1] & ~blank[1:]) + 1
    if not blank[0]:
        starts = np.concatenate(([0], starts))
    before = np.searchsorted(starts, np.flatnonzero(text == 10))
    return np.diff(np.concatenate(([0], before)))


def freefem_text(data: bytes) -> str:
    """What write_freefem writes, from the bytes of a gmsh 2.2 ASCII file."""
    lines = data.split(b"\n")
    position = {line.strip(): index for index, line in enumerate(lines) if line.startswith(b"$")}
    table = np.array(b" ".join(lines[position[b"$Nodes"] + 2: position[b"$EndNodes"]]).split(), dtype=float)
    table = table.reshape(-1, 4)
    number = {int(tag): index + 1 for index, tag in enumerate(table[:, 0])}
    triangles, edges = [], []
    for line in lines[position[b"$Elements"] + 2: position[b"$EndElements"]]:
        fields = [int(field) for field in line.split()]
        label, corners = fields[3], " ".join(str(number[v]) for v in fields[3 + fields[2]:])
        if fields[1] == 2:
            triangles.append(f"{corners} {label}")
        elif fields[1] == 1:
            edges.append(f"{corners} {label}")
    text = [f"{len(table)} {len(triangles)} {len(edges)}", *(f"{x!r} {y!r} 1" for x, y in table[:, 1:3].tolist()),
            *triangles, *edges]
    return "\n".join(text) + "\n"




def positive_sizes(numbers: list[bytes]) -> bool:
    """Whether a size field's numbers (12 a triangle: its corners, then their sizes) give finite,
    positive sizes."""
    sizes = np.array(numbers, dtype=float).reshape(-1, 12)[:, 9:]
    return bool(np.isfinite(sizes).all() and (sizes > 0).all())
