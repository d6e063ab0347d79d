"""Command line: python -m orchestrate {paper,render} ..."""
from __future__ import annotations

import argparse
import json
import platform
import shutil
import sys
import time
from importlib import metadata
from pathlib import Path

from orchestrate.freefem import REPO, SolverError, run_solver
from orchestrate.results import load_result


def package_versions() -> dict[str, str]:
    names = ["numpy", "meshio", "pyvista", "vtk", "matplotlib", "gmsh"]
    versions = {"python": platform.python_version()}
    for name in names:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def write_summary(folder: Path, run_folder: Path, command: str, seconds: float) -> Path:
    result = load_result(run_folder)
    final = {name: float(values[-1]) for name, values in result.history.items()}
    summary = {
        "command": command,
        "wallSeconds": round(seconds, 3),
        "final": final,
        "parameters": result.params,
        "versions": {"freefem": result.params.get("freefemVersion"), **package_versions()},
    }
    target = folder / "summary.json"
    target.write_text(json.dumps(summary, indent=2) + "\n")
    return target


def run_into(folder: Path, args: list[str]) -> float:
    """Run the solver into folder, which appears only once the run is complete."""
    partial = folder.with_name(folder.name + ".partial")
    shutil.rmtree(partial, ignore_errors=True)
    start = time.perf_counter()
    run_solver(partial, args)
    seconds = time.perf_counter() - start
    shutil.rmtree(folder, ignore_errors=True)
    partial.rename(folder)
    return seconds


def command_paper(options) -> int:
    from orchestrate.render import render_all

    folder = Path(options.out)
    folder.mkdir(parents=True, exist_ok=True)
    run_folder = folder / "run"
    print(f"running the paper's scene (edp/main.edp, defaults) into {run_folder} ...")
    seconds = run_into(run_folder, options.solver_args)
    images = render_all(load_result(run_folder), folder)
    summary = write_summary(folder, run_folder, "make paper", seconds)
    for path in [*images, summary]:
        print(f"wrote {path}")
    return 0


def command_render(options) -> int:
    from orchestrate.render import render_all

    result = load_result(options.folder)
    for path in render_all(result, Path(options.out or options.folder)):
        print(f"wrote {path}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m orchestrate", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    paper = commands.add_parser("paper", help="run the paper's scene and write its images")
    paper.add_argument("--out", default=str(REPO / "results" / "paper"), help="image folder (default results/paper)")
    paper.add_argument("solver_args", nargs=argparse.REMAINDER,
                       help="extra solver flags after --, e.g. -- -N 80")
    paper.set_defaults(handler=command_paper)
    render = commands.add_parser("render", help="images of a run folder")
    render.add_argument("folder", help="a run folder (with history.csv and .vtu files)")
    render.add_argument("--out", help="where to write the images (default: the run folder)")
    render.set_defaults(handler=command_render)
    options = parser.parse_args(argv)
    if getattr(options, "solver_args", None) and options.solver_args[0] == "--":
        options.solver_args = options.solver_args[1:]
    try:
        return options.handler(options)
    except SolverError as error:
        print(f"error: {error}\n{error.log_tail}", file=sys.stderr)
        return error.returncode
    except FileNotFoundError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
