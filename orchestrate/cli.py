"""python -m orchestrate {run,sweep,study,bench,gallery,render}: scenes, parameter sweeps, studies,
the benchmark, the gallery and images from the shell."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from orchestrate.freefem import InputError, SolverError
from orchestrate.mesh import MeshError
from orchestrate.results import load_result
from orchestrate.scene import SceneError, parse_value


def parse_assignments(items: list[str], option: str) -> dict:
    """key=value strings as a dict (values read as TOML would: numbers, booleans, strings)."""
    assignments = {}
    for item in items:
        key, separator, value = item.partition("=")
        if not separator or not key:
            raise SceneError(f"{option} {item!r}: expected key=value, e.g. {option} time.N=80")
        assignments[key.strip()] = parse_value(value.strip())
    return assignments


def command_run(options) -> int:
    from orchestrate.runner import run

    overrides = parse_assignments(options.set, "--set")
    if options.allow_unstable:
        overrides["solver.allowUnstable"] = True
    result = run(options.scene, options.out, overrides, force=options.force, progress=sys.stderr.isatty())
    final = result.history
    print(f"{result.folder}: {len(final['t'])} steps, normV(T) = {final['normV'][-1]:.6g}, "
          f"contact length {final['contactLength'][-1]:.4g}, contact iterations/step {final['contactIters'].mean():.1f}")
    return 0


def command_sweep(options) -> int:
    from orchestrate.sweep import parse_grid, sweep

    grid = parse_grid(options.grid)
    rows = sweep(options.scene, grid, options.out, parse_assignments(options.set, "--set"),
                 workers=options.workers, scheduler=options.scheduler, progress=sys.stderr.isatty())
    width = max(len(row["folder"]) for row in rows)
    for row in rows:
        figure = f"normV(T) = {row['normV']:.6g}" if row.get("normV") is not None else row.get("error", "")
        print(f"{row['folder']:<{width}}  {row['status']:<18}  {figure}")
    print(f"table: {Path(options.out) / 'sweep.csv'}")
    return 0 if all(row["status"] != "failed" and row["status"] != "invalid" for row in rows) else 1


def command_study(options) -> int:
    from orchestrate.study import convergence

    convergence(options.scene, options.out, count=options.levels, n1=options.n1, n2=options.n2, steps=options.N,
                time_mesh_level=options.time_mesh_level, space_steps_level=options.space_steps_level,
                workers=options.workers, progress=sys.stderr.isatty())
    print((Path(options.out) / "README.md").read_text())
    return 0


def command_stability(options) -> int:
    from orchestrate.study import stability

    stability(options.scene, options.out)
    print((Path(options.out) / "README.md").read_text())
    return 0


def command_bench(options) -> int:
    from orchestrate.bench import bench

    bench(options.out, levels=options.levels, check_reference=options.check_reference)
    print((Path(options.out) / "README.md").read_text())
    return 0


GALLERY = ("paper", "peel", "indentation", "shear", "tilted_patch")


def command_gallery(options) -> int:
    """Every gallery scene at its own resolution into results/gallery/<name> (docs/gallery.md)."""
    from orchestrate.freefem import REPO
    from orchestrate.runner import run

    unknown = [name for name in options.names if name not in GALLERY]
    if unknown:
        raise SceneError(f"no gallery scene {', '.join(unknown)} (the gallery: {', '.join(GALLERY)})")
    for name in options.names or GALLERY:
        result = run(REPO / "scenes" / f"{name}.toml", Path(options.out) / name, force=True, progress=sys.stderr.isatty())
        print(f"{name}: {result.folder}")
    return 0


def command_render(options) -> int:
    from orchestrate.render import render_all

    result = load_result(options.folder)
    for path in render_all(result, Path(options.out or options.folder)):
        print(f"wrote {path}")
    return 0


def positive(text: str) -> int:
    """An integer ≥ 1 for --workers and --levels-like options."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is not allowed: give an integer >= 1")
    return value


