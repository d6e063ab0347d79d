"""The scene format's reference, docs/scene-format.md, generated from the schema (scene.py) and the
parameter table (edp/lib/parameters.md): every key with its type, default, range, unit and
meaning, so the page cannot drift from what the validation accepts (tests/test_reference.py holds
the committed page to this module's output).

    python -m orchestrate reference            # rewrite docs/scene-format.md
"""
from __future__ import annotations

import re
import typing
from pathlib import Path

from annotated_types import Ge, Gt, Le, Lt, MaxLen, MinLen
from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from orchestrate.freefem import REPO

NAME, HELP = "reference", "write docs/scene-format.md, the scene format's reference, from the schema"
PAGE = REPO / "docs" / "scene-format.md"
BOUND_SIGNS = ((Ge, "ge", "["), (Gt, "gt", "("), (Le, "le", "]"), (Lt, "lt", ")"))


def type_name(annotation) -> str:
    """A short name of a field's type as a scene writes it."""
    origin, arguments = typing.get_origin(annotation), typing.get_args(annotation)
    if origin is typing.Annotated:
        return type_name(arguments[0])
    if origin is typing.Literal:
        return "one of " + ", ".join(f'"{a}"' for a in arguments)
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
        names = [type_name(a) for a in arguments if a is not type(None)]
        return " or ".join(dict.fromkeys(names))
    if origin in (list, tuple):
        inner = [type_name(a) for a in arguments if a is not Ellipsis]
        if origin is tuple and len(inner) > 1:
            return f"[{', '.join(inner)}]"
        return f"list of {inner[0]}" if inner else "list"
    if origin is dict:
        return "table"
    return {int: "integer", float: "number", str: "text", bool: "boolean"}.get(annotation, getattr(annotation, "__name__", str(annotation)))


def range_text(field) -> str:
    """The interval of a numeric field's limits, '-' without any."""
    limits = {}
    for constraint in field.metadata:
        for kind, key, bracket in BOUND_SIGNS:
            if isinstance(constraint, kind):
                limits[key] = (getattr(constraint, key), bracket)
        if isinstance(constraint, (MinLen, MaxLen)):
            return f"length {'≥ ' + str(constraint.min_length) if isinstance(constraint, MinLen) else '≤ ' + str(constraint.max_length)}"
    if not limits:
        return "-"
    low = limits.get("ge") or limits.get("gt") or ("-inf", "(")
    high = limits.get("le") or limits.get("lt") or ("inf", ")")
    return f"{low[1]}{low[0]}, {high[0]}{high[1]}"


def default_text(field) -> str:
    if field.is_required():
        return "required"
    value = field.default
    if value is PydanticUndefined or value is None:
        return "-"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(f'"{v}"' if isinstance(v, str) else str(v) for v in value) + "]"
    return str(value) if value != {} else "{}"


def meaning_and_unit(field) -> tuple[str, str]:
    """The description, and its unit when it ends in one ('... [N/m²]')."""
    text = (field.description or "").strip()
    found = re.search(r"\s*\[([^\[\]]+)\]$", text)
    return (text[:found.start()], found[1]) if found else (text, "-")


def submodel(annotation) -> type[BaseModel] | None:
    return annotation if isinstance(annotation, type) and issubclass(annotation, BaseModel) else None


def table_row(key: str):
    """The parameter-table row of a scene key (bodyN.material.E: the body row E), or None."""
    from orchestrate.parameters import PARAMETERS

    for parameter in PARAMETERS.values():
        if parameter.scene != "-" and key == ("bodyN." if parameter.scope == "body" else "") + parameter.scene:
            return parameter
    return None


def rows(model: type[BaseModel], prefix: str) -> list[str]:
    """One table row per key below `prefix`, nested tables flattened to dotted keys; a field whose
    own checks hold its limits (a custom validator) takes its range from its table row."""
    lines = []
    for name, field in model.model_fields.items():
        nested = submodel(field.annotation)
        if nested is not None:
            lines += rows(nested, f"{prefix}{name}.")
            continue
        meaning, unit = meaning_and_unit(field)
        limits, parameter = range_text(field), table_row(f"{prefix}{name}")
        if limits == "-" and parameter is not None and parameter.range != "-" and parameter.type != "choice":
            limits = parameter.range
        cells = [f"`{prefix}{name}`", type_name(field.annotation), default_text(field), limits, unit, meaning]
        lines.append("| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |")
    return lines


