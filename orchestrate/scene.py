"""Scenes: a TOML file that fully describes a run, validated before anything runs.

A scene has the two bodies (mesh, material, damage, boundary conditions by mesh label), the glue,
the time grid, solver options and outputs; `scenes/paper.toml` is the paper's. Validation is done
by pydantic models that forbid unknown keys; every error names the key, the value and what is
allowed. Expressions (loads, prescribed displacements) go through orchestrate.expr. The FreeFEM
side receives a generated scene file holding only numbers formatted here, labels, file paths
checked here, and expression code written from parsed trees (`to_freefem_scene`).
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
from typing import Annotated, Literal, Union

from pydantic import (BaseModel, BeforeValidator, ConfigDict, Discriminator, Field, Tag, ValidationError, ValidationInfo,
                      field_validator, model_validator)

from orchestrate import expr
from orchestrate.freefem import REPO, InputError
from orchestrate.geo import GeoError, read_sources
from orchestrate.mesh import TIME_LIMIT, geo_constants
from orchestrate.parameters import PARAMETERS, driver_values, field, unbounded_field


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
            raise ValueError(f"the number {str(value)[:40]} is not a finite double")
        value = repr(value)
    value = value.strip()  # spaces around an expression change nothing: "-10*t " is "-10*t", one run
    try:
        expr.parse(value)
    except expr.ExpressionError as error:
        raise ValueError(str(error)) from None
    return value


Expression = Annotated[str, BeforeValidator(_expression)]


def initial_value(name: str):
    """A field for initial data given per position: a number in the table's range, or an
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

    return Annotated[Union[float, str], BeforeValidator(validate), Field(parameter.value(), description=parameter.meaning)]
Real = Annotated[float, Field(strict=True, allow_inf_nan=False)]  # a number, never a boolean or a text
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
            raise ValueError(f"{label!r} is not a boundary label (allowed: integers in "
                             f"{PARAMETERS['contactLabel'].range}, one or a list)")
    if len(set(labels)) < len(labels):
        raise ValueError("a label is named twice")
    return labels


ContactLabels = Annotated[list[int], BeforeValidator(_contact_labels)]


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


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
            raise GeoError(f"gmsh source '{value}' not found beside the scene file ({beside})"
                           + (f" nor in the repository ({project})" if in_meshes else ""))
        path = beside if os.path.lexists(beside) else project
    return read_sources(path)[0].path


class Mesh(Strict):
    """A gmsh source with its size parameter n (elements per side) and other DefineConstant
    values, or a rectangle (meshes/rectangle.geo: labels 1 bottom, 2 right, 3 top, 4 left). A .geo
    file is gmsh code: gmsh reads it confined and bounded (orchestrate/mesh.py)."""
    geo: str | None = Field(None, description="a gmsh .geo file: absolute, or relative to the scene file's folder "
                                              "(where none is there, the repository's meshes/...), meshed in a "
                                              "sandbox (README.md, Your own files); or give rectangle")
    rectangle: tuple[Real, Real, Real, Real] | None = Field(
        default=None, description="[x0, x1, y0, y1]: meshes/rectangle.geo, labels 1 bottom, 2 right, 3 top, 4 left")
    n: int = Field(strict=True, ge=1, le=4096, description="the mesh size parameter of the .geo (elements per side "
                                                           "or per unit length: its header says)")
    structured: bool | None = Field(None, strict=True, description="a structured (transfinite) mesh, where the .geo "
                                                                    "offers one")
    refine: int = Field(0, strict=True, ge=0, le=6, description="times every triangle is split in four (nested meshes)")
    sizes: str | None = Field(None, description="a gmsh view of element sizes (View \"...\" {ST(...){...}; ...};) that "
                                                "sets the mesh's sizes, as `orchestrate adapt` writes it: absolute, or "
                                                "relative to the scene file's folder; the .geo's constant adapted "
                                                "(which it must define) is then 1: no Transfinite lines")
    parameters: dict[Annotated[str, Field(pattern=IDENTIFIER)], Real] = Field(
        {}, description="other DefineConstant values of the .geo, by name (e.g. { split = 1 })")
    contactLabel: ContactLabels = Field(PARAMETERS["contactLabel"].value(), description=PARAMETERS["contactLabel"].meaning)
    timeLimit: float = Field(TIME_LIMIT, strict=True, gt=0, le=86400, allow_inf_nan=False,
                             description="the wall-clock and CPU time gmsh may take to mesh the body, after which "
                                         "it is stopped and the run refused (the default: 2.5 times what the "
                                         "largest mesh a run fits in 23 GiB took, orchestrate/mesh.py) [s]")

    @model_validator(mode="after")
    def one_source(self):
        if (self.geo is None) == (self.rectangle is None):
            raise ValueError("give exactly one of geo (a .geo file) and rectangle ([x0, x1, y0, y1])")
        if self.rectangle is not None:
            x0, x1, y0, y1 = self.rectangle
            if not all(math.isfinite(v) for v in self.rectangle) or not (x0 < x1 and y0 < y1):
                raise ValueError(f"rectangle {list(self.rectangle)} needs finite x0 < x1 and y0 < y1")
        return self

    @model_validator(mode="after")
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
        return self

    @field_validator("geo")
    @classmethod
    def geo_file(cls, value, info: ValidationInfo):
        """Resolved once, when the scene is read: the scene as data (a sweep's worker, scene.toml
        in the run folder) names the same file wherever it is read."""
        if value is None:
            return value
        folder = (info.context or {}).get("folder") or Path.cwd()
        return str(geo_path(value, Path(folder)))

    @field_validator("sizes")
    @classmethod
    def sizes_file(cls, value, info: ValidationInfo):
        """Resolved once, when the scene is read, like geo; read and checked when the mesh is made."""
        if value is None:
            return value
        path = Path(value)
        if not path.is_absolute():
            path = Path((info.context or {}).get("folder") or Path.cwd()) / path
        if not path.is_file():
            raise ValueError(f"sizes: {path} is not a file")
        return str(path.resolve())

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


