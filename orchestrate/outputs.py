"""Files the commands write outside a run folder (compare, plot, render --out, the studies, bench,
reference), under the runner's policy (runner.py): into a new folder, or refused; with --force
only what the same command wrote there is replaced, never through a symbolic link.

A folder is a command's when it holds RECORD, written before any of its files: the command and
the names it writes there, so that an interrupted command's files count as its own too. --force
removes the files it lists (a link among them is unlinked, never followed), keeps the folders of
runs it lists (the runner checks every run in them before reusing it), and refuses a folder that
holds anything else, naming it. An empty folder counts as a new one.

A single file (plot --out fig.png, reference --out page.md) carries its mark inside, as no record
beside it could without a second file to keep: an image has MARK as its Creator (PNG, PDF and SVG
metadata, kept as plain text), a page its own opening sentence. An existing file is replaced
with --force only when it holds its mark, and a link never.

Every file is made under a temporary name in its own folder (O_CREAT | O_EXCL | O_NOFOLLOW: never
an existing file, never through a link) and renamed onto its name, so no reader sees it half
written and a link by that name is replaced, not followed.
"""
from __future__ import annotations

import csv
import json
import os
import secrets
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path

from orchestrate.freefem import InputError

RECORD = "made-by.json"
MARK = "written by python -m orchestrate"  # the Creator of every image the package draws
LARGEST_OWN_FILE = 1 << 30  # bytes: a bigger file is no image or page of ours, and is not read


class OutputError(InputError):
    """An output folder or file that is not this command's to write, refused before anything is."""


@contextmanager
def created(path: Path, mode: str = "w", newline: str | None = None):
    """A handle on a new file that becomes `path` (replacing what is there) once the block ends
    without an error; nothing is left behind when it raises. A file that cannot be written is
    named as `path` in the error (the temporary name means nothing to a user)."""
    temporary = path.with_name(f".{secrets.token_hex(6)}.writing")  # short: `path`'s own name may be at NAME_MAX
    try:
        descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o666)
    except OSError as error:
        raise type(error)(error.errno, error.strerror, str(path)) from None
    try:
        text = {} if "b" in mode else {"encoding": "utf-8", "newline": newline}
        with os.fdopen(descriptor, mode, **text) as handle:
            yield handle
        os.replace(temporary, path)
    except OSError as error:
        temporary.unlink(missing_ok=True)
        raise type(error)(error.errno, error.strerror, str(path)) from None
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def write_text(path: Path, text: str) -> None:
    with created(path) as handle:
        handle.write(text)


def write_csv(path: Path, rows: list[dict], columns: list[str] | None = None) -> None:
    """A table with the given columns (default: the first row's keys), other keys ignored; written
    whole or not at all."""
    with created(path, newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns or list(rows[0]), extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)


def write_figure(figure, path: Path, **options) -> None:
    """A matplotlib figure into `path`, in the format its suffix names, marked as ours."""
    with created(path, "wb") as handle:
        figure.savefig(handle, format=path.suffix.lstrip("."), metadata={"Creator": MARK}, **options)




def command_line(command: str) -> str:
    return f"python -m orchestrate {command}"


def read_record(folder: Path) -> dict | None:
    """The record of a folder (None: none, or not one this package wrote), read without following a link."""
    try:
        descriptor = os.open(folder / RECORD, os.O_RDONLY | os.O_NOFOLLOW)
    except OSError:
        return None
    with os.fdopen(descriptor, encoding="utf-8") as handle:
        try:
            record = json.load(handle)
        except (ValueError, UnicodeDecodeError):
            return None
    fields = {"command": str, "files": list, "folders": list}
    if not isinstance(record, dict) or any(not isinstance(record.get(key), kind) for key, kind in fields.items()):
        return None
    if not all(plain_name(name) for name in record["files"] + record["folders"]):
        return None  # a name with a folder in it would become a path outside this one: not a record we wrote
    return record


def plain_name(name) -> bool:
    """A name of an entry of the folder itself: no separator, not . or .., no NUL."""
    return isinstance(name, str) and name not in ("", ".", "..") and "/" not in name and "\0" not in name


