"""One run of a scene: mesh, write the FreeFEM scene, run edp/main.edp, check, render, summarize.

Paths. FreeFem++ runs with the run's own folder as its working folder and sees only fixed names
there: `-DSCENE=scene.idp` (the generated scene), `-out .`, and the meshes copied in as body1.msh
and body2.msh. No character of a path a user chose reaches FreeFEM's macro preprocessor or its
source text, so none can change the program it compiles.

Completeness. A run is built in `<out>.partial`, held under an exclusive lock for its whole life
(a second run into the same `<out>` is refused), and renamed to `<out>` only once every file the
solver lists has been read back whole and manifest.json (sizes and hashes of every file, and the
digest of the inputs) is written, last. A failure leaves `<out>.failed` with run.log saying why;
an interruption (SIGINT, SIGTERM, SIGHUP) ends FreeFem++'s and gmsh's process groups and leaves
`<out>.partial` with a file INTERRUPTED. `--force` replaces only a run folder, never through a
symbolic link.

Restart. The driver checkpoints its state (edp/lib/checkpoint.idp: by default after every
twentieth of the steps, at least 2 s apart); `resume=True` (`run --resume`, and every sweep)
continues the run in `<out>.partial` from its newest checkpoint when that folder was made from the
same inputs (inputs.json), and gives the files an uninterrupted run gives, to the bit. Computed
steps are never deleted unasked: a partial folder that cannot be continued, or a failed run beside
<out>, is kept and the run refused saying what to do, unless `force`.
"""
from __future__ import annotations

import ctypes
import fcntl
import functools
import hashlib
import importlib
import json
import os
import platform
import re
import shutil
import signal
import threading
import time
from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from orchestrate import mesh as meshing
from orchestrate.freefem import (FILE_PROBLEM, MAIN, REPO, FileProblem, InputError, SolverError, file_problem,
                                 freefem_binary, require_plain_path, run_logged)
from orchestrate.identity import solver_identity
from orchestrate.manifest import (FACTS, IMAGE, MANIFEST, IncompleteRun, StrayFiles, check_files, is_run_entry,
                                  write_manifest)
from orchestrate.outputs import drawn_image
from orchestrate.parameters import driver_name_keys
from orchestrate.progress import RunProgress, run_progress, wanted
from orchestrate.scene import RESULT_FREE, Scene, SceneError, to_freefem_scene
from orchestrate.schema import shown
from orchestrate.steps import StepsError, choose_steps

if TYPE_CHECKING:
    from orchestrate.results import Result

NAME_MAX, PATH_MAX = 255, 4096  # bytes in one path component, and in a whole path, on Linux
SUFFIXES = (".partial", ".failed", ".replaced")  # the run's work folders beside <out>
RUN_FILES = (MANIFEST, FACTS, "params_used.json", "summary.json")  # what marks a folder a run wrote
WORK_FILES = ("inputs.json", "scene.toml", "run.log", "INTERRUPTED")  # and one a run is writing
# What a runner killed while it wrote its last files leaves: the manifest's and an image's
# temporary files (manifest.write_manifest, outputs.created), removed when the run is continued.
RUNNER_SCRATCH = re.compile(r"manifest\.json\.partial|\.[0-9a-f]{12}\.writing")


class RunError(RuntimeError):
    """A run that could not start (its folder exists or is taken) or could not be written."""


class Interrupted(RunError):
    exit_code = 130  # the command's, as for any process ended by Ctrl-C


TooLarge = meshing.TooLarge  # a run whose meshes or memory would not fit this machine, refused before it starts


