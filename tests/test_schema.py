"""The tables' checks (orchestrate/schema.py) on a schema of their own: strict types, limits,
required keys and defaults, unknown keys, every problem reported at once with where it is, checks
of a whole table after its keys, and data that goes back and forth unchanged."""
import pytest

from orchestrate.freefem import REPO
from orchestrate.scene import Scene
from orchestrate.schema import (Boolean, Choice, Integer, Key, ListOf, Number, Optional, Table, TableOf, Tagged,
                                TupleOf, ValidationError, after)

pytestmark = pytest.mark.unit


class Inner(Table):
    k = Key(Integer(ge=1, le=3), 2, "an integer")
    x = Key(Number(gt=0), description="a positive number")


class Pin(Table):
    type = Key(Choice("pin"))
    at = Key(TupleOf(Number(), Number()))


class Outer(Table):
    inner = Key(TableOf(Inner), {})
    flag = Key(Boolean(), False)
    word = Key(Choice("a", "b", "c"), "a")
    items = Key(ListOf(Tagged("type", {"pin": Pin}), min_length=1))
    limit = Key(Optional(Number(le=10)), None)

    @after
    def limit_above_x(self):
        if self.limit is not None and self.limit < self.inner.x:
            raise ValueError("limit is below inner.x")


def problems(data) -> list[tuple]:
    with pytest.raises(ValidationError) as error:
        Outer.model_validate(data)
    return [(p["loc"], p["type"], p["msg"]) for p in error.value.errors()]


GOOD = {"inner": {"x": 1}, "items": [{"type": "pin", "at": [0, 1.5]}]}


def test_defaults_are_data_checked_like_given_values():
    table = Outer.model_validate(GOOD)
    assert (table.inner.k, table.inner.x, table.flag, table.word, table.limit) == (2, 1.0, False, "a", None)
    assert type(table.inner.x) is float and table.items[0].at == (0.0, 1.5)  # an integer taken as a number


@pytest.mark.parametrize("change, expected", [
    ({"inner": {"x": True}}, [(("inner", "x"), "float_type", "Input should be a valid number")]),
    ({"inner": {"x": float("nan")}}, [(("inner", "x"), "finite_number", "Input should be a finite number")]),
    ({"inner": {"x": 0}}, [(("inner", "x"), "greater_than", "Input should be greater than 0")]),
    ({"inner": {"x": 1, "k": 2.0}}, [(("inner", "k"), "int_type", "Input should be a valid integer")]),
    ({"inner": {"x": 1, "k": 4}}, [(("inner", "k"), "less_than_equal", "Input should be less than or equal to 3")]),
    ({"inner": {}}, [(("inner", "x"), "missing", "Field required")]),
    ({"flag": 1}, [(("flag",), "bool_type", "Input should be a valid boolean")]),
    ({"word": "d"}, [(("word",), "literal_error", "Input should be 'a', 'b' or 'c'")]),
    ({"items": []}, [(("items",), "too_short", "List should have at least 1 item after validation, not 0")]),
    ({"items": [{"type": "nail"}]}, [(("items", 0), "union_tag_invalid",
                                      "Input tag 'nail' found using 'type' does not match any of the expected tags: 'pin'")]),
    ({"items": [{"type": "pin", "at": [1]}]}, [(("items", 0, "pin", "at", 1), "missing", "Field required")]),
    ({"limit": 0.5}, [((), "value_error", "limit is below inner.x")]),
    ({"inner": 3, "flag": "no", "extra": 1}, [(("extra",), "extra_forbidden", "Extra inputs are not permitted"),
                                              (("inner",), "model_type", "Input should be a valid dictionary or instance of Inner"),
                                              (("flag",), "bool_type", "Input should be a valid boolean")]),
])
def test_each_problem_is_found_where_it_is(change, expected):
    assert problems({**GOOD, **change}) == expected


def test_a_table_s_own_check_runs_only_once_its_keys_passed():
    assert problems({**GOOD, "limit": 11.0, "inner": {"x": 20}}) == [
        (("limit",), "less_than_equal", "Input should be less than or equal to 10")]


@pytest.mark.parametrize("name", sorted(path.name for path in (REPO / "scenes").glob("*.toml")))
def test_every_scene_goes_to_data_and_back_unchanged(name):
    scene = Scene.load(REPO / "scenes" / name)
    data = scene.model_dump(mode="json")
    assert Scene.model_validate(data) == scene and Scene.model_validate(data).model_dump(mode="json") == data
    changed = scene.model_copy(update={"title": "other"})
    assert changed.title == "other" and changed.body1 is scene.body1 and scene.title != "other"
