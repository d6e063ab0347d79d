"""The command line of `orchestrate.studies.adaptivity`: its arguments and what the command does with them."""
from __future__ import annotations

from orchestrate.cli.options import add_study_out, run_study
from orchestrate.studies.adaptivity import NAME, SIZES, adaptivity

HELP = "adapted meshes on the paper's scene: the estimate against the true error, per cycle and target"


def add_arguments(parser) -> None:
    parser.add_argument("--order", type=int, choices=(1, 2), default=1,
                        help="the displacements' degree of the adapted runs (space.order; default 1)")
    add_study_out(parser, NAME)


def command(options) -> int:
    return run_study(adaptivity, options, SIZES[options.order], options.order)
