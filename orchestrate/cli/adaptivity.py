"""The command line of `orchestrate.studies.adaptivity`: its arguments and what the command does with them."""
from __future__ import annotations

from orchestrate.cli.options import add_force_argument, run_study
from orchestrate.studies.adaptivity import NAME, SIZES, adaptivity

HELP = "adapted meshes on the paper's scene: the estimate against the true error, per cycle and target"


def add_arguments(parser) -> None:
    parser.add_argument("--order", type=int, choices=(1, 2), default=1,
                        help="the displacements' degree of the adapted runs (space.order; default 1)")
    parser.add_argument("--out", default=None, help=f"output folder (default results/{NAME}, results/{NAME}-order2 "
                                                    "with --order 2)")
    add_force_argument(parser, f"study {NAME}")


def command(options) -> int:
    options.out = options.out or f"results/{NAME}" + ("-order2" if options.order == 2 else "")
    return run_study(adaptivity, options, SIZES[options.order], options.order)
