"""A run's space error estimated from its own states: python -m orchestrate estimate RUN.

edp/tools/estimate.edp recovers each body's strains by the Zienkiewicz–Zhu projection (the strains
of u_h projected in L² onto continuous Pk, k the run's degree) and takes η = ‖ε(u_h) − r‖ over both bodies,
in ‖·‖_V's product, at every time the run saved its state (output.fields "state"). η estimates
‖u − u_h‖_V, the space error alone (the time error is the scheme's: compare N and 2N). It is
exact (0) for a uniform strain, and on the paper's scene it is 0.84–0.89 of the distance to a run
on a mesh 8 to 32 times finer (docs/usage.md, "Estimated error").
"""
from __future__ import annotations

import csv
import shutil
import tempfile
from pathlib import Path

from orchestrate.compare import degree, state_times
from orchestrate.freefem import REPO, run_script
from orchestrate.results import Result, load_result

NAME = "estimate"


def estimate(run: str | Path | Result, target: float | None = None, sizes: tuple[Path, Path] | None = None) -> list[dict]:
    """One row per saved state: t, estimate (η of both bodies), estimate1, estimate2, normV
    (‖u_h‖_V) and relative (η/‖u_h‖_V). With a relative `target`, also each body's element sizes
    for a mesh whose estimate would be target·‖u_h‖_V, as gmsh views written to `sizes` (mesh.sizes),
    body 2's on Γ_C no coarser than body 1's trace facing it (the mortar's rule: estimate.edp)."""
    result = run if isinstance(run, Result) else load_result(run)
    states = state_times(result)
    if not states:
        raise RuntimeError(f"cannot estimate {result.folder}: it saved no state (state_NNNN.txt); run with "
                           'output.fields including "state" (the default)')
    # the tool reads names as words: plain names only, each file as the run's manifest records it
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        for body in (1, 2):
            result.mesh_snapshot(body, scratch / f"body{body}.msh")
        for j, (_, name) in enumerate(states):
            result.snapshot(name, scratch / f"state_{j:04d}.txt")
        (scratch / "states.txt").write_text(f"{len(states)}\n" + "".join(f"state_{j:04d}.txt\n" for j in range(len(states))))
        design = ["-target", repr(float(target)), "-sizes1", "sizes1.pos", "-sizes2", "sizes2.pos",
                  "-contact1", str(result.params["contactLabel1"]), "-contact2", str(result.params["contactLabel2"])] \
            if target else []
        done = run_script(REPO / "edp" / "tools" / "estimate.edp", ["-mesh1", "body1.msh", "-mesh2", "body2.msh",
                                                                    "-states", "states.txt", "-out", "estimate.csv",
                                                                    *design], cwd=scratch,
                           defines={"RUNORDER": str(degree(result))})
        if done.returncode != 0:
            raise RuntimeError(f"estimate.edp failed for {result.folder}: {done.error_line}")
        with open(scratch / "estimate.csv") as handle:
            rows = [{key: float(value) for key, value in row.items()} for row in csv.DictReader(handle)]
        for body, path in enumerate(sizes if target else (), 1):
            shutil.copyfile(scratch / f"sizes{body}.pos", path)
    for row in rows:
        row["relative"] = row["estimate"] / row["normV"] if row["normV"] > 0 else 0.0
    return rows


def report(rows: list[dict]) -> str:
    lines = [f"{'t':>10}  {'η (estimate)':>13} {'η/‖u_h‖_V':>10}  {'body 1':>11} {'body 2':>11}  {'‖u_h‖_V':>11}"]
    lines += [f"{row['t']:10.6g}  {row['estimate']:13.4e} {row['relative']:10.3e}  {row['estimate1']:11.4e} "
              f"{row['estimate2']:11.4e}  {row['normV']:11.4e}" for row in rows]
    return "\n".join(lines)
