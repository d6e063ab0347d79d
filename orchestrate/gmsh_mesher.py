"""The child process of orchestrate/mesh.py: mesh one .geo with gmsh's Python API and write it.

    python orchestrate/gmsh_mesher.py SOURCE.geo '{"n": 24}' REFINE TARGET.msh

It imports gmsh and the standard library only, and exits with gmsh's error lines as its message.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path


def mesh(source: Path, numbers: dict[str, float], refine: int, target: Path) -> None:
    import gmsh

    # DefineConstant values take effect only as -setnumber arguments: gmsh.parser.setNumber is
    # ignored for them.
    arguments = ["gmsh"]
    for name, value in numbers.items():
        arguments += ["-setnumber", name, repr(float(value))]
    gmsh.initialize(arguments)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.logger.start()
        gmsh.open(str(source))
        errors = [line for line in gmsh.logger.get() if line.startswith("Error")]
        if errors:
            raise RuntimeError("; ".join(errors))
        gmsh.model.mesh.generate(2)
        for _ in range(refine):
            gmsh.model.mesh.refine()
        gmsh.write(str(target))
    except Exception as error:
        log = "; ".join(line for line in gmsh.logger.get() if "Error" in line) or str(error)
        sys.exit(log)
    finally:
        gmsh.logger.stop()
        gmsh.finalize()


if __name__ == "__main__":
    mesh(Path(sys.argv[1]), json.loads(sys.argv[2]), int(sys.argv[3]), Path(sys.argv[4]))
