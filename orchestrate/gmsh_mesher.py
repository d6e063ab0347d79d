"""The child process of orchestrate/mesh.py: mesh one .geo with gmsh's Python API and write it.

    python orchestrate/gmsh_mesher.py SOURCE.geo '{"n": 24}' REFINE TARGET.msh LIMITS [SIZES.pos]

It imports gmsh and the standard library only, and exits with gmsh's error lines as its message.
A .geo is code in gmsh's language, which can run programs and read and write files: before gmsh
reads the source, the process confines itself with Landlock where the kernel offers it (Linux
5.13 and later, when enabled): from then on it and its children may start no program, read no
file but the sources' copies, write none but the target, open no TCP connection and signal no
other process, and its environment is empty (GetEnv reads nothing). Its resources are bounded
too, whatever the .geo asks (LIMITS, a JSON object): CPU seconds, address space and file size by
rlimits (the parent adds the wall clock), and the node count the .geo's sizes give, estimated from
its boundary mesh before the surfaces are meshed.
"""
from __future__ import annotations

import ctypes
import json
import os
import resource
import signal
import sys
from pathlib import Path

# Landlock (linux/landlock.h): its system calls (the same numbers on x86-64 and the generic table
# of arm64), filesystem and network rights and scopes, by ABI version.
CREATE_RULESET, ADD_RULE, RESTRICT_SELF = 444, 445, 446
EXECUTE, WRITE_FILE, READ_FILE, READ_DIR = 1 << 0, 1 << 1, 1 << 2, 1 << 3
CHANGE = sum(1 << bit for bit in range(4, 13))  # remove folders and files, make devices, folders, files, sockets, fifos, links
REFER, TRUNCATE = 1 << 13, 1 << 14            # ABI 2, 3
TCP = 1 | 2                                   # bind and connect (ABI 4)
SCOPES = 1 | 2                                # abstract unix sockets and signals of other processes (ABI 6)
PR_SET_NO_NEW_PRIVS = 38


class PathBeneath(ctypes.Structure):
    _pack_ = 1
    _fields_ = [("allowed_access", ctypes.c_uint64), ("parent_fd", ctypes.c_int32)]


def system_library():
    libc = ctypes.CDLL(None, use_errno=True)
    libc.syscall.restype = ctypes.c_long
    return libc


def landlock_abi() -> int:
    """The kernel's Landlock ABI version, below 1 when it has none."""
    return system_library().syscall(CREATE_RULESET, None, ctypes.c_size_t(0), ctypes.c_uint32(1))


def confine(target: Path, sources: Path) -> bool:
    """From now on this process and its children start no program, read only beneath `sources`
    (the checked copies), write only the existing file `target`, open no TCP connection and signal
    no other process; False when the kernel has no Landlock (orchestrate/mesh.py meshes only
    trusted sources then)."""
    libc = system_library()
    abi = landlock_abi()
    if abi < 1:
        return False
    truncate = TRUNCATE if abi >= 3 else 0
    handled = [EXECUTE | WRITE_FILE | READ_FILE | READ_DIR | CHANGE | (REFER if abi >= 2 else 0) | truncate]
    handled += [TCP] if abi >= 4 else []
    handled += [SCOPES] if abi >= 6 else []
    attribute = (ctypes.c_uint64 * len(handled))(*handled)  # struct landlock_ruleset_attr, the members this ABI has
    ruleset = libc.syscall(CREATE_RULESET, ctypes.byref(attribute), ctypes.c_size_t(ctypes.sizeof(attribute)),
                           ctypes.c_uint32(0))
    if ruleset < 0:
        raise OSError(ctypes.get_errno(), "landlock_create_ruleset")
    try:
        for path, rights in ((target, WRITE_FILE | READ_FILE | truncate), (sources, READ_FILE | READ_DIR)):
            handle = os.open(path, os.O_PATH | os.O_CLOEXEC)
            try:
                rule = PathBeneath(rights, handle)
                if libc.syscall(ADD_RULE, ruleset, 1, ctypes.byref(rule), 0) < 0:  # 1: LANDLOCK_RULE_PATH_BENEATH
                    raise OSError(ctypes.get_errno(), f"landlock_add_rule {path}")
            finally:
                os.close(handle)
        if libc.prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0 or libc.syscall(RESTRICT_SELF, ruleset, 0) < 0:
            raise OSError(ctypes.get_errno(), "landlock_restrict_self")
    finally:
        os.close(ruleset)
    return True


# Exit codes the parent turns into messages naming the scene's fields.
TOO_MANY_NODES, NOT_P1_TRIANGLES = 3, 4
TRIANGLE, SEGMENT = 2, 1  # gmsh's element types of 3-node triangles and 2-node lines, all the solver reads
EQUILATERAL_NODES = 2 / 3 ** 0.5  # nodes per h² of area in a mesh of equilateral triangles of side h


def bound_resources(limits: dict) -> None:
    """CPU seconds (SIGXCPU ends the process, SIGKILL a second later), address space (an
    allocation beyond it fails) and the size of any file written (SIGXFSZ), none above a hard
    limit already set."""
    for kind, value in ((resource.RLIMIT_CPU, limits["seconds"]), (resource.RLIMIT_AS, limits["memory"]),
                        (resource.RLIMIT_FSIZE, limits["fileSize"])):
        _, hard = resource.getrlimit(kind)
        capped = (lambda wanted: wanted) if hard == resource.RLIM_INFINITY else (lambda wanted: min(wanted, hard))
        soft = capped(int(value))
        resource.setrlimit(kind, (soft, capped(soft + 1) if kind == resource.RLIMIT_CPU else soft))
    signal.signal(signal.SIGXFSZ, signal.SIG_DFL)  # Python ignores it, and gmsh would go on with a file cut short


