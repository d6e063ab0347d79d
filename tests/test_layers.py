"""The Python package in layers, with no circle (docs/architecture.md, "What may import what"):
every import of an orchestrate module, at the top of a file or inside a function, is an edge, and
the edges make no cycle; the studies are imported by the command line alone, the command line by
no module, and a module imports only from its own layer or those below."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from orchestrate.freefem import REPO

pytestmark = pytest.mark.unit

PACKAGE = REPO / "orchestrate"
# From the bottom up; a module may import from its own layer and those below (studies: any module).
LAYERS = [
    {"identity", "expr", "gmsh_mesher"},
    {"freefem"},
    {"geo", "outputs", "progress", "parameters"},
    {"mesh", "manifest", "plots"},
    {"scene", "results"},
    {"arguments", "render", "compare"},
    {"steps"},
    {"runner"},
    {"sweep", "plot", "reference"},
    {"studies", "studies.convergence", "studies.stability", "studies.hertz", "studies.bench", "studies.reports",
     "studies.gallery"},
    {"cli", "__main__", ""},  # "" is the package's __init__: the API users import
]
LAYER = {module: depth for depth, layer in enumerate(LAYERS) for module in layer}


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path) -> set[str]:
    """The orchestrate modules a file imports, wherever the import statement stands."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "orchestrate":
            base = node.module.removeprefix("orchestrate").lstrip(".")
            for alias in node.names:
                name = f"{base}.{alias.name}".lstrip(".")
                found.add(name if name in LAYER else base)
        elif isinstance(node, ast.Import):
            found |= {alias.name.removeprefix("orchestrate.") for alias in node.names
                      if alias.name.startswith("orchestrate.")}
    return found - {""}


def graph() -> dict[str, set[str]]:
    return {module_name(path): imports(path) - {module_name(path)} for path in PACKAGE.rglob("*.py")}


def test_every_module_has_a_layer():
    assert sorted(set(graph()) - set(LAYER)) == []


def test_each_import_goes_down_or_across_never_up():
    upward = [f"{module} imports {target}" for module, targets in graph().items() for target in targets
              if LAYER[target] > LAYER[module] and not (module.startswith("studies") and target.startswith("studies"))]
    assert upward == []


def test_no_import_circle():
    edges = graph()
    state: dict[str, int] = {}

    def circle_from(module: str, path: list[str]) -> list[str] | None:
        state[module] = 1
        for target in sorted(edges.get(module, ())):
            if state.get(target) == 1:
                return path[path.index(target):] + [target] if target in path else [module, target]
            if not state.get(target):
                found = circle_from(target, path + [target])
                if found:
                    return found
        state[module] = 2
        return None

    for module in sorted(edges):
        if not state.get(module):
            assert circle_from(module, [module]) is None


def test_the_layer_check_sees_a_circle(tmp_path, monkeypatch):
    """The check itself: a module importing one above it is reported (so an empty list means
    something)."""
    module = tmp_path / "orchestrate" / "scene.py"
    module.parent.mkdir()
    module.write_text("def f():\n    from orchestrate.runner import run\n")
    monkeypatch.setattr(__import__(__name__), "PACKAGE", tmp_path / "orchestrate")
    assert graph() == {"scene": {"runner"}}
    assert LAYER["runner"] > LAYER["scene"]
