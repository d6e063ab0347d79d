"""Scenes: a TOML file that fully describes a run, validated before anything runs.

A scene has the two bodies (mesh, material, damage, boundary conditions by mesh label), the glue,
the time grid, solver options and outputs; `scenes/paper.toml` is the paper's. Validation is done
by the tables below (orchestrate/schema.py), which refuse unknown keys; every error names the key,
the value and what is allowed. Expressions (loads, prescribed displacements) go through
orchestrate.expr. The FreeFEM side receives a generated scene file holding only numbers formatted
here, labels, file paths checked here, and expression code written from parsed trees
(`to_freefem_scene`).
"""
from __future__ import annotations

import copy
import difflib
import math
import os
import re
import tomllib
import unicodedata
from pathlib import Path

from orchestrate import expr
from orchestrate.freefem import REPO, InputError
from orchestrate.geo import GeoError, read_sources
from orchestrate.gmsh_mesher import box_fault
from orchestrate.mesh import TIME_LIMIT, geo_constants
from orchestrate.parameters import (BODY_SUFFIXES, PARAMETERS, RULES, driver_values, field, rule_holds, rule_names,
                                    scene_key, unbounded_field)
from orchestrate.schema import (PATH_MAX, Boolean, Check, Choice, Custom, Integer, Invalid, Key, ListOf, MapOf, Number,
                                Optional, Table, TableOf, Tagged, Text, Then, TupleOf, ValidationError, after, problem,
                                shown)


class SceneError(InputError):
    """A scene that cannot run; the message lists every problem, one per line."""


def _expression(value):
    if not isinstance(value, str):
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise ValueError(f"an expression must be a string or a number, got {type(value).__name__}")
        try:
            finite = math.isfinite(value)
        except OverflowError:  # an integer beyond every double
            finite = False
        if not finite:
            raise ValueError(f"the number {shown(value)} is not a finite double")
        value = repr(value)
    value = value.strip()  # spaces around an expression change nothing: "-10*t " is "-10*t", one run
    try:
        expr.parse(value)
    except expr.ExpressionError as error:
        raise ValueError(str(error)) from None
    return value


EXPRESSION = Custom(_expression, "text")


def initial_value(name: str) -> Key:
    """A key for initial data given per position: a number in the table's range, or an
    expression of x, y (never t: it is the state at t = 0) whose values FreeFEM checks against the
    same range at every node before the first step. An expression that is a number is that number."""
    parameter = PARAMETERS[name]
    low, high = parameter.bounds["ge"], parameter.bounds["le"]

    def validate(value):
        if isinstance(value, str):
            try:
                tree = expr.parse(value, ("x", "y"))
            except expr.ExpressionError as error:
                raise ValueError(f"{error} (initial data are an expression of the position x, y)") from None
            if not isinstance(tree, expr.Number):
                return value.strip()  # as for loads (_expression): surrounding spaces make no other run
            value = tree.value
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise ValueError(f"give a number in {parameter.range} or an expression of x, y as a string")
        if not low <= value <= high:  # also refuses nan (and integers beyond every double)
            raise ValueError(f"{value} is outside {parameter.range}")
        return float(value)

    return Key(Custom(validate, "number or text"), parameter.value(), parameter.meaning, parameter.range)


MESHES = REPO / "meshes"
IDENTIFIER = r"^[A-Za-z_][A-Za-z_0-9]{0,63}$"
LABEL = PARAMETERS["contactLabel"].bounds  # the range of a boundary label (parameters.toml)


def _contact_labels(value):
    """mesh.contactLabel: one boundary label or a list of them (a contact boundary of several
    parts, which must form one curve: the driver checks that against the mesh), each once."""
    labels = value if isinstance(value, list) else [value]
    if not labels:
        raise ValueError("give a boundary label or a list of them, like 3 or [1, 5]")
    for label in labels:
        if not isinstance(label, int) or isinstance(label, bool) or not LABEL["ge"] <= label <= LABEL["le"]:
            raise ValueError(f"{shown(label)} is not a boundary label (allowed: integers in "
                             f"{PARAMETERS['contactLabel'].range}, one or a list)")
    if len(set(labels)) < len(labels):
        raise ValueError("a label is named twice")
    return labels


