"""Tables of data checked against a schema written as Python classes: what scene.py validates a
scene with. A `Table` subclass lists its keys as class attributes, each a `Key` (a check, a default
and a meaning); it refuses keys it does not have, checks every key it has, and runs its own
`@after` checks once all of them passed. A check is a callable (value, context) → value that raises
`Invalid`; each problem says where it is (loc: the keys and list indices below the table), its
type, a message and the value given, so scene.py's messages name the key, the value and what is
allowed, all problems at once. Defaults are data, checked as a given value is.

Written for the scene's needs, not a general library: a run imports it in a few milliseconds,
where pydantic took 60 ms of a 0.5 s run before FreeFem++ could start (docs/model-choices.md,
"Where the time goes").
"""
from __future__ import annotations

import math
import re
from typing import Any, Callable, ClassVar

MISSING = type("Missing", (), {"__repr__": lambda self: "MISSING"})()  # a required key's default


class Invalid(Exception):
    """Problems of one value: dicts loc, type, msg, input (loc relative to the value checked)."""

    def __init__(self, problems: list[dict]):
        super().__init__(problems)
        self.problems = problems


class ValidationError(ValueError):
    """A table that does not satisfy its schema; `errors()` lists every problem."""

    def __init__(self, problems: list[dict]):
        super().__init__(f"{len(problems)} problem(s): " + "; ".join(
            f"{'.'.join(map(str, p['loc']))}: {p['msg']}" for p in problems))
        self.problems = problems

    def errors(self) -> list[dict]:
        return self.problems


ECHOED = 60  # characters of a value a message repeats: a 5 MB title is named by its start and length
PATH_MAX = 4096  # Linux's longest path: a path is repeated whole up to it, and a longer text is no path


def shown(value, quoted: bool = True, limit: int = ECHOED) -> str:
    """A value as a message repeats it: its repr (a text as it is, unless `quoted`), cut to `limit`
    characters when longer (a text with its length), so that the line stays one a reader can take in."""
    text = repr(value) if quoted or not isinstance(value, str) else value
    if len(text) <= limit:
        return text
    return text[:limit - 1] + "…" + (f" ({len(value)} characters)" if isinstance(value, str) else "")


def problem(kind: str, message: str, value) -> Invalid:
    return Invalid([{"loc": (), "type": kind, "msg": message, "input": value}])


def below(error: Invalid, *loc) -> list[dict]:
    """The problems of a value found at `loc` of the value that holds it."""
    return [{**p, "loc": (*loc, *p["loc"])} for p in error.problems]


def bound_text(value) -> str:
    """A limit as the messages print it: 0.0 as 0, 86400.0 as 86400."""
    return str(int(value)) if isinstance(value, float) and value.is_integer() else str(value)


BOUNDS = {"ge": ("greater than or equal to", lambda v, b: v >= b, "["),
          "gt": ("greater than", lambda v, b: v > b, "("),
          "le": ("less than or equal to", lambda v, b: v <= b, "]"),
          "lt": ("less than", lambda v, b: v < b, ")")}
BOUND_TYPES = {"ge": "greater_than_equal", "gt": "greater_than", "le": "less_than_equal", "lt": "less_than"}


def interval(bounds: dict) -> str:
    """The interval of limits ge/gt/le/lt, as the reference page writes it."""
    low = next(((bounds[k], BOUNDS[k][2]) for k in ("ge", "gt") if k in bounds), ("-inf", "("))
    high = next(((bounds[k], BOUNDS[k][2]) for k in ("le", "lt") if k in bounds), ("inf", ")"))
    return f"{low[1]}{low[0]}, {high[0]}{high[1]}"


class Check:
    """A check of one value; `kind` and `range` describe it on the reference page."""
    kind, range = "value", "-"

    def __call__(self, value, context: dict):
        raise NotImplementedError


class Number(Check):
    """A finite number (an integer is taken as one; a boolean or a text is not), within bounds."""
    kind = "number"

    def __init__(self, **bounds):
        self.bounds, self.range = bounds, interval(bounds)

    def __call__(self, value, context):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise problem("float_type", "Input should be a valid number", value)
        if isinstance(value, int) and not -1e308 < value < 1e308 or not math.isfinite(value):
            raise problem("finite_number", "Input should be a finite number", value)
        return float(within_bounds(value, self.bounds))


class Integer(Number):
    """An integer (a float is refused, even 2.0), within bounds."""
    kind = "integer"

    def __call__(self, value, context):
        if isinstance(value, bool) or not isinstance(value, int):
            raise problem("int_type", "Input should be a valid integer", value)
        return within_bounds(value, self.bounds)


def within_bounds(value, bounds: dict):
    for key, limit in bounds.items():
        words, holds, _ = BOUNDS[key]
        if not holds(value, limit):
            raise problem(BOUND_TYPES[key], f"Input should be {words} {bound_text(limit)}", value)
    return value


