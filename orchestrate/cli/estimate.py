"""The command line of `orchestrate.estimate`: its arguments and what the command does with them."""
from __future__ import annotations

from orchestrate.estimate import NAME, estimate, report

HELP = "a run's space error in ‖·‖_V, estimated from its own states (Zienkiewicz–Zhu recovery of the strains)"


def add_arguments(parser) -> None:
    parser.add_argument("run", metavar="RUN", help="a run folder (with state files: output.fields \"state\")")


def command(options) -> int:
    print(report(estimate(options.run)))
    return 0
