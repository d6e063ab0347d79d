"""The command line of `orchestrate.studies.cantilever`: its arguments and what the command does with them."""
from __future__ import annotations

from pathlib import Path

from orchestrate.cli.options import add_force_argument
from orchestrate.studies.cantilever import NAME, cantilever

HELP = "a cantilever peel: the force on the propagation branch and the front's start against beam theory"


def add_arguments(parser) -> None:
    parser.add_argument("--out", default="results/cantilever", help="output folder (default results/cantilever)")
    add_force_argument(parser, f"study {NAME}")


def command(options) -> int:
    import sys

    cantilever(options.out, progress=sys.stderr.isatty(), force=options.force)
    print((Path(options.out) / "README.md").read_text())
    return 0
