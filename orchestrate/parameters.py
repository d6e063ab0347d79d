"""The driver's parameters and time schemes, edp/lib/parameters.toml, as Python data: the one source
of every parameter's name, type, default, range, unit and meaning, and of each scheme's
coefficients. The scene schema (scene.py) takes its defaults and limits from here and a scene's
values reach the driver under the table's names (`driver_values`), mapped by the table's scene
keys. FreeFEM never reads the TOML: `python -m orchestrate reference` writes its rows and schemes
as the includes edp/lib/parameterTable.idp and edp/lib/schemes.idp, and docs/parameters.md for
people (`generated` gives the three texts; tests/test_parameters.py keeps the files in step).
"""
from __future__ import annotations

import ast
import math
import operator
import tomllib
from dataclasses import dataclass
from pathlib import Path
from orchestrate.expr import number_code
from orchestrate.freefem import REPO
from orchestrate.schema import Boolean, Choice, Custom, Integer, Key, Number

SOURCE = REPO / "edp" / "lib" / "parameters.toml"
TABLE_IDP = REPO / "edp" / "lib" / "parameterTable.idp"
SCHEMES_IDP = REPO / "edp" / "lib" / "schemes.idp"
REFERENCE = REPO / "docs" / "parameters.md"
BODIES = (1, 2)
BODY_SUFFIXES = tuple(str(body) for body in BODIES)  # a body parameter's driver names: E1, E2
# Each scheme's entries as FreeFEM variables (schemes.idp) and their type there.
SCHEME_KEYS = {"order": "int", "viscousWeight": "real", "elasticImplicit": "bool", "levels": "int",
               "rateWeights": "real[int]", "extrapolation": "real[int]", "elasticBound": "real",
               "sourceLimit": "real", "adhesionImplicit": "bool", "glueLimit": "real"}


@dataclass(frozen=True)
class Parameter:
    """One row of the table. A body parameter stands for name1 and name2. Its limits are numbers
    (gt, ge, lt, le; None: no bound; le = inf: infinity itself allowed), or its choices."""
    name: str
    scope: str  # "run" or "body"
    type: str  # real, int, flag, choice, subset (a comma-separated subset of the choices), text, labels
    default: str
    unit: str
    scene: str  # dotted key below a scene (body: below bodyN), or "-"
    meaning: str
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    choices: tuple[str, ...] = ()

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
        if self.type == "subset":
            return [] if text == "none" else text.split(",")
        return text

    @property
    def bounds(self) -> dict[str, float]:
        """The finite limits (gt, ge, lt, le)."""
        return {key: getattr(self, key) for key in ("gt", "ge", "lt", "le")
                if getattr(self, key) is not None and math.isfinite(getattr(self, key))}

    @property
    def closed_at_infinity(self) -> bool:
        """A real that takes infinity itself (le = inf): the text "inf" in a scene and on the command line."""
        return self.le == math.inf

    @property
    def range(self) -> str:
        """The limits as people read them: "(0, inf)", "[1, 4096]", the choices, or "-"."""
        if self.choices:
            return ", ".join(self.choices)
        if self.type not in ("real", "int", "labels"):
            return "-"
        low = self.ge if self.ge is not None else self.gt
        high = self.le if self.le is not None else self.lt
        return (f"{'[' if self.ge is not None else '('}{number_text(low, '-inf')}, "
                f"{number_text(high, 'inf')}{']' if self.le is not None else ')'}")

    def driver_names(self) -> list[str]:
        return [f"{self.name}{i}" for i in BODIES] if self.scope == "body" else [self.name]


# --- rules between parameters ----------------------------------------------------------------------
# A rule's `holds` is a condition in a small language, Python's syntax and FreeFEM's meaning:
# parameters by name, numbers, text in double quotes, + - * /, comparisons, and, or, not. The
# driver checks it as generated code (parameterTable.idp, checkRules), a scene's validation
# evaluates it here: one text, both sides.
RULE_OPERATORS = {ast.Add: ("+", operator.add), ast.Sub: ("-", operator.sub), ast.Mult: ("*", operator.mul),
                  ast.Div: ("/", operator.truediv), ast.Lt: ("<", operator.lt), ast.LtE: ("<=", operator.le),
                  ast.Gt: (">", operator.gt), ast.GtE: (">=", operator.ge), ast.Eq: ("==", operator.eq),
                  ast.NotEq: ("!=", operator.ne), ast.USub: ("-", operator.neg), ast.Not: ("!", operator.not_),
                  ast.And: ("&&", all), ast.Or: ("||", any)}