def geo_path(value: str, folder: Path) -> Path:
    """Where a scene's mesh.geo is: an absolute path as is; a relative one beside the scene file
    (`folder`), else, when no file is there, the repository's (meshes/...), so the project's scenes
    and copies of them keep their `meshes/` paths. Either way the file and its includes are read
    (orchestrate/geo.py); the path returned has its symbolic links resolved."""
    path = Path(value)
    if not path.is_absolute():
        beside, project = folder / path, REPO / path
        in_meshes = project.resolve().is_relative_to(MESHES.resolve())
        if not os.path.lexists(beside) and not (in_meshes and os.path.lexists(project)):
            raise GeoError(f"gmsh source {shown(value, limit=PATH_MAX)} not found beside the scene file "
                           f"({shown(str(beside), False, PATH_MAX)})"
                           + (f" nor in the repository ({project})" if in_meshes else ""))
        path = beside if os.path.lexists(beside) else project
    return read_sources(path)[0].path


def scene_folder(context: dict) -> Path:
    """The folder a scene's relative paths are taken from: its file's (the working folder for a
    scene given as data)."""
    return Path(context.get("folder") or Path.cwd())


def geo_file(value: str, context: dict) -> str:
    """Resolved once, when the scene is read: the scene as data (a sweep's worker, scene.toml
    in the run folder) names the same file wherever it is read."""
    return str(geo_path(value, scene_folder(context)))


def sizes_file(value: str, context: dict) -> str:
    """Resolved once, when the scene is read, like geo; read and checked when the mesh is made."""
    path = Path(value)
    if not path.is_absolute():
        path = scene_folder(context) / path
    if not path.is_file():
        raise ValueError(f"sizes: {shown(str(path), False, PATH_MAX)} is not a file")
    return str(path.resolve())


REAL = Number()  # a finite number, never a boolean or a text


class Mesh(Table):
    """A gmsh source with its size parameter n (elements per side) and other DefineConstant
    values, or a rectangle (meshes/rectangle.geo: labels 1 bottom, 2 right, 3 top, 4 left). A .geo
    file is gmsh code: gmsh reads it confined and bounded (orchestrate/mesh.py)."""
    geo = Key(Optional(Then(Text(), geo_file)), None,
              "a gmsh .geo file: absolute, or relative to the scene file's folder (where none is there, the "
              "repository's meshes/...), meshed in a sandbox (README.md, Your own files); or give rectangle")
    rectangle = Key(Optional(TupleOf(REAL, REAL, REAL, REAL)), None,
                    "[x0, x1, y0, y1]: meshes/rectangle.geo, labels 1 bottom, 2 right, 3 top, 4 left")
    n = Key(Integer(**PARAMETERS["n1"].bounds), description="the mesh size parameter of the .geo (elements per side or per unit "
                                                "length: its header says)")
    structured = Key(Optional(Boolean()), None, "a structured (transfinite) mesh, where the .geo offers one")
    refine = Key(Integer(ge=0, le=6), 0, "times every triangle is split in four (nested meshes)")
    sizes = Key(Optional(Then(Text(), sizes_file)), None,
                "a gmsh view of element sizes (View \"...\" {ST(...){...}; ...};) that sets the mesh's sizes, as "
                "`orchestrate adapt` writes it: absolute, or relative to the scene file's folder; the .geo's constant "
                "adapted (which it must define) is then 1: no Transfinite lines")
    parameters = Key(MapOf(IDENTIFIER, REAL), {},
                     "other DefineConstant values of the .geo, by name (e.g. { split = 1 })")
    contactLabel = Key(Custom(_contact_labels, "list of integer"), PARAMETERS["contactLabel"].value(),
                       PARAMETERS["contactLabel"].meaning, PARAMETERS["contactLabel"].range)
    timeLimit = Key(Number(gt=0, le=86400), TIME_LIMIT,
                    "the wall-clock and CPU time gmsh may take to mesh the body, after which it is stopped and the run "
                    "refused (the default: 2.5 times what the largest mesh a run fits in 23 GiB took, "
                    "orchestrate/mesh.py) [s]")

    @after
    def one_source(self):
        if (self.geo is None) == (self.rectangle is None):
            raise ValueError("give exactly one of geo (a .geo file) and rectangle ([x0, x1, y0, y1])")
        if self.rectangle is not None:
            x0, x1, y0, y1 = self.rectangle
            if not (x0 < x1 and y0 < y1):
                raise ValueError(f"rectangle {list(self.rectangle)} needs finite x0 < x1 and y0 < y1")
            fault = box_fault((x0, y0, x1, y1))  # the child that meshes any .geo refuses it too, naming no key
            if fault:
                raise ValueError(f"rectangle {list(self.rectangle)}: {fault}")

    @after
    def known_parameters(self):
        """parameters set the .geo's other DefineConstant values; n, structured and the rectangle
        have keys of their own (with their limits), and a name the .geo does not define would be
        ignored by gmsh without a word."""
        own = {"n", "structured"} | ({"x0", "x1", "y0", "y1"} if self.rectangle is not None else set())
        constants = geo_constants(self.source())
        if self.sizes is not None and "adapted" not in constants:
            raise ValueError(f"sizes: {self.source().name} has no constant adapted, by which a .geo that a size "
                             "field may grade leaves out its Transfinite lines (DefineConstant[ adapted = 0 ] and "
                             "If (!adapted) ... EndIf around them, as meshes/rectangle.geo)")
        if self.structured is not None and "structured" not in constants:
            raise ValueError(f"structured: {self.source().name} has no structured mesh to choose (it defines "
                             f"{', '.join(constants)})")
        for name in self.parameters:
            if name in own:
                raise ValueError(f"parameters.{name}: set it with its own key (mesh.{'rectangle' if name[0] in 'xy' else name})")
            if name not in constants:
                raise ValueError(f"parameters.{name}: not a constant of {self.source().name} (its constants: "
                                 f"{', '.join(constants)}; {', '.join(sorted(own & set(constants)))} have keys of their own)")

    def source(self) -> Path:
        return MESHES / "rectangle.geo" if self.rectangle is not None else Path(self.geo)

    def size_field(self) -> Path | None:
        return Path(self.sizes) if self.sizes is not None else None

    def numbers(self) -> dict[str, float]:
        """The gmsh -setnumber values for this mesh."""
        numbers: dict[str, float] = {"n": self.n}
        if self.rectangle is not None:
            numbers.update(zip(("x0", "x1", "y0", "y1"), self.rectangle))
        if self.structured is not None:
            numbers["structured"] = int(self.structured)
        if self.sizes is not None:
            numbers["adapted"] = 1
        numbers.update(self.parameters)
        return numbers


