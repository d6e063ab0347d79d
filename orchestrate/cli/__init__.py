"""python -m orchestrate {run,sweep,plot,render,compare,estimate,adapt,gallery,study,bench,
reference,commit-mesh}: scenes, parameter sweeps and their plots, images, runs compared, a run's
error estimated, meshes adapted to it, the gallery, studies, the benchmark, the scene format's
reference and the committed meshes from the shell.

Each command has a module here (orchestrate/cli/NAME.py: its arguments, add_arguments, and what
it does with them, command), over the package's functions; argparse stays in this folder. This
file assembles them and turns errors into one message and an exit code.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from orchestrate.freefem import FILE_PROBLEM, FileProblem, InputError, SolverError, file_problem
from orchestrate.mesh import MeshError

COMMANDS = tuple(f"orchestrate.cli.{name}" for name in
                 ("run", "sweep", "plot", "render", "compare", "estimate", "adapt", "gallery", "bench", "reference",
                  "commitmesh"))
STUDIES = tuple(f"orchestrate.cli.{name}" for name in
                ("convergence", "stability", "hertz", "modeone", "cantilever", "adaptivity"))


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


def named(argv: list[str], modules) -> tuple[str, ...] | None:
    """The module of the command argv starts with, if it is one of `modules` and argv names it as
    it is spelled (a near miss gets the whole list from argparse). A command's module is its name
    without hyphens (mode-one: orchestrate.cli.modeone)."""
    module = f"orchestrate.cli.{argv[0].replace('-', '')}" if argv else None
    return (module,) if module in modules and importlib.import_module(module).NAME == argv[0] else None


def parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The command line's parser: given argv that names a command, with that command alone (a
    command imports only what it uses: `run` never imports matplotlib); else with every command
    (help, or a typo, which argparse answers with the list)."""
    wanted, studies = COMMANDS, STUDIES
    if argv and argv[0] == "study":
        wanted, studies = (), named(argv[1:], STUDIES) or STUDIES
    elif argv and named(argv, COMMANDS):
        wanted, studies = named(argv, COMMANDS), ()
    top = argparse.ArgumentParser(prog="python -m orchestrate", description=__doc__.split("\n\n")[0])
    commands = top.add_subparsers(dest="command", required=True)
    add_commands(commands, wanted)
    if studies:
        study = commands.add_parser("study", help="studies of a scene: convergence, stability, hertz, mode-one, "
                                                  "cantilever, adaptivity")
        add_commands(study.add_subparsers(dest="kind", required=True), studies)
    return top


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    options = parser(argv).parse_args(argv)
    try:
        return options.handler(options)
    except SolverError as error:
        print(f"error: {error}" + (f"\n{error.log_tail}" if error.returncode != FILE_PROBLEM else ""), file=sys.stderr)
        return error.returncode if error.returncode > 0 else 1
    except FileProblem as error:
        print(f"error: {error}", file=sys.stderr)
        return FILE_PROBLEM
    except FileNotFoundError as error:  # the program's own refusals carry no errno: a missing input named
        print(f"error: {file_problem(error) if error.errno else error}", file=sys.stderr)
        return FILE_PROBLEM if error.errno else 2
    except OSError as error:
        if error.errno is None and error.filename is None:  # no file's: a connection refused or timed out, say
            print(f"error: {error}", file=sys.stderr)
            return 1
        print(f"error: {file_problem(error)}", file=sys.stderr)
        return FILE_PROBLEM
    except (InputError, MeshError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except RuntimeError as error:
        print(f"error: {error}", file=sys.stderr)
        return getattr(error, "exit_code", 1)
    except MemoryError:
        print("error: out of memory: ask for less (a coarser mesh, a smaller image, fewer outputs)", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
