"""Meshes of scene bodies, made with gmsh's Python API and cached by content.

The cache key is the .geo text and that of the files it includes, the -setnumber values and
gmsh's version, so an edited source or another gmsh gives a new mesh and never a stale one. A body
given only by its n uses the committed <geo>-n<n>.msh when it exists, the rule edp/main.edp
follows, so a scene and the driver run by hand mesh the paper's scene identically.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import subprocess
import sys
import threading
from pathlib import Path

from orchestrate.freefem import REPO

CACHE = REPO / "results" / ".cache" / "meshes"


class MeshError(RuntimeError):
    """gmsh could not mesh a body."""


INCLUDE = re.compile(r'^\s*Include\s*"([^"]+)"', re.MULTILINE)


def geo_sources(source: Path) -> list[Path]:
    """A .geo file and every file it includes, however deep (gmsh resolves an Include against the
    including file's folder), each once."""
    found = [source.resolve()]
    for path in found:
        for name in INCLUDE.findall(path.read_text()):
            included = (path.parent / name).resolve()
            if included not in found:
                found.append(included)
    return found


def cache_key(source: Path, numbers: dict[str, float], refine: int = 0) -> str:
    import gmsh

    digest = hashlib.sha256()
    for path in geo_sources(source):
        digest.update(path.read_bytes())
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
    # gmsh_mesher.py is run as a file, not as a module of this package, so the child imports gmsh
    # and the standard library only (the package's imports would cost it 0.45 s).
    child = Path(__file__).with_name("gmsh_mesher.py")
    command = [sys.executable, str(child), str(source), json.dumps(numbers), str(refine), str(target)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        target.unlink(missing_ok=True)
        reason = done.stderr.strip().splitlines()[-1] if done.stderr.strip() else f"exit code {done.returncode}"
        raise MeshError(f"gmsh could not mesh {source.name} with {numbers}: {reason}")
