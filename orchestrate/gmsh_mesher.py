"""The child process of orchestrate/mesh.py: mesh one .geo with gmsh's Python API and write it.

    python orchestrate/gmsh_mesher.py SOURCE.geo '{"n": 24}' REFINE TARGET.msh

It imports gmsh and the standard library only, and exits with gmsh's error lines as its message.
Before gmsh reads the source, the process confines itself with Landlock where the kernel offers it
(Linux 5.13 and later, when enabled): from then on it and its children may start no program,
read no file but the checked copies, write none but the target, open no TCP connection and
signal no other process. The .geo check (orchestrate/geo.py) refuses what gmsh
could do otherwise; this holds even for what the check might miss.
"""
from __future__ import annotations

import ctypes
import json
import os
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
    no other process; False when the kernel has no Landlock (the .geo check is then the only guard)."""
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


def mesh(source: Path, numbers: dict[str, float], refine: int, target: Path) -> None:
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
        confine(target, source.parent)
        gmsh.open(str(source))
        # The file is the one the runner reads: one gmsh 2.2 text file, whatever the .geo set.
        gmsh.option.setNumber("Mesh.MshFileVersion", 2.2)
        gmsh.option.setNumber("Mesh.Binary", 0)
        gmsh.option.setNumber("Mesh.PartitionSplitMeshFiles", 0)
        errors = [line for line in gmsh.logger.get() if line.startswith("Error")]
        if errors:
            raise RuntimeError("; ".join(errors))
        gmsh.model.mesh.generate(2)
        for _ in range(refine):
            gmsh.model.mesh.refine()
        gmsh.write(str(target))
    except Exception as error:
        log = "; ".join(line for line in gmsh.logger.get() if "Error" in line) or str(error)
        sys.exit(log)
    finally:
        gmsh.logger.stop()
        gmsh.finalize()


if __name__ == "__main__":
    mesh(Path(sys.argv[1]), json.loads(sys.argv[2]), int(sys.argv[3]), Path(sys.argv[4]))
