"""The command line of `orchestrate.studies.bench`: its arguments and what the command does with them."""
from __future__ import annotations

import argparse

from pathlib import Path

from orchestrate.cli.options import add_force_argument, at_least_two
from orchestrate.studies.bench import ADAPT_TARGETS, NAME, TARGETS, bench, number

HELP = "run time against error on this machine, every scheme on uniform and graded meshes, bdf2 on adapted ones (results/bench)"


def add_arguments(parser) -> None:
    parser.add_argument("--levels", type=at_least_two, default=5,
                        help="measured graded levels (default 5: h1 = 6/6 ... 6/96); the reference is the graded "
                             "level two finer")
    parser.add_argument("--uniform-levels", type=at_least_two, default=None,
                        help="measured uniform levels (default: as many as --levels)")
    parser.add_argument("--time-fraction", type=unit_fraction, default=0.25,
                        help="the time error each level's N aims at, as a fraction of the level's space error "
                             "(default 0.25)")
    parser.add_argument("--targets", type=percentages, default=TARGETS, metavar="P1,P2,...",
                        help="errors in %% to find the fastest run for: between the two levels that bracket each, "
                             "the coarsest mesh that reaches it is searched; a target no two levels bracket is not "
                             "(default 1,0.2)")
    parser.add_argument("--adapt-targets", type=percentages, default=ADAPT_TARGETS, metavar="P1,P2,...",
                        help="estimates in %% that `adapt` designs bdf2's adapted meshes for, from the uniform "
                             "pilot (default 5,2,1,0.5)")
    parser.add_argument("--out", default="results/bench", help="a new folder for the table, report and plot")
    add_force_argument(parser, NAME)


def command(options) -> int:
    bench(options.out, levels=options.levels, fraction=options.time_fraction, uniform_levels=options.uniform_levels,
          targets=options.targets, adapt_targets=options.adapt_targets, force=options.force)
    print((Path(options.out) / "README.md").read_text())
    return 0


def unit_fraction(text: str) -> float:
    value = number(text)
    if not 0 < value <= 1:
        raise argparse.ArgumentTypeError(f"{text!r}: a number in (0, 1]")
    return value


def percentages(text: str) -> tuple[float, ...]:
    values = []
    for piece in text.split(","):
        value = number(piece)
        if not 0 < value < 100:
            raise argparse.ArgumentTypeError(f"{piece.strip()!r}: each target error is a percentage in (0, 100)")
        if value / 100 in values:
            raise argparse.ArgumentTypeError(f"{piece.strip()!r} is listed twice")
        values.append(value / 100)
    return tuple(values)
