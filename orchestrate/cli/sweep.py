"""The command line of `orchestrate.sweep`: its arguments and what the command does with them."""
from __future__ import annotations

from pathlib import Path

from orchestrate.arguments import parse_assignments
from orchestrate.cli.options import add_trust_geo, positive
from orchestrate.sweep import MAX_UNASKED, grid_of, read_table, sweep

NAME, HELP = "sweep", "run the cartesian product of overrides on dask.distributed"


def add_arguments(parser) -> None:
    parser.add_argument("scene", help="a scene file, e.g. scenes/paper.toml")
    parser.add_argument("--grid", action="append", default=[], metavar="KEY=[V1, V2, ...]",
                        help="values of one scene key: a TOML list, which takes any value (expressions as strings "
                             "in quotes, commas and all: --grid 'body1.boundary[label=4].fy=[\"-10*min(t, 0.5)\", "
                             "\"-20*t\"]'), or plain values split at every comma (--grid time.N=20,40; a piece of "
                             "an expression cut at a comma is refused). A boundary condition is named by its label "
                             "(body1.boundary[label=4].fy, preferred: it survives reordering) or its 0-based index "
                             "(body1.boundary.1.fy). The runs are the product of every key's values")
    parser.add_argument("--grid-file", metavar="FILE",
                        help="a TOML file of scene keys and their lists of values, for many values: one key a line, "
                             "'\"body1.boundary[label=4].fy\" = [\"-10*t\", \"-20*t\"]', or tables "
                             "('[glue]' then 'gammaNu = [0, 1]'); with --grid, whose keys come after its own (a key "
                             "in both is refused)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override for every run (keys as for --grid)")
    parser.add_argument("--out", default="results/sweep",
                        help="sweep folder (default results/sweep); a sweep into the folder of an earlier one adds its "
                             "rows to that one's sweep.csv")
    parser.add_argument("--workers", type=positive, default=2, help="LocalCluster workers (default 2)")
    parser.add_argument("--scheduler", help="address of an existing dask scheduler, e.g. tcp://host:8786")
    parser.add_argument("--yes", action="store_true",
                        help=f"run a grid of more than {MAX_UNASKED} combinations (refused without it: likely a "
                             "slip)")
    parser.add_argument("--images", action="store_true",
                        help="render every run's images (off by default: a sweep's figures are in sweep.csv, and "
                             "`render` draws any run's images later)")
    add_trust_geo(parser)


def command(options) -> int:
    import sys

    base = parse_assignments(options.set, "--set")
    grid = grid_of(options.grid, options.grid_file)
    if not options.images and "output.images" not in grid:
        base.setdefault("output.images", False)
    rows = sweep(options.scene, grid, options.out, base,
                 workers=options.workers, scheduler=options.scheduler, progress=sys.stderr.isatty(), yes=options.yes,
                 trust_geo=options.trust_geo)
    width = max(len(row["folder"]) for row in rows)
    for row in rows:
        figure = f"normV(T) = {row['normV']:.6g}" if row.get("normV") is not None else row.get("error", "")
        print(f"{row['folder']:<{width}}  {row['status']:<18}  {figure}")
    table = Path(options.out) / "sweep.csv"
    earlier = len(read_table(table)[1]) - len(rows)
    print(f"table: {table}" + (f" (with the {earlier} rows of earlier sweeps into {options.out})" if earlier else ""))
    return 0 if all(row["status"] in ("completed", "skipped (complete)") for row in rows) else 1
