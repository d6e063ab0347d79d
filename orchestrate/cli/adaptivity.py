"""The command line of `orchestrate.studies.adaptivity`: its arguments and what the command does with them."""
from __future__ import annotations

from orchestrate.cli.options import add_study_out, run_study
from orchestrate.studies.adaptivity import NAME, adaptivity

HELP = "adapted meshes on the paper's scene: the estimate against the true error, per cycle and target"


def add_arguments(parser) -> None:
    add_study_out(parser, NAME)


def command(options) -> int:
    return run_study(adaptivity, options)
