"""How close does time.N = "auto" come to its target, and what does it cost? Runs a scene with
each scheme at a target, measures u(T) against bdf2 with many more steps on the same meshes, and
the mesh's own error against two refinements. The figures of docs/gallery.md (polymer_pad) and
docs/model-choices.md (peel) were measured with it:

    .venv/bin/python docs/examples/time_targets.py scenes/polymer_pad.toml --reference-N 2576 \\
        --runs bdf2:1e-3 bdf2:1e-4 semi-implicit:1e-3 semi-implicit:1e-4 --euler-N 10600 --space-N 322
"""
import argparse
import json
import tempfile
from pathlib import Path

from orchestrate import run
from orchestrate.steps import relative_distance

QUIET = {"output.times": "final", "output.fields": ["state"], "output.images": False}


def wall(result) -> float:
    return json.loads((result.folder / "summary.json").read_text())["wallSeconds"]


def steps(result) -> int:
    return len(result.history["t"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene")
    parser.add_argument("--reference-N", type=int, required=True, help="bdf2 steps of the reference")
    parser.add_argument("--runs", nargs="+", default=[], metavar="SCHEME:TARGET")
    parser.add_argument("--euler-N", type=int, help="also the paper's scheme at this N")
    parser.add_argument("--space-N", type=int, help="also the mesh error: bdf2 at this N on meshes 1x, 2x, 4x finer")
    options = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        reference = run(options.scene, scratch / "reference", {**QUIET, "time.scheme": "bdf2",
                                                               "time.N": options.reference_N})
        for item in options.runs:
            scheme, target = item.split(":")
            result = run(options.scene, scratch / item.replace(":", "-"),
                         {**QUIET, "time.scheme": scheme, "time.N": "auto", "time.targetError": float(target)})
            error = relative_distance(result.folder, reference.folder, steps(result), options.reference_N)
            print(f"{scheme} target {target}: N = {steps(result)}, error {error:.3g}, wall {wall(result):.1f} s")
        if options.euler_N:
            result = run(options.scene, scratch / "euler", {**QUIET, "time.scheme": "euler", "time.N": options.euler_N})
            error = relative_distance(result.folder, reference.folder, options.euler_N, options.reference_N)
            print(f"euler: N = {options.euler_N}, error {error:.3g}, wall {wall(result):.1f} s")
        if options.space_N:
            from orchestrate.scene import Scene

            scene = Scene.load(options.scene)
            levels = []
            for factor in (1, 2, 4):
                sizes = {"body1.mesh.n": factor * scene.body1.mesh.n, "body2.mesh.n": factor * scene.body2.mesh.n}
                levels.append(run(options.scene, scratch / f"mesh{factor}",
                                  {**QUIET, **sizes, "time.scheme": "bdf2", "time.N": options.space_N}).folder)
            pairs = {"1x to 2x": (0, 1), "2x to 4x": (1, 2), "1x to 4x": (0, 2)}
            print("mesh: " + ", ".join(f"{name} {relative_distance(levels[a], levels[b], options.space_N, options.space_N):.3g}"
                                       for name, (a, b) in pairs.items()))


if __name__ == "__main__":
    main()
