"""Meshes of scene bodies, made with gmsh's Python API, cached by content and checked whole.

A .geo is code in gmsh's language (it can run programs, read and write files, loop forever): the
sources and the files they include are read once (orchestrate/geo.py) and gmsh meshes a private
copy of that text in a child process confined by Landlock and bounded in time, memory, file size
and nodes (gmsh_mesher.py, `MeshLimits`). Where the kernel has no Landlock only trusted sources
are meshed: the project's own meshes/ (reviewed and committed with the program, which runs with
the user's rights anyway) and a user's with --trust-geo. The cache key is that text and the text
of the files it includes, the -setnumber values and gmsh's version, so an edited source or another
gmsh gives a new mesh and never a stale one. A body given only by its n uses the committed
<geo>-n<n>.msh of meshes/ when it exists, the rule edp/main.edp follows, so a scene and the driver
run by hand mesh the paper's scene identically.

gmsh exits 0 even when it could not write its whole file (a full disk, a file-size limit), and a
.msh cut short crashes FreeFEM's reader: every mesh is read back (`read_msh`) before it enters the
cache and again before it is used (once while the file is unchanged: what it holds is kept against
the file's stamp, `WHOLE`); a bad cache entry is rebuilt. Where a triangle is below gmshload's
area limit the driver gets the mesh in FreeFEM's own format, made once per cache entry and kept
beside it.
"""
from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import unicodedata
from dataclasses import dataclass, field
from pathlib import Path

from orchestrate.freefem import REPO, dying_with_parent, stop_group
from orchestrate.geo import PROJECT_MESHES, GeoError, GeoFile, copy_name, read_sources, write_copies
from orchestrate.gmsh_mesher import (BAD_GEOMETRY, BAD_SIZES, NOT_P1_TRIANGLES, SILENT_FAILURE, TOO_MANY_NODES,
                                     landlock_abi)
from orchestrate.identity import KeptFacts
from orchestrate.parameters import BYTES_PER_NODE

CACHE = REPO / "results" / ".cache" / "meshes"
MSH_BYTES_PER_NODE = 120  # a gmsh 2.2 text file per node (its triangles included): 83 MB at 741 038 nodes
GMSH_ADDRESS_SPACE = 2 ** 30  # the mesher's address space before it meshes (python, gmsh, threads: 0.4 GB measured)
# The largest mesh a run fits in this machine's 23 GiB is about 2.9 M nodes (BYTES_PER_NODE). gmsh's
# frontal-Delaunay meshing of rectangle.geo took 15 s for 0.19 M nodes, 96 s for 0.74 M and 731 s for
# 2.96 M (550 s of CPU, 4.5 GB resident, a 352 MB file; 2 cores shared with a test suite): the default
# leaves such a mesh 2.5 times that, so only a .geo that would never finish meets it.
TIME_LIMIT = 1800.0


SIZES_BYTES = 256 * 2 ** 20  # a size field's largest file: a view of about a million triangles


class MeshError(RuntimeError):
    """gmsh could not mesh a body, or a mesh file is not whole."""


class TooLarge(MeshError):
    """A run whose meshes or memory would not fit this machine, refused before it starts."""


@dataclass(frozen=True)
class MeshLimits:
    """What one mesher may use, and how messages name it: `body` (body1, body2) as in the scene,
    its timeLimit (wall clock and CPU seconds), and whether an unconfined gmsh may read the body's
    .geo on a kernel without Landlock (--trust-geo). Memory, file size and nodes follow from the
    memory this machine has free: no more nodes than a run could hold (BYTES_PER_NODE)."""
    body: str = "bodyN"
    seconds: float = TIME_LIMIT
    trusted: bool = False

    def resources(self) -> dict:
        free = memory_available() or os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
        nodes = free // BYTES_PER_NODE
        own = 2 * nodes * MSH_BYTES_PER_NODE
        inherited = resource.getrlimit(resource.RLIMIT_FSIZE)[0]  # a user's ulimit -f binds the mesher too
        file_size = own if inherited == resource.RLIM_INFINITY else min(own, inherited)
        return {"seconds": math.ceil(self.seconds), "memory": free + GMSH_ADDRESS_SPACE, "fileSize": file_size,
                "fileSizeInherited": file_size < own, "nodes": nodes, "free": free}


