"""The command line of `orchestrate.studies.modeone`: its arguments and what the command does with them."""
from __future__ import annotations

from orchestrate.cli.options import add_study_out, run_study
from orchestrate.studies.modeone import NAME, STEPS, mode_one

HELP = "one adhesive interface opened in mode I: the work of separation against G_c"


def steps(text: str) -> tuple[int, ...]:
    import argparse

    try:
        values = tuple(int(item) for item in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: give step counts as integers, e.g. 100,200") from None
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: give positive step counts, e.g. 100,200")
    return values


def add_arguments(parser) -> None:
    parser.add_argument("--steps", type=steps, default=STEPS, help="the ladder of N, comma-separated "
                                                                   f"(default {','.join(map(str, STEPS))})")
    add_study_out(parser, NAME)


def command(options) -> int:
    return run_study(mode_one, options, options.steps)