def listed(names) -> str:
    names = sorted(names)
    return ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")


def refuse_link(path: Path, option: str, advice: str) -> None:
    if path.is_symlink():
        raise OutputError(f"{option} {path} is a symbolic link: {advice} (nothing is written through a link)")


def entries(folder: Path, option: str) -> set[str]:
    """The names in `folder`, none when it is not there; refused when it is a link or a file."""
    if not os.path.lexists(folder):
        return set()
    refuse_link(folder, option, "give a folder's own path")
    if not folder.is_dir():
        raise OutputError(f"{option} {folder} is a file, not a folder: choose another {option}")
    return set(os.listdir(folder))


def write_record(folder: Path, command: str, files, folders, note: str) -> None:
    record = {"command": command, "files": sorted(files), "folders": sorted(folders), "note": note}
    write_text(folder / RECORD, json.dumps(record, indent=1) + "\n")


def drawn_image(path: Path) -> bool:
    """An image this package drew (its format's signature and the package's mark)."""
    return path.suffix.lower() in SIGNATURES and holds_mark(path, MARK)


def require_writable(folder: Path) -> None:
    """A folder a command is to write in, or the folder it would be made in, that cannot be written
    (a read-only file system, no permission) is said now, before the command's work (a benchmark's
    runs take minutes), as the OSError a write would meet."""
    existing = next((path for path in (folder, *folder.parents) if os.path.lexists(path)), None)
    if existing is None or not existing.is_dir():
        return  # a file on the way: the command's own check names it
    try:  # a probe, not os.access: root passes access() where a read-only or virtual file system refuses
        handle, probe = tempfile.mkstemp(prefix=".orchestrate-probe-", dir=existing)
    except OSError as error:
        raise OSError(error.errno, f"{error.strerror}: it cannot be written", str(existing)) from None
    os.close(handle)
    os.unlink(probe)


def refuse_folder(folder: Path, command: str, force: bool, option: str = "--out") -> None:
    """Raises unless `command` may write into `folder`: a new or empty folder, or with `force` one
    whose record is this command's and which holds nothing else; and a folder it can write."""
    require_writable(folder)
    present = entries(folder, option)
    if not present:
        return
    record = read_record(folder)
    if record is None:
        raise OutputError(f"{option} {folder} exists and holds files no orchestrate command recorded writing "
                          f"({listed(present)}; no {RECORD}): choose a new or empty folder")
    if record["command"] != command:
        raise OutputError(f"{option} {folder} holds the files of `{command_line(record['command'])}`, not of "
                          f"`{command_line(command)}`: choose another {option}")
    if not force:
        raise OutputError(f"{option} {folder} exists (written by `{command_line(command)}` before): pass --force "
                          f"to replace its files, or choose another {option}")
    foreign = present - {RECORD, *record["files"], *record["folders"]}
    if foreign:
        raise OutputError(f"{option} {folder} also holds {listed(foreign)}, which `{command_line(command)}` did not "
                          f"write: --force replaces only its own files; move those away or choose another {option}")
    odd = [name for name in record["folders"] if name in present and not (folder / name).is_symlink()
           and not (folder / name).is_dir()]
    if odd:
        raise OutputError(f"{option} {folder}: {listed(odd)} should be a folder of runs and is not: remove it or "
                          f"choose another {option}")


def claim_growing_folder(folder: Path, command: str, files, folders, work_suffixes=(), option: str = "--out") -> Path:
    """`folder` ready for `command` to add to, with no --force: a command that continues its own
    folder (a sweep runs the rows it lacks). New, empty, or recorded as this command's and holding
    only what its record lists (with the work folders beside its run folders, `work_suffixes`)
    and images this package drew; recorded with the union of the old and new names before anything
    is written."""
    require_writable(folder)
    present = entries(folder, option)
    old = read_record(folder) if present else {"command": command, "files": [], "folders": []}
    if old is None or old["command"] != command:
        whose = "no orchestrate command recorded writing" if old is None else f"`{command_line(old['command'])}` wrote"
        raise OutputError(f"{option} {folder} exists and holds files {whose} ({listed(present)}; a folder of this "
                          f"command holds its {RECORD}, which versions before it did not write): choose a new or "
                          f"empty folder, or one an earlier `{command_line(command)}` recorded")
    folders = sorted({*old["folders"], *folders})
    own = {RECORD, *old["files"], *files, *folders, *(name + suffix for name in folders for suffix in work_suffixes)}
    foreign = {name for name in present - own if not drawn_image(folder / name)}
    if foreign:
        raise OutputError(f"{option} {folder} also holds {listed(foreign)}, which `{command_line(command)}` did not "
                          f"write: move those away or choose another {option}")
    folder.mkdir(parents=True, exist_ok=True)
    write_record(folder, command, {*old["files"], *files}, folders,
                 "the files and run folders this command wrote here, which a later one continues")
    return folder