DEFINE_CONSTANT = re.compile(r"DefineConstant\s*\[(.*?)\]\s*;", re.DOTALL)
CONSTANT_NAME = re.compile(r"(?:^|,)\s*([A-Za-z_][A-Za-z_0-9]*)\s*=")


def geo_constants(source: Path) -> list[str]:
    """The DefineConstant names of a .geo file and its includes: the values -setnumber can set.
    (Only top-level `name = value` items: a constant given as {value, Min ..., Name "..."} is
    found by its name before the brace.)"""
    names = []
    for file in read_sources(source):
        for block in DEFINE_CONSTANT.findall(re.sub(r"//[^\n]*", "", file.text)):
            names += [name for name in CONSTANT_NAME.findall(re.sub(r"\{[^}]*\}", "0", block)) if name not in names]
    return names


@dataclass(frozen=True, eq=False)
class MeshInfo:
    """What a whole gmsh 2.2 file holds: node and triangle counts, the number of boundary
    segments of each physical line tag (the FreeFEM labels), the smallest triangle area, each
    tag's segments (their end points, ((x1, y1), (x2, y2)) each), for a tag with a node in no
    triangle, where, and the SHA-256 of the bytes read (what hand_over passes on must be them)."""
    nodes: int
    triangles: int
    segments: dict[int, int]
    smallest_area: float = math.inf
    curves: dict[int, list] = field(default_factory=dict)
    stray: dict[int, tuple[float, float]] = field(default_factory=dict)
    digest: str = ""

    @classmethod
    def from_record(cls, record: dict, digest: str = "") -> MeshInfo:
        def by_tag(values: dict) -> dict:
            return {int(tag): value for tag, value in values.items()}

        return cls(record["nodes"], record["triangles"], by_tag(record["segments"]), record["smallestArea"],
                   by_tag(record["curves"]), {tag: tuple(point) for tag, point in by_tag(record["stray"]).items()},
                   digest)


def msh():
    """orchestrate/msh.py, which parses with numpy: a run whose meshes were all read before never
    loads it (nor numpy)."""
    from orchestrate import msh

    return msh


def parse_msh(path: Path) -> MeshInfo:
    """The file parsed, whatever was read before."""
    data = mesh_bytes(path)
    return MeshInfo.from_record(parsed(path, data), hashlib.sha256(data).hexdigest())


