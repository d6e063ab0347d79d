"""The command line of `orchestrate.runner`: its arguments and what the command does with them."""
from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

from orchestrate.arguments import parse_assignments
from orchestrate.cli.options import add_trust_geo
from orchestrate.freefem import InputError
from orchestrate.runner import run

if TYPE_CHECKING:
    from orchestrate.results import Result

NAME, HELP = "run", "run a scene (TOML) into a folder"


def add_arguments(parser) -> None:
    parser.add_argument("scene", help="a scene file, e.g. scenes/paper.toml")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override a scene value, e.g. --set time.N=80 --set body1.material.E=2000; a boundary "
                             "condition by its label, --set 'body1.boundary[label=4].fy=-20*min(t, 0.5)' (or its "
                             "0-based index, body1.boundary.1.fy)")
    parser.add_argument("--out", help="output folder (default results/<scene name> in the current folder)")
    parser.add_argument("--force", action="store_true", help="replace the output folder if it holds a run")
    parser.add_argument("--resume", action="store_true",
                        help="continue an interrupted run of the same inputs from its last checkpoint (in <out>.partial)")
    parser.add_argument("--allow-unstable", action="store_true",
                        help="run even when the time step exceeds an explicit stability bound (docs/model.md §7)")
    parser.add_argument("--check-against", metavar="SUMMARY",
                        help="after the run, compare its final figures with another run's summary.json (a file or "
                             "a folder holding one) to a relative 1e-8 and exit 1 if one differs: a committed "
                             "result reproduced on this machine")
    add_trust_geo(parser)




REPRODUCED = {"rtol": 1e-8, "atol": 1e-12}  # other BLAS or CPUs change the last digits, not more


MEASURED = {"stepSeconds"}  # times, not results


def differences(summary: dict, expected: dict) -> list[str]:
    """The final figures (and iterations per step) of two summaries that differ beyond REPRODUCED."""
    def figures(data):
        return {**{name: value for name, value in data["final"].items() if name not in MEASURED},
                "contactItersPerStep": data.get("contactItersPerStep")}

    found = figures(summary)
    return [f"{name}: {found.get(name)} here, {value} expected" for name, value in figures(expected).items()
            if found.get(name) is None or value is None
            or abs(found[name] - value) > REPRODUCED["rtol"] * abs(value) + REPRODUCED["atol"]]


def expected_summary(expected: str) -> tuple[Path, dict]:
    """The summary.json --check-against names, read and checked before the run: a JSON object
    whose "final" holds the figures."""
    path = Path(expected)
    path = path / "summary.json" if path.is_dir() else path
    if not path.is_file():
        raise InputError(f"--check-against {expected}: no summary.json there")
    try:
        summary = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError) as error:
        raise InputError(f"--check-against {path}: not JSON ({error})") from None
    if not isinstance(summary, dict) or not isinstance(summary.get("final"), dict):
        raise InputError(f"--check-against {path}: not a run's summary.json (no \"final\" figures)")
    return path, summary


def check_against(result: Result, path: Path, expected: dict) -> int:
    differing = differences(json.loads((result.folder / "summary.json").read_text()), expected)
    for line in differing:
        print(f"differs from {path}: {line}")
    if not differing:
        print(f"reproduces {path}: every final figure within a relative {REPRODUCED['rtol']:g} "
              f"(absolute {REPRODUCED['atol']:g})")
    return 1 if differing else 0


def command(options) -> int:
    import sys

    overrides = parse_assignments(options.set, "--set")
    if options.allow_unstable:
        overrides["solver.allowUnstable"] = True
    expected = expected_summary(options.check_against) if options.check_against else None
    result = run(options.scene, options.out, overrides, force=options.force, resume=options.resume,
                 progress=sys.stderr.isatty(), trust_geo=options.trust_geo)
    final = result.history
    print(f"{result.folder}: {len(final['t'])} steps, normV(T) = {final['normV'][-1]:.6g}, "
          f"contact length {final['contactLength'][-1]:.4g}, contact iterations/step {final['contactIters'].mean():.1f}")
    for warning in json.loads((result.folder / "summary.json").read_text())["warnings"]:
        print(f"warning: {warning}")
    return check_against(result, *expected) if expected else 0
