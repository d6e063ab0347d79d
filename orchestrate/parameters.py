"""The driver's parameter table, edp/lib/parameters.md, as Python data: the one source of every
parameter's name, type, default, range, unit and meaning. The FreeFEM driver reads the same
file, so the scene schema (scene.py) takes its defaults and limits from here and a scene's values
reach the driver under the table's names (`driver_values`), mapped by the table's scene keys.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from pydantic import Field

from orchestrate.freefem import REPO

TABLE = REPO / "edp" / "lib" / "parameters.md"
BODIES = (1, 2)


@dataclass(frozen=True)
class Parameter:
    """One row of the table. A body parameter stands for name1 and name2."""
    name: str
    scope: str  # "run" or "body"
    type: str  # real, int, flag, choice, text, labels
    default: str
    range: str
    unit: str
    scene: str  # dotted key below a scene (body: below bodyN), or "-"
    meaning: str

    def value(self, text: str | None = None):
        """The table's default (or `text`) as the Python value a scene holds."""
        text = self.default if text is None else text
        if self.type == "real":
            return float(text)
        if self.type == "int":
            return int(text)
        if self.type == "flag":
            return text == "1"
        if self.type == "labels":
            return [int(label) for label in text.split(",")]
        return text

    @property
    def choices(self) -> tuple[str, ...]:
        return tuple(word.strip() for word in self.range.split(",")) if self.type == "choice" else ()

    @property
    def bounds(self) -> dict[str, float]:
        """pydantic limits (gt, ge, lt, le) of an interval range; none for an infinite bound."""
        if self.type not in ("real", "int", "labels") or self.range == "-":
            return {}
        low, high = (part.strip() for part in self.range[1:-1].split(","))
        limits = {}
        if low != "-inf":
            limits["ge" if self.range[0] == "[" else "gt"] = self._number(low)
        if high != "inf":
            limits["le" if self.range[-1] == "]" else "lt"] = self._number(high)
        return limits

    def _number(self, text: str) -> float:
        return float(text) if self.type == "real" else int(text)

    def driver_names(self) -> list[str]:
        return [f"{self.name}{i}" for i in BODIES] if self.scope == "body" else [self.name]


def load(path: Path = TABLE) -> dict[str, Parameter]:
    """The rows of the Markdown table (the lines starting with '|', past the header)."""
    rows = {}
    for line in path.read_text().splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if not line.startswith("|") or len(cells) != 8 or cells[0] in ("name", "") or cells[0].startswith("-"):
            continue
        rows[cells[0]] = Parameter(*cells)
    return rows


PARAMETERS = load()


def field(name: str, **extra):
    """The pydantic Field of a table parameter: its default, limits and meaning; strict, so a
    boolean is no number and a float no integer; finite reals only."""
    parameter = PARAMETERS[name]
    options = {"allow_inf_nan": False} if parameter.type == "real" else {}
    if parameter.type != "choice":  # a choice is a Literal, strict by nature
        options["strict"] = True
    description = f"{parameter.meaning} [{parameter.unit}]" if parameter.unit != "-" else parameter.meaning
    return Field(parameter.value(), description=description, **parameter.bounds, **options, **extra)


def scene_value(data: dict, dotted: str):
    """The value at a dotted key of a scene's dump (a list element by its index: boundary.1.fy)."""
    node = data
    for part in dotted.split("."):
        node = node[int(part)] if isinstance(node, list) else node[part]
    return node


def driver_values(scene_data: dict) -> dict[str, float | int | str]:
    """A scene's values (its JSON dump) under the driver's names, for every table row with a
    scene key: flags as 0/1, lists (output times, field groups) as comma-separated text; a real
    given as an expression of x, y (ζ⁰, β⁰) is not a value of the driver's."""
    from orchestrate.expr import number_code

    values = {}
    for parameter in PARAMETERS.values():
        if parameter.scene == "-":
            continue
        keys = [f"body{i}.{parameter.scene}" for i in BODIES] if parameter.scope == "body" else [parameter.scene]
        for name, key in zip(parameter.driver_names(), keys):
            value = scene_value(scene_data, key)
            if parameter.type == "real" and isinstance(value, str):
                continue  # initial data given by position: an expression, written as a macro (scene.py)
            if isinstance(value, bool):
                value = int(value)
            elif isinstance(value, list):
                value = ",".join(number_code(v) if isinstance(v, float) else str(v) for v in value) or "none"
            elif isinstance(value, float) and not math.isfinite(value):
                raise ValueError(f"{key} = {value} is not finite")
            values[name] = value
    return values