class Material(Strict):
    """σ = Aε(u̇) + ζGε(u): (Aτ) = μ tr(τ) I + η τ; G from E, ν (plane stress or strain)."""
    E: float = field("E")
    nu: float = field("nu")
    planeStrain: bool = field("planeStrain")
    mu: float = field("mu")
    eta: float = field("eta")
    kappa: float = field("kappa")

    @model_validator(mode="after")
    def viscosity_definite(self):
        if 2 * self.mu + self.eta <= 0:
            raise ValueError(f"mu = {self.mu} with eta = {self.eta}: A needs 2 mu + eta > 0")
        return self


class BodyDamage(Strict):
    """φ = λ_D (1 − ζ)/ζ − ½ λ_u R(ε·ε) + λ_w, and the initial damage ζ0."""
    lambdaD: float = field("lambdaD")
    lambdaU: float = field("lambdaU")
    lambdaW: float = field("lambdaW")
    zeta0: initial_value("zeta0")


LABEL_FIELD = {"strict": True, **LABEL, "description": "the boundary label it acts on"}


class Clamped(Strict):
    type: Literal["clamped"] = Field(description="u = 0 on the label")
    label: int = Field(**LABEL_FIELD)


class Roller(Strict):
    type: Literal["roller"] = Field(description="one component of u is 0 on the label, the other free")
    label: int = Field(**LABEL_FIELD)
    component: Literal["x", "y"] = Field(description="the component held")


class Displacement(Strict):
    type: Literal["displacement"] = Field(description="one component of u prescribed on the label")
    label: int = Field(**LABEL_FIELD)
    component: Literal["x", "y"] = Field(description="the component prescribed")
    value: Expression = Field(description="its value, an expression of x, y, t [m]")


class Traction(Strict):
    type: Literal["traction"] = Field(description="a traction on the label")
    label: int = Field(**LABEL_FIELD)
    fx: Expression = Field("0", description="its x component, an expression of x, y, t [N/m²]")
    fy: Expression = Field("0", description="its y component, an expression of x, y, t [N/m²]")


Boundary = Annotated[Union[Clamped, Roller, Displacement, Traction], Field(discriminator="type")]


class Body(Strict):
    mesh: Mesh
    material: Material = Material()
    damage: BodyDamage = BodyDamage()
    boundary: list[Boundary] = Field(min_length=1, description="the boundary conditions, a list of tables "
                                                              "[[bodyN.boundary]] (types below)")
    volume_force: tuple[Expression, Expression] = Field(("0", "0"), description="[fx, fy], expressions of x, y, t [N/m³]")

    @model_validator(mode="after")
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
        return self


def _steps(value):
    """time.N: an integer in the table's range, or "auto"."""
    if value == "auto":
        return value
    bounds = PARAMETERS["N"].bounds
    if not isinstance(value, int) or isinstance(value, bool) or not bounds["ge"] <= value <= bounds["le"]:
        raise ValueError(f'Input should be an integer in {PARAMETERS["N"].range} or "auto"')
    return value


