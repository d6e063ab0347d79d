"""The command line of `orchestrate.studies.convergence`: its arguments and what the command does with them."""
from __future__ import annotations

import sys
from pathlib import Path

from orchestrate.arguments import parse_assignments
from orchestrate.cli.options import add_force_argument, at_least_two, choices_list, positive
from orchestrate.parameters import PARAMETERS
from orchestrate.studies.convergence import KINDS, NAME, convergence, time_mesh_level

HELP = "lock-step, time-only and space-only ladders, errors and rates"


def add_arguments(parser) -> None:
    parser.add_argument("scene", help="a scene whose meshes are nested under n -> 2n, e.g. scenes/paper.toml")
    parser.add_argument("--ladders", type=choices_list(KINDS), default=list(KINDS),
                        help="which ladders, comma-separated (default: lockstep,time,space)")
    parser.add_argument("--levels", type=at_least_two, default=6, help="levels per ladder, the finest is the reference")
    parser.add_argument("--n1", type=positive, default=6, help="body 1 elements per side at the coarsest level")
    parser.add_argument("--n2", type=positive, default=8, help="body 2 elements per side at the coarsest level")
    parser.add_argument("--N", type=positive, default=20, help="time steps at the coarsest level")
    parser.add_argument("--time-mesh-level", type=int, default=None,
                        help="mesh level of the time-only ladders, at most the finest space level (default: 3, or "
                             "the finest space level when --levels is smaller)")
    parser.add_argument("--space-steps-level", type=int, default=4, help="step level of the space-only ladder")
    parser.add_argument("--schemes", type=choices_list(PARAMETERS["scheme"].choices), default=None,
                        help="a time ladder per scheme, comma-separated (default: the scene's scheme)")
    parser.add_argument("--time-N", type=positive, default=None,
                        help="time steps at the coarsest level of the time ladders (default: --N)")
    parser.add_argument("--time-levels", type=at_least_two, default=None,
                        help="levels of each time ladder (default: --levels)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a scene value for every run, as run --set (e.g. --set time.scheme=bdf2 for the lock-step "
                             "and space ladders; the time ladders take --schemes); not the meshes' n, time.N or the "
                             "outputs, which the ladders set")
    parser.add_argument("--workers", type=positive, default=2, help="runs at a time")
    parser.add_argument("--out", default="results/convergence", help="a new folder for the tables, plots and runs")
    add_force_argument(parser, f"study {NAME}")


def command(options) -> int:
    convergence(options.scene, options.out, count=options.levels, n1=options.n1, n2=options.n2, steps=options.N,
                time_mesh_level=time_mesh_level(options.levels, options.time_mesh_level),
                space_steps_level=options.space_steps_level,
                kinds=options.ladders, schemes=options.schemes or (None,), time_steps=options.time_N,
                time_count=options.time_levels, workers=options.workers, progress=sys.stderr.isatty(),
                force=options.force, settings=parse_assignments(options.set, "--set"))
    print((Path(options.out) / "README.md").read_text())
    return 0
