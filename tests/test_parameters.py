"""One source for every parameter: edp/lib/parameters.toml, which the scene schema reads and from
which the driver's includes are generated; here the generated files are held to it, and each side
to the table — the defaults a default run uses, and the accepted
range of every bounded parameter, value by value at its bounds."""
import json

import pytest

from orchestrate import Scene, SceneError, run
from orchestrate.freefem import MAIN, REPO, run_script
from orchestrate.identity import solver_identity
from orchestrate.parameters import PARAMETERS, SCHEMES, generated

pytestmark = pytest.mark.solver

CHECK = REPO / "edp" / "tools" / "check.edp"
MINIMAL = """
[body1.mesh]
geo = "meshes/paper_body1.geo"
n = 6
[[body1.boundary]]
type = "clamped"
label = 5
[body2.mesh]
geo = "meshes/paper_body2.geo"
n = 8
[[body2.boundary]]
type = "clamped"
label = 3
[output]
images = false
"""


@pytest.mark.parametrize("path", list(generated()), ids=lambda path: path.name)
@pytest.mark.unit
def test_the_generated_files_are_the_table_s(path):
    assert path.read_text() == generated()[path], f"{path} is stale: run python -m orchestrate reference --force"


@pytest.mark.unit
def test_no_library_names_a_scheme():
    """The schemes are data: their names appear in the files generated from the table only."""
    for path in (REPO / "edp").rglob("*.idp"):
        if path not in generated():
            text = path.read_text()
            assert not any(f'"{name}"' in text for name in SCHEMES), path


@pytest.mark.parametrize("old, new, words", [
    ("levels = 2", "levels = 3", "levels = 3 is not 1 or 2"),
    ("rateWeights = [1.5, -2.0, 0.5]", "rateWeights = [1.5, -2.0]", "rateWeights = [1.5, -2.0] is not 3 numbers"),
    ("elasticImplicit = true\nlevels = 2", 'elasticImplicit = "yes"\nlevels = 2', "elasticImplicit = 'yes' is not bool"),
])
@pytest.mark.unit
def test_a_scheme_the_driver_cannot_take_is_refused_when_the_table_is_read(tmp_path, old, new, words):
    from orchestrate.parameters import SOURCE, load

    table = tmp_path / "parameters.toml"
    assert old in SOURCE.read_text()
    table.write_text(SOURCE.read_text().replace(old, new))
    with pytest.raises(ValueError, match=words.replace("[", r"\[").replace("]", r"\]")):
        load(table)


@pytest.mark.unit
def test_each_scheme_s_coefficients_are_consistent():
    """Facts of the schemes that hold independently of the code: the rate weights are exact on
    linear functions (sum 0, first moment 1) and the first is the viscous weight; the
    extrapolation keeps constants, and a two-level one is exact on linear functions; only an
    implicit elasticity lifts the elastic bound."""
    for name, scheme in SCHEMES.items():
        w = scheme["rateWeights"]
        assert sum(w) == 0 and -(w[1] + 2 * w[2]) == 1 and w[0] == scheme["viscousWeight"], name
        e = scheme["extrapolation"]
        assert sum(e) == 1 and (scheme["levels"] == 1) == (e[1] == 0 and w[2] == 0), name
        assert scheme["levels"] == 1 or e[0] + 2 * e[1] == 0, name
        assert (scheme["elasticBound"] == 0) == scheme["elasticImplicit"], name


def expected(parameter):
    """The table's default as params_used.json writes it (flags and integers as numbers, labels and
    subsets as the list's text)."""
    if parameter.type in ("labels", "subset"):
        return parameter.default
    value = parameter.value()
    return int(value) if isinstance(value, bool) else value


def test_a_scene_that_sets_nothing_runs_with_the_table_defaults(tmp_path):
    scene = tmp_path / "minimal.toml"
    scene.write_text(MINIMAL)
    used = json.loads((run(scene, tmp_path / "run").folder / "params_used.json").read_text())
    for parameter in PARAMETERS.values():
        if parameter.scene == "-":
            continue
        for name in parameter.driver_names():
            assert used[name] == expected(parameter), name


def test_the_driver_by_hand_runs_with_the_table_defaults(tmp_path):
    assert run_script(MAIN, ["-out", tmp_path]).returncode == 0
    used = json.loads((tmp_path / "params_used.json").read_text())
    for parameter in PARAMETERS.values():
        for name in parameter.driver_names():
            if name not in ("out", "solverIdentity"):  # the launcher gives both (freefem_command: the solver's)
                assert used[name] == expected(parameter), name
    assert used["solverIdentity"] == solver_identity()


def test_help_lists_every_parameter_with_its_default_and_exits_0():
    done = run_script(MAIN, ["-help"])
    assert done.returncode == 0
    for parameter in PARAMETERS.values():
        for name in parameter.driver_names():
            assert f"  -{name} ({parameter.type}, default '{parameter.default}'" in done.stdout, name


def probes(parameter):
    """Values at and just beyond each finite bound of a parameter, with whether the range takes
    them (and, for an open bound, one just inside)."""
    bounds = parameter.bounds
    for key, bound in bounds.items():
        outward = -1 if key in ("ge", "gt") else 1
        step = 1 if parameter.type in ("int", "labels") else max(abs(bound), 1.0) * 1e-9
        yield bound, key in ("ge", "le")
        yield bound + outward * step, False
        if key in ("gt", "lt"):
            yield bound - outward * step, True


CASES = [(parameter.name, value, inside) for parameter in PARAMETERS.values() for value, inside in probes(parameter)]


@pytest.mark.parametrize("name, value, inside", CASES, ids=[f"{n}={v!r}" for n, v, _ in CASES])
def test_the_driver_and_the_scene_take_the_same_range(name, value, inside):
    parameter = PARAMETERS[name]
    flag = parameter.driver_names()[0]
    text = str(value) if parameter.type in ("int", "labels") else repr(float(value))
    done = run_script(CHECK, [f"-{flag}", text])
    assert (done.returncode == 0) == inside, (flag, text, done.error_line)
    if not inside:
        assert done.returncode == 3 and flag in done.error_line
    if parameter.scene != "-":
        key = ("body1." if parameter.scope == "body" else "") + parameter.scene
        if inside:
            Scene.load(REPO / "scenes" / "paper.toml", {key: value})
        else:
            with pytest.raises(SceneError, match=key.replace(".", r"\.")):
                Scene.load(REPO / "scenes" / "paper.toml", {key: value})


@pytest.mark.parametrize("name", [p.name for p in PARAMETERS.values() if p.type == "choice"])
def test_choices_are_the_same_on_both_sides(name):
    parameter = PARAMETERS[name]
    for choice in parameter.choices:
        assert run_script(CHECK, [f"-{name}", choice]).returncode == 0
        Scene.load(REPO / "scenes" / "paper.toml", {parameter.scene: choice})
    assert run_script(CHECK, [f"-{name}", "nonesuch"]).returncode == 3
    with pytest.raises(SceneError):
        Scene.load(REPO / "scenes" / "paper.toml", {parameter.scene: "nonesuch"})


@pytest.mark.unit
def test_every_scene_key_of_the_table_is_a_scene_field():
    scene = Scene.load(REPO / "scenes" / "paper.toml").model_dump(mode="json")
    for parameter in PARAMETERS.values():
        if parameter.scene != "-":
            node = scene["body1"] if parameter.scope == "body" else scene
            for part in parameter.scene.split("."):
                assert part in node, (parameter.name, parameter.scene)
                node = node[part]
