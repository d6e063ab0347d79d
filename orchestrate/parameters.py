"""The driver's parameters and time schemes, edp/lib/parameters.toml, as Python data: the one source
of every parameter's name, type, default, range, unit and meaning, and of each scheme's
coefficients. The scene schema (scene.py) takes its defaults and limits from here and a scene's
values reach the driver under the table's names (`driver_values`), mapped by the table's scene
keys. FreeFEM never reads the TOML: `python -m orchestrate reference` writes its rows and schemes
as the includes edp/lib/parameterTable.idp and edp/lib/schemes.idp, and docs/parameters.md for
people (`generated` gives the three texts; tests/test_parameters.py keeps the files in step).
"""
from __future__ import annotations

import math
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
# Each scheme's entries as FreeFEM variables (schemes.idp) and their type there.
SCHEME_KEYS = {"order": "int", "viscousWeight": "real", "elasticImplicit": "bool", "levels": "int",
               "rateWeights": "real[int]", "extrapolation": "real[int]", "elasticBound": "real",
               "sourceLimit": "real", "adhesionImplicit": "bool", "glueLimit": "real"}


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
        """The limits (gt, ge, lt, le) of an interval range; none for an infinite bound."""
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


def load(path: Path = SOURCE) -> tuple[dict[str, Parameter], dict[str, dict]]:
    """The parameters by name and the schemes by name; the scheme parameter's choices are the
    schemes, and each scheme has every coefficient."""
    data = tomllib.loads(path.read_text())
    rows = {row["name"]: Parameter(**row) for row in data["parameter"]}
    schemes = data["scheme"]
    if rows["scheme"].choices != tuple(schemes):
        raise ValueError(f"{path}: the scheme parameter's range {rows['scheme'].range!r} is not the schemes {list(schemes)}")
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
    return rows, schemes


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


PARAMETERS, SCHEMES = load()
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


def table_idp() -> str:
    rows = "\n".join("addTableRow(" + ", ".join(freefem_text(getattr(p, key)) for key in
                                                ("scope", "name", "type", "default", "range", "unit")) + ");"
                     for p in PARAMETERS.values())
    return f"""// {GENERATED}
// Every parameter's row (scope, name, type, default, range, unit) for params.idp; what each means is
// in docs/parameters.md, never here, so rewording it changes no solver digest.
IFMACRO(!parameterTableIdp)
macro parameterTableIdp 1 //
macro parameterRows
{rows}
//
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
    return f"""# Parameters of the driver

<!-- {GENERATED} -->

Every parameter of `edp/main.edp`: the flag `-name value` of a run by hand (`FreeFem++ edp/main.edp
-help` lists them with their defaults and ranges), and the scene key of a scene (docs/scene-format.md).
A *body* parameter exists once per body: `E` is the flags `-E1` and `-E2` and the scene keys
`body1.material.E` and `body2.material.E`. Names follow the paper's symbols: `zeta` ζ, `beta` β,
`gammaNu` γ_ν, `gammaR` γ_r, `pTau` p_τ, `lambdaD`/`lambdaU`/`lambdaW` λ_D/λ_u/λ_w, `kappa` κ,
`eta` η, `mu` μ, `nu` ν. The defaults are the paper's scene.

Types: *real*, *int*, *flag* (0 or 1; a boolean in scenes), *choice* (one of the words in the range
column), *text*, *labels* (boundary labels, comma-separated on the command line like `1,5`, a number
or a list in scenes; each in the range, each once). Ranges are intervals, `(` and `)` open, `[` and
`]` closed; `inf` means no bound. Units are SI (lengths in m, times in s, forces per unit thickness
in N/m); any consistent set works. A scene key `-` means the parameter is the driver's only.
Constraints between parameters are checked in `edp/lib/parameters.idp`: 2μ + η > 0 per body;
`outTimes` and `outFields` have their own syntax.

{table}

## Time schemes

{schemes}

Each scheme's coefficients (the weight of A/k, whether G is implicit, the rate and extrapolation
weights, the bounds of its explicit terms) are in `edp/lib/parameters.toml`; docs/model.md §9 and
docs/model-choices.md derive them.
"""


def generated() -> dict[Path, str]:
    return {TABLE_IDP: table_idp(), SCHEMES_IDP: schemes_idp(), REFERENCE: reference_md()}

