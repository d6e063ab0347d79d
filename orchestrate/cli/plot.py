"""The command line of `orchestrate.plot`: its arguments and what the command does with them."""
from __future__ import annotations

from orchestrate.cli.options import add_force_argument
from orchestrate.plot import MEASURED, is_sweep, plot_columns, plot_sweep, read_sweep

NAME, HELP = ("plot", "draw a sweep's final figure against a swept value, or two history columns of a run (or of "
                      "each run of a sweep) against each other")


def add_arguments(parser) -> None:
    parser.add_argument("source", metavar="SOURCE", help="a sweep folder (the --out of `sweep`) or a run folder")
    parser.add_argument("--y", required=True, metavar="FIGURE",
                        help=f"a sweep's figure drawn against a swept key: one of {', '.join(MEASURED)}; or a column of "
                             "history.csv (normV, forceY1, betaMean, ...) drawn against --x, for each run")
    parser.add_argument("--x", metavar="KEY", help="a swept key (default: the first swept key; the other swept keys give "
                                                   "one curve per combination), or a column of history.csv (default for a "
                                                   "run folder, or for a --y that is no sweep figure: t)")
    parser.add_argument("--log", choices=("none", "x", "y", "xy"), default="none",
                        help="which axes are logarithmic (refused for an axis with a value <= 0, or of words)")
    parser.add_argument("--out", help="the image file, .png, .pdf or .svg (default: a sweep's <SOURCE>/<FIGURE>-vs-<KEY>.png, "
                                      "beside a run folder <SOURCE>-<FIGURE>-vs-<KEY>.png; its folder is made if new); "
                                      "an existing one is replaced only with --force")
    add_force_argument(parser, NAME, single_file=True)


def command(options) -> int:
    if is_sweep(options.source) and options.y in MEASURED and (options.x is None or options.x in read_sweep(options.source)[0]):
        target = plot_sweep(options.source, options.y, options.x, options.out, options.log, force=options.force)
    else:
        target = plot_columns(options.source, options.y, options.x or "t", options.out, options.log, force=options.force)
    print(f"image: {target}")
    return 0
