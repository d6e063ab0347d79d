"""Scene files: good ones load; each bad one is refused with one message naming the key, the
value and what is allowed. Bad files are the paper's scene with one text edit."""
import pytest

from orchestrate.freefem import REPO
from orchestrate.scene import Scene, SceneError, apply_overrides

pytestmark = pytest.mark.unit

PAPER = (REPO / "scenes" / "paper.toml").read_text()


def scene_with(tmp_path, old: str, new: str) -> Scene:
    assert old in PAPER, old
    path = tmp_path / "scene.toml"
    path.write_text(PAPER.replace(old, new, 1))
    return Scene.load(path)


def test_the_paper_scene_loads_with_the_paper_values():
    scene = Scene.load(REPO / "scenes" / "paper.toml")
    assert (scene.time.T, scene.time.N) == (1.0, 40)
    assert scene.body1.material.E == 1000 and scene.body2.mesh.n == 32
    assert [b.type for b in scene.body1.boundary] == ["clamped", "traction", "traction"]


def test_a_scene_written_back_loads_to_the_same_scene(tmp_path):
    scene = Scene.load(REPO / "scenes" / "paper.toml")
    path = tmp_path / "again.toml"
    path.write_text(scene.to_toml())
    assert Scene.load(path) == scene


def test_overrides_set_dotted_keys_and_list_items():
    scene = Scene.load(REPO / "scenes" / "paper.toml", {"time.N": 80, "body1.boundary.1.fy": "-20*t"})
    assert scene.time.N == 80 and scene.body1.boundary[1].fy == "-20*t"


BAD = [
    ("[body1.material]", "[body1.materal]", ["body1.materal: unknown key", "did you mean 'material'"]),
    ("[solver]", "[solverr]", ["solverr: unknown key", "did you mean 'solver'"]),
    ("bmOmega = 1.0", "bmOmegaa = 1.0", ["solver.bmOmegaa: unknown key", "did you mean 'bmOmega'"]),
    ("N = 40", "N = 0", ["time.N = 0", "an integer in [1, 10000000]"]),
    ("N = 40", "N = 40.5", ["time.N = 40.5", "integer"]),
    ("T = 1.0", 'T = "one"', ["time.T = 'one'", "valid number"]),
    ("T = 1.0", "T = -1.0", ["time.T = -1.0", "greater than 0"]),
    ("nu = 0.3", "nu = 0.7", ["body1.material.nu = 0.7", "less than 0.5"]),
    ("nu = 0.3", "nu = -1.5", ["body1.material.nu = -1.5", "greater than -1"]),
    ("E = 1000.0", "E = -5.0", ["body1.material.E = -5.0", "greater than 0"]),
    ("E = 1000.0", "E = nan", ["body1.material.E", "finite"]),
    ("mu = 30.0", "mu = -30.0", ["body1.material.mu = -30.0", "mu > -eta/2"]),  # a rule of parameters.toml
    ('planeStrain = false', 'planeStrain = "yes"', ["body1.material.planeStrain = 'yes'", "valid boolean"]),
    ('planeStrain = false', 'plane = "stress"', ["body1.material.plane: unknown key", "did you mean 'planeStrain'"]),
    ("zeta0 = 1.0", "zeta0 = 1.5", ["body1.damage.zeta0 = 1.5", "outside [0, 1]"]),
    ("beta0 = 1.0", "beta0 = -0.1", ["glue.beta0 = -0.1", "outside [0, 1]"]),
    ("L = 1.0", "L = 0.0", ["glue.L = 0.0", "greater than 0"]),
    ('type = "clamped"\nlabel = 5', 'type = "clmped"\nlabel = 5', ["body1.boundary.0", "'clmped'", "'clamped'"]),
    ('type = "clamped"\nlabel = 5', 'type = "roller"\nlabel = 5', ["body1.boundary.0.component: missing"]),
    ('fy = "-10*t"', 'fy = "exec(\\"ls\\")"', ["body1.boundary.1.fy", "'\"' is not allowed"]),
    ('fy = "-10*t"', 'fy = "-10*t; system(1)"', ["body1.boundary.1.fy", "';' is not allowed"]),
    ('fy = "-10*t"', "fz = \"-10*t\"", ["body1.boundary.1.fz: unknown key", "did you mean 'fy'"]),
    ('geo = "meshes/paper_body1.geo"', 'geo = "../../etc/passwd.geo"', ["body1.mesh.geo", "not found beside the scene file"]),
    ('geo = "meshes/paper_body1.geo"', 'geo = "meshes/nowhere.geo"', ["body1.mesh.geo", "not found"]),
    ('geo = "meshes/paper_body1.geo"', 'geo = "meshes/paper_body1-n24.msh"', ["body1.mesh.geo", "not a gmsh .geo"]),
    ('geo = "meshes/paper_body1.geo"', 'geo = "meshes/paper_body1.geo"\nrectangle = [0, 6, 0, 6]',
     ["body1.mesh", "exactly one of geo"]),
    ("n = 24", "n = 0", ["body1.mesh.n = 0", "greater than or equal to 1"]),
    ("contactLabel = 1", "contactLabel = [1, 1]", ["body1.mesh.contactLabel", "a label is named twice"]),
    ("contactLabel = 1", "contactLabel = []", ["body1.mesh.contactLabel", "a list of them"]),
    ("contactLabel = 1", "contactLabel = [1, -2]", ["body1.mesh.contactLabel", "-2 is not a boundary label"]),
    ('[[body2.boundary]]\ntype = "clamped"\nlabel = 3', '[[body2.boundary]]\ntype = "clamped"\nlabel = 4',
     ["body2", "prescribed twice"]),
    ('times = "final"', 'times = "sometimes"', ["output.times = 'sometimes'", 'give "final", "all", "none" or a list']),
    ('times = "final"', 'times = [0.5, "1"]', ["output.times = [0.5, '1']", "'1' is not a time"]),
    ('fields = ["bodies", "stress", "contact", "state"]', 'fields = ["bodies", "strain"]', ["output.fields.1 = 'strain'"]),
    ('linearSolver = "CHOLMOD"', 'linearSolver = "PETSc"', ["solver.linearSolver = 'PETSc'", "'CHOLMOD'"]),
    ("contactTol = 1e-10", "contactTol = 0.0", ["solver.contactTol = 0.0", "greater than 0"]),
    ("[time]", "time = 3\n[timee]", ["time: Input should be a valid dictionary", "timee: unknown key"]),
    ("T = 1.0", "T = 1.0 1.0", ["not valid TOML"]),
    ("images = true", 'images = true\nunits = "kPa"', ["output.units = 'kPa'", 'give "SI", "mm-N-s", or a table']),
    ("images = true", 'images = true\nunits = { length = "m^2" }', ["output.units.length = 'm^2'", "1 to 8 letters"]),
    ("images = true", 'images = true\nunits = { lenght = "mm" }', ["output.units.lenght: unknown key", "'length'"]),
]