HEADER = "| key | type | default | range | unit | meaning |\n|---|---|---|---|---|---|"

RULES = """## What else a scene must satisfy

- **Contact boundaries.** Body 1's (its `mesh.contactLabel`) is one straight segment: the mortar
  side. Body 2's faces it and is a segment parallel to it or a curve that every line normal to
  body 1's crosses at most once; they may have any extents (the contact acts on the overlap of
  their projections onto body 1's line) and may start apart, never overlapping. Put a curved
  side in body 2 (docs/model.md §10).
- **Holding the bodies.** Each body needs at least one clamped, roller or displacement
  condition; rigid motions it leaves free are held by the contact alone, which refuses a sliding
  along Γ_C and loads that pull the body away (docs/model-choices.md, "Floating bodies").
- **Labels** must be boundary labels of the body's mesh; the headers of the `meshes/` sources
  below say which is which.
- **Tractions** `fx`, `fy` are in the global x, y components (a pressure p on a top face is
  `fy = "-p"`, on a bottom face `fy = "p"`); expressions follow the grammar of README.md
  ("Python"), in x, y, t (initial data in x, y only).
- **Output times** lie in (0, T]; `output.fields = []` writes no `.vtu`; `render --fields sigma*`
  needs `"stress"`.
"""


def mesh_sources() -> list[str]:
    """Each gmsh source of meshes/: its constants (mesh.n, mesh.parameters) and its header comment."""
    from orchestrate.mesh import geo_constants

    lines = ["## The gmsh sources in meshes/", ""]
    for path in sorted((REPO / "meshes").glob("*.geo")):
        header = []
        for line in path.read_text().splitlines():
            if not line.startswith("//"):
                break
            header.append(line[2:].strip())
        lines += [f"### `meshes/{path.name}`", "", f"Constants: {', '.join(geo_constants(path))}.", "",
                  *(f"> {line}" for line in header), ""]
    return lines


def page() -> str:
    from orchestrate import scene

    body = rows(scene.Body, "bodyN.")
    run = [line for line in rows(scene.Scene, "") if not line.startswith(("| `body1.", "| `body2."))]
    boundary = []
    for kind, model in scene.BOUNDARY_TYPES.items():
        boundary += [f"### {kind}", "", HEADER, *rows(model, ""), ""]
    return "\n".join([
        "# Scene format",
        "",
        "Generated by `python -m orchestrate reference` from the schema (orchestrate/scene.py) and the "
        "parameter table (edp/lib/parameters.md); do not edit by hand. A scene is a TOML file "
        "(`scenes/paper.toml` is the paper's, commented). A key left out takes its default; a key the "
        "schema does not have, a value of another type or outside its range is refused before anything "
        "runs, with the key and what is allowed. Ranges are intervals ( ) open, [ ] closed. Units are SI "
        "(any consistent set works: docs/model.md §12). Expressions are text in the whitelist grammar of "
        "README.md (loads in x, y, t; initial data in x, y). `--set key=value` overrides any key "
        "(`--set body1.material.E=2000`); a boundary condition is named by its label, "
        "`--set 'body1.boundary[label=4].fy=-20*t'`, or by its 0-based index in the list, "
        "`body1.boundary.1.fy` (the label is to prefer: it does not change when the conditions are reordered). "
        "`sweep --grid` and `--grid-file` take the same keys.",
        "",
        "## The run",
        "",
        HEADER, *run,
        "",
        "## Each body (`body1`, `body2`)",
        "",
        "The keys below `bodyN.` exist for both bodies.",
        "",
        HEADER, *body,
        "",
        "## Boundary conditions (`[[bodyN.boundary]]`, a list of tables)",
        "",
        "Each has a `type` and the keys of its type; a label may carry one condition per component, and "
        "a traction where its displacement is not wholly prescribed.",
        "",
        *boundary,
        RULES,
        *mesh_sources(),
    ])


def add_arguments(parser) -> None:
    parser.add_argument("--out", default=str(PAGE), help=f"where to write it (default {PAGE.relative_to(REPO)})")


def command(options) -> int:
    Path(options.out).write_text(page())
    print(f"wrote {options.out}")
    return 0
