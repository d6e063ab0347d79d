"""Python orchestration of the FreeFEM solver (edp/main.edp) for adhesive, damaging contact.

The package stays thin: it launches FreeFem++, reads what the solver wrote (history.csv, VTK)
and makes images. It never re-implements the solver.

Every name below is imported when first used (PEP 562): `import orchestrate` costs nothing, a
command loads only the modules it needs (`python -m orchestrate run` never loads matplotlib,
the comparison or the sweep), and a script pays for what it touches.
"""
from __future__ import annotations

import importlib
import sys
import types

# name: the module that defines it
EXPORTS = {"REPO": "freefem", "SolverError": "freefem", "Comparison": "compare", "compare": "compare",
           "Result": "results", "load_result": "results", "run": "runner", "Scene": "scene", "SceneError": "scene",
           "sweep": "sweep", "plot_columns": "plot", "plot_sweep": "plot"}
__all__ = sorted(EXPORTS)


class Package(types.ModuleType):
    """orchestrate.compare and orchestrate.sweep are functions, as they were when this file
    imported them eagerly; but importing the module of the same name (which any of the package's
    modules may do first) makes Python set the package's attribute to that module. This keeps
    the function there."""

    def __setattr__(self, name: str, value) -> None:
        if isinstance(value, types.ModuleType) and EXPORTS.get(name) == name:
            return
        super().__setattr__(name, value)


def __getattr__(name: str):
    if name not in EXPORTS:
        raise AttributeError(f"module 'orchestrate' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"orchestrate.{EXPORTS[name]}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *EXPORTS})


sys.modules[__name__].__class__ = Package
