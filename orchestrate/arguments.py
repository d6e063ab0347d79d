"""Key=value assignments, as `--set` and `--grid` give them and a scene reads them: split at the
first '=' outside brackets, values read as TOML reads values."""
from __future__ import annotations

import re

from orchestrate.scene import SceneError, parse_value
from orchestrate.schema import shown


# KEY=VALUE split at the first '=' outside brackets: a key may name a boundary condition by its
# label, body1.boundary[label=4].fy (scene.py, LABELLED).
ASSIGNMENT = re.compile(r"((?:[^=\[]|\[[^\]]*\])+)=(.*)", re.S)


def split_assignment(item: str, option: str, form: str, example: str) -> tuple[str, str]:
    """`KEY=VALUE` as its key and value text, both stripped; else an error showing the form."""
    match = ASSIGNMENT.fullmatch(item)
    if not match or not match[1].strip():
        raise SceneError(f"{option} {shown(item)}: expected {form}, e.g. {option} {example}")
    return match[1].strip(), match[2].strip()


def parse_assignments(items: list[str], option: str) -> dict:
    """key=value strings as a dict (values read as TOML would: numbers, booleans, strings)."""
    assignments = {}
    for item in items:
        key, value = split_assignment(item, option, "key=value", "time.N=80")
        if key in assignments:
            raise SceneError(f"{option} {shown(key, False)} is given twice: give it once")
        assignments[key] = parse_value(value)
    return assignments