class Time(Strict):
    """N = "auto" chooses the steps for targetError (orchestrate/steps.py, docs/model-choices.md)."""
    T: float = field("T")
    N: Annotated[Union[int, Literal["auto"]], BeforeValidator(_steps)] = Field(
        PARAMETERS["N"].value(), description=PARAMETERS["N"].meaning + ', or "auto" (with targetError)')
    scheme: Literal[PARAMETERS["scheme"].choices] = field("scheme")
    startSteps: int = field("startSteps")
    startSubsteps: int = field("startSubsteps")
    targetError: float | None = Field(None, strict=True, gt=0, le=0.5, allow_inf_nan=False,
                                      description='with N = "auto": the relative time error of u(T) in the V norm '
                                                  'to reach')

    @model_validator(mode="after")
    def target_with_auto(self):
        if self.N == "auto" and self.targetError is None:
            raise ValueError('N = "auto" needs targetError, the relative time error to reach (e.g. 1e-3)')
        if self.N != "auto" and self.targetError is not None:
            raise ValueError(f'targetError applies to N = "auto" only (N = {self.N} here)')
        return self


class Glue(Strict):
    gammaNu: float = field("gammaNu")
    gammaR: float = field("gammaR")
    pTau: float = field("pTau")
    debondMobility: unbounded_field("debondMobility")
    adhesionEnergy: float = field("adhesionEnergy")
    shearDebonding: bool = field("shearDebonding")
    bondingCoupled: bool = field("bondingCoupled")
    L: float = field("L")
    beta0: initial_value("beta0")


class DamageNumerics(Strict):
    zetaMin: float = field("zetaMin")


class Space(Strict):
    order: int = field("order")


class Solver(Strict):
    contactSolver: Literal[PARAMETERS["contactSolver"].choices] = field("contactSolver")
    contactTol: float = field("contactTol")
    contactMaxIt: int = field("contactMaxIt")
    bmOmega: float = field("bmOmega")
    condensation: Literal[PARAMETERS["condensation"].choices] = field("condensation")
    contactColumnsMB: float = field("contactColumnsMB")
    columnBlock: int = field("columnBlock")
    damageTol: float = field("damageTol")
    damageMaxIt: int = field("damageMaxIt")
    boundTol: float = field("boundTol")
    linearSolver: Literal[PARAMETERS["linearSolver"].choices] = field("linearSolver")
    allowUnstable: bool = field("allowUnstable")
    divergenceFactor: float = field("divergenceFactor")

    @property
    def factored(self) -> bool:
        """Whether the driver condenses the contact problem on CHOLMOD's factor (as contact.idp
        decides it: run.json condensation)."""
        return self.condensation == "factor" or (self.condensation == "auto" and self.linearSolver == "CHOLMOD")

    @model_validator(mode="after")
    def factor_needs_cholmod(self):
        if self.condensation == "factor" and self.linearSolver != "CHOLMOD":
            raise ValueError(f"condensation = factor splits CHOLMOD's solves: it needs linearSolver = CHOLMOD "
                             f"(linearSolver = {self.linearSolver} here; give condensation = columns)")
        return self


UNIT_NAME = re.compile(r"[A-Za-zµ]{1,8}")  # a unit's name as the images print it: letters only (no TeX)
UNIT_PRESET, UNIT_TABLE = "units-preset", "units-table"  # output.units' two forms (tags, not keys: left out of messages)


def _unit_preset(value):
    if value not in ("SI", "mm-N-s"):
        raise ValueError('give "SI", "mm-N-s", or a table of the scene\'s own units, '
                         '{ length = "mm", force = "N", time = "s" }')
    return value


class Units(Strict):
    """A consistent set of units, by their names (the images label numbers with them)."""
    length: str = Field("m", description="the unit of length, e.g. m, mm, um")
    force: str = Field("N", description="the unit of force, e.g. N, kN, mN")
    time: str = Field("s", description="the unit of time, e.g. s, ms, h")

    @field_validator("length", "force", "time")
    @classmethod
    def unit_name(cls, value: str) -> str:
        if not UNIT_NAME.fullmatch(value):
            raise ValueError("a unit's name is 1 to 8 letters (m, mm, kN, ms, ...), as the images print it")
        return value


