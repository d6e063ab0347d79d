"""The gallery: every scene of docs/gallery.md at its own resolution, into results/gallery/<name>."""
from __future__ import annotations

from pathlib import Path

from orchestrate.freefem import REPO
from orchestrate.plot import plot_columns
from orchestrate.runner import refuse_existing, run
from orchestrate.scene import SceneError
from orchestrate.studies.hertz import gallery_figures

SCENES = ("paper", "peel", "indentation", "shear", "tilted_patch", "polymer_pad", "hertz", "punch", "precrack",
          "joint")
# The joint's own curves, beside its folder (plot's default): the peeling force and the crack tip.
JOINT_CURVES = ("reactionY1_2", "debondFront")


def gallery(names, out: str | Path, force: bool = False, progress: bool = False) -> dict[str, Path]:
    """The scenes `names` (all when none) run into `out`/<name>; every folder checked before any
    run (only folders of runs are replaced, with `force`)."""
    unknown = [name for name in names if name not in SCENES]
    if unknown:
        raise SceneError(f"no gallery scene {', '.join(unknown)} (the gallery: {', '.join(SCENES)})")
    folders = {name: Path(out).absolute() / name for name in names or SCENES}
    for folder in folders.values():  # every one now, not after the runs before it
        refuse_existing(folder, force)
    for name, folder in folders.items():
        result = run(REPO / "scenes" / f"{name}.toml", folder, force=force, progress=progress)
        if name == "hertz":  # its comparison with the analytic solution, as in results/hertz
            gallery_figures(result, result.folder)
        if name == "joint":
            for column in JOINT_CURVES:
                plot_columns(result.folder, column, force=True)
    return folders