class Material(Table):
    """σ = Aε(u̇) + ζGε(u): (Aτ) = μ tr(τ) I + η τ; G from E, ν (plane stress or strain)."""
    E = field("E")
    nu = field("nu")
    planeStrain = field("planeStrain")
    mu = field("mu")
    eta = field("eta")
    kappa = field("kappa")


class BodyDamage(Table):
    """φ = λ_D (1 − ζ)/ζ − ½ λ_u R(ε·ε) + λ_w, and the initial damage ζ0."""
    lambdaD = field("lambdaD")
    lambdaU = field("lambdaU")
    lambdaW = field("lambdaW")
    zeta0 = initial_value("zeta0")


def label_key() -> Key:
    return Key(Integer(**LABEL), description="the boundary label it acts on")


def component_key(meaning: str) -> Key:
    return Key(Choice("x", "y"), description=meaning)


class Clamped(Table):
    type = Key(Choice("clamped"), description="u = 0 on the label")
    label = label_key()


class Roller(Table):
    type = Key(Choice("roller"), description="one component of u is 0 on the label, the other free")
    label = label_key()
    component = component_key("the component held")


class Displacement(Table):
    type = Key(Choice("displacement"), description="one component of u prescribed on the label")
    label = label_key()
    component = component_key("the component prescribed")
    value = Key(EXPRESSION, description="its value, an expression of x, y, t [m]")


class Traction(Table):
    type = Key(Choice("traction"), description="a traction on the label")
    label = label_key()
    fx = Key(EXPRESSION, "0", "its x component, an expression of x, y, t [N/m²]")
    fy = Key(EXPRESSION, "0", "its y component, an expression of x, y, t [N/m²]")


BOUNDARY_TYPES = {"clamped": Clamped, "roller": Roller, "displacement": Displacement, "traction": Traction}


class Body(Table):
    mesh = Key(TableOf(Mesh))
    material = Key(TableOf(Material), {})
    damage = Key(TableOf(BodyDamage), {})
    boundary = Key(ListOf(Tagged("type", BOUNDARY_TYPES), min_length=1),
                   description="the boundary conditions, a list of tables [[bodyN.boundary]] (types below)")
    volume_force = Key(TupleOf(EXPRESSION, EXPRESSION), ["0", "0"], "[fx, fy], expressions of x, y, t [N/m³]")

    @after
    def consistent_boundary(self):
        prescribed: dict[int, set[str]] = {}
        for condition in self.boundary:
            if isinstance(condition, Traction):
                continue
            components = {"x", "y"} if isinstance(condition, Clamped) else {condition.component}
            taken = prescribed.setdefault(condition.label, set())
            if taken & components:
                raise ValueError(f"label {condition.label}: component(s) {sorted(taken & components)} prescribed twice")
            taken |= components
        for condition in self.boundary:
            if isinstance(condition, Traction):
                if prescribed.get(condition.label) == {"x", "y"}:
                    raise ValueError(f"label {condition.label}: a traction on a boundary whose displacement is prescribed")
        if not prescribed:
            raise ValueError("no clamped, roller or displacement condition: nothing would hold the body's sliding along "
                             "Γ_C (the contact is frictionless; docs/model-choices.md, Floating bodies)")