class Boolean(Check):
    kind = "boolean"

    def __call__(self, value, context):
        if not isinstance(value, bool):
            raise problem("bool_type", "Input should be a valid boolean", value)
        return value


class Text(Check):
    kind = "text"

    def __init__(self, max_length: int | None = None, pattern: str | None = None):
        self.max_length, self.pattern = max_length, pattern
        if max_length is not None:
            self.range = f"length ≤ {max_length}"

    def __call__(self, value, context):
        if not isinstance(value, str):
            raise problem("string_type", "Input should be a valid string", value)
        if self.max_length is not None and len(value) > self.max_length:
            raise problem("string_too_long", f"String should have at most {self.max_length} characters", value)
        if self.pattern is not None and not re.search(self.pattern, value):
            raise problem("string_pattern_mismatch", f"String should match pattern '{self.pattern}'", value)
        return value


def quoted_choices(options) -> str:
    quoted = [f"'{option}'" for option in options]
    return quoted[0] if len(quoted) == 1 else ", ".join(quoted[:-1]) + " or " + quoted[-1]


class Choice(Check):
    """One of a few words."""

    def __init__(self, *options: str):
        self.options = options
        self.kind = "one of " + ", ".join(f'"{option}"' for option in options)

    def __call__(self, value, context):
        if not isinstance(value, str) or value not in self.options:
            raise problem("literal_error", f"Input should be {quoted_choices(self.options)}", value)
        return value


class Optional(Check):
    """None, or a value the inner check accepts."""

    def __init__(self, inner: Check):
        self.inner, self.kind, self.range = inner, inner.kind, inner.range

    def __call__(self, value, context):
        return None if value is None else self.inner(value, context)


class Then(Check):
    """A value the first check accepts, then given to a function (a ValueError it raises is the
    value's problem): a check that needs the value's type first (a path, a unit's name)."""

    def __init__(self, first: Check, function: Callable):
        self.first, self.function, self.kind, self.range = first, function, first.kind, first.range

    def __call__(self, value, context):
        value = self.first(value, context)
        try:
            return self.function(value, context)
        except ValueError as error:
            raise problem("value_error", str(error), value) from None


class Custom(Check):
    """A function (value) → value that checks a value of any type (a ValueError it raises is the
    value's problem), described on the reference page by `kind`."""

    def __init__(self, function: Callable, kind: str):
        self.function, self.kind = function, kind

    def __call__(self, value, context):
        try:
            return self.function(value)
        except ValueError as error:
            raise problem("value_error", str(error), value) from None


class ListOf(Check):
    def __init__(self, item: Check, min_length: int = 0):
        self.item, self.min_length = item, min_length
        self.kind = f"list of {item.kind}"
        self.range = f"length ≥ {min_length}" if min_length else "-"

    def __call__(self, value, context):
        if not isinstance(value, (list, tuple)):
            raise problem("list_type", "Input should be a valid list", value)
        if len(value) < self.min_length:
            raise problem("too_short", f"List should have at least {self.min_length} item{'s' * (self.min_length > 1)} "
                                       f"after validation, not {len(value)}", value)
        return checked_items(value, [self.item] * len(value), context, list)


class TupleOf(Check):
    """A list of a fixed length, each element with its own check."""

    def __init__(self, *items: Check):
        self.items = items
        self.kind = f"[{', '.join(item.kind for item in items)}]"

    def __call__(self, value, context):
        if not isinstance(value, (list, tuple)):
            raise problem("tuple_type", "Input should be a valid tuple", value)
        if len(value) > len(self.items):
            raise problem("too_long", f"Tuple should have at most {len(self.items)} items after validation, "
                                      f"not {len(value)}", value)
        missing = [{"loc": (i,), "type": "missing", "msg": "Field required", "input": value}
                   for i in range(len(value), len(self.items))]
        try:
            items = checked_items(value, self.items, context, tuple)
        except Invalid as error:
            raise Invalid(error.problems + missing) from None
        if missing:
            raise Invalid(missing)
        return items


def checked_items(values, checks, context, kind):
    found, problems = [], []
    for i, (value, check) in enumerate(zip(values, checks)):
        try:
            found.append(check(value, context))
        except Invalid as error:
            problems += below(error, i)
    if problems:
        raise Invalid(problems)
    return kind(found)


class MapOf(Check):
    """A table of names (matching a pattern) to values of one check."""
    kind = "table"

    def __init__(self, pattern: str, value: Check):
        self.name, self.value = Text(pattern=pattern), value

    def __call__(self, value, context):
        if not isinstance(value, dict):
            raise problem("dict_type", "Input should be a valid dictionary", value)
        found, problems = {}, []
        for name, item in value.items():
            try:
                found[self.name(name, context)] = self.value(item, context)
            except Invalid as error:
                problems += below(error, name)
        if problems:
            raise Invalid(problems)
        return found


