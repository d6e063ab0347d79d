"""python -m orchestrate {run,sweep,plot,render,compare,gallery,study,bench,reference}: scenes,
parameter sweeps and their plots, images, runs compared, the gallery, studies, the benchmark and
the scene format's reference from the shell.

Each command lives in its module, which offers its own arguments (add_arguments) and handler
(command); this file only assembles them and turns errors into one message and an exit code.
"""
from __future__ import annotations

import argparse
import importlib
import re
import sys

from orchestrate.freefem import InputError, SolverError
from orchestrate.mesh import MeshError
from orchestrate.scene import SceneError, parse_value

COMMANDS = ("orchestrate.runner", "orchestrate.sweep", "orchestrate.plot", "orchestrate.render", "orchestrate.compare",
            "orchestrate.gallery", "orchestrate.bench", "orchestrate.reference")
STUDIES = ("orchestrate.convergence", "orchestrate.stability", "orchestrate.hertz")


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


class DefaultsShown(argparse.HelpFormatter):
    """Help that ends every option with its default, unless its text already gives it."""

    def _get_help_string(self, action):
        text = action.help or ""
        shown = action.default not in (None, False, [], (), argparse.SUPPRESS) and action.option_strings
        if shown and "default" not in text:
            text += (" " if text else "") + "(default: %(default)s)"
        return text


def add_commands(subparsers, modules) -> None:
    for name in modules:
        module = importlib.import_module(name)
        parser = subparsers.add_parser(module.NAME, help=module.HELP, description=module.HELP,
                                       formatter_class=DefaultsShown)
        module.add_arguments(parser)
        parser.set_defaults(handler=module.command)


def parser() -> argparse.ArgumentParser:
    top = argparse.ArgumentParser(prog="python -m orchestrate", description=__doc__.split("\n\n")[0])
    commands = top.add_subparsers(dest="command", required=True)
    add_commands(commands, COMMANDS)
    study = commands.add_parser("study", help="studies of a scene: convergence, stability, hertz")
    add_commands(study.add_subparsers(dest="kind", required=True), STUDIES)
    return top


def main(argv: list[str] | None = None) -> int:
    options = parser().parse_args(argv)
    try:
        return options.handler(options)
    except SolverError as error:
        print(f"error: {error}\n{error.log_tail}", file=sys.stderr)
        return error.returncode if error.returncode > 0 else 1
    except (InputError, MeshError, FileNotFoundError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except RuntimeError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