class Output(Strict):
    """Files at `times` ("final", "all", "none" or a list of times in (0, T]) holding the
    `fields`: "bodies" (u, zeta, vonMises), "stress" (sigma11/22/12 too), "contact" (the line),
    "state" (the unknowns, for error norms between runs)."""
    times: Literal["final", "all", "none"] | Annotated[list[Real], Field(min_length=1)] = Field(
        PARAMETERS["outTimes"].default, description=PARAMETERS["outTimes"].meaning + " [s]")
    fields: list[Literal["bodies", "stress", "contact", "state"]] = Field(
        PARAMETERS["outFields"].default.split(","), description=PARAMETERS["outFields"].meaning)
    images: bool = Field(True, strict=True, description="render fields.png, contact_line.png, history.png "
                                                        "(and beta_xt.png) after the run")
    units: Annotated[Union[Annotated[Literal["SI", "mm-N-s"], BeforeValidator(_unit_preset), Tag(UNIT_PRESET)],
                           Annotated[Units, Tag(UNIT_TABLE)]],
                     Discriminator(lambda value: UNIT_TABLE if isinstance(value, (dict, Units)) else UNIT_PRESET)] = Field(
        "SI", description="what the images label the numbers with: SI (m, N, N/m², s), mm-N-s (mm, N, N/mm² = MPa, s), "
                          "or a table of the scene's own { length = ..., force = ..., time = ... } (a stress is then "
                          "labelled force/length², a force per unit thickness force/length); the solver needs none")
    checkpointEvery: int = field("checkpointEvery")
    checkpointSeconds: float = field("checkpointSeconds")


class Scene(Strict):
    title: str = Field("", max_length=500, description="what the scene is, for its files and images")
    time: Time = Time()
    space: Space = Space()
    body1: Body
    body2: Body
    glue: Glue = Glue()
    damage: DamageNumerics = DamageNumerics()
    solver: Solver = Solver()
    output: Output = Output()

    @field_validator("title")
    @classmethod
    def title_text(cls, value):
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            raise ValueError("the title is not valid Unicode text (a lone surrogate)") from None
        return value

    @model_validator(mode="after")
    def output_times_in_range(self):
        if isinstance(self.output.times, list):
            for value in self.output.times:
                if not (math.isfinite(value) and 0 < value <= self.time.T):
                    raise ValueError(f"output.times: {value} is outside (0, T = {self.time.T}]")
        return self

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
    """A TOML file (a scene, a sweep's grid) as data; any reason it cannot be read is a SceneError."""
    try:
        return tomllib.loads(path.read_text())
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


def _by_index(data: dict, key: str, option: str) -> str:
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
    held = ", ".join(f"{i} {item.get('type', '?')} on label {item.get('label', '?')}" if isinstance(item, dict)
                     else f"{i} {item!r}" for i, item in enumerate(items))
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

BOUNDARY_TYPES = {"clamped": Clamped, "roller": Roller, "displacement": Displacement, "traction": Traction}


def _model_at(path: tuple) -> type[BaseModel] | None:
    """The model class found at a location of a scene (boundary tags included), for suggestions."""
    model: object = Scene
    for part in path:
        if isinstance(part, int):
            continue
        if part in BOUNDARY_TYPES and model is None:
            model = BOUNDARY_TYPES[part]
            continue
        if part in (UNIT_PRESET, UNIT_TABLE):
            model = Units if part == UNIT_TABLE else None
            continue
        if model is None:
            return None
        fields = getattr(model, "model_fields", {})
        if part not in fields:
            return None
        annotation = fields[part].annotation
        model = next((a for a in getattr(annotation, "__args__", (annotation,))
                      if isinstance(a, type) and issubclass(a, BaseModel)), None)
    return model if isinstance(model, type) and issubclass(model, BaseModel) else None


def is_table(value) -> bool:
    """A table or a list of tables: the input of a check of a whole body or list of conditions,
    whose contents in the message would bury it (the message names what is wrong)."""
    return isinstance(value, dict) or (isinstance(value, list) and any(isinstance(item, dict) for item in value))


def describe(error: dict) -> str:
    """One line naming the key, the value and what is allowed."""
    raw = tuple(error["loc"])
    location = tuple(part for part in raw if part not in BOUNDARY_TYPES and part not in (UNIT_PRESET, UNIT_TABLE))
    key = ".".join(str(part) for part in location) or "scene"
    if error["type"] == "extra_forbidden":
        parent = _model_at(raw[:-1])
        names = list(parent.model_fields) if parent else []
        close = difflib.get_close_matches(str(raw[-1]), names, n=1, cutoff=0.5)
        hint = f"did you mean '{close[0]}'?" if close else f"valid keys: {', '.join(names)}"
        return f"{key}: unknown key ({hint})"
    if error["type"] == "missing":
        return f"{key}: missing (required)"
    message = error["msg"].removeprefix("Value error, ")
    if error["type"] in ("model_type", "dict_type") or "input" not in error or is_table(error["input"]):
        return f"{key}: {message}"
    return f"{key} = {error['input']!r}: {message}"


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
    return "\n".join(lines) + "\n"
