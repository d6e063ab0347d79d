"""The solver's identity: the SHA-256 of everything of the FreeFEM program that can change a result.

Derived, never listed by hand: from edp/main.edp, every file it includes (`include "…"`, followed
through the files it includes), every plugin it loads (`load "…"`: the project's source and built
.so, or FreeFEM's own .so), the files beside the included ones that are not scripts (the data a
library may read at run time), and the FreeFem++ executable. A new .idp or
plugin enters it with no edit here. Part of a run's identity (runner.inputs_of); bin/ff passes it
to the driver for runs started by hand, so a checkpoint never continues under other code.

Standard library only: bin/ff runs this file with the system's python3 (`python3 identity.py
[main.edp]` prints the identity).
"""
from __future__ import annotations

import functools
import hashlib
import os
import re
import shutil
import sys
from pathlib import Path

EDP = Path(__file__).resolve().parent.parent / "edp"
FREEFEM_PLUGINS = Path("/usr/lib/freefem++")  # where Debian's FreeFem++ keeps its own plugins
# Beside the included files but never read by the driver: other scripts, and lib/parameters.toml,
# the source the generated includes are made from (its meanings are prose: rewording one is no
# other program).
NOT_READ = (".edp", ".toml")
# A directive at the start of a line (comments and strings elsewhere hold the words too).
DIRECTIVE = re.compile(rb'^[ \t]*(include|load)[ \t]+"([^"\n]+)"', re.MULTILINE)


def directives(path: Path) -> list[tuple[str, str]]:
    return [(kind.decode(), name.decode()) for kind, name in DIRECTIVE.findall(path.read_bytes())]


def program_files(main: Path) -> list[Path]:
    """The driver, what it includes (from the driver's folder, as FreeFEM resolves a relative
    include), the plugins it loads and the data files beside the included files."""
    found, plugins, pending = {main.resolve()}, set(), [main.resolve()]
    while pending:
        for kind, name in directives(pending.pop()):
            if kind == "load":
                plugins.add(name)
                continue
            path = (main.parent / name).resolve()
            if path not in found:
                if not path.is_file():
                    raise FileNotFoundError(f"{main}: includes {name}, which is not there")
                found.add(path)
                pending.append(path)
    data = {path for folder in {path.parent for path in found} for path in folder.iterdir()  # not an editor's .swp
            if path.is_file() and path.suffix not in NOT_READ and not path.name.startswith(".")}
    return sorted(found | data) + [file for name in sorted(plugins) for file in plugin_files(main.parent, name)]


def plugin_files(edp: Path, name: str) -> list[Path]:
    """A loaded plugin's files: the project's source and .so (edp/plugins), else FreeFEM's .so;
    none for one built into FreeFem++."""
    source = edp / "plugins" / f"{name}.cpp"
    if source.is_file():
        return [source, source.with_suffix(".so")]
    own = FREEFEM_PLUGINS / f"{name}.so"
    return [own] if own.is_file() else []


@functools.cache
def file_digest(path: Path, size: int, mtime: int, inode: int, changed: int) -> str:
    """A file's SHA-256, computed once per content stamp (the executable is 16 MB)."""
    sha = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            sha.update(block)
    return sha.hexdigest()


def stamped_digest(path: Path) -> str:
    try:
        status = path.stat()
    except FileNotFoundError:
        return "missing"  # a plugin not built yet: bin/plugins check refuses the run
    return file_digest(path, status.st_size, status.st_mtime_ns, status.st_ino, status.st_ctime_ns)


def solver_identity(main: Path = EDP / "main.edp") -> str:
    """The SHA-256 over the program's files (by their paths below edp/ or their absolute paths)
    and the FreeFem++ executable."""
    sha = hashlib.sha256()
    root = main.resolve().parent
    freefem = shutil.which("FreeFem++")
    files = program_files(main) + ([Path(os.path.realpath(freefem))] if freefem else [])
    for path in files:
        label = path.relative_to(root).as_posix() if path.is_relative_to(root) else str(path)
        sha.update(f"{label}\0{stamped_digest(path)}\n".encode())
    return sha.hexdigest()


if __name__ == "__main__":
    print(solver_identity(Path(sys.argv[1]) if len(sys.argv) > 1 else EDP / "main.edp"))
