"""The command line of `orchestrate.studies.hertz`: its arguments and what the command does with them."""
from __future__ import annotations

from pathlib import Path

from orchestrate.arguments import parse_assignments
from orchestrate.cli.options import add_force_argument, choices_list, fractions_list, positive
from orchestrate.freefem import InputError
from orchestrate.studies.hertz import NAME, hertz

HELP = "Hertz line contact against the analytic solution, over mesh levels"


def add_arguments(parser) -> None:
    parser.add_argument("--levels", type=positive, default=4,
                        help="mesh levels, n = coarsest·2^l (default 4; with two or more, the finest is the "
                             "reference of the mesh errors)")
    parser.add_argument("--coarsest", type=positive, default=8,
                        help="contact-zone elements per unit length at level 0 (default 8)")
    parser.add_argument("--orders", type=choices_list(("1", "2")), default=("1",),
                        help="the displacements' degrees, comma-separated: each case at each (default 1)")
    parser.add_argument("--adapt-targets", type=fractions_list, default=(), metavar="E1,E2,...",
                        help="also run the cases same and dissimilar on adapted meshes: an `orchestrate adapt` loop "
                             "per target (the relative estimate to reach, comma-separated, e.g. 0.02,0.01) and degree")
    parser.add_argument("--pilot", type=positive, default=None,
                        help="with --adapt-targets: the adapt loops' pilot meshes, the scene's at this n (default 4)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a scene value for every run, as run --set (e.g. a smaller approach, --set "
                             "'body2.boundary.1.value=\"-0.05*min(t, 1)\"'); not the meshes' n, the degree or "
                             "the images, which the study sets")
    parser.add_argument("--out", default=None, help="output folder (default results/hertz, results/hertz-order with "
                                                    "degree 2 among --orders)")
    add_force_argument(parser, f"study {NAME}")


def command(options) -> int:
    import sys

    if options.pilot is not None and not options.adapt_targets:
        raise InputError("--pilot sets the adapt loops' pilot meshes: give it with --adapt-targets")
    options.out = options.out or ("results/hertz-order" if "2" in options.orders else "results/hertz")
    hertz(options.out, options.levels, options.coarsest, progress=sys.stderr.isatty(), force=options.force,
          orders=tuple(sorted(int(order) for order in options.orders)), settings=parse_assignments(options.set, "--set"),
          adapt_targets=options.adapt_targets, pilot=options.pilot or 4)
    print((Path(options.out) / "README.md").read_text())
    return 0
