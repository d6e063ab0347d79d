"""The gallery: every scene of docs/gallery.md at its own resolution, into results/gallery/<name>."""
from __future__ import annotations

import sys
from pathlib import Path

from orchestrate.freefem import REPO
from orchestrate.runner import refuse_existing, run
from orchestrate.scene import SceneError
from orchestrate.studies.hertz import gallery_figures

SCENES = ("paper", "peel", "indentation", "shear", "tilted_patch", "polymer_pad", "hertz", "punch", "precrack")

NAME, HELP = "gallery", "run the gallery scenes into results/gallery"


def add_arguments(parser) -> None:
    parser.add_argument("names", nargs="*", metavar="NAME", help=f"some of {', '.join(SCENES)} (default: all)")
    parser.add_argument("--out", default="results/gallery", help="where the scenes' folders go")
    parser.add_argument("--force", action="store_true",
                        help="replace the scenes' run folders there (only folders of runs, as `run --force`)")


def command(options) -> int:
    unknown = [name for name in options.names if name not in SCENES]
    if unknown:
        raise SceneError(f"no gallery scene {', '.join(unknown)} (the gallery: {', '.join(SCENES)})")
    folders = {name: Path(options.out).absolute() / name for name in options.names or SCENES}
    for folder in folders.values():  # every one now, not after the runs before it
        refuse_existing(folder, options.force)
    for name, folder in folders.items():
        result = run(REPO / "scenes" / f"{name}.toml", folder, force=options.force, progress=sys.stderr.isatty())
        if name == "hertz":  # its comparison with the analytic solution, as in results/hertz

            gallery_figures(result, result.folder)
        print(f"{name}: {result.folder}")
    return 0