class TableOf(Check):
    """A nested table of a Table class."""

    def __init__(self, table: type[Table]):
        self.table, self.kind = table, "table"

    def __call__(self, value, context):
        return self.table.checked(value, context)


class Tagged(Check):
    """A table whose key `tag` names its Table class (a boundary condition's type)."""

    def __init__(self, tag: str, tables: dict[str, type[Table]]):
        self.tag, self.tables = tag, tables
        self.kind = " or ".join(table.__name__ for table in tables.values())

    def __call__(self, value, context):
        if isinstance(value, tuple(self.tables.values())):
            return value
        if not isinstance(value, dict):
            raise problem("model_attributes_type", "Input should be a valid dictionary or object to extract fields from",
                          value)
        if self.tag not in value:
            raise problem("union_tag_not_found", f"Unable to extract tag using discriminator '{self.tag}'", value)
        name = value[self.tag]
        table = self.tables.get(name) if isinstance(name, str) else None
        if table is None:
            expected = ", ".join(repr(t) for t in self.tables)
            raise problem("union_tag_invalid", f"Input tag {shown(name)} found using '{self.tag}' does not match any "
                                               f"of the expected tags: {expected}", value)
        try:
            return table.checked(value, context)
        except Invalid as error:
            raise Invalid(below(error, name)) from None


class Key:
    """One key of a table: its check, its default (data, checked like a given value; MISSING for a
    required key), its meaning (ending in its unit as '[unit]'), and its range on the reference page
    where the check does not say it (a custom check's)."""

    def __init__(self, check: Check, default: Any = MISSING, description: str = "", range: str | None = None):
        self.check, self.default, self.description = check, default, description
        self.range = range if range is not None else check.range

    @property
    def required(self) -> bool:
        return self.default is MISSING


def after(method: Callable) -> Callable:
    """A check of a whole table, run once each of its keys passed; a ValueError it raises is the
    table's problem."""
    method.after_check = True
    return method


class Table:
    """A table of keys (class attributes that are Keys), checked by `model_validate`. Instances
    hold each key as an attribute; `model_dump` gives the data back, `model_copy` a copy with some
    keys replaced (not checked again)."""
    keys: ClassVar[dict[str, Key]] = {}
    after_checks: ClassVar[tuple[Callable, ...]] = ()

    def __init_subclass__(cls):
        cls.keys = {name: value for name, value in vars(cls).items() if isinstance(value, Key)}
        for name in cls.keys:
            delattr(cls, name)
        cls.after_checks = tuple(value for value in vars(cls).values() if getattr(value, "after_check", False))

    def __init__(self, **values):
        self.__dict__.update(values)

    @classmethod
    def model_validate(cls, data, context: dict | None = None):
        """The table from its data; ValidationError lists every problem. `context` reaches the
        checks (scene.py: the folder relative paths are taken from)."""
        try:
            return cls.checked(data, context or {})
        except Invalid as error:
            raise ValidationError(error.problems) from None

    @classmethod
    def checked(cls, data, context: dict):
        if isinstance(data, cls):
            return data
        if not isinstance(data, dict):
            raise problem("model_type", f"Input should be a valid dictionary or instance of {cls.__name__}", data)
        problems = [{"loc": (name,), "type": "extra_forbidden", "msg": "Extra inputs are not permitted",
                     "input": value} for name, value in data.items() if name not in cls.keys]
        values = {}
        for name, key in cls.keys.items():
            if name not in data and key.required:
                problems.append({"loc": (name,), "type": "missing", "msg": "Field required", "input": data})
                continue
            try:
                values[name] = key.check(data.get(name, key.default), context)
            except Invalid as error:
                problems += below(error, name)
        if problems:
            raise Invalid(problems)
        table = cls(**values)
        for check in cls.after_checks:
            try:
                check(table)
            except ValueError as error:
                raise problem("value_error", str(error), data) from None
        return table

    def model_dump(self, mode: str = "python", exclude_none: bool = False) -> dict:
        """The table as data: nested tables as dicts; in mode "json", tuples as lists."""
        return {name: dumped(value, mode, exclude_none) for name, value in self.__dict__.items()
                if not (exclude_none and value is None)}

    def model_copy(self, update: dict | None = None):
        return type(self)(**{**self.__dict__, **(update or {})})

    def __eq__(self, other):
        return type(other) is type(self) and other.__dict__ == self.__dict__

    __hash__ = None

    def __repr__(self):
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in self.__dict__.items())})"


def dumped(value, mode: str, exclude_none: bool):
    if isinstance(value, Table):
        return value.model_dump(mode, exclude_none)
    if isinstance(value, (list, tuple)):
        items = [dumped(item, mode, exclude_none) for item in value]
        return items if mode == "json" or isinstance(value, list) else tuple(items)
    if isinstance(value, dict):
        return {name: dumped(item, mode, exclude_none) for name, item in value.items()}
    return value