def estimated_nodes() -> tuple[int, float, float]:
    """The nodes gmsh's surface mesh will have, from the boundary mesh already made: the area the
    surfaces' boundaries enclose over the square of their mean segment length, or of the size no
    element exceeds (Mesh.MeshSizeMax times Mesh.MeshSizeFactor) where that is smaller; with that
    area and spacing. An estimate: a size field finer inside than on the boundary is met by the
    resource limits only, and a transfinite surface, which keeps its boundary's spacing whatever
    MeshSizeMax says, is overestimated when that is smaller."""
    import gmsh

    tags, coordinates, _ = gmsh.model.mesh.getNodes()
    point = {tag: (coordinates[3 * i], coordinates[3 * i + 1]) for i, tag in enumerate(tags)}
    area = length = segments = 0.0
    for _, surface in gmsh.model.getEntities(2):
        enclosed = 0.0
        for _, curve in gmsh.model.getBoundary([(2, surface)], combined=False, oriented=True):
            types, _, nodes = gmsh.model.mesh.getElements(1, abs(curve))
            for kind, pairs in zip(types, nodes):
                step = gmsh.model.mesh.getElementProperties(kind)[3]
                for i in range(0, len(pairs), step):
                    (xa, ya), (xb, yb) = point[pairs[i]], point[pairs[i + 1]]
                    enclosed += (1 if curve > 0 else -1) * (xa * yb - xb * ya) / 2
                    length += ((xb - xa) ** 2 + (yb - ya) ** 2) ** 0.5
                    segments += 1
        area += abs(enclosed)
    largest = gmsh.option.getNumber("Mesh.MeshSizeMax") * gmsh.option.getNumber("Mesh.MeshSizeFactor")
    spacing = min(length / segments, largest) if segments else 0.0
    return (int(EQUILATERAL_NODES * area / spacing ** 2) if spacing else 0), area, spacing


def require_linear_triangles() -> None:
    """The solver reads 3-node triangles and 2-node boundary lines (FreeFEM's gmshload, P1): a
    .geo that makes other elements is refused naming them and the options that make them."""
    import gmsh

    others = {gmsh.model.mesh.getElementProperties(kind)[0] for dim, wanted in ((2, TRIANGLE), (1, SEGMENT))
              for kind in gmsh.model.mesh.getElementTypes(dim) if kind != wanted}
    if others:
        options = [f"{name} = {gmsh.option.getNumber(name):g}" for name in ("Mesh.ElementOrder", "Mesh.RecombineAll")
                   if gmsh.option.getNumber(name) != (1 if name == "Mesh.ElementOrder" else 0)]
        print(f"its mesh has {', '.join(sorted(others))} elements ({', '.join(options) or 'a Recombine command'}): "
              "the solver takes 3-node triangles only (Mesh.ElementOrder = 1, no Recombine, Mesh.RecombineAll = 0)",
              file=sys.stderr)
        sys.exit(NOT_P1_TRIANGLES)


def size_field(sizes: Path) -> None:
    """The element sizes of the view in `sizes` (mesh.sizes: orchestrate adapt's), and those alone:
    the .geo's point sizes, curvature and boundary extension give way to it."""
    import gmsh

    gmsh.merge(str(sizes))
    field = gmsh.model.mesh.field.add("PostView")
    gmsh.model.mesh.field.setNumber(field, "ViewTag", gmsh.view.getTags()[-1])
    gmsh.model.mesh.field.setAsBackgroundMesh(field)
    for name in ("Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature", "Mesh.MeshSizeExtendFromBoundary"):
        gmsh.option.setNumber(name, 0)


def mesh(source: Path, numbers: dict[str, float], refine: int, target: Path, limits: dict,
         sizes: Path | None = None) -> None:
    bound_resources(limits)
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
        target.touch()  # the one file it may write, made before the confinement
        if gmsh.use_numpy:  # gmsh's arrays come through numpy.ctypeslib, which numpy loads when first used
            import numpy.ctypeslib  # noqa: F401  (here: once confined, no module can be read)
        confine(target, source.parent)
        os.environ.clear()  # unsets them for gmsh's getenv too
        gmsh.open(str(source))
        # The file is the one the runner reads: one gmsh 2.2 text file, whatever the .geo set.
        gmsh.option.setNumber("Mesh.MshFileVersion", 2.2)
        gmsh.option.setNumber("Mesh.Binary", 0)
        gmsh.option.setNumber("Mesh.PartitionSplitMeshFiles", 0)
        if sizes is not None:
            size_field(sizes)
        errors = [line for line in gmsh.logger.get() if line.startswith("Error")]
        if errors:
            raise RuntimeError("; ".join(errors))
        gmsh.model.mesh.generate(1)
        nodes, area, spacing = estimated_nodes()
        if nodes * 4 ** refine > limits["nodes"]:
            print(json.dumps({"nodes": nodes * 4 ** refine, "area": area, "spacing": spacing}), file=sys.stderr)
            sys.exit(TOO_MANY_NODES)
        gmsh.model.mesh.generate(2)
        for _ in range(refine):
            gmsh.model.mesh.refine()
        require_linear_triangles()
        gmsh.write(str(target))
    except Exception as error:
        log = "; ".join(line for line in gmsh.logger.get() if "Error" in line) or str(error) or type(error).__name__
        sys.exit(log)
    finally:
        gmsh.logger.stop()
        gmsh.finalize()


if __name__ == "__main__":
    mesh(Path(sys.argv[1]), json.loads(sys.argv[2]), int(sys.argv[3]), Path(sys.argv[4]), json.loads(sys.argv[5]),
         Path(sys.argv[6]) if len(sys.argv) > 6 else None)
