"""The command line of `orchestrate.render`: its arguments and what the command does with them."""
from __future__ import annotations

import math
from pathlib import Path

from orchestrate.cli.options import add_force_argument
from orchestrate.freefem import InputError
from orchestrate.outputs import claim_folder, refuse_folder
from orchestrate.render import FIELDS, IMAGES, render_all
from orchestrate.results import load_result
from orchestrate.schema import shown

NAME, HELP = "render", "images of a run folder"


def number_pair(text: str) -> tuple[float, float]:
    """'a,b' as two finite numbers, for --range."""
    import argparse

    parts = text.split(",")
    try:
        values = tuple(float(part) for part in parts)
    except ValueError:
        values = ()
    if len(values) != 2 or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"'{text}' is not two numbers a,b")
    return values


# The most pixels an image may hold: matplotlib's Agg needs about 4 bytes each, twice (300 MP: 2.4 GB).
MAX_PIXELS = 300e6


def figure_size(text: str) -> tuple[float, float]:
    """--size W,H: two positive numbers (inches)."""
    import argparse

    width, height = number_pair(text)
    if not (0 < width <= 100 and 0 < height <= 100):
        raise argparse.ArgumentTypeError(f"'{text}': give a width and a height in (0, 100] inches")
    return width, height


def resolution(text: str) -> int:
    import argparse

    if not text.isdigit() or not 10 <= int(text) <= 2400:
        raise argparse.ArgumentTypeError(f"'{text}': give dots per inch, an integer in [10, 2400]")
    return int(text)


def field_list(text: str) -> tuple[str, ...]:
    import argparse

    names = tuple(name.strip() for name in text.split(","))
    unknown = [name for name in names if name not in FIELDS]
    if unknown or not names:
        raise argparse.ArgumentTypeError(f"no field {shown(', '.join(unknown), False) or repr('')} (fields: "
                                         f"{', '.join(FIELDS)})")
    if len(set(names)) < len(names):
        raise argparse.ArgumentTypeError(f"'{text}' names a field twice: each is one panel")
    return names


def colour_ranges(text: str):
    """--range: shared, per-body, or FIELD=LOW,HIGH (repeatable: one field each)."""
    import argparse

    if text in ("shared", "per-body"):
        return text
    field, equals, pair = text.partition("=")
    if not equals or field not in FIELDS:
        raise argparse.ArgumentTypeError(f"'{text}': give shared, per-body, or FIELD=LOW,HIGH with FIELD one of "
                                         f"{', '.join(FIELDS)} (e.g. sigma22=-20,20)")
    low, high = number_pair(pair)
    if not low < high:
        raise argparse.ArgumentTypeError(f"'{text}': give LOW < HIGH")
    return {field: (low, high)}


def add_arguments(parser) -> None:
    parser.add_argument("folder", help="a run folder (with history.csv and .vtu files)")
    parser.add_argument("--out", help="a new folder for the images (default: the run folder)")
    add_force_argument(parser, NAME)
    parser.add_argument("--time", type=float, metavar="T",
                        help="the output time of fields.* and contact_line.* (default: the last): one the run wrote, "
                             "within 1e-9·T; another is refused, naming the nearest")
    parser.add_argument("--fields", type=field_list, default=("vonMises", "zeta"), metavar="F1,F2",
                        help=f"the fields of fields.*, comma-separated (default vonMises,zeta; of {', '.join(FIELDS)})")
    parser.add_argument("--magnification", type=float, metavar="M",
                        help="displacements drawn magnified by this (default: a round factor that makes the largest "
                             "5 %% of the scene; 0: undeformed)")
    parser.add_argument("--range", type=colour_ranges, action="append", dest="ranges", metavar="RANGE",
                        help="colour ranges: shared (one bar for both bodies, default), per-body, or FIELD=LOW,HIGH "
                             "for one field (repeat for others), e.g. --range sigma22=-20,20")
    parser.add_argument("--cmap", metavar="NAME", help="a matplotlib colormap for every field (default viridis, magma for damage)")
    parser.add_argument("--size", type=figure_size, metavar="W,H", help="the size of fields.* in inches, width,height "
                                                         "(default: from the scene's shape)")
    parser.add_argument("--format", choices=("png", "pdf", "svg"), default="png", dest="image_format",
                        help="file format of every image (default png)")
    parser.add_argument("--dpi", type=resolution, help="resolution of every png image (default: 150 for fields, "
                                                       "about 110 for the plots)")


def command(options) -> int:
    import matplotlib

    if options.cmap and options.cmap not in matplotlib.colormaps:
        raise InputError(f"--cmap {shown(options.cmap, False)}: not a matplotlib colormap (for example viridis, magma, "
                         "cividis)")
    if options.magnification is not None and not (math.isfinite(options.magnification) and options.magnification >= 0):
        raise InputError(f"--magnification {options.magnification}: give a finite number >= 0 (0: undeformed)")
    ranges, given = "shared", {}
    for choice in options.ranges or []:
        if isinstance(choice, dict):
            given.update(choice)
        else:
            ranges = choice
    if given and ranges == "per-body":
        raise InputError("--range per-body and --range FIELD=LOW,HIGH: give one kind")
    if options.size and options.dpi and options.size[0] * options.size[1] * options.dpi ** 2 > MAX_PIXELS:
        raise InputError(f"--size {options.size[0]:g},{options.size[1]:g} at --dpi {options.dpi}: "
                         f"{options.size[0] * options.size[1] * options.dpi ** 2 / 1e6:,.0f} megapixels, more than the "
                         f"{MAX_PIXELS / 1e6:,.0f} an image can be drawn with here: lower either")
    if options.out:
        refuse_folder(Path(options.out), NAME, options.force)  # before the run folder is read
    result = load_result(options.folder)
    if options.time is not None:
        result.output_at(options.time, option="--time")  # refused before an image is drawn
    folder = Path(options.folder)
    if options.out:
        folder = claim_folder(Path(options.out), NAME, [f"{name}.{options.image_format}" for name in IMAGES],
                              options.force)
    for path in render_all(result, folder, options.image_format, options.dpi,
                           time=options.time, fields=options.fields, magnification=options.magnification,
                           ranges=given or ranges, cmap=options.cmap, size=options.size):
        print(f"wrote {path}")
    return 0