@pytest.mark.parametrize("old, new, words", BAD, ids=[new.split("\n")[0][:40] for _, new, _ in BAD])
def test_a_bad_scene_is_refused_with_a_clear_message(tmp_path, old, new, words):
    with pytest.raises(SceneError) as error:
        scene_with(tmp_path, old, new)
    for word in words:
        assert word in str(error.value), (word, str(error.value))


def test_a_body_without_dirichlet_condition_is_refused_its_sliding_free(tmp_path):
    text = PAPER.replace('[[body2.boundary]]\ntype = "clamped"\nlabel = 3\n\n[[body2.boundary]]\ntype = "clamped"\nlabel = 4',
                         '[[body2.boundary]]\ntype = "traction"\nlabel = 2\nfx = "1"')
    path = tmp_path / "float.toml"
    path.write_text(text)
    with pytest.raises(SceneError, match="body2.*nothing would hold the body's sliding along Γ_C"):
        Scene.load(path)


def test_a_missing_body_is_named(tmp_path):
    path = tmp_path / "one.toml"
    path.write_text(PAPER[:PAPER.index("# Body 2")])
    with pytest.raises(SceneError, match="body2: missing"):
        Scene.load(path)


def test_overrides_into_values_are_refused():
    with pytest.raises(SceneError, match="holds a value"):
        apply_overrides({"time": {"N": 3}}, {"time.N.x": 1})
    with pytest.raises(SceneError, match="not an index"):
        apply_overrides({"b": [1, 2]}, {"b.5": 1})


def test_a_bad_override_is_named_as_one_not_as_a_line_of_the_scene_file():
    with pytest.raises(SceneError) as error:
        Scene.load(REPO / "scenes" / "paper.toml", {"time.NN": 3, "body1.material.E": -3.0})
    lines = str(error.value).splitlines()
    assert "--set time.NN: unknown key (did you mean 'N'?)" in lines
    assert "--set body1.material.E = -3.0: Input should be greater than 0" in lines
    with pytest.raises(SceneError) as error:
        Scene.load(REPO / "scenes" / "paper.toml", {"time.T": 2.0, "body1.material.mu": -30.0})
    lines = str(error.value).splitlines()
    assert "--set body1.material.mu = -30.0: -30.0 is not allowed: mu > -eta/2 (the viscosity A must be positive " \
           "definite)" in lines and not any(line.startswith("--set time.T") for line in lines)


