"""The command line of `orchestrate.studies.stability`: its arguments and what the command does with them."""
from __future__ import annotations

import argparse

from pathlib import Path

from orchestrate.cli.options import add_force_argument
from orchestrate.studies.stability import GLUE_STIFFNESSES, NAME, YOUNG, listed, stability

HELP = "predicted against observed explicit time-step bound"


def add_arguments(parser) -> None:
    parser.add_argument("scene", nargs="?", default="scenes/paper.toml", help="the scene whose data it varies "
                                                                              "(default: scenes/paper.toml)")
    parser.add_argument("--out", default="results/stability", help="a new folder for the table, report and plot")
    add_force_argument(parser, f"study {NAME}")
    parser.add_argument("--young", type=positive_values, default=listed(YOUNG), metavar="E1,E2,...",
                        help="Young's moduli of the cases of the elastic bound (each with and without damage) "
                             "and of the implicit schemes ('' leaves them out)")
    parser.add_argument("--p-tau", type=positive_values, default=listed(GLUE_STIFFNESSES), metavar="P1,P2,...",
                        help="tangential glue stiffnesses p_τ of the glue-bound cases, per scheme ('' leaves them out)")


def command(options) -> int:
    import sys

    stability(options.scene, options.out, young=options.young, glue=options.p_tau, progress=sys.stderr.isatty(),
              force=options.force)
    print((Path(options.out) / "README.md").read_text())
    return 0


def positive_values(text: str) -> tuple[float, ...]:
    """A comma-separated list of positive numbers, or nothing (that family of cases left out)."""
    try:
        values = tuple(float(item) for item in text.split(",") if item.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a comma-separated list of numbers") from None
    if any(not value > 0 for value in values):
        raise argparse.ArgumentTypeError(f"'{text}': every value must be > 0")
    return values