def _steps(value):
    """time.N: an integer in the table's range, or "auto"."""
    if value == "auto":
        return value
    bounds = PARAMETERS["N"].bounds
    if not isinstance(value, int) or isinstance(value, bool) or not bounds["ge"] <= value <= bounds["le"]:
        raise ValueError(f'Input should be an integer in {PARAMETERS["N"].range} or "auto"')
    return value


class Time(Table):
    """N = "auto" chooses the steps for targetError (orchestrate/steps.py, docs/model-choices.md)."""
    T = field("T")
    N = Key(Custom(_steps, 'integer or one of "auto"'), PARAMETERS["N"].value(),
            PARAMETERS["N"].meaning + ', or "auto" (with targetError)', PARAMETERS["N"].range)
    scheme = field("scheme")
    startSteps = field("startSteps")
    startSubsteps = field("startSubsteps")
    targetError = Key(Optional(Number(gt=0, le=0.5)), None,
                      'with N = "auto": the relative time error of u(T) in the V norm to reach')

    @after
    def target_with_auto(self):
        if self.N == "auto" and self.targetError is None:
            raise ValueError('N = "auto" needs targetError, the relative time error to reach (e.g. 1e-3)')
        if self.N != "auto" and self.targetError is not None:
            raise ValueError(f'targetError applies to N = "auto" only (N = {self.N} here)')


class Glue(Table):
    gammaNu = field("gammaNu")
    gammaR = field("gammaR")
    pTau = field("pTau")
    debondMobility = unbounded_field("debondMobility")
    adhesionEnergy = field("adhesionEnergy")
    shearDebonding = field("shearDebonding")
    bondingCoupled = field("bondingCoupled")
    L = field("L")
    beta0 = initial_value("beta0")


class DamageNumerics(Table):
    zetaMin = field("zetaMin")


class Space(Table):
    order = field("order")


class Solver(Table):
    contactSolver = field("contactSolver")
    contactTol = field("contactTol")
    contactMaxIt = field("contactMaxIt")
    bmOmega = field("bmOmega")
    condensation = field("condensation")
    contactColumnsMB = field("contactColumnsMB")
    columnBlock = field("columnBlock")
    damageTol = field("damageTol")
    damageMaxIt = field("damageMaxIt")
    boundTol = field("boundTol")
    linearSolver = field("linearSolver")
    allowUnstable = field("allowUnstable")
    divergenceFactor = field("divergenceFactor")


UNIT_NAME = re.compile(r"[A-Za-zµ]{1,8}")  # a unit's name as the images print it: letters only (no TeX)


def unit_name(value: str, context: dict) -> str:
    if not UNIT_NAME.fullmatch(value):
        raise ValueError("a unit's name is 1 to 8 letters (m, mm, kN, ms, ...), as the images print it")
    return value


class Units(Table):
    """A consistent set of units, by their names (the images label numbers with them)."""
    length = Key(Then(Text(), unit_name), "m", "the unit of length, e.g. m, mm, um")
    force = Key(Then(Text(), unit_name), "N", "the unit of force, e.g. N, kN, mN")
    time = Key(Then(Text(), unit_name), "s", "the unit of time, e.g. s, ms, h")


class UnitsCheck(Check):
    """output.units: a preset's name, or a table of the scene's own units."""
    kind = 'one of "SI", "mm-N-s" or Units'

    def __call__(self, value, context):
        if isinstance(value, (dict, Units)):
            return Units.checked(value, context)
        if value not in ("SI", "mm-N-s"):
            raise problem("value_error", 'give "SI", "mm-N-s", or a table of the scene\'s own units, '
                                         '{ length = "mm", force = "N", time = "s" }', value)
        return value


def _output_times(value):
    """output.times: a word, or a list of times (their range is the scene's: Scene's check)."""
    if value in ("final", "all", "none"):
        return value
    if not isinstance(value, list) or not value:
        raise ValueError('give "final", "all", "none" or a list of times in (0, T]')
    for time in value:
        if isinstance(time, bool) or not isinstance(time, (int, float)) or not -1e308 < time < 1e308:
            raise ValueError(f"{shown(time)} is not a time: give numbers in (0, T]")
    return [float(time) for time in value]