def test_a_boundary_condition_is_overridden_by_its_label_and_nothing_else_changes():
    paper = Scene.load(REPO / "scenes" / "paper.toml")
    scene = Scene.load(REPO / "scenes" / "paper.toml", {"body1.boundary[label=2].fx": "5*min(t, 0.5)"})
    changed = paper.model_dump()
    assert changed["body1"]["boundary"][2] == {"type": "traction", "label": 2, "fx": "10*y*t", "fy": "0"}
    changed["body1"]["boundary"][2]["fx"] = "5*min(t, 0.5)"  # the paper's label-2 traction is its third condition
    assert scene.model_dump() == changed
    by_index = Scene.load(REPO / "scenes" / "paper.toml", {"body1.boundary.2.fx": "5*min(t, 0.5)"})
    assert by_index == scene


def test_a_label_key_given_on_the_command_line_keeps_its_brackets():
    from orchestrate.arguments import parse_assignments

    assert parse_assignments(["body1.boundary[label=4].fy=-10*min(t, 1)", "title=a=b"], "--set") == \
        {"body1.boundary[label=4].fy": "-10*min(t, 1)", "title": "a=b"}


def test_a_bad_value_by_label_is_named_by_the_key_as_written():
    with pytest.raises(SceneError) as error:
        Scene.load(REPO / "scenes" / "paper.toml", {"body1.boundary[label=4].fy": "exec(1)", "body1.boundary[label=2].fz": "1"})
    lines = str(error.value).splitlines()
    assert any(line.startswith("--set body1.boundary[label=4].fy = 'exec(1)': name 'exec' is not allowed") for line in lines)
    assert "--set body1.boundary[label=2].fz: unknown key (did you mean 'fy'?)" in lines


@pytest.mark.parametrize("key, words", [
    ("body1.boundary[label=9].fy", ["--set body1.boundary[label=9].fy", "no condition of body1.boundary is on label 9",
                                    "0 clamped on label 5, 1 traction on label 4, 2 traction on label 2"]),
    ("body1.boundary[lable=4].fy", ["'boundary[lable=4]' is no key", "NAME[label=N]", "NAME.I", "0-based index"]),
    ("body1.boundary[4].fy", ["'boundary[4]' is no key", "body1.boundary[label=4].fy", "body1.boundary.1.fy"]),
    ("body1.boundry[label=4].fy", ["the scene has no body1.boundry", "did you mean 'boundary'"]),
    ("body1.material[label=4].E", ["body1.material is not a list", "bodyN.boundary"]),
])
def test_a_label_key_that_names_no_condition_is_refused_with_the_forms_allowed(key, words):
    with pytest.raises(SceneError) as error:
        Scene.load(REPO / "scenes" / "paper.toml", {key: "1"})
    for word in words:
        assert word in str(error.value), (word, str(error.value))


def test_a_label_of_two_conditions_is_refused_naming_both(tmp_path):
    roller = '[[body1.boundary]]\ntype = "roller"\nlabel = 2\ncomponent = "y"\n\n[[body1.boundary]]\ntype = "traction"\nlabel = 2'
    path = tmp_path / "scene.toml"
    path.write_text(PAPER.replace('[[body1.boundary]]\ntype = "traction"\nlabel = 2', roller, 1))
    assert [(b.type, b.label) for b in Scene.load(path).body1.boundary][2:] == [("roller", 2), ("traction", 2)]
    with pytest.raises(SceneError) as error:
        Scene.load(path, {"body1.boundary[label=2].fx": "1"})
    assert "--set body1.boundary[label=2].fx: label 2 carries 2 conditions" in str(error.value)
    assert "2 roller on label 2, 3 traction on label 2" in str(error.value)
    assert "address one by its 0-based index, e.g. body1.boundary.2" in str(error.value)
    assert Scene.load(path, {"body1.boundary.3.fx": "1"}).body1.boundary[3].fx == "1"


def test_two_keys_naming_one_value_are_refused():
    with pytest.raises(SceneError, match=r"body1.boundary.1.fy and body1.boundary\[label=4\].fy name the same value"):
        Scene.load(REPO / "scenes" / "paper.toml", {"body1.boundary.1.fy": "1", "body1.boundary[label=4].fy": "2"})


