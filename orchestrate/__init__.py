"""Python orchestration of the FreeFEM solver (edp/main.edp) for adhesive, damaging contact.

The package stays thin: it launches FreeFem++, reads what the solver wrote (history.csv, VTK)
and makes images. It never re-implements the solver.

The plotting functions are imported when first used (PEP 562): matplotlib then loads only for a
command or a script that draws (`python -m orchestrate run` with no images never loads it).
"""
from __future__ import annotations

from orchestrate.compare import Comparison, compare
from orchestrate.freefem import REPO, SolverError
from orchestrate.results import Result, load_result
from orchestrate.runner import run
from orchestrate.scene import Scene, SceneError
from orchestrate.sweep import sweep

DRAWN = ("plot_columns", "plot_sweep")  # of orchestrate.plot
__all__ = ["REPO", "Comparison", "Result", "Scene", "SceneError", "SolverError", "compare", "load_result", "plot_columns",
           "plot_sweep", "run", "sweep"]


def __getattr__(name: str):
    if name not in DRAWN:
        raise AttributeError(f"module 'orchestrate' has no attribute {name!r}")
    from orchestrate import plot

    return getattr(plot, name)
