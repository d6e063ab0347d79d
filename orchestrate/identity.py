"""The solver's identity: the SHA-256 of everything of the FreeFEM program that can change a result.

Derived, never listed by hand: from edp/main.edp, every file it includes (`include "…"`, followed
through the files it includes), every plugin it loads (`load "…"`: the project's source and built
.so, or FreeFEM's own .so), the files beside the included ones that are not scripts (the data a
library may read at run time), and the FreeFem++ executable. A new .idp or
plugin enters it with no edit here. Part of a run's identity (runner.inputs_of); bin/ff passes it
to the driver for runs started by hand, so a checkpoint never continues under other code.

Also the stamp of a project plugin's build (`plugin_stamp`, `stale_plugins`): bin/plugins writes
it beside each .so it compiles and refuses a run whose plugin was built from another source or
for another FreeFem++; orchestrate checks the same stamps in-process.

The SHA-256 of a file outside the repository (FreeFem++'s 16 MB, its plugins) is kept in
results/.cache/digests/ against the file's stamp (size, times, inode), as git's index keeps one
(`StampedFacts`): a command does not read it again on every run. The repository's own files,
which a user edits, are hashed afresh by each process (8 ms).

Standard library only: bin/ff and bin/plugins run this file with the system's python3, isolated
and without its site packages (`python3 -I -S`: 13 ms to start here, not 65 ms). `--check-plugins` fails
naming a plugin that needs building, and with `--identity` then prints the identity: bin/ff's two
checks in one process. `--plugin-stamp SOURCE` prints a plugin's stamp, `--stale-plugins` the .so
files that need building, and no option (or a driver's path) the identity.
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import sys
import threading
import time
from pathlib import Path

EDP = Path(__file__).resolve().parent.parent / "edp"
CACHE = EDP.parent / "results" / ".cache"
SETTLED = 2.0  # seconds since a file's last change before a fact of it is kept
FREEFEM_PLUGINS = Path("/usr/lib/freefem++")  # where Debian's FreeFem++ keeps its own plugins
# Its CHOLMOD objects are read through them (factorsplit.cpp): a plugin is built for their version.
CHOLMOD_HEADERS = Path("/usr/include/suitesparse/cholmod_core.h")
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


class KeptFacts:
    """Facts kept between processes: one small JSON file per name in `folder`, named by the digest
    of the name, written atomically, taken only when it names the name, the stamp asked for and
    `version` (the code that made the fact) and `check` accepts its fact. An unreadable or
    unwritable store only costs the computing."""

    def __init__(self, folder: Path, version: str = "", check=lambda fact: True):
        self.folder, self.version, self.check = folder, version, check

    def entry_file(self, name: str) -> Path:
        return self.folder / f"{hashlib.sha256(name.encode('utf-8', 'surrogateescape')).hexdigest()[:32]}.json"

    def stored(self, name: str, stamp: list | None = None):
        """The fact kept for `name` at `stamp`, or None."""
        try:
            entry = json.loads(self.entry_file(name).read_text())
        except (OSError, ValueError):
            return None
        whole = (isinstance(entry, dict) and entry.get("path") == name and entry.get("version") == self.version
                 and entry.get("stamp") == stamp and "fact" in entry)
        return entry["fact"] if whole and self.check(entry["fact"]) else None

    def store(self, name: str, stamp: list | None, fact) -> None:
        import tempfile  # only where a fact is new: its import (random's) is a few ms of every bin/ff call

        partial = None
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            handle, partial = tempfile.mkstemp(dir=self.folder, suffix=".partial")
            with os.fdopen(handle, "w") as file:
                json.dump({"path": name, "version": self.version, "stamp": stamp, "fact": fact}, file)
            os.replace(partial, self.entry_file(name))
        except OSError:
            pass
        finally:
            if partial:
                Path(partial).unlink(missing_ok=True)


class StampedFacts(KeptFacts):
    """What `compute` made of a file, kept against the file's stamp (device, inode, size,
    modification and change times: a change to the file changes one of them, the change time even
    when a program puts the others back), as git's index keeps a file's hash. A fact of a file
    changed less than SETTLED seconds before it was read is kept by this process only: another's
    change within the same clock tick would keep its stamp. compute's exceptions pass through,
    and nothing is kept of a file it refused."""

    def __init__(self, folder: Path, compute, version: str = "", check=lambda fact: True):
        super().__init__(folder, version, check)
        self.compute, self.memory, self.lock = compute, {}, threading.Lock()

    def of(self, path: Path):
        now = time.time_ns()
        status = path.stat()
        stamp = [status.st_dev, status.st_ino, status.st_size, status.st_mtime_ns, status.st_ctime_ns]
        here = tuple(stamp)
        with self.lock:
            if here in self.memory:
                return self.memory[here]
        fact = self.stored(str(path), stamp)
        if fact is None:
            fact = self.compute(path)
            if now - max(status.st_mtime_ns, status.st_ctime_ns) > SETTLED * 1e9:
                self.store(str(path), stamp, fact)
        with self.lock:
            self.memory[here] = fact
        return fact


def sha256_of(path: Path) -> str:
    sha = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            sha.update(block)
    return sha.hexdigest()


def is_hex_digest(fact) -> bool:
    return isinstance(fact, str) and len(fact) == 64 and all(c in "0123456789abcdef" for c in fact)


DIGESTS = StampedFacts(CACHE / "digests", sha256_of, "sha256", is_hex_digest)


def digest_of(path: Path) -> str:
    """A file's SHA-256: kept between processes for a file outside the repository (FreeFem++ and
    its plugins, which the package manager replaces whole), read afresh for the repository's own,
    which a user edits, perhaps on a file system whose change times follow what a program sets."""
    try:
        return DIGESTS.of(path) if not path.is_relative_to(EDP.parent) else sha256_of(path)
    except FileNotFoundError:
        return "missing"  # a plugin not built yet: its check refuses the run


def solver_identity(main: Path = EDP / "main.edp") -> str:
    """The SHA-256 over the program's files (by their paths below edp/ or their absolute paths)
    and the FreeFem++ executable."""
    sha = hashlib.sha256()
    root = main.resolve().parent
    freefem = shutil.which("FreeFem++")
    files = program_files(main) + ([Path(os.path.realpath(freefem))] if freefem else [])
    for path in files:
        label = path.relative_to(root).as_posix() if path.is_relative_to(root) else str(path)
        sha.update(f"{label}\0{digest_of(path)}\n".encode())
    return sha.hexdigest()


def plugin_stamp(source: Path) -> str:
    """What a plugin's .so is built for: its source's SHA-256, and FreeFem++'s and the CHOLMOD
    headers' size and whole-second mtime (dpkg keeps a package's file times, so an upgrade
    changes them; a chmod, a reinstall of the same package or an unpacked image do not)."""
    def size_and_time(path: Path) -> str:
        status = path.stat()
        return f"{status.st_size} {status.st_mtime_ns // 10**9}"

    freefem = shutil.which("FreeFem++")
    if freefem is None:
        raise FileNotFoundError("FreeFem++ is not installed: run `make setup`")
    headers = size_and_time(CHOLMOD_HEADERS) if CHOLMOD_HEADERS.is_file() else ""
    return f"{digest_of(source.resolve())} {size_and_time(Path(os.path.realpath(freefem)))} {headers}"


def stale_plugins(folder: Path = EDP / "plugins") -> list[Path]:
    """The .so files of `folder` that are missing or not built from their source as it is now,
    for the FreeFem++ and headers installed now (by the stamp beside each, <name>.built-for)."""
    def current(source: Path) -> bool:
        built, stamp = source.with_suffix(".so"), source.with_suffix(".built-for")
        try:
            return built.is_file() and stamp.read_text().rstrip("\n") == plugin_stamp(source)
        except (OSError, UnicodeDecodeError):
            return False

    return [source.with_suffix(".so") for source in sorted(folder.glob("*.cpp")) if not current(source)]


def plugins_fault(folder: Path = EDP / "plugins") -> str | None:
    """Why the project's plugins cannot run now, or None."""
    if shutil.which("FreeFem++") is None:
        return "FreeFem++ is not installed: run `make setup`"
    stale = stale_plugins(folder)
    if stale:
        return f"the FreeFEM plugin {stale[0]} is missing, or not built from its source for this FreeFem++: run `make setup`"
    return None


def main(arguments: list[str]) -> int:
    if arguments[:1] == ["--plugin-stamp"] and len(arguments) == 2:
        print(plugin_stamp(Path(arguments[1])))
    elif arguments[:1] == ["--stale-plugins"] and len(arguments) <= 2:
        print(*stale_plugins(*map(Path, arguments[1:])), sep="\n")
    elif arguments in (["--check-plugins"], ["--check-plugins", "--identity"]):
        fault = plugins_fault()
        if fault:
            print(f"ERROR: {fault}", file=sys.stderr)
            return 3
        if "--identity" in arguments:
            print(solver_identity())
    else:
        print(solver_identity(Path(arguments[0]) if arguments else EDP / "main.edp"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