# Keys of output that change no result: when a run checkpoints, whether it makes images and their units.
RESULT_FREE = ("checkpointEvery", "checkpointSeconds", "images", "units")


class Output(Table):
    """Files at `times` ("final", "all", "none" or a list of times in (0, T]) holding the
    `fields`: "bodies" (u, zeta, vonMises), "stress" (sigma11/22/12 too), "contact" (the line),
    "state" (the unknowns, for error norms between runs)."""
    times = Key(Custom(_output_times, 'one of "final", "all", "none" or list of number'),
                PARAMETERS["outTimes"].default, PARAMETERS["outTimes"].meaning + " [s]")
    fields = Key(ListOf(Choice(*PARAMETERS["outFields"].choices)), PARAMETERS["outFields"].value(),
                 PARAMETERS["outFields"].meaning)
    images = Key(Boolean(), True, "render fields.png, contact_line.png, history.png (and beta_xt.png) after the run")
    units = Key(UnitsCheck(), "SI",
                "what the images label the numbers with: SI (m, N, N/m², s), mm-N-s (mm, N, N/mm² = MPa, s), or a "
                "table of the scene's own { length = ..., force = ..., time = ... } (a stress is then labelled "
                "force/length², a force per unit thickness force/length); the solver needs none")
    checkpointEvery = field("checkpointEvery")
    checkpointSeconds = field("checkpointSeconds")


def _title(value: str, context: dict) -> str:
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise ValueError("the title is not valid Unicode text (a lone surrogate)") from None
    return value


class Scene(Table):
    title = Key(Then(Text(max_length=500), _title), "", "what the scene is, for its files and images")
    time = Key(TableOf(Time), {})
    space = Key(TableOf(Space), {})
    body1 = Key(TableOf(Body))
    body2 = Key(TableOf(Body))
    glue = Key(TableOf(Glue), {})
    damage = Key(TableOf(DamageNumerics), {})
    solver = Key(TableOf(Solver), {})
    output = Key(TableOf(Output), {})

    @after
    def rules_hold(self):
        """The rules between parameters (parameters.toml), as the driver checks them: the first that
        fails is the problem of the scene key it names."""
        values = driver_values(self.model_dump(mode="json"))
        for rule, suffix in ((rule, suffix) for rule in RULES
                             for suffix in (BODY_SUFFIXES if rule["scope"] == "body" else ("",))):
            names = {name: values.get(name + suffix) for name in rule_names(rule["holds"])}
            if None not in names.values() and not rule_holds(rule["holds"], names):
                key = scene_key(rule["names"], suffix)
                raise Invalid([{"loc": tuple(key.split(".")), "type": "value_error", "input": values[rule["names"] + suffix],
                                "msg": f"{shown(values[rule['names'] + suffix])} is not allowed: {rule['says']}"}])

    @classmethod
    def load(cls, path: str | Path, overrides: dict | None = None, grid: tuple = ()) -> "Scene":
        path = Path(path)
        return cls.from_dict(read_toml(path, "scene"), overrides, source=str(path), folder=path.absolute().parent,
                             grid=grid)

    @classmethod
    def from_dict(cls, data: dict, overrides: dict | None = None, source: str = "scene",
                  folder: Path | None = None, grid: tuple = ()) -> "Scene":
        """A scene from its data; relative file paths in it (mesh.geo) are taken from `folder`, the
        scene file's (by default the working folder). A refused override is named as given: by
        --grid for the keys of `grid`, by --set for the others."""
        overrides = overrides or {}
        try:
            return cls.model_validate(apply_overrides(data, overrides), context={"folder": folder})
        except ValidationError as error:
            given = {field: (key, "--grid" if key in grid else "--set")
                     for key, field in resolve_keys(data, overrides).items()}
            raise SceneError(f"{source}:\n" + "\n".join(as_given(describe(e), given) for e in error.errors())) from None

    def with_overrides(self, overrides: dict) -> "Scene":
        return Scene.from_dict(self.model_dump(mode="json"), overrides)

    def to_toml(self) -> str:
        return to_toml(self.model_dump(mode="json", exclude_none=True))


# --- overrides -------------------------------------------------------------------------------

def parse_value(text: str):
    """A --set value as TOML would read it (numbers, booleans, arrays, strings), else a string."""
    try:
        return tomllib.loads(f"value = {text}")["value"]
    except tomllib.TOMLDecodeError:
        return text


