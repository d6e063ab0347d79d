"""The gallery: every scene of docs/gallery.md at its own resolution, into results/gallery/<name>."""
from __future__ import annotations

import sys
from pathlib import Path

from orchestrate.freefem import REPO
from orchestrate.scene import SceneError

SCENES = ("paper", "peel", "indentation", "shear", "tilted_patch", "polymer_pad", "hertz", "punch", "precrack")

NAME, HELP = "gallery", "run the gallery scenes into results/gallery"


def add_arguments(parser) -> None:
    parser.add_argument("names", nargs="*", metavar="NAME", help=f"some of {', '.join(SCENES)} (default: all)")
    parser.add_argument("--out", default="results/gallery", help="where the scenes' folders go")


def command(options) -> int:
    from orchestrate.runner import run

    unknown = [name for name in options.names if name not in SCENES]
    if unknown:
        raise SceneError(f"no gallery scene {', '.join(unknown)} (the gallery: {', '.join(SCENES)})")
    for name in options.names or SCENES:
        result = run(REPO / "scenes" / f"{name}.toml", Path(options.out) / name, force=True, progress=sys.stderr.isatty())
        if name == "hertz":  # its comparison with the analytic solution, as in results/hertz
            from orchestrate.hertz import gallery_figures

            gallery_figures(result, result.folder)
        print(f"{name}: {result.folder}")
    return 0
