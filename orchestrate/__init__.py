"""Python orchestration of the FreeFEM solver (edp/main.edp) for adhesive, damaging contact.

The package stays thin: it launches FreeFem++, reads what the solver wrote (history.csv, VTK)
and makes images. It never re-implements the solver.
"""
from orchestrate.compare import Comparison, compare
from orchestrate.freefem import REPO, SolverError
from orchestrate.plot import plot_columns, plot_sweep
from orchestrate.results import Result, load_result
from orchestrate.runner import run
from orchestrate.scene import Scene, SceneError
from orchestrate.sweep import sweep

__all__ = ["REPO", "Comparison", "Result", "Scene", "SceneError", "SolverError", "compare", "load_result", "plot_columns",
           "plot_sweep", "run", "sweep"]