def read_toml(path: Path, kind: str) -> dict:
    """A TOML file (a scene, a sweep's grid) as data; any reason it cannot be read is a SceneError. A
    byte-order mark before the first line (editors on Windows write one into UTF-8 files) is
    skipped: TOML allows it (a valid UTF-8 document, toml-lang/toml#437), Python's reader does not."""
    try:
        return tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except FileNotFoundError:
        raise SceneError(f"{kind} file {path} not found") from None
    except IsADirectoryError:
        raise SceneError(f"{kind} {path} is a folder: give a {kind} file (TOML)") from None
    except UnicodeDecodeError as error:
        raise SceneError(f"{path}: not UTF-8 text (byte {error.start}): a {kind} is a TOML file") from None
    except OSError as error:
        raise SceneError(f"{kind} file {path} cannot be read: {error.strerror}") from None
    except tomllib.TOMLDecodeError as error:
        raise SceneError(f"{path}: not valid TOML: {error}") from None
    except RecursionError:
        raise SceneError(f"{path}: lists or tables nested deeper than the TOML reader can follow: a {kind} file "
                         "holds keys and values a few levels deep") from None


# An element of a list of tables by its boundary label: body1.boundary[label=4] is the one
# condition of body1 on label 4, wherever it stands in the list (the index form, body1.boundary.1,
# changes meaning when the scene's conditions are reordered).
LABELLED = re.compile(r"([A-Za-z_][A-Za-z_0-9]*)\[label=([0-9]+)\]")
KEY_FORMS = "NAME[label=N] (the condition on boundary label N, e.g. body1.boundary[label=4].fy) or NAME.I " \
            "(its 0-based index, e.g. body1.boundary.1.fy)"


def resolve_keys(data: dict, keys, option: str = "--set") -> dict[str, str]:
    """Each override key → the same key with every element named by its label written as its index
    in `data` (body1.boundary[label=4].fy → body1.boundary.1.fy). An unknown label, a label of
    several conditions, or two keys naming one value are refused, naming the key."""
    fields: dict[str, str] = {}
    for key in keys:
        field = _by_index(data, key, option)
        other = next((given for given, known in fields.items() if known == field), None)
        if other is not None:
            raise SceneError(f"{option} {other} and {key} name the same value ({field}): give it once")
        fields[key] = field
    return fields


# The longest key a scene has (body1.mesh.parameters. and a 64-character name) with room to spare:
# a longer one is a slip (a value pasted as a key), refused before any message repeats it.
LONGEST_KEY = 200


def _by_index(data: dict, key: str, option: str) -> str:
    if len(key) > LONGEST_KEY:
        raise SceneError(f"{option} {shown(key, False)}: no scene key is that long ({len(key)} characters; keys "
                         "such as time.N, body1.boundary[label=4].fy: docs/scene-format.md lists them)")
    node, parts = data, []
    for part in key.split("."):
        if "[" not in part and "]" not in part:
            parts.append(part)
            if isinstance(node, list):
                node = node[int(part)] if part.isdigit() and int(part) < len(node) else None
            else:
                node = node.get(part) if isinstance(node, dict) else None
            continue
        match = LABELLED.fullmatch(part)
        if not match:
            raise SceneError(f"{option} {key}: '{part}' is no key: an element of a list is {KEY_FORMS}")
        name, label, where = match[1], int(match[2]), ".".join([*parts, match[1]])
        items = node.get(name) if isinstance(node, dict) else None
        if not isinstance(items, list):
            raise SceneError(f"{option} {key}: {_no_list(node, name, where)}")
        index = _labelled(items, label, f"{option} {key}: ", where)
        parts += [name, str(index)]
        node = items[index]
        if key.endswith(f"{part}.label"):
            raise SceneError(f"{option} {key}: [label={label}] picks the condition by its label, which cannot be "
                             f"reassigned through it: name the condition by its index, {option} "
                             f"{'.'.join(parts)}.label=...")
    return ".".join(parts)


def _no_list(node, name: str, where: str) -> str:
    if isinstance(node, dict) and name in node:
        return f"{where} is not a list: [label=N] picks one of a list of boundary conditions (bodyN.boundary)"
    close = difflib.get_close_matches(name, list(node), n=1, cutoff=0.5) if isinstance(node, dict) else []
    return f"the scene has no {where}" + (f" (did you mean '{close[0]}'?)" if close else "")