def claim_folder(folder: Path, command: str, files, force: bool, folders=(), option: str = "--out") -> Path:
    """`folder` ready for `command` to write `files` in (and runs in `folders`): checked as by
    refuse_folder, made if new, emptied of the files its record lists, and recorded as this
    command's before anything is written."""
    refuse_folder(folder, command, force, option)
    folder.mkdir(parents=True, exist_ok=True)
    old = read_record(folder) or {"files": [], "folders": []}
    present = set(os.listdir(folder))
    for name in old["files"] + old["folders"]:
        if name not in present:
            continue
        path = folder / name
        if path.is_symlink() or (name in old["files"] and path.is_file()):
            path.unlink()
        elif name in old["files"] and os.path.lexists(path):
            raise OutputError(f"{option} {folder}: {name} was a file of `{command_line(command)}` and is now a "
                              f"folder: remove it or choose another {option}")
    write_record(folder, command, files, folders,
                 "the files this command wrote here: --force replaces these and refuses a folder holding others")
    return folder


def refuse_file(path: Path, force: bool, mark: str, option: str = "--out") -> None:
    """Raises unless `path` may be written: no such file, or with `force` a regular file that holds
    `mark` (one this program wrote)."""
    if not os.path.lexists(path):
        return
    refuse_link(path, option, "give another file name")
    if not path.is_file():
        raise OutputError(f"{option} {path} exists and is not a file: choose another {option}")
    if not force:
        raise OutputError(f"{option} {path} exists: pass --force to replace it (only a file this program "
                          f"wrote), or choose another {option}")
    if not holds_mark(path, mark):
        raise OutputError(f"{option} {path} exists and was not written by this program (it lacks '{mark}'): "
                          f"--force replaces only the program's own files; choose another {option}")


def claim_file(path: Path, force: bool, mark: str, option: str = "--out") -> None:
    """`path` ready to be written: refuse_file's checks, then its folder made when new (as run --out
    makes its parents), unless a folder on the way is a file."""
    refuse_file(path, force, mark, option)
    folder = path.absolute().parent
    found = next(parent for parent in (folder, *folder.parents) if os.path.lexists(parent))
    if not found.is_dir():
        raise OutputError(f"{option} {path}: {found} is a file, not a folder: choose another {option}")
    folder.mkdir(parents=True, exist_ok=True)


# How each kind of file this package writes begins: a file named so that does not begin so is no
# image of ours, whatever words it holds; a page (.md) holds its mark in its opening lines.
SIGNATURES = {".png": b"\x89PNG\r\n\x1a\n", ".pdf": b"%PDF-", ".svg": b"<?xml"}
OPENING = 4096  # bytes of a page that hold its mark


def holds_mark(path: Path, mark: str) -> bool:
    """A regular file (never a link, a folder or a pipe, which a read would wait on) that holds
    `mark` as a file of its kind does."""
    try:
        descriptor = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except OSError:
        return False
    status = os.fstat(descriptor)
    if not stat.S_ISREG(status.st_mode) or status.st_size > LARGEST_OWN_FILE:
        os.close(descriptor)
        return False
    with os.fdopen(descriptor, "rb") as handle:
        data = handle.read()
    signature = SIGNATURES.get(path.suffix.lower())
    if signature is None:
        return mark.encode() in data[:OPENING]
    return data.startswith(signature) and mark.encode() in data
