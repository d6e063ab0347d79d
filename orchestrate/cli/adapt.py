"""The command line of `orchestrate.adapt`: its arguments and what the command does with them."""
from __future__ import annotations

from pathlib import Path

from orchestrate.adapt import CYCLES, NAME, adapt
from orchestrate.arguments import parse_assignments
from orchestrate.cli.options import add_force_argument, add_trust_geo, fraction, positive

HELP = "meshes designed from a pilot run's error estimate, run again until the estimate reaches a target"


def add_arguments(parser) -> None:
    parser.add_argument("scene", help="a scene file, e.g. scenes/paper.toml (its meshes are the pilot's)")
    parser.add_argument("--target", type=fraction, required=True,
                        help="the relative estimate η/‖u_h‖_V to reach (the largest over the saved states), e.g. 0.01")
    parser.add_argument("--cycles", type=positive, default=CYCLES, help="the most mesh designs after the pilot")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="override a scene value for every run, as run --set")
    parser.add_argument("--out", help="output folder (default adapt-<scene name> in the current folder)")
    add_force_argument(parser, NAME)
    add_trust_geo(parser)


def command(options) -> int:
    import sys

    out = Path(options.out or f"adapt-{Path(options.scene).stem}")
    adapt(options.scene, out, options.target, options.cycles, parse_assignments(options.set, "--set"),
          progress=sys.stderr.isatty(), force=options.force, trust_geo=options.trust_geo)
    print((out / "README.md").read_text())
    return 0
