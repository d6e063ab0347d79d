"""The command line of `orchestrate.studies.bench`: its arguments and what the command does with them."""
from __future__ import annotations

import argparse

from pathlib import Path

from orchestrate.cli.options import add_force_argument, at_least_two, choices_list
from orchestrate.studies.bench import ADAPT_TARGETS, DEGREES, NAME, TARGETS, bench, number

HELP = ("run time against error on this machine, every scheme on uniform and graded meshes, bdf2 on adapted ones, "
        "displacements of degree 1 and 2 (results/bench)")


def add_arguments(parser) -> None:
    parser.add_argument("--levels", type=at_least_two, default=5,
                        help="measured graded levels at degree 1 (default 5: h1 = 6/6 ... 6/96), one fewer at "
                             "degree 2, two at least (its level l has the nodes of degree 1's l + 1); the reference is the graded "
                             "level two finer than the finest measured at the highest degree, at that degree")
    parser.add_argument("--uniform-levels", type=at_least_two, default=None,
                        help="measured uniform levels at degree 1 (default: as many as --levels), one fewer at "
                             "degree 2, two at least")
    parser.add_argument("--degrees", type=choices_list(("1", "2")), default=[str(d) for d in DEGREES], metavar="1,2",
                        help="the degrees of the displacements to measure (space.order; default 1,2)")
    parser.add_argument("--time-fraction", type=unit_fraction, default=0.25,
                        help="the time error each level's N aims at, as a fraction of the level's space error "
                             "(default 0.25)")
    parser.add_argument("--targets", type=percentages, default=TARGETS, metavar="E1,E2,...",
                        help="errors in %% to find the fastest run for: between the two levels that bracket each, "
                             "the coarsest mesh that reaches it is searched; a target no two levels bracket is not "
                             "(default 1,0.2)")
    parser.add_argument("--adapt-targets", type=percentages, default=ADAPT_TARGETS[1], metavar="E1,E2,...",
                        help="estimates in %% that `adapt` designs bdf2's adapted meshes for at degree 1, from the "
                             "uniform pilot (default 5,2,1,0.5)")
    parser.add_argument("--adapt-targets-p2", type=percentages, default=ADAPT_TARGETS[2], metavar="E1,E2,...",
                        help="the same at degree 2, from the uniform pilot at half its n (n1 = 12, n2 = 16: the same "
                             "nodes) (default 0.5,0.2,0.1,0.05; the estimate is about 0.6 times the error at "
                             "degree 2)")
    parser.add_argument("--out", default="results/bench", help="a new folder for the table, report and plot")
    add_force_argument(parser, NAME)


def command(options) -> int:
    bench(options.out, levels=options.levels, fraction=options.time_fraction, uniform_levels=options.uniform_levels,
          targets=options.targets, adapt_targets={1: options.adapt_targets, 2: options.adapt_targets_p2},
          degrees=tuple(sorted(int(degree) for degree in options.degrees)), force=options.force)
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
