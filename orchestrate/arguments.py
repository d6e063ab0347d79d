"""What the commands' options take, as values: key=value assignments (read as TOML reads values)
and the number and word-list types of argparse options. Used by the command line and by the
modules whose commands it assembles, below all of them (the CLI imports them, never the reverse).
"""
from __future__ import annotations

import argparse
import re

from orchestrate.scene import SceneError, parse_value


# KEY=VALUE split at the first '=' outside brackets: a key may name a boundary condition by its
# label, body1.boundary[label=4].fy (scene.py, LABELLED).
ASSIGNMENT = re.compile(r"((?:[^=\[]|\[[^\]]*\])+)=(.*)", re.S)


def split_assignment(item: str, option: str, form: str, example: str) -> tuple[str, str]:
    """`KEY=VALUE` as its key and value text, both stripped; else an error showing the form."""
    match = ASSIGNMENT.fullmatch(item)
    if not match or not match[1].strip():
        raise SceneError(f"{option} {item!r}: expected {form}, e.g. {option} {example}")
    return match[1].strip(), match[2].strip()


def parse_assignments(items: list[str], option: str) -> dict:
    """key=value strings as a dict (values read as TOML would: numbers, booleans, strings)."""
    assignments = {}
    for item in items:
        key, value = split_assignment(item, option, "key=value", "time.N=80")
        if key in assignments:
            raise SceneError(f"{option} {key} is given twice: give it once")
        assignments[key] = parse_value(value)
    return assignments


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
