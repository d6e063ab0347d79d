"""The child process of orchestrate/mesh.py: mesh one .geo with gmsh's Python API and write it.

    python orchestrate/gmsh_mesher.py SOURCE.geo '{"n": 24}' REFINE TARGET.msh LIMITS [SIZES.pos]

It imports gmsh, numpy (which gmsh's arrays come through) and the standard library only, and exits
with gmsh's error lines as its message.
A .geo is code in gmsh's language, which can run programs and read and write files: before gmsh
reads the source, the process confines itself with Landlock where the kernel offers it (Linux
5.13 and later, when enabled): from then on it and its children may start no program, read no
file but the sources' copies, write none but the target, open no TCP connection and signal no
other process, and its environment is empty (GetEnv reads nothing). Its resources are bounded
too, whatever the .geo asks (LIMITS, a JSON object): CPU seconds, address space and file size by
rlimits (the parent adds the wall clock), and the node count the .geo's sizes give, estimated from
its boundary mesh and its size field before the surfaces are meshed. Before gmsh meshes anything,
the body's coordinates and a size field's points and sizes must lie where gmsh meshes faithfully
(`box_fault`, `sizes_fault`): beyond, it merges points, ignores sizes or spends its memory and
time on a few elements.
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
TOO_MANY_NODES, NOT_P1_TRIANGLES, BAD_GEOMETRY, BAD_SIZES, SILENT_FAILURE = 3, 4, 5, 6, 7

# Where gmsh 4.15 meshes a body faithfully, measured on meshes/rectangle.geo. Its extent (the larger
# side of its box): a square of side 1e-11 meshed at n = 30 kept 120 of its 1 127 nodes (1e-10 all);
# one of side 1e30 spent 2 GB on its boundary and failed, and elements above 1e22 pass gmsh's
# largest size (Mesh.MeshSizeMax). Its coordinates: a unit square at x = 1e7 kept 141 of its 513
# nodes (at 1e6 all). Its box's shorter side: gmsh merges points closer than 1e-8 of the extent
# (Geometry.Tolerance). A size field's sizes: in a unit square, one of 1e-16 exhausted gmsh's
# memory, 1e-30 and below are ignored (the field then sets nothing), down to 1e-12 they are met;
# orchestrate adapt's views give their points to 9 digits, which resolve nothing finer than 1e-8
# of the extent. The bounds keep 10² to 10⁵ from each failure.
EXTENT = (1e-6, 1e15)
OFFSET = 1e4   # a coordinate's magnitude, in extents
FLAT = 1e-6    # the box's shorter side, in extents
SIZES = (1e-8, 1e2)  # a size field's sizes, in extents
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


def box_fault(box: tuple[float, float, float, float]) -> str | None:
    """Why gmsh would not mesh a body in the box (x0, y0, x1, y1) faithfully, naming the value and
    the range allowed; None when it would."""
    x0, y0, x1, y1 = box
    extent = max(x1 - x0, y1 - y0)
    if not EXTENT[0] <= extent <= EXTENT[1]:  # not a number either
        return f"the body's extent (the larger side of its box) {extent:g} is outside [{EXTENT[0]:g}, {EXTENT[1]:g}]"
    far = max(abs(value) for value in box)
    if far > OFFSET * extent:
        return (f"the body's coordinate {far:g} is outside [{-OFFSET * extent:g}, {OFFSET * extent:g}], {OFFSET:g} "
                f"times its extent {extent:g} (move it nearer the origin)")
    if min(x1 - x0, y1 - y0) < FLAT * extent:
        return (f"the shorter side of the body's box {min(x1 - x0, y1 - y0):g} is below {FLAT * extent:g}, {FLAT:g} "
                f"times its extent {extent:g}")
    return None


def geometry_box() -> tuple[float, float, float, float] | None:
    """The box (x0, y0, x1, y1) of the geometry gmsh has read, None for an empty one."""
    import gmsh

    if not gmsh.model.getEntities():
        return None
    x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(-1, -1)
    return x0, y0, x1, y1


def size_table(sizes: Path):
    """A size field's triangles, one row each: its corners' x, y, z, then their sizes (the parent
    checked that every line between the first and the last is one ST(...){...};)."""
    import numpy

    rows = sizes.read_bytes().rstrip(b"\n").split(b"\n")[1:-1]
    fields = b",".join(row[3:-2].replace(b"){", b",") for row in rows).split(b",")
    return numpy.array(fields, dtype=float).reshape(-1, 12)


def sizes_fault(table, box: tuple[float, float, float, float]) -> str | None:
    """Why gmsh would not follow the size field `table` (size_table) on the body in `box`: a size
    outside SIZES times the extent, or a point farther than the extent from the box; None."""
    import numpy

    x0, y0, x1, y1 = box
    extent = max(x1 - x0, y1 - y0)
    low, high = SIZES[0] * extent, SIZES[1] * extent
    sizes = table[:, 9:]
    wrong = ~((sizes >= low) & (sizes <= high))
    if wrong.any():
        row, column = numpy.argwhere(wrong)[0]
        value = sizes[row, column]
        return (f"size {value:g} at line {row + 2} is {'below' if value < low else 'above'} the sizes allowed (the "
                f"allowed range is [{low:g}, {high:g}], {SIZES[0]:g} to {SIZES[1]:g} times the extent {extent:g} of "
                "this body)")
    points = table[:, :9].reshape(-1, 3)
    reach = [(x0 - extent, x1 + extent), (y0 - extent, y1 + extent), (-extent, extent)]
    outside = ~numpy.all([(points[:, j] >= a) & (points[:, j] <= b) for j, (a, b) in enumerate(reach)], axis=0)
    if outside.any():
        point = points[numpy.argmax(outside)]
        return (f"point ({point[0]:g}, {point[1]:g}, {point[2]:g}) at line {numpy.argmax(outside) // 3 + 2} lies "
                f"outside [{reach[0][0]:g}, {reach[0][1]:g}] × [{reach[1][0]:g}, {reach[1][1]:g}] × "
                f"[{reach[2][0]:g}, {reach[2][1]:g}], the body's box widened by its extent {extent:g}")
    return None


def field_nodes(table) -> int:
    """The nodes a mesh following the size field `table` has: 2/√3 ∫ h⁻² over its triangles, h
    linear in each (as gmsh interpolates it): ∫_T h⁻² = 2|T| (−ln)[h1, h2, h3], the second divided
    difference of −ln at the corners' sizes (Hermite–Genocchi), taken from the sizes in decreasing
    order; where they differ by less than a thousandth, |T|/h² at their mean."""
    import numpy

    corners = table[:, :9].reshape(-1, 3, 3)[:, :, :2]
    (ax, ay), (bx, by), (cx, cy) = (corners[:, j].T for j in range(3))
    area = 0.5 * numpy.abs((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))
    a, b, c = numpy.sort(table[:, 9:], axis=1)[:, ::-1].T

    def first(high, low):  # (−ln)[high, low], high ≥ low > 0
        step = high - low
        return numpy.where(step > 1e-6 * low, -numpy.log1p(step / low) / numpy.maximum(step, 1e-300),
                           -(1 - step / (2 * low)) / low)

    spread = a - c
    close = spread < 1e-3 * a
    second = numpy.where(close, 0.0, (first(a, b) - first(b, c)) / numpy.where(close, 1.0, spread))
    mean = (a + b + c) / 3
    integral = numpy.where(close, area / mean ** 2, 2 * area * second)
    return int(EQUILATERAL_NODES * integral.sum())


def require_faithful(table) -> None:
    """Exits (BAD_GEOMETRY, BAD_SIZES, the reason on the last line) unless gmsh would mesh the
    geometry it has read, and follow the size field `table` (or None) on it, faithfully: its box
    (box_fault), no two of its points merged by gmsh's geometrical tolerance, the field's sizes and
    points (sizes_fault)."""
    import gmsh

    box = geometry_box()
    if box is None:
        return  # nothing to mesh: the parent refuses the mesh for its missing labels
    merged = [line for line in gmsh.logger.get() if "closer than the geometrical tolerance" in line]
    fault = box_fault(box) or (f"the body has two points gmsh merges ({merged[0]})" if merged else None)
    if fault:
        print(fault, file=sys.stderr)
        sys.exit(BAD_GEOMETRY)
    fault = sizes_fault(table, box) if table is not None else None
    if fault:
        print(fault, file=sys.stderr)
        sys.exit(BAD_SIZES)


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
        table = size_table(sizes) if sizes is not None else None
        confine(target, source.parent)
        os.environ.clear()  # unsets them for gmsh's getenv too
        gmsh.open(str(source))
        require_faithful(table)
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
        wanted = field_nodes(table) if table is not None else 0
        if max(nodes, wanted) * 4 ** refine > limits["nodes"]:
            print(json.dumps({"nodes": max(nodes, wanted) * 4 ** refine, "area": area, "spacing": spacing,
                              "field": wanted > nodes}), file=sys.stderr)
            sys.exit(TOO_MANY_NODES)
        gmsh.model.mesh.generate(2)
        for _ in range(refine):
            gmsh.model.mesh.refine()
        require_linear_triangles()
        gmsh.write(str(target))
    except Exception as error:
        log = "; ".join(line for line in gmsh.logger.get() if "Error" in line) or str(error)
        if not log:  # gmsh's API turns an exception of its C++ code (std::bad_alloc) into one with no text
            sys.exit(SILENT_FAILURE)
        sys.exit(log)
    finally:
        gmsh.logger.stop()
        gmsh.finalize()


if __name__ == "__main__":
    mesh(Path(sys.argv[1]), json.loads(sys.argv[2]), int(sys.argv[3]), Path(sys.argv[4]), json.loads(sys.argv[5]),
         Path(sys.argv[6]) if len(sys.argv) > 6 else None)
