"""The command line of `orchestrate.studies.cantilever`: its arguments and what the command does with them."""
from __future__ import annotations

from orchestrate.cli.options import add_study_out, run_study
from orchestrate.studies.cantilever import NAME, cantilever

HELP = "a cantilever peel: the force on the propagation branch and the front's start against beam theory"


def add_arguments(parser) -> None:
    add_study_out(parser, NAME)


def command(options) -> int:
    return run_study(cantilever, options)