def at_least_two(text: str) -> int:
    value = positive(text)
    if value < 2:
        raise argparse.ArgumentTypeError("a ladder needs at least 2 levels (the finest is the reference)")
    return value


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m orchestrate", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    run = commands.add_parser("run", help="run a scene (TOML) into a folder")
    run.add_argument("scene", help="a scene file, e.g. scenes/paper.toml")
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                     help="override a scene value, e.g. --set time.N=80 --set body1.material.E=2000")
    run.add_argument("--out", help="output folder (default results/<scene name>)")
    run.add_argument("--force", action="store_true", help="replace the output folder if it exists")
    run.add_argument("--allow-unstable", action="store_true",
                     help="run even when the time step exceeds the explicit stability bound k* (MODEL.md §7)")
    run.set_defaults(handler=command_run)
    sweep = commands.add_parser("sweep", help="run the cartesian product of overrides on dask.distributed")
    sweep.add_argument("scene", help="a scene file, e.g. scenes/paper.toml")
    sweep.add_argument("--grid", action="append", required=True, metavar="KEY=V1,V2,...",
                       help="values of one scene key, e.g. --grid time.N=20,40 --grid glue.gammaNu=0,1")
    sweep.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override for every run")
    sweep.add_argument("--out", default="results/sweep", help="sweep folder (default results/sweep)")
    sweep.add_argument("--workers", type=positive, default=2, help="LocalCluster workers (default 2)")
    sweep.add_argument("--scheduler", help="address of an existing dask scheduler, e.g. tcp://host:8786")
    sweep.set_defaults(handler=command_sweep)
    study = commands.add_parser("study", help="studies of a scene: convergence, stability")
    kinds = study.add_subparsers(dest="kind", required=True)
    convergence = kinds.add_parser("convergence", help="lock-step, time-only and space-only ladders, errors and rates")
    convergence.add_argument("scene", help="a scene whose meshes are nested under n -> 2n, e.g. scenes/paper.toml")
    convergence.add_argument("--levels", type=at_least_two, default=6, help="levels per ladder, the finest is the reference")
    convergence.add_argument("--n1", type=positive, default=6, help="body 1 elements per side at the coarsest level")
    convergence.add_argument("--n2", type=positive, default=8, help="body 2 elements per side at the coarsest level")
    convergence.add_argument("--N", type=positive, default=20, help="time steps at the coarsest level")
    convergence.add_argument("--time-mesh-level", type=int, default=3, help="mesh level of the time-only ladder")
    convergence.add_argument("--space-steps-level", type=int, default=4, help="step level of the space-only ladder")
    convergence.add_argument("--workers", type=positive, default=2)
    convergence.add_argument("--out", default="results/convergence")
    convergence.set_defaults(handler=command_study)
    stable = kinds.add_parser("stability", help="predicted against observed explicit time-step bound")
    stable.add_argument("scene", nargs="?", default="scenes/paper.toml")
    stable.add_argument("--out", default="results/stability")
    stable.set_defaults(handler=command_stability)
    benchmark = commands.add_parser("bench", help="run time against error on this machine (results/bench)")
    benchmark.add_argument("--levels", type=at_least_two, default=5,
                           help="measured uniform levels (one fewer graded: the next graded level is the reference)")
    benchmark.add_argument("--check-reference", action="store_true",
                           help="also run a uniform level finer than every other and measure every run against it too "
                                "(about six minutes more)")
    benchmark.add_argument("--out", default="results/bench")
    benchmark.set_defaults(handler=command_bench)
    gallery = commands.add_parser("gallery", help="run the gallery scenes into results/gallery")
    gallery.add_argument("names", nargs="*", metavar="NAME", help=f"some of {', '.join(GALLERY)} (default: all)")
    gallery.add_argument("--out", default="results/gallery")
    gallery.set_defaults(handler=command_gallery)
    render = commands.add_parser("render", help="images of a run folder")
    render.add_argument("folder", help="a run folder (with history.csv and .vtu files)")
    render.add_argument("--out", help="where to write the images (default: the run folder)")
    render.set_defaults(handler=command_render)
    options = parser.parse_args(argv)
    try:
        return options.handler(options)
    except SolverError as error:
        print(f"error: {error}\n{error.log_tail}", file=sys.stderr)
        return error.returncode
    except (InputError, MeshError, FileNotFoundError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except RuntimeError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
