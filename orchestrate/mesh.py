"""Meshes of scene bodies, made with gmsh's Python API and cached by content.

The cache key is the .geo text, the -setnumber values and gmsh's version, so an edited source or
another gmsh gives a new mesh and never a stale one. A body given only by its n uses the committed
<geo>-n<n>.msh when it exists, the rule edp/main.edp follows, so a scene and the driver run by
hand mesh the paper's scene identically.
"""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import threading
from pathlib import Path

from orchestrate.freefem import REPO

CACHE = REPO / "results" / ".cache" / "meshes"


class MeshError(RuntimeError):
    """gmsh could not mesh a body."""


def cache_key(source: Path, numbers: dict[str, float], refine: int = 0) -> str:
    import gmsh

    digest = hashlib.sha256()
    digest.update(source.read_bytes())
    digest.update(json.dumps([sorted(numbers.items()), refine]).encode())
    digest.update(gmsh.__version__.encode())
    return digest.hexdigest()[:24]


def body_mesh(source: Path, numbers: dict[str, float], refine: int = 0, cache: Path | None = None) -> Path:
    """The .msh file of a gmsh source with DefineConstant values `numbers` (n among them), its
    triangles split in four `refine` times (red refinement: the meshes are nested)."""
    cache = cache or CACHE
    committed = source.with_name(f"{source.stem}-n{int(numbers['n'])}.msh")
    if set(numbers) == {"n"} and refine == 0 and committed.exists():
        return committed
    target = cache / f"{source.stem}-{cache_key(source, numbers, refine)}.msh"
    if target.exists():
        return target
    cache.mkdir(parents=True, exist_ok=True)
    partial = target.with_name(f"{target.stem}.{os.getpid()}.{threading.get_ident()}.partial.msh")
    generate(source, numbers, refine, partial)
    os.replace(partial, target)  # atomic: a concurrent reader sees a whole file or none
    return target


def generate(source: Path, numbers: dict[str, float], refine: int, target: Path) -> None:
    """Mesh in a fresh Python process: gmsh keeps every -setnumber value for the life of the
    process (initialize/finalize do not reset them), so meshing in-process would give a later
    body the constants of an earlier one that its own scene leaves at their defaults."""
    command = [sys.executable, "-m", "orchestrate.mesh", str(source), json.dumps(numbers), str(refine), str(target)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        target.unlink(missing_ok=True)
        reason = done.stderr.strip().splitlines()[-1] if done.stderr.strip() else f"exit code {done.returncode}"
        raise MeshError(f"gmsh could not mesh {source.name} with {numbers}: {reason}")


def generate_here(source: Path, numbers: dict[str, float], refine: int, target: Path) -> None:
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
            raise MeshError("; ".join(errors))
        gmsh.model.mesh.generate(2)
        for _ in range(refine):
            gmsh.model.mesh.refine()
        gmsh.write(str(target))
    except Exception as error:
        log = "; ".join(line for line in gmsh.logger.get() if "Error" in line) or str(error)
        raise MeshError(log) from None
    finally:
        gmsh.logger.stop()
        gmsh.finalize()


if __name__ == "__main__":
    try:
        generate_here(Path(sys.argv[1]), json.loads(sys.argv[2]), int(sys.argv[3]), Path(sys.argv[4]))
    except MeshError as error:
        sys.exit(str(error))
