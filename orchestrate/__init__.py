"""Python orchestration of the FreeFEM solver (edp/main.edp) for adhesive, damaging contact.

The package stays thin: it launches FreeFem++, reads what the solver wrote (history.csv, VTK)
and makes images. It never re-implements the solver.
"""
from orchestrate.freefem import REPO, SolverError, run_solver
from orchestrate.results import Result, load_result

__all__ = ["REPO", "SolverError", "run_solver", "Result", "load_result"]
