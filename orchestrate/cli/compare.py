"""The command line of `orchestrate.compare`: its arguments and what the command does with them."""
from __future__ import annotations

from pathlib import Path

from orchestrate.cli.options import add_force_argument
from orchestrate.compare import FILES, NAME, compare, write
from orchestrate.freefem import InputError
from orchestrate.outputs import refuse_folder

HELP = "differences of two runs in the model's norms, and their histories overlaid"


def add_arguments(parser) -> None:
    parser.add_argument("run_a", metavar="RUN_A", help="a run folder (with state files: output.fields \"state\")")
    parser.add_argument("run_b", metavar="RUN_B", help="another run of the same bodies")
    parser.add_argument("--out", help="a new folder for comparison.csv, report.txt and history.png "
                                      "(default: compare-<A>-<B> in the current folder)")
    add_force_argument(parser, NAME)


def command(options) -> int:
    if Path(options.run_a).resolve() == Path(options.run_b).resolve():  # compare() itself takes one: a self-check
        raise InputError(f"RUN_A and RUN_B are both {options.run_a}: give two runs (a run's distance to itself is 0)")
    out = Path(options.out or f"compare-{Path(options.run_a).resolve().name}-{Path(options.run_b).resolve().name}")
    refuse_folder(out, NAME, options.force)  # before the comparison, which takes a FreeFem++ run
    comparison = compare(options.run_a, options.run_b)
    write(comparison, out, force=options.force)
    print(comparison.report())
    print(f"files: {', '.join(str(out / name) for name in FILES)}")
    return 0