def _labelled(items: list, label: int, context: str, where: str) -> int:
    """The index of the one element of `items` on `label`; an error naming each element otherwise."""
    found = [i for i, item in enumerate(items) if isinstance(item, dict) and type(item.get("label")) is int
             and item["label"] == label]
    if len(found) == 1:
        return found[0]
    held = ", ".join(f"{i} {shown(item.get('type', '?'), False)} on label {shown(item.get('label', '?'), False)}"
                     if isinstance(item, dict) else f"{i} {shown(item)}" for i, item in enumerate(items))
    if not found:
        raise SceneError(f"{context}no condition of {where} is on label {label} (its conditions: {held})")
    raise SceneError(f"{context}label {label} carries {len(found)} conditions of {where} ({held}): address "
                     f"one by its 0-based index, e.g. {where}.{found[0]}")


def apply_overrides(data: dict, overrides: dict, option: str = "--set") -> dict:
    """Set dotted keys (`time.N`, `body1.material.E`, `body1.boundary[label=4].fy`,
    `body1.boundary.2.fy`) in a copy of data."""
    fields = resolve_keys(data, overrides, option)
    data = copy.deepcopy(data)
    for key, value in overrides.items():
        parts = fields[key].split(".")
        node = data
        for depth, part in enumerate(parts):
            last = depth == len(parts) - 1
            if isinstance(node, list):
                if not part.isdigit() or int(part) >= len(node):
                    raise SceneError(f"{option} {key}: '{part}' is not an index of a list of {len(node)}")
                part = int(part)
            elif not isinstance(node, dict):
                raise SceneError(f"{option} {key}: '{'.'.join(parts[:depth])}' holds a value, not a table")
            if last:
                node[part] = value
                if key == "time.N" and value != "auto" and "time.targetError" not in overrides:
                    node.pop("targetError", None)  # a given N replaces "auto" and its target
            else:
                if isinstance(node, dict) and part not in node:
                    node[part] = {}
                node = node[part]
    return data


def as_given(line: str, given: dict[str, tuple[str, str]]) -> str:
    """A message line about an overridden value (`given`: its key by index → the key as written
    and its option), named as the override it came from, not as a line of the scene file."""
    for name, (key, option) in given.items():
        if line.startswith(tuple(f"{name}{end}" for end in ": .")):  # the key, its value, below it
            return f"{option} {key}{line[len(name):]}"
    return line


# --- messages --------------------------------------------------------------------------------

def _table_at(path: tuple) -> type[Table] | None:
    """The table class found at a location of a scene (boundary tags included), for suggestions."""
    table: type[Table] | None = Scene
    for part in path:
        if isinstance(part, int):
            continue
        if table is None:  # below a list of boundary conditions, the tag names the table
            table = BOUNDARY_TYPES.get(part)
            continue
        key = table.keys.get(part)
        if key is None:
            return None
        table = _table_of(key.check)
    return table


def _table_of(check: Check) -> type[Table] | None:
    if isinstance(check, TableOf):
        return check.table
    return Units if isinstance(check, UnitsCheck) else None


def is_table(value) -> bool:
    """A table or a list of tables: the input of a check of a whole body or list of conditions,
    whose contents in the message would bury it (the message names what is wrong)."""
    return isinstance(value, dict) or (isinstance(value, list) and any(isinstance(item, dict) for item in value))


def describe(error: dict) -> str:
    """One line naming the key, the value and what is allowed."""
    raw = tuple(error["loc"])
    location = tuple(part for part in raw if part not in BOUNDARY_TYPES)
    key = shown(".".join(str(part) for part in location), False) or "scene"
    if error["type"] == "extra_forbidden":
        parent = _table_at(raw[:-1])
        names = list(parent.keys) if parent else []
        close = difflib.get_close_matches(str(raw[-1])[:100], names, n=1, cutoff=0.5)
        hint = f"did you mean '{close[0]}'?" if close else f"valid keys: {', '.join(names)}"
        return f"{key}: unknown key ({hint})"
    if error["type"] == "missing":
        return f"{key}: missing (required)"
    message = error["msg"]
    if error["type"] in ("model_type", "dict_type") or "input" not in error or is_table(error["input"]):
        return f"{key}: {message}"
    return f"{key} = {shown(error['input'])}: {message}"


# --- TOML writing (the scene as run) ---------------------------------------------------------

def toml_string(value: str) -> str:
    """A TOML basic string: quotes and backslashes escaped, every control character (TOML allows
    none raw, DEL included) as a \\uXXXX escape."""
    return '"' + "".join("\\" + c if c in '"\\' else f"\\u{ord(c):04X}" if unicodedata.category(c) == "Cc" else c
                         for c in value) + '"'


def toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(type(value))