def rule_tree(text: str) -> ast.expr:
    tree = ast.parse(text, mode="eval").body
    for node in ast.walk(tree):
        allowed = (ast.BoolOp, ast.BinOp, ast.UnaryOp, ast.Compare, ast.Name, ast.Constant, ast.Load,
                   *RULE_OPERATORS)
        if not isinstance(node, allowed) or isinstance(node, ast.Constant) and not isinstance(node.value, (int, float, str)):
            raise ValueError(f"{SOURCE}: rule {text!r}: {type(node).__name__} is not in the rules' language")
        if isinstance(node, ast.Compare) and len(node.ops) != 1:
            raise ValueError(f"{SOURCE}: rule {text!r}: one comparison at a time (FreeFEM chains none)")
    return tree


def rule_names(text: str) -> list[str]:
    return [node.id for node in ast.walk(rule_tree(text)) if isinstance(node, ast.Name)]


def rule_holds(text: str, values: dict) -> bool:
    """A rule's condition on `values` (the driver's names)."""
    def value(node):
        if isinstance(node, ast.Constant):
            return node.value
        if isinstance(node, ast.Name):
            return values[node.id]
        if isinstance(node, ast.BoolOp):
            return RULE_OPERATORS[type(node.op)][1](value(operand) for operand in node.values)
        if isinstance(node, ast.UnaryOp):
            return RULE_OPERATORS[type(node.op)][1](value(node.operand))
        if isinstance(node, ast.BinOp):
            return RULE_OPERATORS[type(node.op)][1](value(node.left), value(node.right))
        return RULE_OPERATORS[type(node.ops[0])][1](value(node.left), value(node.comparators[0]))
    return bool(value(rule_tree(text)))


def rule_code(text: str, suffix: str = "") -> str:
    """A rule's condition as FreeFEM code, each parameter's name followed by `suffix` (a body's 1 or 2)."""
    def code(node) -> str:
        if isinstance(node, ast.Constant):
            return freefem_text(node.value) if isinstance(node.value, str) else repr(node.value)
        if isinstance(node, ast.Name):
            return node.id + suffix
        if isinstance(node, ast.BoolOp):
            return "(" + f" {RULE_OPERATORS[type(node.op)][0]} ".join(code(operand) for operand in node.values) + ")"
        if isinstance(node, ast.UnaryOp):
            return f"({RULE_OPERATORS[type(node.op)][0]}{code(node.operand)})"
        if isinstance(node, ast.BinOp):
            return f"({code(node.left)} {RULE_OPERATORS[type(node.op)][0]} {code(node.right)})"
        return f"({code(node.left)} {RULE_OPERATORS[type(node.ops[0])][0]} {code(node.comparators[0])})"
    return code(rule_tree(text))


def number_text(value: float | None, infinite: str) -> str:
    """A limit as the table's readers write it: 0, 0.5, 10000000, inf."""
    if value is None or math.isinf(value):
        return infinite if value is None or value > 0 else "-inf"
    return str(int(value)) if value == int(value) and abs(value) < 1e15 else repr(float(value))


def load(path: Path = SOURCE) -> tuple[dict[str, Parameter], dict[str, dict], list[dict], dict]:
    """The parameters by name, the schemes by name, the rules between parameters and the measured
    constants; the scheme parameter's choices are the schemes, and each scheme has every coefficient."""
    data = tomllib.loads(path.read_text())
    rows = {row["name"]: Parameter(**{**row, "choices": tuple(row.get("choices", ()))}) for row in data["parameter"]}
    schemes = data["scheme"]
    if rows["scheme"].choices != tuple(schemes):
        raise ValueError(f"{path}: the scheme parameter's choices {rows['scheme'].range!r} are not the schemes {list(schemes)}")
    for name, scheme in schemes.items():
        if set(scheme) != {*SCHEME_KEYS, "meaning"}:
            raise ValueError(f"{path}: scheme {name} has {sorted(scheme)}, not {sorted({*SCHEME_KEYS, 'meaning'})}")
        for key, kind in SCHEME_KEYS.items():
            length = len(scheme[key]) if kind == "real[int]" and isinstance(scheme[key], list) else 1
            if not SCHEME_CHECKS[kind](scheme[key]) or length != LENGTHS.get(key, 1):
                raise ValueError(f"{path}: scheme {name}: {key} = {scheme[key]!r} is not {SCHEME_SHAPES.get(key, kind)}")
        if scheme["levels"] == 2 and not scheme["adhesionImplicit"]:  # the libraries' explicit adhesion is one-level
            raise ValueError(f"{path}: scheme {name} has two levels and adhesionImplicit = false: only a one-level scheme"
                             " takes the glue and the bonding explicitly")
    for rule in data["rule"]:
        unknown = set(rule_names(rule["holds"])) - set(rows)
        if unknown or rule["names"] not in rows or rule["scope"] not in ("run", "body"):
            raise ValueError(f"{path}: rule {rule['holds']!r} names {sorted(unknown) or rule['names']}, not parameters of "
                             "the table, or its scope is not run or body")
    return rows, schemes, data["rule"], data["measured"]