def test_a_label_selected_by_label_cannot_be_reassigned_and_a_body_s_error_is_one_line():
    """[label=4].label=5 would move the condition its key names; and a check of a whole body
    (label 5 clamped and loaded) names the body, not every value in it."""
    with pytest.raises(SceneError) as error:
        Scene.load(REPO / "scenes" / "paper.toml", {"body1.boundary[label=4].label": 5})
    assert str(error.value) == ("--set body1.boundary[label=4].label: [label=4] picks the condition by its label, "
                                "which cannot be reassigned through it: name the condition by its index, --set "
                                "body1.boundary.1.label=...")
    with pytest.raises(SceneError) as error:
        Scene.load(REPO / "scenes" / "paper.toml", {"body1.boundary.1.label": 5})
    assert str(error.value).splitlines()[1:] == ["body1: label 5: a traction on a boundary whose displacement is "
                                                 "prescribed"]
    assert Scene.load(REPO / "scenes" / "paper.toml", {"body1.boundary.1.label": 3}).body1.boundary[1].label == 3


HUGE = "x" * 5 * 2 ** 20  # a 5 MB text pasted where a value goes


@pytest.mark.parametrize("key", ["title", "body1.mesh.contactLabel", "glue.gammaNu", "body1.boundary[label=4].fy"])
def test_a_huge_value_is_named_by_its_start_and_length_not_repeated_whole(key):
    with pytest.raises(SceneError) as error:
        Scene.load(REPO / "scenes" / "paper.toml", {key: HUGE if key != "body1.boundary[label=4].fy" else [HUGE]})
    message = str(error.value)
    assert key in message and len(message) < 500, message[:1000]
    assert key.endswith(".fy") or f"({len(HUGE)} characters)" in message


def test_a_huge_key_or_grid_value_is_not_repeated_whole():
    from orchestrate.arguments import parse_assignments
    from orchestrate.sweep import parse_grid

    for attempt in (lambda: Scene.load(REPO / "scenes" / "paper.toml", {HUGE: 1}),
                    lambda: parse_assignments([HUGE], "--set"),
                    lambda: parse_grid([f"body1.boundary[label=4].fy={HUGE}(,1"]),
                    lambda: parse_grid([f"time.N=[{HUGE}"])):
        with pytest.raises(SceneError) as error:
            attempt()
        assert len(str(error.value)) < 700, str(error.value)[:1000]


def test_a_scene_file_that_begins_with_a_byte_order_mark_is_the_same_scene(tmp_path):
    """Editors on Windows begin UTF-8 files with U+FEFF; TOML takes it as the encoding's mark,
    Python's tomllib as a stray character of line 1."""
    path = tmp_path / "scene.toml"
    path.write_bytes(b"\xef\xbb\xbf" + PAPER.replace('"meshes/', f'"{REPO}/meshes/').encode())
    assert Scene.load(path) == Scene.load(REPO / "scenes" / "paper.toml")
    grid = tmp_path / "grid.toml"
    grid.write_bytes(b"\xef\xbb\xbf" + b"[glue]\ngammaNu = [0, 1]\n")
    from orchestrate.sweep import read_grid_file

    assert read_grid_file(grid) == {"glue.gammaNu": [0, 1]}


def test_an_unquoted_inf_is_refused_saying_how_to_write_it(tmp_path, capsys):
    """TOML reads a bare inf as a float; debondMobility's infinity is the word "inf". The message
    gives the forms to write, and those forms load."""
    from orchestrate.arguments import parse_assignments
    from orchestrate.cli import main

    path = tmp_path / "scene.toml"
    path.write_text(PAPER.replace("[glue]\n", "[glue]\ndebondMobility = inf\n", 1).replace('"meshes/', f'"{REPO}/meshes/'))
    with pytest.raises(SceneError) as error:
        Scene.load(path)
    assert 'glue.debondMobility = inf: ' in str(error.value) and 'debondMobility = "inf"' in str(error.value)
    assert main(["run", str(REPO / "scenes" / "paper.toml"), "--set", "glue.debondMobility=inf",
                 "--out", str(tmp_path / "run")]) == 2
    message = capsys.readouterr().err
    assert "--set glue.debondMobility = inf" in message and "--set 'glue.debondMobility=\"inf\"'" in message
    path.write_text(path.read_text().replace("debondMobility = inf", 'debondMobility = "inf"'))
    assert Scene.load(path).glue.debondMobility == "inf"
    advised = parse_assignments(['glue.debondMobility="inf"'], "--set")  # the shell's quotes removed
    assert Scene.load(REPO / "scenes" / "paper.toml", advised).glue.debondMobility == "inf"
    assert not (tmp_path / "run").exists()