def to_toml(data: dict, prefix: str = "") -> str:
    scalars = {k: v for k, v in data.items() if not isinstance(v, dict)}
    tables = {k: v for k, v in data.items() if isinstance(v, dict)}
    lines = [f"{k} = {toml_value(v)}" for k, v in scalars.items()]
    text = ("\n".join(lines) + "\n") if lines else ""
    for name, table in tables.items():
        text += f"\n[{prefix}{name}]\n" + to_toml(table, f"{prefix}{name}.")
    return text


# --- the FreeFEM scene -----------------------------------------------------------------------

def _dirichlet(body: Body) -> str:
    terms = []
    for condition in body.boundary:
        if isinstance(condition, Clamped):
            terms.append(f"on({condition.label}, ux = 0., uy = 0.)")
        elif isinstance(condition, Roller):
            terms.append(f"on({condition.label}, u{condition.component} = 0.)")
        elif isinstance(condition, Displacement):
            terms.append(f"on({condition.label}, u{condition.component} = {expr.freefem(condition.value)})")
    return " + ".join(terms)


def _loads(body: Body, i: int) -> str | None:
    terms = []
    fx, fy = body.volume_force
    if not (expr.is_zero(fx) and expr.is_zero(fy)):
        terms.append(f"int2d(Th{i})({expr.freefem(fx)}*vx + {expr.freefem(fy)}*vy)")
    for condition in body.boundary:
        if isinstance(condition, Traction):
            parts = [f"{expr.freefem(value)}*v{c}" for c, value in (("x", condition.fx), ("y", condition.fy))
                     if not expr.is_zero(value)]
            if parts:
                terms.append(f"int1d(Th{i}, {condition.label})({' + '.join(parts)})")
    return " + ".join(terms) or None


def _number(value) -> str:
    return str(value) if isinstance(value, int) and not isinstance(value, bool) else expr.number_code(value)


def _labels(body: Body) -> str:
    """Every boundary label the body's conditions name, for the driver to check against the mesh."""
    return ", ".join(str(label) for label in dict.fromkeys(condition.label for condition in body.boundary))


def _label_keys(body: Body, i: int) -> str:
    """The driver's check that each label the scene names is in the body's mesh, naming it by its
    scene key (edp/lib/meshes.idp, sceneLabels): the rule is the driver's, the keys the scene's."""
    contact = body.mesh.contactLabel
    named = [(f"body{i}.mesh.contactLabel = {contact[0] if len(contact) == 1 else contact}", label) for label in contact]
    named += [(f"body{i}.boundary.{j}.label = {condition.label}", condition.label) for j, condition in enumerate(body.boundary)]
    return " ".join(f'requireLabel(Th{i}, {label}, {i}, "{key}", meshFile{i});' for key, label in named)


def to_freefem_scene(scene: Scene) -> str:
    """The generated FreeFEM scene file (data only) for edp/main.edp -DSCENE=scene.idp, run in the
    run folder: the meshes are that folder's body1.msh and body2.msh, so no path is written."""
    lines = ["// Generated by orchestrate from a scene file: numbers formatted by Python, expressions",
             "// written from their parsed form (orchestrate/expr.py). Edit the scene, not this file."]
    if scene.space.order != 1:  # the degree the driver is compiled for (edp/lib/parameters.idp), unless given by -DORDER
        lines += ["IFMACRO(!ORDER)", f"macro ORDER {scene.space.order} //", "ENDIFMACRO"]
    parameters = {**driver_values(scene.model_dump(mode="json")), "mesh1": "body1.msh", "mesh2": "body2.msh"}
    for name, value in parameters.items():
        code = f'"{value}"' if isinstance(value, str) else _number(value)
        lines.append(f'setParam("{name}", {code});')
    # Initial data by position (docs/model-choices.md, "Initial data"): a macro of x, y that the
    # driver evaluates at the nodes of ζ and averages on the segments of β.
    initial = [(f"initialDamage{i}", body.damage.zeta0) for i, body in ((1, scene.body1), (2, scene.body2))]
    for name, value in initial + [("initialBonding", scene.glue.beta0)]:
        if isinstance(value, str):
            lines.append(f"macro {name}(x, y) {expr.to_freefem(expr.parse(value, ('x', 'y')))} //")
    for i, body in ((1, scene.body1), (2, scene.body2)):
        lines.append(f"macro dirichlet{i}(ux, uy) {_dirichlet(body)} //")
        loads = _loads(body, i)
        if loads:
            lines.append(f"macro loads{i}(vx, vy) {loads} //")
        lines.append(f"macro boundaryLabels{i} {_labels(body)} //")
        lines.append(f"macro sceneLabels{i} {_label_keys(body, i)} //")
    return "\n".join(lines) + "\n"
