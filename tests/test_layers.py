"""The Python package in layers, with no circle (docs/architecture.md, "What may import what"):
every import of an orchestrate module, at the top of a file or inside a function, absolute or
relative, is an edge; the edges make no cycle; a module imports only from its own layer or those
below; and the studies and argparse are the command line's alone."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from orchestrate.freefem import REPO

pytestmark = pytest.mark.unit

# From the bottom up; a module may import from its own layer and those below. "" is the package's
# __init__, the API users import (`from orchestrate import run` is an import of it).
LAYERS = [
    {"identity", "expr", "gmsh_mesher", "msh", "schema"},
    {"freefem"},
    {"geo", "outputs", "progress", "parameters", "formats"},
    {"mesh", "manifest", "plots"},
    {"scene", "results"},
    {"arguments", "render", "compare", "estimate"},
    {"steps"},
    {"runner"},
    {"sweep", "plot", "reference", "adapt"},
    {"studies", "studies.convergence", "studies.stability", "studies.hertz", "studies.bench", "studies.reports",
     "studies.gallery", "studies.modeone", "studies.cantilever", "studies.adaptivity"},
    {"cli", "cli.options", "cli.run", "cli.sweep", "cli.plot", "cli.render", "cli.compare", "cli.reference", "cli.gallery",
     "cli.bench", "cli.convergence", "cli.stability", "cli.hertz", "__main__", "", "cli.modeone", "cli.cantilever", "cli.estimate", "cli.adapt", "cli.adaptivity", "cli.commitmesh"},
]
LAYER = {module: depth for depth, layer in enumerate(LAYERS) for module in layer}


def module_name(package: Path, path: Path) -> str:
    parts = path.relative_to(package).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(package: Path, path: Path, modules: set[str]) -> set[str]:
    """The orchestrate modules a file imports, wherever the statement stands ("" the package)."""
    name = module_name(package, path)
    here = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:  # relative: from . / .. of this module's package
                parts = here.split(".") if here else []
                base = ".".join(parts[:len(parts) - (node.level - 1)] + ([node.module] if node.module else []))
            elif node.module and node.module.split(".")[0] == "orchestrate":
                base = node.module.removeprefix("orchestrate").lstrip(".")
            else:
                continue
            for alias in node.names:
                target = f"{base}.{alias.name}".lstrip(".")
                found.add(target if target in modules else base)
        elif isinstance(node, ast.Import):
            found |= {alias.name.removeprefix("orchestrate").lstrip(".") for alias in node.names
                      if alias.name.split(".")[0] == "orchestrate"}
    return found - {name}


PACKAGE = REPO / "orchestrate"


def graph(package: Path = PACKAGE) -> dict[str, set[str]]:
    paths = list(package.rglob("*.py"))
    modules = {module_name(package, path) for path in paths}
    return {module_name(package, path): imports(package, path, modules) for path in paths}


def upward(edges: dict[str, set[str]]) -> list[str]:
    return sorted(f"{module or 'the package'} imports {target or 'the package'}" for module, targets in edges.items()
                  for target in targets if LAYER[target] > LAYER[module])


def circle(edges: dict[str, set[str]]) -> list[str] | None:
    """One import circle, as the modules along it, or None."""
    state: dict[str, int] = {}

    def walk(module: str, path: list[str]) -> list[str] | None:
        state[module] = 1
        for target in sorted(edges.get(module, ())):
            if state.get(target) == 1:
                return path[path.index(target):] + [target]
            if not state.get(target):
                found = walk(target, path + [target])
                if found:
                    return found
        state[module] = 2
        return None

    for module in sorted(edges):
        if not state.get(module):
            found = walk(module, [module])
            if found:
                return found
    return None


def test_every_module_has_a_layer():
    assert sorted(set(graph()) - set(LAYER)) == []


def test_each_import_goes_down_or_across_never_up():
    assert upward(graph()) == []


def test_no_import_circle():
    assert circle(graph()) is None


def test_only_the_command_line_imports_the_studies_and_argparse():
    importers = {module for module, targets in graph().items() if not module.startswith("studies")
                 and any(target.startswith("studies") for target in targets)}
    assert all(module.startswith("cli.") for module in importers), importers
    argparse = sorted(module_name(PACKAGE, path) for path in PACKAGE.rglob("*.py") if "argparse" in path.read_text())
    assert all(module == "cli" or module.startswith("cli.") for module in argparse), argparse


def test_the_checks_see_an_upward_import_and_a_circle(tmp_path):
    """The checks themselves, on a package made for them: a relative import up a layer, an import
    of the package's API from below, and a circle between two modules of one layer are each
    reported (so that the empty answers above mean something)."""
    package = tmp_path / "orchestrate"
    package.mkdir()
    (package / "__init__.py").write_text("from orchestrate.runner import run\n")
    (package / "scene.py").write_text("def f():\n    from .runner import run\n    from orchestrate import run\n")
    (package / "runner.py").write_text("from orchestrate.sweep import sweep\n")
    (package / "sweep.py").write_text("import orchestrate.plot\n")
    (package / "plot.py").write_text("from . import sweep\n")
    edges = graph(package)
    assert edges["scene"] == {"runner", ""} and edges["plot"] == {"sweep"}
    assert upward(edges) == ["runner imports sweep", "scene imports runner", "scene imports the package"]
    found = circle(edges)
    assert found[0] == found[-1] and set(found) == {"plot", "sweep"}


def test_a_command_loads_only_what_it_uses():
    """`python -m orchestrate run …` builds a parser of that command alone, and neither it nor the
    package's API imports matplotlib (the plotting names load when first used), nor a library a
    run can do without before FreeFem++ starts (pydantic, importlib.metadata: 75 ms); every command's
    module is its name without hyphens, which is how the parser finds it without importing the
    others."""
    import importlib
    import os
    import subprocess
    import sys

    from orchestrate.cli import COMMANDS, STUDIES

    for module in COMMANDS + STUDIES:
        assert importlib.import_module(module).NAME.replace("-", "") == module.rsplit(".", 1)[1]
    unloaded = ("matplotlib", "orchestrate.render", "orchestrate.studies", "numpy", "meshio", "gmsh", "orchestrate.compare",
                "orchestrate.sweep", "orchestrate.results", "pydantic", "importlib.metadata")
    probe = ("import os, sys; from orchestrate.cli import parser; import orchestrate, orchestrate.runner; "
             "parser(['run', 'scene.toml']).parse_args(['run', 'scene.toml']); "
             "print(sorted(name for name in os.environ['UNLOADED'].split() if name in sys.modules))")
    done = subprocess.run([sys.executable, "-c", probe], cwd=REPO, capture_output=True, text=True, check=True,
                          env={**os.environ, "UNLOADED": " ".join(unloaded)})
    assert done.stdout.strip() == "[]"  # what a run needs before FreeFem++ starts: numpy loads while it runs
    from orchestrate import plot_sweep  # the lazy name still works

    assert plot_sweep.__module__ == "orchestrate.plot"


def test_the_package_s_names_are_its_functions_whatever_was_imported_first():
    """orchestrate.compare and orchestrate.sweep are the functions, also after their modules of
    the same name were imported (by the package's own modules, or a user); every name of
    __all__ is there, and a wrong one is an AttributeError."""
    import subprocess
    import sys

    probe = ("import orchestrate.compare, orchestrate.sweep, orchestrate; from orchestrate import compare, sweep; "
             "print(callable(orchestrate.compare), callable(orchestrate.sweep), compare.__name__, sweep.__module__, "
             "all(hasattr(orchestrate, name) for name in orchestrate.__all__), hasattr(orchestrate, 'nothing'))")
    done = subprocess.run([sys.executable, "-c", probe], cwd=REPO, capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["True", "True", "compare", "orchestrate.sweep", "True", "False"]


def test_the_command_ends_fast_but_says_what_it_could_not_print(tmp_path):
    """`python -m orchestrate` ends its process without Python's teardown, yet output it could not
    write (a full disk, a reader gone) still ends it with Python's code 120 and a message; run
    inside another program (runpy), it returns to that program."""
    import os
    import subprocess
    import sys

    env = {name: value for name, value in os.environ.items() if name != "PYTHONUNBUFFERED"}
    command = [sys.executable, "-m", "orchestrate", "reference", "--out", str(tmp_path / "page.md"), "--force"]
    with open("/dev/full", "w") as full:
        done = subprocess.run(command, cwd=REPO, env=env, stdout=full, stderr=subprocess.PIPE, text=True)
    assert done.returncode == 120 and "No space left on device" in done.stderr
    host = ("import runpy, sys; sys.argv = ['orchestrate', 'reference', '--out', sys.argv[1], '--force']\n"
            "try:\n    runpy.run_module('orchestrate', run_name='__main__')\n"
            "except SystemExit as end:\n    print('the host goes on after', end.code)")
    done = subprocess.run([sys.executable, "-c", host, str(tmp_path / "again.md")], cwd=REPO, env=env,
                          capture_output=True, text=True)
    assert done.stdout.splitlines()[-1] == "the host goes on after 0", done.stderr
