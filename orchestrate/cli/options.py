"""What the commands' options share: the types of their values and the options several commands
take (--force, --trust-geo, a study's --out)."""
from __future__ import annotations

import argparse

from orchestrate.outputs import RECORD


def add_force_argument(parser, command: str, single_file: bool = False) -> None:
    """--force, for a command that writes a folder (or, `single_file`, one file) outside a run."""
    if single_file:
        replaced = "the --out file if this program wrote it (an image it drew, a page it generated), never a link"
    else:
        replaced = (f"the files an earlier `{command}` wrote in --out (its {RECORD} lists them); a folder that holds "
                    "anything else is refused, and nothing is written through a link")
    parser.add_argument("--force", action="store_true", help=f"replace {replaced}")


def add_trust_geo(parser) -> None:
    parser.add_argument("--trust-geo", action="store_true",
                        help="on a kernel without Landlock, mesh the scene's own .geo files all the same: gmsh then "
                             "runs them unconfined, and a .geo can run programs and read or write your files")


def positive(text: str) -> int:
    """An integer ≥ 1 for --workers and --levels-like options."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is not allowed: give an integer >= 1")
    return value


def at_least_two(text: str) -> int:
    value = positive(text)
    if value < 2:
        raise argparse.ArgumentTypeError("a ladder needs at least 2 levels (the finest is the reference)")
    return value


def fraction(text: str) -> float:
    """A relative estimate to reach, in (0, 1), for adapt's --target."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"{text}: give the relative estimate to reach, in (0, 1), e.g. 0.01")
    return value


def fractions_list(text: str) -> tuple[float, ...]:
    """Distinct relative estimates, comma-separated, for --adapt-targets-like options."""
    values = tuple(fraction(piece.strip()) for piece in text.split(","))
    if len(set(values)) != len(values):
        raise argparse.ArgumentTypeError(f"'{text}' lists a target twice")
    return values


def choices_list(allowed) -> callable:
    """A comma-separated list of distinct words among `allowed`, for --ladders-like options."""
    def parse(text: str) -> list[str]:
        words = [word.strip() for word in text.split(",")]
        for word in words:
            if word not in allowed:
                raise argparse.ArgumentTypeError(f"'{word}' is not one of {', '.join(allowed)}")
        if len(set(words)) != len(words):
            raise argparse.ArgumentTypeError(f"'{text}' lists a word twice")
        return words
    return parse


def add_study_out(parser, name: str) -> None:
    """--out and --force of `study NAME`, whose results go to results/NAME by default."""
    parser.add_argument("--out", default=f"results/{name}", help=f"output folder (default results/{name})")
    add_force_argument(parser, f"study {name}")


def run_study(study, options, *arguments) -> int:
    """`study(--out, *arguments)` with --force and a progress bar where one can be seen, then its
    README.md printed."""
    import sys
    from pathlib import Path

    study(options.out, *arguments, progress=sys.stderr.isatty(), force=options.force)
    print((Path(options.out) / "README.md").read_text())
    return 0
