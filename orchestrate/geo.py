"""The .geo files of a mesh: a source and every file it includes, read once.

gmsh meshes a private copy of this text whose Include lines name the copies (`write_copies`), so
the mesh and its cache key (orchestrate/mesh.py) are of one text: a file edited after it was read,
or a link that points elsewhere by the time gmsh opens it, never reaches gmsh. The includes are
found as gmsh's lexer reads `Include "file";` (comments and strings cut as in src/parser/Gmsh.l);
an Include this reading misses (a computed name, one gmsh's block skipping reads otherwise) is no
hazard and leaves the key whole: the mesher may read nothing but the copies, so there it fails.

What a .geo may do is bounded by the mesher's sandbox (gmsh_mesher.py: Landlock, rlimits, an empty
environment), not by a check of its text, which gmsh's language can hide code from (its block
skipping reads characters otherwise than its lexer). One command is refused here because the
sandbox cannot stop it: FileExists, which tells a .geo whether a path exists (Landlock confines
opening files, not looking them up), so that a mesh could encode which of the user's files exist.
Being a reading of the text, that refusal gives way to code hidden from it by gmsh's skipping;
what leaks then is one bit per path, into a mesh.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from orchestrate.freefem import REPO, InputError, require_plain_path

PROJECT_MESHES = (REPO / "meshes").resolve()  # the project's own sources, committed and reviewed


class GeoError(InputError):
    """A .geo file refused: the message names the file, the line, the command and why."""


TOKEN = re.compile(r"""
    (?P<space>\s+)
  | (?P<comment>//[^\n]*|/\*.*?\*/)
  | (?P<string>"[^"]*"|'[^']*')
  | (?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z_0-9]*)
  | (?P<open>/\*|["'])
  | (?P<symbol>.)
""", re.VERBOSE | re.DOTALL)


@dataclass(frozen=True)
class Token:
    kind: str
    text: str
    start: int
    end: int


@dataclass(frozen=True)
class GeoFile:
    """A source: its path (links resolved), its text as read, and for each Include the span of
    its file-name literal in the text and the index of the included file."""
    path: Path
    text: str
    includes: tuple[tuple[int, int, int], ...]


def tokens(text: str) -> list[Token]:
    """The tokens gmsh's lexer reads, comments and blanks left out; an unclosed comment or string
    is an "open" token."""
    found = []
    for match in TOKEN.finditer(text):
        if match.lastgroup not in ("space", "comment"):
            found.append(Token(match.lastgroup, match.group(), match.start(), match.end()))
    return found

def source_file(path: Path, what: str) -> Path:
    """The regular .geo file `path` names, its symbolic links resolved (the target is what is
    checked and read)."""
    try:
        resolved = path.resolve(strict=True)
    except FileNotFoundError:
        raise GeoError(f"{what} {path} not found") from None
    except (OSError, RuntimeError) as error:  # a loop of links, a folder that cannot be read
        raise GeoError(f"{what} {path} cannot be opened ({error})") from None
    require_plain_path(resolved, what)
    if not resolved.is_file():
        raise GeoError(f"{what} {path} is not a regular file")
    if resolved.suffix != ".geo":
        raise GeoError(f"{what} {path}{f' (a link to {resolved})' if resolved != path.absolute() else ''} "
                       "is not a gmsh .geo file")
    return resolved


def _includes(path: Path, text: str, includer: str) -> list[tuple[Token, int]]:
    """The Include literals of a source and their lines; FileExists refused (see above)."""
    items = tokens(text)
    includes = []
    for index, token in enumerate(items):
        if token.kind == "name" and token.text == "FileExists":
            line = text.count("\n", 0, token.start) + 1
            raise GeoError(f"{path}, line {line}{includer}: FileExists looks for a file, which the mesher's sandbox "
                           "cannot hide: a mesh could tell which of your files exist (write the .geo without it)")
        if (token.text == "Include" and index + 2 < len(items) and items[index + 1].kind == "string"
                and items[index + 2].text == ";"):
            includes.append((items[index + 1], text.count("\n", 0, token.start) + 1))
    return includes


def read_sources(source: Path) -> list[GeoFile]:
    """A .geo file and every file it includes, however deep, each read once. An Include names a
    file relative to the folder of the file that includes it (its links resolved)."""
    paths = [source_file(source, "gmsh source")]
    texts, spans, includers = {}, {}, {paths[0]: ""}
    for path in paths:
        try:
            texts[path] = path.read_bytes().decode("utf-8", "surrogateescape")
        except OSError as error:
            raise GeoError(f"gmsh source {path} cannot be read ({error.strerror})") from None
        spans[path] = []
        for literal, line in _includes(path, texts[path], includers[path]):
            included = source_file(path.parent / literal.text[1:-1], f"{path}, line {line}: Include")
            if included not in includers:
                includers[included] = f" (included by {path}, line {line})"
                paths.append(included)
            spans[path].append((literal.start, literal.end, paths.index(included)))
    return [GeoFile(path, texts[path], tuple(spans[path])) for path in paths]


def copy_name(index: int, path: Path) -> str:
    """The file name of source `index` among the copies: its index first (two sources may share a
    name), in characters any string literal can hold."""
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", f"{index}-{path.name}")


def write_copies(files: list[GeoFile], folder: Path) -> Path:
    """The checked sources written into `folder`, every Include naming its copy; returns the top
    file's copy, the one to give gmsh."""
    for index, file in enumerate(files):
        text, end = [], 0
        for start, stop, included in file.includes:
            text += [file.text[end:start], f'"{copy_name(included, files[included].path)}"']
            end = stop
        text.append(file.text[end:])
        (folder / copy_name(index, file.path)).write_bytes("".join(text).encode("utf-8", "surrogateescape"))
    return folder / copy_name(0, files[0].path)
