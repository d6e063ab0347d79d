"""The command line of `orchestrate.mesh.commit_mesh`: its arguments and what the command does with them."""
from __future__ import annotations

from pathlib import Path

from orchestrate.freefem import InputError
from orchestrate.mesh import commit_mesh
from orchestrate.parameters import PARAMETERS
from orchestrate.scene import geo_path

NAME, HELP = ("commit-mesh", "make a committed mesh of meshes/ again (<geo>-n<n>.msh, which a body given only by n "
              "runs on) from its .geo as it is now, with the record of what it was made from that every run checks")


def add_arguments(parser) -> None:
    parser.add_argument("geo", help="the .geo file, e.g. meshes/paper_body1.geo (from the current folder, else the "
                                    "repository's)")
    parser.add_argument("--n", type=int, required=True, help="its mesh size parameter n, e.g. 24")


def command(options) -> int:
    n = PARAMETERS["n1"]  # the range a body's n takes in a scene (mesh.n) and on the driver's command line
    if not n.bounds.get("ge", -float("inf")) <= options.n <= n.bounds.get("le", float("inf")):
        raise InputError(f"--n {options.n}: give an integer in {n.range}, as a scene's mesh.n")
    print(f"wrote {commit_mesh(geo_path(options.geo, Path.cwd()), options.n)} and its record")
    return 0
