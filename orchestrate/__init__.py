"""Python orchestration of the FreeFEM solver (edp/main.edp) for adhesive, damaging contact.

The package stays thin: it launches FreeFem++, reads what the solver wrote (history.csv, VTK)
and makes images. It never re-implements the solver.
"""
from orchestrate.freefem import REPO, SolverError
from orchestrate.results import Result, load_result
from orchestrate.runner import run
from orchestrate.scene import Scene, SceneError
from orchestrate.sweep import sweep

__all__ = ["REPO", "Result", "Scene", "SceneError", "SolverError", "load_result", "run", "sweep"]