@contextmanager
def signals_as_interrupt():
    """Turn SIGTERM and SIGHUP into an exception while a run is in progress (main thread only),
    so the child processes are ended and the partial folder marked, as for Ctrl-C."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise Interrupted(f"interrupted by signal {signal.Signals(signum).name}")

    previous = {number: signal.signal(number, handler) for number in (signal.SIGTERM, signal.SIGHUP)}
    try:
        yield
    finally:
        for number, action in previous.items():
            signal.signal(number, action)


@functools.cache
def package_versions() -> dict[str, str]:
    from importlib import metadata  # 15 ms: loaded while FreeFem++ runs (prepare_reading)

    versions = {"python": platform.python_version()}
    for name in ("numpy", "meshio", "pyvista", "vtk", "matplotlib", "gmsh", "dask", "distributed"):
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def default_folder(scene_path: Path | None) -> Path:
    """results/<scene name> in the current folder: a user's runs go to the user's project."""
    return Path("results") / (scene_path.stem if scene_path else "run")


def output_folder(out: str | Path) -> Path:
    """The absolute output folder, its parent's symbolic links resolved but never its own; refused
    with the reason when its name cannot hold a run (control characters, not UTF-8, too long)."""
    require_plain_path(Path(out), "--out")
    path = Path(os.path.abspath(out))
    if path.name in ("", ".", ".."):
        raise InputError(f"--out {str(out)!r} names no folder: give a folder name, e.g. --out results/run")
    if path.name.endswith(SUFFIXES):
        raise InputError(f"--out {str(out)!r}: a name ending in {', '.join(SUFFIXES)} is the runner's own, for the "
                         "folders beside a run: choose another")
    longest = max(len(suffix) for suffix in SUFFIXES)
    if len(path.name.encode()) + longest > NAME_MAX:
        raise InputError(f"--out: the folder name is {len(path.name.encode())} bytes long; at most "
                         f"{NAME_MAX - longest} are allowed (a file name holds {NAME_MAX} and the run adds '.replaced')")
    if len(os.fsencode(path)) + longest + 64 > PATH_MAX:
        raise InputError(f"--out: the path is {len(os.fsencode(path))} bytes long; a run's files need it under "
                         f"{PATH_MAX - longest - 64}")
    return path.parent.resolve() / path.name


def holds(path: Path, names) -> bool:
    """A real folder (not a link), empty or holding one of the files `names`."""
    return path.is_dir() and not path.is_symlink() and (
        not any(path.iterdir()) or any((path / name).is_file() for name in names))


def is_run_folder(path: Path) -> bool:
    """A folder a run wrote, or an empty one: what --force may replace (the curated results/
    folders keep a run's summary and images)."""
    return holds(path, RUN_FILES)


def is_work_folder(path: Path) -> bool:
    """A folder a run is writing or left (<out>.partial, .failed, .replaced), or an empty one:
    what a run may empty or remove. Anything else by those names is a user's and is kept."""
    return holds(path, RUN_FILES + WORK_FILES)


def refuse_existing(out: Path, force: bool) -> None:
    if not os.path.lexists(out):
        return
    if out.is_symlink():
        raise RunError(f"{out} is a symbolic link: give the folder itself (a run never deletes through a link)")
    if not is_run_folder(out):
        raise RunError(f"{out} exists and is not a run folder (no manifest.json, run.json or summary.json): choose another "
                       "--out (--force replaces only the folders of runs)")
    if not force:
        raise RunError(f"{out} exists: choose another --out or pass --force to replace it")
    foreign = [name for name in os.listdir(out) if not is_run_entry(name)
               or IMAGE.fullmatch(name) and not drawn_image(out / name)]  # an image by name only: the user's
    if foreign:
        raise RunError(f"{out} holds a run and also {', '.join(sorted(foreign)[:5])}{' …' if len(foreign) > 5 else ''}, "
                       "which no run writes: --force replaces only a run's own files; move those away or choose another --out")


def refuse_foreign(folder: Path) -> None:
    if os.path.lexists(folder) and not is_work_folder(folder):
        raise RunError(f"{folder} exists and is not a run's folder (a file, a link, or files no run wrote): "
                       "remove it or choose another --out")


@contextmanager
def claimed(out: Path, keep=None):
    """`<out>.partial`, held under an exclusive lock until the block ends; emptied unless `keep`
    says its contents are to be continued (keep(partial) -> bool, asked under the lock)."""
    partial = out.with_name(out.name + ".partial")
    refuse_foreign(partial)
    try:
        partial.mkdir(parents=True, exist_ok=True)
        handle = os.open(partial, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
    except OSError as error:
        raise FileProblem(f"cannot make the run's folder: {file_problem(error)}") from None
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise RunError(f"another run is writing {out} (it holds {partial}): wait for it or choose another --out") \
                from None
        try:
            moved = os.fstat(handle).st_ino != os.stat(partial, follow_symlinks=False).st_ino
        except FileNotFoundError:
            moved = True
        if moved:
            raise RunError(f"{partial} was replaced while this run claimed it: another run is writing {out}")
        if not (keep and keep(partial)):
            for path in partial.iterdir():  # what an earlier, crashed run left
                shutil.rmtree(path) if path.is_dir() and not path.is_symlink() else path.unlink()
        yield partial
    finally:
        os.close(handle)


def result_code(scene: Scene) -> str:
    """The FreeFEM scene of a run with the RESULT_FREE keys at fixed values: what of the generated
    code a result depends on (a resumed run may checkpoint at another rate)."""
    output = scene.output.model_copy(update={"checkpointEvery": 0, "checkpointSeconds": 0.0, "images": True})
    return to_freefem_scene(scene.model_copy(update={"output": output}))




def inputs_of(scene: Scene) -> dict:
    """Everything a run's result depends on: the scene as validated (RESULT_FREE aside) and the
    FreeFEM scene written from it (so a change in how it is written counts), the solver's identity
    (its sources, plugins and FreeFem++: orchestrate/identity.py) and what determines each body's
    mesh (committed file content, or .geo sources, the mesher, numbers and gmsh version). A run folder whose manifest holds the same digest is the same run."""
    data = scene.model_dump(mode="json")
    data["output"] = {key: value for key, value in data["output"].items() if key not in RESULT_FREE}
    for body in ("body1", "body2"):  # where a .geo lives changes no result: its text is in "meshes"; nor
        data[body]["mesh"].pop("geo")  # does the time gmsh may take, nor where its size field is (its text is)
        data[body]["mesh"].pop("timeLimit")
        data[body]["mesh"].pop("sizes")
    parts = {"scene": hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest(),
             "freefemScene": hashlib.sha256(result_code(scene).encode()).hexdigest(),
             "solver": solver_identity(MAIN),
             "meshes": [meshing.mesh_identity(body.mesh.source(), body.mesh.numbers(), body.mesh.refine,
                                              body.mesh.size_field()) for body in (scene.body1, scene.body2)]}
    parts["digest"] = hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()
    return parts


CHECKPOINTS = ("checkpoint-a.txt", "checkpoint-b.txt")


def sealed_checkpoint(path: Path) -> tuple[int, str] | None:
    """(step, run identity) of a whole checkpoint file: its last line "end <step>" repeats its
    first, "checkpoint <step>", its third is "run <identity>" and the line before the last is the
    SHA-256 of all above it (the driver's rule, edp/lib/checkpoint.idp); None for any other file."""
    try:
        data = path.read_bytes()
    except OSError:
        return None
    lines = data.split(b"\n")
    if len(lines) < 6 or lines[-1] != b"" or not lines[-3].startswith(b"seal "):
        return None
    body = b"\n".join(lines[:-3]) + b"\n"
    first, identity = lines[0].split(), lines[2].split()
    whole = (len(first) == 2 and first[0] == b"checkpoint" and lines[-2] == b"end " + first[1]
             and len(identity) == 2 and identity[0] == b"run"
             and lines[-3][len(b"seal "):].decode(errors="replace") == hashlib.sha256(body).hexdigest())
    return (int(first[1]), identity[1].decode(errors="replace")) if whole and first[1].isdigit() else None


def sealed_checkpoints(partial: Path) -> list[tuple[int, str]]:
    """(step, run identity) of each whole checkpoint in a partial folder."""
    return [found for name in CHECKPOINTS if (found := sealed_checkpoint(partial / name))]


def checkpoint_step(partial: Path) -> int:
    """The step of the newest whole checkpoint in a partial folder (0: none)."""
    return max([0] + [step for step, _ in sealed_checkpoints(partial)])


def steps_done(partial: Path) -> int:
    """The steps an interrupted run in `partial` computed: history.csv's rows (0 without one)."""
    try:
        with open(partial / "history.csv", "rb") as history:
            return max(sum(1 for _ in history) - 1, 0)
    except OSError:
        return 0


# What becomes of a `<out>.partial` folder a run finds (resumable): made anew, continued from its
# newest checkpoint, or finished (its driver ran to the end; what is left is Python's: the files
# read back, images, manifest).
FRESH, RESTART, FINISHED = "fresh", "restart", "finished"


def resumable(partial: Path, inputs: dict, resume: bool, force: bool) -> str:
    """What to do with `<out>.partial` (FRESH, RESTART or FINISHED). Continued when asked (resume)
    and it holds a checkpoint of a run of these inputs, or a run of these inputs its driver
    finished. Computed steps are never discarded unasked: a folder holding any that cannot be
    continued is refused, saying why and what to do, unless force says to start over; one holding
    none (a run stopped while meshing) is made anew."""
    found = sealed_checkpoints(partial)
    done = steps_done(partial)
    finished = driver_finished(partial)
    if not found and not done and not finished:
        return FRESH
    recorded = recorded_inputs(partial)
    same = recorded.get("digest") == inputs["digest"]
    continued = same and (finished or bool(found) and {identity for _, identity in found} == {inputs["digest"]})
    if force and not (resume and continued):
        return FRESH
    kept = f"its files stay there: --force to start over (they are then deleted), or move {partial.name} away to keep them"
    foreign = [name for name in sorted(os.listdir(partial))
               if not (is_run_entry(name) or name in WORK_FILES or RUNNER_SCRATCH.fullmatch(name))]
    if foreign:
        raise RunError(f"{partial} holds {', '.join(foreign[:5])}, which no run writes: move it away, then --resume "
                       f"again; {kept}")
    if not same:
        raise RunError(f"{partial} holds a run of other inputs ({differing_inputs(recorded, inputs)}): it cannot be "
                       f"continued with this scene; {kept}")
    if finished:
        if not resume:
            raise RunError(f"{partial} holds a run whose solver finished and whose files were not published: --resume "
                           f"to read them back and publish them; {kept}")
        return FINISHED
    if not found:
        damaged = [name for name in CHECKPOINTS if (partial / name).exists()]
        why = (f"its checkpoints ({', '.join(damaged)}) are cut short or damaged" if damaged else
               "no checkpoint to continue from (output.checkpointEvery sets how often a run writes one; none is written "
               "within a start in substeps, time.startSteps)")
        raise RunError(f"{partial} holds an interrupted run of {done} computed steps and {why}; {kept}")
    step = max(step for step, _ in found)
    if not resume:
        raise RunError(f"{partial} holds an interrupted run with a checkpoint at step {step}: --resume to continue it; "
                       f"{kept}")
    if not continued:
        raise RunError(f"{partial} holds a checkpoint of a run of other inputs: it cannot be continued with this one; "
                       f"{kept}")
    return RESTART


def driver_finished(folder: Path) -> bool:
    """Whether the driver finished the run in `folder` (run.json, its last act, says finished: true)."""
    try:
        return json.loads((folder / FACTS).read_bytes()).get("finished") is True
    except (OSError, ValueError, AttributeError):
        return False


def recorded_inputs(partial: Path) -> dict:
    """The inputs a partial folder was made from (inputs.json), or {} without a readable record."""
    try:
        recorded = json.loads((partial / "inputs.json").read_text())
    except (OSError, ValueError):
        return {}
    return recorded if isinstance(recorded, dict) else {}


INPUT_PARTS = {"scene": "the scene", "freefemScene": "the scene as the driver reads it",
               "solver": "the solver's code", "meshes": "the meshes"}


def differing_inputs(recorded: dict, inputs: dict) -> str:
    """Which parts of a run's inputs differ from a folder's record of them, in words."""
    if not recorded:
        return "it holds no readable inputs.json, the record of the inputs it was made from"
    parts = [part for part in INPUT_PARTS if recorded.get(part) != inputs.get(part)]
    if "scene" in parts and "freefemScene" in parts:  # the second follows from the first
        parts.remove("freefemScene")
    words = [INPUT_PARTS[part] for part in parts] or ["the inputs"]
    return (", ".join(words[:-1]) + " and " if len(words) > 1 else "") + words[-1] + (" differ" if len(words) > 1 else " differs")


def refuse_failed(failed: Path, force: bool) -> None:
    """A failed run beside <out> that computed steps is kept unless force: a new run would replace
    it (one refused before its first step, by its input or its meshes, is replaced: nothing of it
    is lost but its run.log)."""
    if force or failed.is_symlink() or not os.path.lexists(failed):
        return
    refuse_foreign(failed)
    if not steps_done(failed) and not sealed_checkpoints(failed):
        return
    raise RunError(f"{failed} holds a run that failed ({failure_of(failed)}); a failed run cannot be continued, and a new "
                   f"run into {failed.name.removesuffix('.failed')} would replace it: move it away to keep it, or pass "
                   "--force to replace it")


def failure_of(folder: Path) -> str:
    """The reason a run.log gives for a failure: its last ERROR line, cut to a readable length."""
    try:
        lines = [line for line in (folder / "run.log").read_text(errors="replace").splitlines() if line.startswith("ERROR:")]
    except OSError:
        lines = []
    reason = lines[-1].removeprefix("ERROR:").strip() if lines else "run.log gives no reason"
    return reason if len(reason) <= 160 else reason[:157] + "..."


def run(scene: Scene | str | Path, out: str | Path | None = None, overrides: dict | None = None, *,
        force: bool = False, resume: bool = False, progress: bool | str = "auto", mesh_cache: Path | None = None,
        solver_flags: tuple = (), trust_geo: bool = False) -> Result:
    """Run a scene (a Scene or a .toml path, with dotted-key overrides) into folder `out`.
    resume: continue the interrupted run in `<out>.partial` from its newest checkpoint when it has
    the same inputs; progress: a bar on stderr or in a notebook, True, False or "auto" (where one
    can be seen: orchestrate/progress.py); mesh_cache: another mesh cache folder (the benchmark's,
    to time meshing); solver_flags: extra driver flags that change no result (RESULT_FREE_FLAGS, e.g.
    -measureSolves 10; any other is refused);
    trust_geo: mesh a user's .geo even where no Landlock confines gmsh (orchestrate/mesh.py)."""
    wanted(progress)  # a wrong value is said before anything runs
    require_result_free(solver_flags)
    scene_path = None if isinstance(scene, Scene) else Path(scene)
    scene = Scene.load(scene_path, overrides) if scene_path else scene.with_overrides(overrides or {})
    require_plain_path(REPO, "the repository's location")
    freefem_binary()  # its absence is said before anything is written
    out = output_folder(out or default_folder(scene_path))
    refuse_existing(out, force)
    inputs = inputs_of(scene)
    failed = out.with_name(out.name + ".failed")
    refuse_failed(failed, force)
    started = time.perf_counter()
    restart = finished = False

    def keep(partial: Path) -> bool:
        nonlocal restart, finished
        state = resumable(partial, inputs, resume, force)
        restart, finished = state == RESTART, state == FINISHED
        return state != FRESH

    steps = None if scene.time.N == "auto" else scene.time.N  # "auto": known once the pilots ran
    with (claimed(out, keep) as partial,
          run_progress(progress, out.name, steps, checkpoint_step(partial) if restart else 0) as bar):
        try:
            refuse_existing(out, force)  # again, now that no other run can take the folder
        except RunError:
            partial.rmdir()
            raise
        for name in os.listdir(partial):
            if name == "INTERRUPTED" or RUNNER_SCRATCH.fullmatch(name):
                (partial / name).unlink()
        (partial / "inputs.json").write_text(json.dumps(inputs, indent=1) + "\n")
        try:
            with signals_as_interrupt():
                planned, plan = resolve_steps(scene, partial, mesh_cache, restart or finished, bar, trust_geo)
                summary, verified = build(planned, partial, bar, mesh_cache,
                                          ("-runIdentity", inputs["digest"], "-solverIdentity", inputs["solver"],
                                           *solver_flags), restart, trust_geo, finished)
                if plan:
                    summary["timeSteps"] = plan
                summary["wallSeconds"] = round(time.perf_counter() - started, 3)
                (partial / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
                write_manifest(partial, inputs, verified)
                retire(failed)
                publish(partial, out)
        except (KeyboardInterrupt, Interrupted) as error:
            meshing.stop_meshing()
            reason = str(error) or "Ctrl-C"
            noted(partial / "INTERRUPTED", f"This run was {reason}; its files are incomplete.\n")
            raise Interrupted(f"run {reason}; the incomplete files are in {partial}: --resume continues it from its "
                              "last checkpoint") from None
        except StrayFiles as error:  # a file dropped into the folder while it ran: the run itself is whole
            keep_interrupted(partial, str(error))
            raise RunError(f"{error}: move it away, then --resume to publish the run (its solver finished)") from None
        except (SolverError, meshing.MeshError, InputError, TooLarge, IncompleteRun) as error:
            if isinstance(error, SolverError) and error.returncode == FILE_PROBLEM:
                keep_interrupted(partial, str(error))  # nothing wrong with the run: --resume once there is space
                raise FileProblem(f"{error}. The run's files stay in {partial}: free space, then --resume") from None
            if (restart or finished) and not (isinstance(error, SolverError) and error.returncode not in KEPT_FAILURES):
                keep_interrupted(partial, str(error))  # it did not continue: the interrupted run is as it was
                where = f"from its checkpoint at step {checkpoint_step(partial)}" if restart else "(its solver had finished)"
                raise RunError(f"{partial} could not be continued {where}: {error}. Its files stay there: --resume again "
                               f"once that is mended, --force to start over (they are then deleted), or move "
                               f"{partial.name} away to keep them") from None
            fail_into(partial, failed, str(error))
            if isinstance(error, SolverError):  # where its files went, and the driver's message without FreeFEM's trace
                raise SolverError(error.returncode, f"{error.message} (the run's files are in {failed})",
                                  without_trace(error.log_tail)) from None
            raise
        except OSError as error:  # a full disk, a file-size limit, a folder that cannot be written
            said = file_problem(error, f"a file in {partial}")
            keep_interrupted(partial, said)
            raise FileProblem(f"cannot write the run: {said}. The files written so far stay in {partial}: free space, "
                              "then --resume") from None
        except Exception as error:  # a fault of this program: the folder still says what happened
            fail_into(partial, failed, f"{type(error).__name__}: {error}")
            raise
    from orchestrate.results import Result

    return Result(out)  # built and checked above (build, write_manifest): not read a second time


# FreeFEM's call trace after a failure (bin/ff strips it the same way): its lines, not the driver's.
TRACE = re.compile(r" *current line = .*| call .* at  line [0-9]+|exit\([0-9]+\)| err code [0-9]+ ,  mpirank .*")


def without_trace(text: str) -> str:
    return "\n".join(line for line in text.splitlines() if not TRACE.fullmatch(line))


# The driver's flags a caller may add to a run (solver_flags): those that change no result (the
# benchmark's measurements, the memory a run may take), so that a run folder never holds files
# its scene and its inputs' digest do not give.
RESULT_FREE_FLAGS = ("-measureSolves", "-memoryLimitMB")


def require_result_free(flags: tuple) -> None:
    names = list(flags[::2])
    wrong = [name for name in names if name not in RESULT_FREE_FLAGS]
    if wrong or len(flags) % 2:
        raise InputError(f"solver_flags {shown(list(flags))}: give pairs of a flag and its value, the flags "
                         f"{', '.join(RESULT_FREE_FLAGS)} only (any other changes the run: give it in the scene)")


# The driver's exit codes after which a resumed run is still the interrupted one (docs/usage.md,
# "Exit codes"): its input or checkpoint refused (3), a file it could not write (74: after space is
# freed, --resume continues it). Any other code stopped a step it took: it is a failed run.
KEPT_FAILURES = (3, FILE_PROBLEM)


def keep_interrupted(partial: Path, reason: str) -> None:
    """An interrupted run that could not be continued: why, at the end of its run.log and in
    INTERRUPTED (as far as the disk lets them be written: the reason is raised anyway)."""
    noted(partial / "run.log", f"\nERROR: resuming failed: {reason}\n")
    noted(partial / "INTERRUPTED", f"This run was interrupted, and resuming it failed: {reason}\n")


def fail_into(partial: Path, failed: Path, reason: str) -> None:
    """A failed run: its reason at the end of run.log, its folder renamed <out>.failed. On a disk
    that refuses even that, the folder stays <out>.partial: the caller raises the reason anyway."""
    noted(partial / "run.log", f"\nERROR: {reason}\n")
    try:
        retire(failed)
        partial.rename(failed)
    except OSError:
        pass


def noted(path: Path, text: str) -> None:
    """`text` appended to a file of a failed run, if the disk lets it be."""
    try:
        with open(path, "a") as file:
            file.write(text)
    except OSError:
        pass


def retire(folder: Path) -> None:
    """Remove a work folder beside <out> (a link there: the link only; a folder no run wrote:
    refused, never removed)."""
    if folder.is_symlink():
        folder.unlink()
    elif os.path.lexists(folder):
        refuse_foreign(folder)
        shutil.rmtree(folder)


_LIBC = ctypes.CDLL(None, use_errno=True)
AT_FDCWD, RENAME_EXCHANGE = -100, 2


def exchange(first: Path, second: Path) -> bool:
    """Swap two folders in one step (Linux renameat2); False where the system cannot."""
    swap = getattr(_LIBC, "renameat2", None)
    return swap is not None and swap(AT_FDCWD, os.fsencode(first), AT_FDCWD, os.fsencode(second), RENAME_EXCHANGE) == 0


def publish(partial: Path, out: Path) -> None:
    """Rename the complete run to `out`, replacing the run folder there (checked before): in one
    atomic swap where the system allows it, so `out` never goes missing."""
    if not os.path.lexists(out):
        partial.rename(out)
    elif exchange(partial, out):
        shutil.rmtree(partial)  # the run it replaced
    else:
        retired = out.with_name(out.name + ".replaced")
        retire(retired)
        out.rename(retired)
        partial.rename(out)
        shutil.rmtree(retired)


def meshes_of(scene: Scene, folder: Path, mesh_cache: Path | None, bar: RunProgress,
              trust_geo: bool = False) -> list[meshing.MeshInfo]:
    """Both bodies meshed at once (each in a gmsh process of its own, under its limits: the first
    to fail stops the other), copied into the run folder as body1.msh and body2.msh after their
    labelled curves are checked. The labels the scene names and whether the run fits this
    machine's memory are the driver's to check (edp/lib/meshes.idp, contact.idp)."""
    bar.phase("meshing")
    bodies = (scene.body1, scene.body2)
    pool = ThreadPoolExecutor(2)
    try:
        futures = [pool.submit(meshing.body_mesh, b.mesh.source(), b.mesh.numbers(), b.mesh.refine, mesh_cache,
                               lambda index=index: bar.phase(f"meshing body {index} (gmsh)"),
                               meshing.MeshLimits(f"body{index}", b.mesh.timeLimit, trust_geo), b.mesh.size_field())
                   for index, b in enumerate(bodies, 1)]
        wait(futures, return_when=FIRST_EXCEPTION)
        paths = [future.result() for future in futures]
    except BaseException:
        meshing.stop_meshing()
        raise
    finally:
        pool.shutdown(wait=True)
    infos = []
    for index, path in enumerate(paths, 1):
        info = meshing.read_msh(path)  # read whole when body_mesh took it: not parsed again
        require_boundary_curves(index, info)
        meshing.hand_over(path, info, folder / f"body{index}.msh")
        infos.append(info)
    return infos


# The driver's flags its messages suggest, as this layer spells them.
DRIVER_ADVICE = {"-allowUnstable 1": "--allow-unstable (or solver.allowUnstable = true in the scene)"}


def python_spelling(message: str) -> str:
    """A driver message with the flags it suggests in the spelling of `orchestrate run`, and the
    parameters it names ("parameter T = -1") by their scene keys (the rules the driver alone checks,
    the output times' among them, are said in the scene's terms)."""
    for flag, spelling in DRIVER_ADVICE.items():
        message = message.replace(flag, spelling)
    keys = driver_name_keys()
    return re.sub(r"\bparameter ([A-Za-z][A-Za-z0-9]*)\b", lambda found: keys.get(found[1], found[0]), message)


def require_boundary_curves(index: int, info: meshing.MeshInfo) -> None:
    """A labelled curve must bound the body's triangles: a vertex in none has no equation, and
    FreeFEM meets a singular matrix without saying where (the labels a scene names and the shape
    of Γ_C are the driver's to check: edp/lib/meshes.idp, mortar.idp)."""
    if info.stray:
        label, (x, y) = min(info.stray.items())
        raise SceneError(f"body{index}.mesh.geo: label {label} of body {index}'s mesh is on a curve that bounds none "
                         f"of its triangles (at ({x:.6g}, {y:.6g})): a Physical Curve must be part of the boundary of "
                         "the meshed surface, else FreeFEM gets vertices it cannot solve for")


def resolve_steps(scene: Scene, folder: Path, mesh_cache: Path | None, restart: bool,
                  bar: RunProgress = RunProgress(), trust_geo: bool = False) -> tuple[Scene, dict | None]:
    """The scene with its N, and the plan (steps.json) when time.N is "auto": chosen by pilot runs
    (orchestrate/steps.py), or read back when a run of it is continued from its checkpoint."""
    if scene.time.N != "auto":
        return scene, None
    plan_file = folder / "steps.json"
    if restart and plan_file.is_file():
        plan = json.loads(plan_file.read_text())
    else:
        bar.phase("choosing N (pilot runs)")
        try:
            plan = choose_steps(scene, folder / "pilots", run, mesh_cache, trust_geo)
        except StepsError as error:
            raise SceneError(str(error)) from None
        plan_file.write_text(json.dumps(plan, indent=1) + "\n")
    time_grid = scene.time.model_copy(update={"N": plan["N"], "targetError": None})
    return scene.model_copy(update={"time": time_grid}), plan


def prepare_reading() -> None:
    """What reading a run back and its summary need and a command has not loaded yet (numpy and
    the readers, the packages' versions: 50 ms of a 0.5 s run), made while FreeFem++ runs. A
    failure is left to the reading itself, which meets it again and says it once."""
    try:
        importlib.import_module("orchestrate.results")
        package_versions()
    except Exception:
        pass


def start_quietly(thread: threading.Thread) -> None:
    """Start a thread that only saves time: a system that refuses one costs the time, not the run."""
    try:
        thread.start()
    except RuntimeError:
        pass


def solve(scene: Scene, folder: Path, bar: RunProgress, solver_flags: tuple, restart: bool):
    """FreeFem++ on the run folder (from its checkpoint with `restart`), its steps on the bar.
    What reads the run back is made ready meanwhile (prepare_reading): this process only waits."""
    bar.steps(scene.time.N, checkpoint_step(folder) if restart else 0)
    flags = ["-out", ".", *(["-restart", "."] if restart else []), *solver_flags]
    readers = threading.Thread(target=prepare_reading, daemon=True)
    with bar.following(folder / "history.csv"):
        done = run_logged(MAIN, flags, folder / "run.log", folder, defines={"SCENE": "scene.idp"}, append=restart,
                          meanwhile=lambda: start_quietly(readers))
    if readers.is_alive():
        readers.join()
    return done


def build(scene: Scene, folder: Path, bar: RunProgress, mesh_cache: Path | None = None, solver_flags: tuple = (),
          restart: bool = False, trust_geo: bool = False, finished: bool = False) -> tuple[dict, dict]:
    """Everything of a run inside `folder` (continued from its checkpoint with `restart`; with
    `finished`, a run whose driver had finished: only read back); returns the summary (without the
    total wall time) and the SHA-256 of the driver's files, each checked against its content
    (manifest.check_files)."""
    timing = {"meshing": 0.0, "solver": 0.0}
    if not finished:
        (folder / "scene.toml").write_text(scene.to_toml())
        clock = time.perf_counter()
        meshes_of(scene, folder, mesh_cache, bar, trust_geo)
        timing["meshing"] = time.perf_counter() - clock
        (folder / "scene.idp").write_text(to_freefem_scene(scene))
        clock = time.perf_counter()
        done = solve(scene, folder, bar, solver_flags, restart)
        timing["solver"] = time.perf_counter() - clock
        if done.returncode != 0:
            tail = "\n".join(done.stdout.splitlines()[-15:])
            said = done.error_line or f"it left no message: {folder / 'run.log'} could not hold one (a full disk?)"
            raise SolverError(done.returncode, python_spelling(said), tail)
    bar.phase("reading the files back")
    from orchestrate.results import Result

    run_facts = check_files(folder)
    result = Result(folder)
    clock = time.perf_counter()
    if scene.output.images and result.outputs:
        from orchestrate.render import render_all
        render_all(result, folder, announce=lambda name: bar.phase(f"rendering {name}"))
    timing["images"] = time.perf_counter() - clock
    timing.update({"solverSetupCpu": run_facts.get("setupSeconds"), "solverLoopCpu": run_facts.get("loopSeconds"),
                   "solverOutputCpu": run_facts.get("outputSeconds"), "solverTotalCpu": run_facts.get("totalSeconds"),
                   "backsubsPerStep": run_facts.get("backsubSecondsPerStep")})
    final = {name: float(values[-1]) for name, values in result.history.items()}
    return {
        "title": scene.title,
        "status": "completed",
        "warnings": run_warnings(run_facts, scene.time.T / scene.time.N),
        "final": final,
        "contactItersPerStep": float(result.history["contactIters"].mean()),
        "timing": {name: round(value, 6) if value is not None else None for name, value in timing.items()},
        "versions": {"freefem": result.params.get("freefemVersion"), **package_versions()},
        "scene": portable(scene.model_dump(mode="json")),
    }, run_facts["fileDigests"]


def portable(data):
    """A scene's dump with the files of the repository named from its root (meshes/x.geo), as
    the shipped scenes name them: summary.json is a record people read and commit, and the
    checkout's own folder is no part of the run (scene.toml keeps the paths the run read)."""
    if isinstance(data, dict):
        return {key: portable(value) for key, value in data.items()}
    if isinstance(data, list):
        return [portable(value) for value in data]
    if isinstance(data, str) and data.startswith(f"{REPO}/"):
        return data[len(f"{REPO}/"):]
    return data


def run_warnings(run_facts: dict, k: float) -> list[str]:
    """What a completed run's facts say the user should know about its figures."""
    step = run_facts.get("zetaBelowCriticalStep") or 0
    if not step:
        return []
    level = max(run_facts.get("zetaCritical1") or 0, run_facts.get("zetaCritical2") or 0)
    return [f"zeta fell below {level:.4g} at step {step} (t = {step * k:.6g}), the level under which the explicit "
            "damage source is unstable unless the obstacle zeta >= 0 holds it there: check the figures against a run "
            "with a smaller step"]
