"""The command line of `orchestrate.plot`: its arguments and what the command does with them."""
from __future__ import annotations

from orchestrate.cli.options import add_force_argument
from orchestrate.plot import MEASURED, plot_sweep

NAME, HELP = "plot", "draw a figure of a sweep (sweep.csv) against a swept value"


def add_arguments(parser) -> None:
    parser.add_argument("sweep", metavar="SWEEP", help="a sweep folder (the --out of `sweep`)")
    parser.add_argument("--y", required=True, choices=MEASURED, metavar="FIGURE",
                        help=f"the figure drawn: one of {', '.join(MEASURED)}")
    parser.add_argument("--x", metavar="KEY", help="the swept key along the axis (default: the first swept key); the other swept "
                                    "keys give one curve per combination")
    parser.add_argument("--log", choices=("none", "x", "y", "xy"), default="none", help="which axes are logarithmic")
    parser.add_argument("--out", help="the image file, .png, .pdf or .svg (default: <SWEEP>/<FIGURE>-vs-<KEY>.png); "
                                      "an existing one is replaced only with --force")
    add_force_argument(parser, NAME, single_file=True)


def command(options) -> int:
    target = plot_sweep(options.sweep, options.y, options.x, options.out, options.log, force=options.force)
    print(f"image: {target}")
    return 0