def finite(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


# What the driver can take of each coefficient (schemes.idp declares real[int] of these lengths;
# the libraries know one- and two-level schemes).
SCHEME_SHAPES = {"levels": "1 or 2", "rateWeights": "3 numbers", "extrapolation": "2 numbers", "order": "1 or 2"}
LENGTHS = {"rateWeights": 3, "extrapolation": 2}
SCHEME_CHECKS = {
    "int": lambda value: isinstance(value, int) and not isinstance(value, bool) and value in (1, 2),
    "real": lambda value: finite(value) and value >= 0,
    "bool": lambda value: isinstance(value, bool),
    "real[int]": lambda value: isinstance(value, list) and all(finite(v) for v in value),
}


PARAMETERS, SCHEMES, RULES, MEASURED = load()
BYTES_PER_NODE = MEASURED["bytesPerNode"]  # FreeFem++'s peak memory per mesh node (parameters.toml, [measured])
ORDER = {name: scheme["order"] for name, scheme in SCHEMES.items()}  # each scheme's order in k


CHECKS = {"real": Number, "int": Integer}


def field(name: str) -> Key:
    """The scene key of a table parameter: its check (strict, so a boolean is no number and a float
    no integer; finite reals only), default, limits and meaning."""
    parameter = PARAMETERS[name]
    if parameter.type == "choice":
        check = Choice(*parameter.choices)
    elif parameter.type == "flag":
        check = Boolean()
    else:  # a real or an integer (a row of another type has a key of its own in scene.py)
        check = CHECKS[parameter.type](**parameter.bounds)
    return Key(check, parameter.value(), described(parameter))


def described(parameter: Parameter) -> str:
    return f"{parameter.meaning} [{parameter.unit}]" if parameter.unit != "-" else parameter.meaning


def unbounded_field(name: str) -> Key:
    """The scene key of a real whose range is closed at infinity ("[0, inf]"): a finite number in
    the range, or the text "inf" (JSON and TOML have no infinite number)."""
    parameter = PARAMETERS[name]
    low = parameter.bounds.get("ge", parameter.bounds.get("gt"))
    table, _, leaf = parameter.scene.rpartition(".")

    def validate(value):
        if value == "inf":
            return value
        if value == math.inf:  # TOML's bare inf, a float: the range's end is the word, as the driver reads it
            raise ValueError(f'infinity is the text "inf" here, in quotes: {leaf} = "inf" under [{table}] of a scene '
                             f"file, --set '{parameter.scene}=\"inf\"' on the command line")
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not -1e308 < value < 1e308 \
                or value < low or (value == low and "gt" in parameter.bounds):
            raise ValueError(f'give a number in {parameter.range} or "inf"')
        return float(value)

    return Key(Custom(validate, 'number or one of "inf"'), parameter.value(), described(parameter), parameter.range)


def scene_key(name: str, suffix: str = "") -> str:
    """The scene key of a parameter of the table (a body's, for the body `suffix` names: 1 or 2)."""
    parameter = PARAMETERS[name]
    return f"body{suffix}.{parameter.scene}" if parameter.scope == "body" else parameter.scene


def driver_name_keys() -> dict[str, str]:
    """Each driver name of a parameter that has a scene key (E1, T, ...), to its scene key."""
    return {name: scene_key(parameter.name, name[len(parameter.name):]) for parameter in PARAMETERS.values()
            if parameter.scene != "-" for name in parameter.driver_names()}


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
    values = {}
    for parameter in PARAMETERS.values():
        if parameter.scene == "-":
            continue
        keys = [f"body{i}.{parameter.scene}" for i in BODIES] if parameter.scope == "body" else [parameter.scene]
        for name, key in zip(parameter.driver_names(), keys):
            value = scene_value(scene_data, key)
            if parameter.type == "real" and isinstance(value, str):
                if value == "inf":  # a range closed at infinity (unbounded_field): the driver reads the word
                    values[name] = value
                continue  # else initial data given by position: an expression, written as a macro (scene.py)
            if isinstance(value, bool):
                value = int(value)
            elif isinstance(value, list):
                value = ",".join(number_code(v) if isinstance(v, float) else str(v) for v in value) or "none"
            elif isinstance(value, float) and not math.isfinite(value):
                raise ValueError(f"{key} = {value} is not finite")
            values[name] = value
    return values


# --- the generated files ---------------------------------------------------------------------------

GENERATED = "Generated by `python -m orchestrate reference` from edp/lib/parameters.toml: edit that file, not this one."


ASCII_UNITS = str.maketrans({"²": "^2", "³": "^3", "·": "*"})


def freefem_text(text: str) -> str:
    """A FreeFEM string literal: its lexer stops at a byte past ASCII in a string (N/m² → N/m^2)."""
    text = text.translate(ASCII_UNITS)
    if '"' in text or "\\" in text or not text.isascii() or not text.isprintable():
        raise ValueError(f"{SOURCE}: {text!r} holds a quote, a backslash or a character past printable ASCII, which a "
                         "FreeFEM string cannot")
    return f'"{text}"'


def freefem_number(value) -> str:
    """A coefficient as FreeFEM reads it back to the same double (repr is the shortest round trip)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):
        return "[" + ", ".join(freefem_number(v) for v in value) + "]"
    return repr(value) if isinstance(value, int) else repr(float(value))


def freefem_limit(value: float | None, infinite: float) -> str:
    """A limit as a FreeFEM expression: a number, or ±inf (1e308*10) for none."""
    value = infinite if value is None else value
    return ("-" if value < 0 else "") + "1e308*10" if math.isinf(value) else repr(value)


def table_row(p: Parameter) -> str:
    low = p.ge if p.ge is not None else p.gt
    high = p.le if p.le is not None else p.lt
    words = " " + " ".join(p.choices) + " " if p.choices else ""
    return ("addTableRow(" + ", ".join(freefem_text(getattr(p, key)) for key in ("scope", "name", "type", "default"))
            + f", {freefem_text(p.range)}, {freefem_text(p.unit)}, {freefem_limit(low, -math.inf)}, {int(p.ge is not None)}, "
              f"{freefem_limit(high, math.inf)}, {int(p.le is not None)}, {freefem_text(words)});")


def rule_check(rule: dict, suffix: str = "") -> str:
    return (f'requireRule({freefem_text(rule["names"] + suffix)}, {rule_code(rule["holds"], suffix)}, '
            f'{freefem_text(rule["says"])});')


def table_idp() -> str:
    rows = "\n".join(table_row(p) for p in PARAMETERS.values())
    rules = "\n".join(rule_check(rule, suffix) for rule in RULES
                      for suffix in (BODY_SUFFIXES if rule["scope"] == "body" else ("",)))
    return f"""// {GENERATED}
// Every parameter's row for params.idp: scope, name, type, default, its range as people read it and
// unit (for messages and -help), its limits as numbers (the lower one and whether it is closed, the
// upper one and whether it is closed; 1e308*10 is infinity) and its choices; and the rules between
// parameters, checked once every parameter is read. What each means is in docs/parameters.md, never
// here, so rewording it changes no solver digest.
IFMACRO(!parameterTableIdp)
macro parameterTableIdp 1 //
macro parameterRows
{rows}
//
macro checkRules
{rules}
//
real bytesPerNode = {freefem_number(BYTES_PER_NODE)};  // FreeFem++'s peak memory per mesh node, measured
ENDIFMACRO
"""


def idp_name(key: str) -> str:
    """A coefficient's FreeFEM variable: viscousWeight → schemeViscousWeight."""
    return f"scheme{key[0].upper()}{key[1:]}"


def schemes_idp() -> str:
    names = list(SCHEMES)
    declared = "\n".join(f"{kind} {idp_name(key)}{f'({LENGTHS[key]})' if key in LENGTHS else ''};"
                         for key, kind in SCHEME_KEYS.items())
    branches = []
    for j, name in enumerate(names):
        values = " ".join(f"{idp_name(key)} = {freefem_number(SCHEMES[name][key])};" for key in SCHEME_KEYS)
        branches.append(f'{"if" if j == 0 else "else if"} (scheme == {freefem_text(name)}) {{ {values} }}')
    allowed = ", ".join(names)
    branches.append(f'else fail(3, "parameter scheme = \'" + scheme + "\' is not allowed: allowed {allowed}");')
    return f"""// {GENERATED}
// The time schemes as data (docs/model.md §6, §9): schemeCoefficients, invoked by readParameters once
// `scheme` is read, declares the chosen scheme's coefficients, and no library names a scheme. What
// each coefficient means is said in parameters.toml: schemeViscousWeight the weight of A/k in K,
// schemeElasticImplicit G in K, schemeLevels the past levels a later step reads, schemeRateWeights
// k·u̇ⁿ ≈ w₀uⁿ + w₁uⁿ⁻¹ + w₂uⁿ⁻², schemeExtrapolation e₁uⁿ⁻¹ + e₂uⁿ⁻², and the explicit terms'
// bounds (schemeElasticBound 0: none).
IFMACRO(!schemesIdp)
macro schemesIdp 1 //
// Step n of a two-level scheme past its first: it reads the levels n − 1 and n − 2.
macro twoLevels(n) (schemeLevels == 2 && n > 1) //
macro schemeCoefficients
{declared}
{chr(10).join(branches)}
//
ENDIFMACRO
"""


def markdown_cell(text: str) -> str:
    return text.replace("|", "\\|") or " "


def reference_md() -> str:
    header = ["name", "scope", "type", "default", "range", "unit", "scene key", "meaning"]
    rows = [header, ["---"] * len(header)] + [
        [p.name, p.scope, p.type, p.default, p.range, p.unit, p.scene, p.meaning] for p in PARAMETERS.values()]
    table = "\n".join("| " + " | ".join(markdown_cell(cell) for cell in row) + " |" for row in rows)
    schemes = "\n".join(f"- `{name}`: {scheme['meaning']} (order {scheme['order']})" for name, scheme in SCHEMES.items())
    rules = "\n".join(f"- `{rule['holds']}`{' (each body)' if rule['scope'] == 'body' else ''}: {rule['says']}"
                      for rule in RULES)
    return f"""# Parameters of the driver

<!-- {GENERATED} -->

Every parameter of `edp/main.edp`: the flag `-name value` of a run by hand (`FreeFem++ edp/main.edp
-help` lists them with their defaults and ranges), and the scene key of a scene (docs/scene-format.md).
A *body* parameter exists once per body: `E` is the flags `-E1` and `-E2` and the scene keys
`body1.material.E` and `body2.material.E`. Names follow the paper's symbols: `zeta` ζ, `beta` β,
`gammaNu` γ_ν, `gammaR` γ_r, `pTau` p_τ, `lambdaD`/`lambdaU`/`lambdaW` λ_D/λ_u/λ_w, `kappa` κ,
`eta` η, `mu` μ, `nu` ν. The defaults are the paper's scene.

Types: *real*, *int*, *flag* (0 or 1; a boolean in scenes), *choice* (one of the words in the range
column), *subset* (some of those words: comma-separated on the command line, `none` for none; a list
in scenes), *text*, *labels* (boundary labels, comma-separated on the command line like `1,5`, a
number or a list in scenes; each in the range, each once). Ranges are intervals, `(` and `)` open,
`[` and `]` closed; `inf` means no bound (`inf]`: infinity itself allowed, written `inf`). Units are
SI (lengths in m, times in s, forces per unit thickness in N/m); any consistent set works. A scene
key `-` means the parameter is the driver's only. `outTimes` has its own syntax.

{table}

## Rules between parameters

Checked by the driver and by a scene's validation, both from this one table (a body rule for each
body):

{rules}

## Time schemes

{schemes}

Each scheme's coefficients (the weight of A/k, whether G is implicit, the rate and extrapolation
weights, the bounds of its explicit terms) are in `edp/lib/parameters.toml`; docs/model.md §9 and
docs/model-choices.md derive them.
"""


def generated() -> dict[Path, str]:
    return {TABLE_IDP: table_idp(), SCHEMES_IDP: schemes_idp(), REFERENCE: reference_md()}

