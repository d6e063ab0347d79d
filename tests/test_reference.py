"""docs/scene-format.md is the reference of the scene format users read: it must be the page the
schema gives today (`python -m orchestrate reference --force` rewrites it), and name every key a scene
may hold, with the table's limits where the schema checks them itself."""
from __future__ import annotations

import pytest

from orchestrate.parameters import PARAMETERS
from orchestrate.reference import PAGE, page

pytestmark = pytest.mark.unit


def test_the_committed_reference_is_the_schema_s():
    assert PAGE.read_text() == page(), "docs/scene-format.md is stale: run python -m orchestrate reference --force"


def test_every_table_parameter_of_a_scene_is_in_the_reference_with_its_range_and_unit():
    text = page()
    for parameter in PARAMETERS.values():
        if parameter.scene == "-":
            continue
        key = ("bodyN." if parameter.scope == "body" else "") + parameter.scene
        line = next((row for row in text.splitlines() if row.startswith(f"| `{key}` |")), None)
        assert line is not None, key
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        if parameter.type in ("real", "int", "labels") and parameter.range != "-":
            low, high = (part.strip() for part in parameter.range[1:-1].split(","))
            assert cells[3][0] == parameter.range[0] and cells[3][-1] == parameter.range[-1], (key, cells[3])
            assert float(cells[3][1:-1].split(",")[0]) == float(low) and float(cells[3][1:-1].split(",")[1]) == float(high)
        if parameter.unit != "-":
            assert cells[4] == parameter.unit, (key, cells[4])
