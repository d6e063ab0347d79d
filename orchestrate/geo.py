"""The .geo files of a mesh, read and checked before gmsh sees them.

A .geo file is a program in gmsh's language, and a scene may come from someone else (a shared
scene file, a sweep on a cluster): a scene must not be able to make gmsh run a program, write a
file or read one other than the checked sources. Every .geo, the project's and a user's, and every
file it includes, is read once (`read_sources`), its symbolic links resolved, and checked token by
token with comments and strings cut as gmsh's lexer cuts them (src/parser/Gmsh.l). gmsh then meshes
a private copy of the checked text whose Include lines name the copies (`write_copies`), so a file
edited after the check, or a link that points elsewhere by the time gmsh opens it, never reaches
gmsh.

Refused (gmsh's grammar, src/parser/Gmsh.y and Gmsh.l, and its manual, "General commands"):
the commands that run programs (System, SystemCall, NonBlockingSystemCall, OnelabRun, the
ExternalProcess size field), that write files (Save, Print, Printf(...) > file, CreateDir,
SendToServer, Plugin: some plugins do) or read them (Merge, MergeWithBoundingBox, ShapeFromFile,
ListFromFile, FileExists, the Structured size field, GetEnv for the environment), Exit (it ends
the mesher's process), S2N (it makes a command name from a string, which no check can read), an
Include whose file name is computed, the options of every category but Mesh and Geometry
(General, Solver, Print, PostProcessing and View options name files and programs gmsh uses) and
Geometry's DoubleClicked commands (gmsh code of their own); and what gmsh's lexer may read
otherwise than this check: a NUL byte, a comment or string never closed, a string beyond gmsh's
1023 characters, and in a block gmsh may skip (If … EndIf, For … EndFor, Macro or Function …
Return) what its skipping reads otherwise (`blocks`, `skip_refusal`).

The mesher is also confined where the kernel offers Landlock (gmsh_mesher.py): no program may
be started and no file written but its target, whatever this check missed. Where it does not,
a user's .geo may hold no such block at all: the project's own meshes/ are exempt.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from orchestrate.freefem import REPO, InputError, require_plain_path
from orchestrate.gmsh_mesher import landlock_abi

PROJECT_MESHES = (REPO / "meshes").resolve()  # the project's own sources, committed and reviewed


class GeoError(InputError):
    """A .geo file refused: the message names the file, the line, the command and why."""


WHY = ("a .geo file is gmsh code and a scene may come from others, so its meshes may not run programs or touch "
       "other files")

COMMANDS = {
    "System": "runs a program",
    "SystemCall": "runs a program",
    "NonBlockingSystemCall": "runs a program",
    "OnelabRun": "runs a program (a ONELAB client)",
    "Plugin": "runs a post-processing plugin (some write files)",
    "Save": "writes a file",
    "Print": "writes an image file",
    "CreateDir": "makes a folder",
    "SendToServer": "sends data to a ONELAB server",
    "Merge": "reads another file",
    "MergeWithBoundingBox": "reads another file",
    "ShapeFromFile": "reads a CAD file",
    "ListFromFile": "reads numbers from a file",
    "FileExists": "looks for a file",
    "GetEnv": "reads the environment",
    "Exit": "ends the mesher's process",
    "S2N": "makes a command name from a string, which no check can read",
    "StringToName": "makes a command name from a string, which no check can read",
}
FIELDS = {"ExternalProcess": "runs a program", "Structured": "reads a file"}
OPTION_CATEGORIES = ("General", "Solver", "Print", "PostProcessing", "View")
STRING_LIMIT = 1023  # gmsh's lexer stops a longer string there (Gmsh.l, parsestring): it and this check would differ

TOKEN = re.compile(r"""
    (?P<space>\s+)
  | (?P<comment>//[^\n]*|/\*.*?\*/)
  | (?P<string>"[^"]*"|'[^']*')
  | (?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z_0-9]*)
  | (?P<open>/\*|["'])
  | (?P<symbol>>>|>=|\.\.\.|.)
""", re.VERBOSE | re.DOTALL)


@dataclass(frozen=True)
class Token:
    kind: str
    text: str
    start: int
    end: int


@dataclass(frozen=True)
class GeoFile:
    """A checked source: its path (links resolved), its text as read, and for each Include the
    span of its file-name literal in the text and the index of the included file."""
    path: Path
    text: str
    includes: tuple[tuple[int, int, int], ...]


def tokens(text: str) -> list[Token]:
    """The tokens gmsh's lexer reads, comments and blanks left out; an unclosed comment or string
    is an "open" token (gmsh reads the rest of the file into it)."""
    found = []
    for match in TOKEN.finditer(text):
        if match.lastgroup not in ("space", "comment"):
            found.append(Token(match.lastgroup, match.group(), match.start(), match.end()))
    return found


def _closing(items: list[Token], index: int, opening: str, closing: str) -> int:
    """The index of the token closing the bracket at `index`, or len(items)."""
    depth = 0
    for position in range(index, len(items)):
        depth += (items[position].text == opening) - (items[position].text == closing)
        if depth == 0:
            return position
    return len(items)


def _text_at(items: list[Token], index: int) -> str:
    return items[index].text if index < len(items) else ""


def refusal(items: list[Token], index: int) -> str | None:
    """What is refused at token `index` (the command and why), or None."""
    token, after = items[index], _text_at(items, index + 1)
    if token.kind == "open":
        return "a comment or string that is never closed"
    if token.kind == "string" and len(token.text) - 2 > STRING_LIMIT:
        return (f"a string of {len(token.text) - 2} characters (gmsh's reader stops at {STRING_LIMIT}, so how it "
                "reads the rest cannot be checked)")
    if token.kind != "name":
        return None
    name = token.text
    if name in COMMANDS:
        return f"{name} {COMMANDS[name]}"
    if name in OPTION_CATEGORIES and after in (".", "["):
        return f"{name} options name files and programs gmsh uses (a mesh needs only Mesh and Geometry options)"
    if name == "Geometry" and after == "." and _text_at(items, index + 2).startswith("DoubleClicked"):
        return f"Geometry.{_text_at(items, index + 2)} holds gmsh code to run"
    if name == "Printf" and after == "(":
        if _text_at(items, _closing(items, index + 1, "(", ")") + 1) in (">", ">>"):
            return "Printf(...) > file writes a file"
    if name == "Field" and after == "[":
        equals = _closing(items, index + 1, "[", "]") + 1
        kind = _text_at(items, equals + 1)
        if _text_at(items, equals) == "=" and kind in FIELDS:
            return f"the {kind} size field {FIELDS[kind]}"
    if name == "Include" and (index + 2 >= len(items) or items[index + 1].kind != "string"
                              or items[index + 2].text != ";"):
        return 'Include with a computed file name (write it out: Include "file.geo";)'
    return None


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


OPENERS = {"If": "EndIf", "For": "EndFor", "Macro": "Return", "Function": "Return"}
KEYWORDS = ("ElseIf", "Else", "EndIf", "If", "EndFor", "For", "Return", "Macro", "Function")
# gmsh skips a block it does not run (an If branch not taken, a For of no turns, a Macro's body)
# by reading raw characters for its keywords (Gmsh.y, skip and skipTest), a keyword being letters
# [A-Za-z_] after a character that is none (a digit counts as a separator). After a candidate R,
# E, I or F it reads ahead and gives back all but the character after that letter; after a nested
# If or For it keeps the 3 or 4 characters it read past it. A quote or / lost there makes it miss a
# string or comment that this check sees, so it could end the block inside one and run what this
# check took for its text; an E kept there hides an EndIf. And a For or Macro starts its next turn
# or call on the line after its header, so the rest of that line must hold no string or comment.
LOST_CHARACTER = re.compile(r"""[REIF]["'/]""")
OVER_READ = re.compile(r"""(?<![A-Za-z_])(?:If|For)[^\n\r]{0,3}["'/E]""")
REST_OF_LINE = re.compile(r"[ \t]*(?://[^\n\r]*)?(?:[\n\r]|$)")


def blocks(items: list[Token], text: str) -> list[tuple[int, int]]:
    """The spans of the text that gmsh may skip: from each If, For, Macro or Function to its end
    (the end of the file when it has none)."""
    spans, open_blocks = [], []
    for token in items:
        if token.kind != "name":
            continue
        if token.text in OPENERS:
            open_blocks.append(token)
        elif open_blocks and OPENERS[open_blocks[-1].text] == token.text:
            spans.append((open_blocks.pop().start, token.end))
    spans += [(token.start, len(text)) for token in open_blocks]
    return spans


def hidden_keyword(name: str) -> str | None:
    """A keyword gmsh's skipping finds inside the name `name` (after a digit, or followed by one),
    which this check does not take for one."""
    for start in [0, *(position for position in range(1, len(name)) if name[position - 1].isdigit())]:
        for keyword in KEYWORDS:
            rest = name[start + len(keyword):]
            if name.startswith(keyword, start) and name != keyword and not (rest[:1].isalpha() or rest[:1] == "_"):
                return keyword
    return None


def skip_refusal(items: list[Token], index: int, text: str) -> str | None:
    """What gmsh's skipping could read otherwise than this check at token `index`, or None."""
    token = items[index]
    if token.kind != "name":
        return None
    keyword = hidden_keyword(token.text)
    if keyword:
        return (f"the name {token.text}: gmsh's skipping of a block reads '{keyword}' in it (a digit ends a keyword "
                "there), where this check sees a name")
    if token.text in ("For", "Macro", "Function"):
        header = index + 1  # For: its range in () or {}; Macro, Function: the name
        if token.text == "For":
            while header < len(items) and items[header].text not in ("(", "{"):
                header += 1
            header = _closing(items, header, items[header].text, ")" if items[header].text == "(" else "}") \
                if header < len(items) else header
        end = items[header].end if header < len(items) else len(text)
        if not REST_OF_LINE.match(text, end):
            return (f"code on the line of a {token.text} header: gmsh starts each turn or call on the next line, so "
                    "the rest of this one may hold no string or comment (put the body on the lines below)")
    return None


def skipped_refusal(text: str, start: int, end: int) -> tuple[int, str] | None:
    """Where and why a block gmsh may skip is refused, or None."""
    block = text[start:end]
    for pattern, what in ((LOST_CHARACTER, "after R, E, I or F it may lose the next character"),
                          (OVER_READ, "after a nested If or For it keeps the next few characters unread")):
        found = pattern.search(block)
        if found:
            return start + found.start(), (f"'{found.group()}' in a block gmsh may skip: gmsh skips such a block by "
                                           f"reading characters for its keywords and {what}, so a quote, / or EndIf "
                                           "there could hide code from this check (write it another way, e.g. 0.5*R "
                                           "for R/2, or move it out of the block)")
    return None


def _check(path: Path, text: str, includer: str) -> list[tuple[Token, int]]:
    """Refuse what the text may not do; return its Include literals."""
    if "\0" in text:
        raise GeoError(f"{path}, line {text.count(chr(10), 0, text.index(chr(0))) + 1}{includer}: a NUL byte "
                       "(gmsh's reader ends a string or comment there, so how it reads the rest cannot be checked); "
                       + WHY)
    items = tokens(text)
    includes = []
    for index, token in enumerate(items):
        refused = refusal(items, index) or skip_refusal(items, index, text)
        if refused:
            raise GeoError(f"{path}, line {text.count(chr(10), 0, token.start) + 1}{includer}: {refused}; {WHY}")
        if token.text == "Include":
            includes.append((items[index + 1], text.count("\n", 0, token.start) + 1))
    spans = blocks(items, text)
    if spans and not path.is_relative_to(PROJECT_MESHES) and landlock_abi() < 1:
        raise GeoError(f"{path}, line {text.count(chr(10), 0, spans[0][0]) + 1}{includer}: an If, For, Macro or "
                       "Function block, on a kernel without Landlock: gmsh skips such blocks reading characters "
                       "otherwise than this check can, and without Landlock nothing else stops what it might miss "
                       "(write the block out, or run where the kernel has Landlock, Linux 5.13 and later); " + WHY)
    for start, end in spans:
        refused = skipped_refusal(text, start, end)
        if refused:
            raise GeoError(f"{path}, line {text.count(chr(10), 0, refused[0]) + 1}{includer}: {refused[1]}; {WHY}")
    return includes


def read_sources(source: Path) -> list[GeoFile]:
    """A .geo file and every file it includes, however deep, each read once and checked. An Include
    names a file relative to the folder of the file that includes it (its links resolved)."""
    paths = [source_file(source, "gmsh source")]
    texts, spans, includers = {}, {}, {paths[0]: ""}
    for path in paths:
        try:
            texts[path] = path.read_bytes().decode("utf-8", "surrogateescape")
        except OSError as error:
            raise GeoError(f"gmsh source {path} cannot be read ({error.strerror})") from None
        spans[path] = []
        for literal, line in _check(path, texts[path], includers[path]):
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
