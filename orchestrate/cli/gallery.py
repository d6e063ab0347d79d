"""The command line of `orchestrate.studies.gallery`: its arguments and what the command does with them."""
from __future__ import annotations

import sys

from orchestrate.studies.gallery import SCENES, gallery

NAME, HELP = "gallery", "run the gallery scenes into results/gallery"


def add_arguments(parser) -> None:
    parser.add_argument("names", nargs="*", metavar="NAME", help=f"some of {', '.join(SCENES)} (default: all)")
    parser.add_argument("--out", default="results/gallery", help="where the scenes' folders go")
    parser.add_argument("--force", action="store_true",
                        help="replace the scenes' run folders there (only folders of runs, as `run --force`)")


def command(options) -> int:
    for name, folder in gallery(options.names, options.out, options.force, progress=sys.stderr.isatty()).items():
        print(f"{name}: {folder}")
    return 0