def mesh_bytes(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except OSError as error:
        raise MeshError(f"mesh file {path} cannot be read ({error.strerror})") from None


def parsed(path: Path, data: bytes) -> dict:
    """The bytes of the file `path` parsed by orchestrate/msh.py: a MeshInfo's record."""
    module = msh()
    try:
        return module.parse_msh(data)
    except module.NotWhole as fault:
        raise MeshError(f"mesh file {path} is not a whole gmsh 2.2 mesh: {fault} "
                        "(cut short by a full disk or a file-size limit? mesh it again)") from None


def whole_record(record) -> bool:
    try:
        MeshInfo.from_record(record)
        return True
    except (KeyError, TypeError, ValueError, AttributeError):
        return False


# What the files read whole hold, by the SHA-256 of their bytes, kept across processes by the
# parser that read them (msh.py's digest): each mesh is parsed once, not once to trust it and once
# to use it, nor again by the next run; a file edited or swapped, whatever its stamp, is other bytes.
WHOLE = KeptFacts(REPO / "results" / ".cache" / "meshes-read",
                  hashlib.sha256(Path(__file__).with_name("msh.py").read_bytes()).hexdigest(), whole_record)
_whole: dict[str, dict] = {}  # this process's records, by digest (hashing costs about 1 ms per MB)


def read_msh(path: Path) -> MeshInfo:
    """Read a gmsh 2.2 ASCII file back whole: every section closed, as many node and element lines
    as their headers say, finite coordinates. Raises MeshError naming the file and the fault. Bytes
    read whole before are not parsed again (WHOLE)."""
    data = mesh_bytes(path)
    digest = hashlib.sha256(data).hexdigest()
    record = _whole.get(digest) or WHOLE.stored(digest)
    if record is None:
        record = parsed(path, data)
        WHOLE.store(digest, None, record)
    _whole[digest] = record
    return MeshInfo.from_record(record, digest)


def forget_whole_files() -> None:
    """Read every mesh file's record anew from now on, as a fresh process would (the benchmark times runs so)."""
    _whole.clear()


# FreeFEM's gmshload stops ("bug : mes < 1e-8 !", exit 1) at a triangle of smaller area in an ASCII
# file, whatever the length unit (docs/freefem-facts.md); its readmesh of FreeFEM's own format has
# no such limit, and the driver reads either (edp/lib/meshes.idp, loadMesh).
GMSHLOAD_SMALLEST_AREA = 1e-8


def write_freefem(source: Path, target: Path) -> None:
    """The gmsh 2.2 ASCII mesh `source` in FreeFEM's own format (nv nt nbe; x y label per vertex;
    the triangles, then the boundary edges, by 1-based vertex numbers, with their physical tags),
    the mesh gmshload would make: its vertices in their order with label 1 and the doubles an
    ASCII reader parses (written back exactly by repr), the triangles and edges in their order."""
    write_atomically(target, msh().freefem_text(source.read_bytes()).encode())


def write_atomically(target: Path, data: bytes) -> None:
    """`data` at `target`, through a partial file of this process and thread (remove_orphans knows it)."""
    partial = target.with_name(f"{target.stem}.{os.getpid()}.{threading.get_ident()}.partial{target.suffix}")
    try:
        partial.write_bytes(data)
        partial.replace(target)  # atomic: a concurrent run reads a whole file or none
    finally:
        partial.unlink(missing_ok=True)


def hand_over(path: Path, info: MeshInfo, target: Path) -> None:
    """The mesh `path` (read whole: info) as the driver is to read it, at `target`: the bytes read,
    or where a triangle is below gmshload's area limit the same mesh in FreeFEM's format — for a
    cached mesh made once, beside it in the cache (a warm run copies it), for a committed one each
    time. The file must still hold the bytes read (info.digest): the driver gets what was checked."""
    data = mesh_bytes(path)
    if hashlib.sha256(data).hexdigest() != info.digest:
        raise MeshError(f"mesh file {path} changed after it was read and checked: run again")
    if info.smallest_area < GMSHLOAD_SMALLEST_AREA:
        own = path.resolve().parent == (REPO / "meshes").resolve()
        data = msh().freefem_text(data).encode() if own else freefem_twin(path, data)
    target.write_bytes(data)


def freefem_twin(path: Path, data: bytes) -> bytes:
    """The cached gmsh mesh `data`, read from `path`, in FreeFEM's format, kept beside it and named
    by the digest of that mesh and of this module (which converts it): never the twin of another
    file or of an older conversion. Made again when it is not what its record holds (cached)."""
    digest = hashlib.sha256(data)
    digest.update(Path(__file__).read_bytes())
    twin = path.with_name(f"{path.stem}.{digest.hexdigest()[:16]}.mesh")
    kept = cached(twin)
    if kept is None:
        kept = msh().freefem_text(data).encode()
        record(twin, hashlib.sha256(kept).hexdigest())
        write_atomically(twin, kept)
    return kept


# Every cache entry has a record beside it, <entry>.sha256: the entry's SHA-256 in sha256sum's
# format, written when the entry is made (before it: an entry is never there without one) and
# checked at every use, so an entry edited, cut short or swapped for another file is made again,
# never used.
def record_of(entry: Path) -> Path:
    return entry.with_name(entry.name + ".sha256")


def recorded(entry: Path, digest: str) -> bool:
    """Whether the record of `entry` holds `digest`."""
    try:
        return record_of(entry).read_text() == f"{digest}  {entry.name}\n"
    except (OSError, UnicodeDecodeError):
        return False


def record(entry: Path, digest: str) -> None:
    write_atomically(record_of(entry), f"{digest}  {entry.name}\n".encode())


def discard(entry: Path) -> None:
    entry.unlink(missing_ok=True)
    record_of(entry).unlink(missing_ok=True)


def cached(entry: Path) -> bytes | None:
    """The bytes of a cache entry that its record holds, else None (and the entry removed)."""
    try:
        data = entry.read_bytes()
    except OSError:
        data = None
    if data is not None and recorded(entry, hashlib.sha256(data).hexdigest()):
        return data
    discard(entry)
    return None


def cache_key(source: Path, numbers: dict[str, float], refine: int = 0, sizes: Path | None = None) -> str:
    return sources_key(read_sources(source), numbers, refine, read_sizes(sizes))


# A size field's lines, as edp/tools/estimate.edp writes them and nothing else: gmsh parses the
# file with its .geo language, so any other line could be a command.
SIZES_OPEN, SIZES_CLOSE = b'View "sizes" {', b"};"
NUMBER = rb"[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?"
SIZES_LINE = re.compile(rb"ST\(" + rb",".join([NUMBER] * 9) + rb"\)\{" + rb",".join([NUMBER] * 3) + rb"\};")


_checked_sizes: set[bytes] = set()  # the SHA-256 of the size fields checked whole


def read_sizes(path: Path | None, key: str = "mesh.sizes") -> bytes | None:
    """A size field for gmsh (`key`, bodyN.mesh.sizes): a gmsh view of element sizes as `orchestrate
    adapt` writes it, View "sizes" { one ST(x1,y1,z1,x2,y2,z2,x3,y3,z3){h1,h2,h3}; a line }; and
    nothing else, every size a positive number, of a bounded length. gmsh reads it (by its .geo
    parser, confined where the kernel can), so a file of any other form is refused. The same bytes
    are checked once per process (a run's identity and its mesh both read it; a fine design takes
    seconds to check, and its hash milliseconds)."""
    if path is None:
        return None
    if not path.is_file() or path.stat().st_size > SIZES_BYTES or len(text := path.read_bytes()) > SIZES_BYTES:
        raise MeshError(f"{key}: {path} is not a file of at most {SIZES_BYTES} bytes")
    digest = hashlib.sha256(text).digest()
    if digest not in _checked_sizes:
        checked_sizes(path, text, key)
        _checked_sizes.add(digest)
    return text


def checked_sizes(path: Path, text: bytes, key: str) -> None:
    """Refuses `text`, the size field read from `path`, unless it has read_sizes' form."""
    lines = text.split(b"\n")
    if lines and lines[-1] == b"":
        lines.pop()
    wrong = next((j for j, line in enumerate(lines[1:-1], 2) if not SIZES_LINE.fullmatch(line)), None)
    if len(lines) < 3 or lines[0] != SIZES_OPEN or lines[-1] != SIZES_CLOSE or wrong is not None:
        where = f" (line {wrong})" if wrong is not None else ""
        raise MeshError(f"{key}: {path} is not a gmsh view of element sizes as orchestrate adapt writes one{where}: "
                        f'{SIZES_OPEN.decode()} ST(x1,y1,z1,x2,y2,z2,x3,y3,z3){{h1,h2,h3}}; ... {SIZES_CLOSE.decode()}')
    if not msh().positive_sizes(re.findall(NUMBER, b" ".join(lines[1:-1]))):
        raise MeshError(f"{key}: {path} holds a size that is not a positive number")


def sources_key(files: list[GeoFile], numbers: dict[str, float], refine: int, sizes: bytes | None = None) -> str:
    digest = hashlib.sha256()
    for text in [file.text.encode("utf-8", "surrogateescape") for file in files]:
        digest.update(text)
    if sizes is not None:
        digest.update(b"sizes:" + hashlib.sha256(sizes).digest())
    digest.update(Path(__file__).with_name("gmsh_mesher.py").read_bytes())
    digest.update(json.dumps([sorted(numbers.items()), refine]).encode())
    digest.update(gmsh_version().encode())
    return digest.hexdigest()[:24]


@functools.cache
def gmsh_version() -> str:
    """The version of the gmsh package the mesher imports, read from the first gmsh dist-info on
    sys.path as importlib.metadata finds it, without loading that module (15 ms of a run, most of
    it its e-mail parser) or gmsh's library; "none" where no gmsh is installed."""
    for folder in sys.path:
        for info in sorted(Path(folder or ".").glob("gmsh-*.dist-info")):
            try:
                lines = (info / "METADATA").read_text(errors="replace").splitlines()
            except OSError:
                continue
            for line in lines:
                if line.startswith("Version:"):
                    return line.removeprefix("Version:").strip()
    return "none"


def committed_mesh(source: Path, numbers: dict[str, float], refine: int) -> Path | None:
    """The committed <geo>-n<n>.msh a body given only by n uses, when there is one: the project's
    own, in meshes/ (a file beside a user's .geo is not read unchecked as its mesh), refused unless
    it is the mesh of the sources as they are now (require_made_from)."""
    committed = source.with_name(f"{source.stem}-n{int(numbers['n'])}.msh")
    own = source.resolve().parent == (REPO / "meshes").resolve() and committed.is_file() and not committed.is_symlink()
    if set(numbers) != {"n"} or refine != 0 or not own:
        return None
    require_made_from(committed, read_sources(source), int(numbers["n"]))
    return committed


# A committed mesh's record (<mesh>.sha256, sha256sum's format) holds the SHA-256 of each source it
# was made from (the .geo and what it includes, by their paths from the mesh's folder) and of the
# mesh, after a comment saying how it was made; edp/lib/meshes.idp checks the .geo's and the mesh's
# lines the same way when the driver is run by hand.
def made_from(committed: Path, files: list[GeoFile], mesh: bytes) -> list[str]:
    """The record's lines of the sources `files` and the mesh bytes `mesh`, comments aside."""
    return [f"{hashlib.sha256(file.text.encode('utf-8', 'surrogateescape')).hexdigest()}  "
            f"{os.path.relpath(file.path, committed.parent)}" for file in files] + \
        [f"{hashlib.sha256(mesh).hexdigest()}  {committed.name}"]


def require_made_from(committed: Path, files: list[GeoFile], n: int) -> None:
    """Refuses the committed mesh unless its record lists exactly the sources as they are now and
    the mesh as it is, naming what changed and the command that makes it again."""
    record = record_of(committed)
    try:
        listed = [line for line in record.read_text().splitlines() if not line.startswith("#")]
    except (OSError, UnicodeDecodeError):
        listed = None
    wanted = made_from(committed, files, mesh_bytes(committed))
    if listed == wanted:
        return
    changed = [line.split("  ", 1)[1] for line in wanted if line not in (listed or [])]
    why = (f"it has no record {record.name} of what it was made from" if listed is None else
           f"{', '.join(changed) or 'the list of its sources'} changed since its record {record.name} was written")
    raise MeshError(f"the committed mesh {committed} is not the mesh of {files[0].path.name} with n = {n} as it is "
                    f"now ({why}): make it again with `python -m orchestrate commit-mesh {files[0].path} --n {n}`")


def commit_mesh(source: Path, n: int) -> Path:
    """The committed mesh <geo>-n<n>.msh of a .geo of meshes/ made again, with its record: by gmsh's
    command line (gmsh -2 -setnumber n <n>), as the driver meshes a body by hand and as every
    committed mesh was made, from the checked sources' copies, read back whole."""
    files = read_sources(source)
    if files[0].path.parent != PROJECT_MESHES:
        raise GeoError(f"{source}: only the project's meshes/ hold committed meshes")
    committed = files[0].path.with_name(f"{files[0].path.stem}-n{n}.msh")
    with tempfile.TemporaryDirectory() as folder:
        made = Path(folder) / committed.name
        command = ["gmsh", "-2", str(write_copies(files, Path(folder))), "-setnumber", "n", str(n), "-o", str(made)]
        done = subprocess.run(command, capture_output=True, text=True, errors="replace")
        if done.returncode != 0 or not made.is_file():
            said = printable(done.stdout + done.stderr).strip().splitlines()
            errors = [line for line in said if "Error" in line] or said[-3:]  # the .geo's own reason, not gmsh's log
            raise MeshError(f"gmsh could not mesh {source} with n = {n}: {' | '.join(errors)}")
        read_msh(made)
        mesh = made.read_bytes()
    version = subprocess.run(["gmsh", "--version"], capture_output=True, text=True)
    how = (f"# made by gmsh {(version.stdout + version.stderr).strip()}: gmsh -2 {files[0].path.name} -setnumber n {n} "
           f"-o {committed.name}")
    lines = [how, *made_from(committed, files, mesh)]
    write_atomically(record_of(committed), "".join(f"{line}\n" for line in lines).encode())
    write_atomically(committed, mesh)
    return committed


def mesh_identity(source: Path, numbers: dict[str, float], refine: int = 0, sizes: Path | None = None) -> str:
    """What determines a body's mesh before it is made: the committed file's content, or the
    cache key (sources, numbers, size field, gmsh version). Part of a run's completion key."""
    committed = None if sizes else committed_mesh(source, numbers, refine)
    if committed is not None:
        return "committed:" + hashlib.sha256(committed.read_bytes()).hexdigest()
    return "generated:" + cache_key(source, numbers, refine, sizes)


def body_mesh(source: Path, numbers: dict[str, float], refine: int = 0, cache: Path | None = None,
              announce=None, limits: MeshLimits = MeshLimits(), sizes: Path | None = None) -> Path:
    """The .msh file of a gmsh source with DefineConstant values `numbers` (n among them), its
    element sizes from the view `sizes` when given (read_sizes), its triangles split in four
    `refine` times (red refinement: the meshes are nested), read back whole; announce() is called
    when gmsh is to make it (none of a committed or cached mesh), under `limits`."""
    committed = None if sizes else committed_mesh(source, numbers, refine)
    if committed is not None:
        read_msh(committed)
        return committed
    cache = cache or CACHE
    cache.mkdir(parents=True, exist_ok=True)
    remove_orphans(cache)
    files = read_sources(source)  # read once: the key and the mesh are of the same, checked text
    field = read_sizes(sizes, f"{limits.body}.mesh.sizes")
    target = cache / f"{source.stem}-{sources_key(files, numbers, refine, field)}.msh"
    if target.exists():
        try:
            if recorded(target, read_msh(target).digest):
                return target
        except MeshError:
            pass
        discard(target)  # a damaged, edited or swapped entry is made again, never reused
    partial = target.with_name(f"{target.stem}.{os.getpid()}.{threading.get_ident()}.partial.msh")
    if announce:
        announce()
    try:
        generate(files, numbers, refine, partial, limits, field)
        record(target, read_msh(partial).digest)
        os.replace(partial, target)  # atomic: a concurrent reader sees a whole file or none
    finally:
        partial.unlink(missing_ok=True)
    return target


def remove_orphans(cache: Path) -> None:
    """Partial meshes and source copies of mesher processes that no longer run (killed while
    meshing)."""
    for path in [*cache.glob("*.partial.msh"), *cache.glob("*.partial.mesh"), *cache.glob("*.partial.sha256"),
                 *cache.glob("*.partial.geo")]:
        try:
            pid = int(path.name.split(".")[-4])
            os.kill(pid, 0)
        except (ValueError, IndexError, ProcessLookupError):
            shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink(missing_ok=True)
        except PermissionError:
            pass  # another user's live process


_children: set[subprocess.Popen] = set()
_children_lock = threading.Lock()


def stop_meshing() -> None:
    """End every gmsh child still running (an interrupted run must not wait for them)."""
    with _children_lock:
        for process in list(_children):
            stop_group(process)


def generate(files: list[GeoFile], numbers: dict[str, float], refine: int, target: Path,
             limits: MeshLimits = MeshLimits(), sizes: bytes | None = None) -> None:
    """Mesh the sources, from their private copies, in a fresh Python process under `limits`:
    gmsh keeps every -setnumber value for the life of the process (initialize/finalize do not
    reset them), so meshing in-process would give a later body the constants of an earlier one
    that its own scene leaves at their defaults. The child dies with this process."""
    require_confinement(files, limits)
    # gmsh_mesher.py is run as a file, not as a module of this package, so the child imports gmsh
    # and the standard library only (the package's imports would cost it 0.45 s).
    child = Path(__file__).with_name("gmsh_mesher.py")
    folder = target.with_suffix(".geo")  # beside the partial mesh: removed with it if this process is killed
    folder.mkdir()
    resources = limits.resources()
    try:
        command = [sys.executable, str(child), str(write_copies(files, folder)), json.dumps(numbers), str(refine),
                   str(target), json.dumps(resources)]
        if sizes is not None:  # beside the copies: the one folder the confined mesher may read
            (folder / "sizes.pos").write_bytes(sizes)
            command.append(str(folder / "sizes.pos"))
        process = subprocess.Popen(dying_with_parent(command), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                   text=True, errors="replace", start_new_session=True)
        with _children_lock:
            _children.add(process)
        try:
            _, stderr = process.communicate(timeout=limits.seconds)
        except subprocess.TimeoutExpired:
            stop_group(process)
            _, stderr = process.communicate()
            stderr = None
        finally:
            with _children_lock:
                _children.discard(process)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    if stderr is not None and process.returncode == 0:
        return
    target.unlink(missing_ok=True)
    for index, file in enumerate(files):  # gmsh names the copies; the user knows the sources
        stderr = stderr and stderr.replace(str(folder / copy_name(index, file.path)), str(file.path))
    stderr = stderr and stderr.replace(str(folder / "sizes.pos"), f"{limits.body}.mesh.sizes")
    raise failure(files[0].path, numbers, refine, limits, resources, process.returncode, stderr)


def require_confinement(files: list[GeoFile], limits: MeshLimits) -> None:
    """Without Landlock gmsh would run whatever the .geo says with the user's rights: only the
    project's own sources, or a user's the user vouches for, are meshed there."""
    if limits.trusted or landlock_abi() >= 1:
        return
    foreign = [file.path for file in files if not file.path.is_relative_to(PROJECT_MESHES)]
    if foreign:
        raise GeoError(f"{limits.body}.mesh.geo: {foreign[0]} is not one of the project's meshes/ and this kernel "
                       "has no Landlock (Linux 5.13 and later, enabled), which would confine gmsh: a .geo is gmsh "
                       "code, which may run programs and read or write any of your files; mesh it only if you trust "
                       "it, with --trust-geo (orchestrate run, orchestrate sweep)")


def failure(source: Path, numbers: dict[str, float], refine: int, limits: MeshLimits, resources: dict,
            returncode: int, stderr: str | None) -> MeshError:
    """The message of a mesher that failed or was stopped, naming the limit or field concerned;
    gmsh's text is the .geo's (its Error lines), so its control characters are shown escaped."""
    geo = f"{limits.body}'s .geo ({source.name} with {numbers})"
    time_limit = f"{limits.body}.mesh.timeLimit = {limits.seconds:g} s"
    if stderr is None:
        return MeshError(f"{time_limit}: gmsh did not finish meshing {geo} within it; raise it or coarsen the mesh")
    if returncode == -signal.SIGXCPU:
        return MeshError(f"{time_limit}: gmsh used that much CPU time without finishing meshing {geo}; raise it or "
                         "coarsen the mesh")
    if returncode == -signal.SIGXFSZ and resources.get("fileSizeInherited"):
        return MeshError(f"gmsh's mesh of {geo} grew beyond the file-size limit this process runs under "
                         f"({resources['fileSize']:,} bytes, ulimit -f): raise it, or coarsen the mesh")
    if returncode == -signal.SIGXFSZ:
        return MeshError(f"gmsh's mesh of {geo} grew beyond {resources['fileSize'] / 1e6:.3g} MB, the file of a mesh "
                         "this machine's free memory could run: coarsen the mesh")
    lines = printable(stderr).strip().splitlines()
    if returncode == TOO_MANY_NODES:
        return too_many_nodes(json.loads(lines[-1]), geo, refine, limits, resources)
    if returncode in (NOT_P1_TRIANGLES, BAD_GEOMETRY):
        return MeshError(f"{limits.body}.mesh.geo ({source.name} with {numbers}): {lines[-1]}")
    if returncode == BAD_SIZES:
        return MeshError(f"{limits.body}.mesh.sizes: {lines[-1]}")
    if returncode == SILENT_FAILURE or any(word in line for line in lines
                                           for word in ("Out of memory", "bad_alloc", "MemoryError")):
        return MeshError(f"gmsh ran out of the {resources['memory'] / 2**30:.1f} GiB it may use (this machine's free "
                         f"memory) meshing {geo}, or stopped on another error of its own code without a message: "
                         "coarsen the mesh")
    reason = lines[-1] if lines else (f"killed by signal {-returncode}" if returncode < 0 else f"exit code {returncode}")
    return MeshError(f"gmsh could not mesh {source.name} with {numbers}: {reason}")


def too_many_nodes(found: dict, geo: str, refine: int, limits: MeshLimits, resources: dict) -> TooLarge:
    """The refusal of a mesh whose estimated nodes (gmsh_mesher's TOO_MANY_NODES: from its boundary
    mesh, or from its size field where that gives more) a run could not hold."""
    refined = f", refined {refine} times" if refine else ""
    need = (f"; a run on them needs about {found['nodes'] * BYTES_PER_NODE / 2**30:.1f} GiB and "
            f"{resources['free'] / 2**30:.1f} GiB are free")
    if found.get("field"):
        return TooLarge(f"{limits.body}.mesh.sizes: the size field would give {geo} about {found['nodes']:,} nodes "
                        f"(2/√3 ∫ h⁻² over its triangles{refined}){need}: give it larger sizes (a larger orchestrate "
                        f"adapt --target), or lower {limits.body}.mesh.refine")
    return TooLarge(f"{geo} would give about {found['nodes']:,} nodes (an area of {found['area']:.4g} meshed at "
                    f"its boundary's spacing {found['spacing']:.3g}{refined}){need}: lower {limits.body}.mesh.n or "
                    f"{limits.body}.mesh.refine, or the .geo's mesh sizes (Mesh.MeshSizeMax, its points' sizes)")


def printable(text: str) -> str:
    """`text` with every control or format character (a terminal's escape sequences, a
    direction override) written as its Python escape; line ends kept."""
    return "".join(character if character == "\n" or unicodedata.category(character)[0] != "C"
                   else character.encode("unicode_escape").decode() for character in text)


def memory_available() -> int:
    """Bytes the system can still give (MemAvailable), or 0 when unknown."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0
