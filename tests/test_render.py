"""Images of a run: Figure 2 of the seed (the fields on the deformed bodies) with its colour bars
spanning the data and every body whole in view, the options of `render`, and the contact-line
and history plots."""
import subprocess
import sys

import meshio
import numpy as np
import pytest
from PIL import Image

from orchestrate import run
from orchestrate.cli import main
from orchestrate.freefem import REPO
from orchestrate.outputs import RECORD
from orchestrate.render import render_fields
from orchestrate.results import cell_field

pytestmark = pytest.mark.runs


@pytest.fixture(scope="module")
def coarse(tmp_path_factory):
    return run(REPO / "scenes" / "paper.toml", tmp_path_factory.mktemp("render") / "run",
               {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.N": 20, "output.times": [0.5, 1.0]})


def test_images_exist_and_are_not_blank(coarse):
    for name in ("fields.png", "contact_line.png", "history.png"):
        image = np.asarray(Image.open(coarse.folder / name).convert("RGB"), dtype=float)
        colours = np.unique(image.reshape(-1, 3), axis=0)
        assert len(colours) > 50, f"{name} looks blank"


def test_colour_bars_span_the_data_and_every_body_is_whole_in_view(coarse, tmp_path):
    """And the magnification is a round factor of at least 1 (displacements never drawn smaller)."""
    shown = render_fields(coarse, tmp_path / "fields.png")
    bodies = [coarse.fields(part) for part in ("body1", "body2")]
    von_mises = np.concatenate([cell_field(body, "vonMises") for body in bodies])
    zeta = np.concatenate([body.point_data["zeta"] for body in bodies])
    assert shown["vonMises"] == pytest.approx((von_mises.min(), von_mises.max()), rel=1e-12, abs=1e-300)
    assert shown["zeta"] == pytest.approx((zeta.min(), zeta.max()), rel=1e-12)
    assert von_mises.max() > 0 and zeta.min() < 1
    assert shown["magnification"] >= 1
    drawn = np.vstack([body.points[:, :2] + shown["magnification"] * body.point_data["u"][:, :2] for body in bodies])
    x0, x1, y0, y1 = shown["view"]
    assert x0 < drawn[:, 0].min() and drawn[:, 0].max() < x1 and y0 < drawn[:, 1].min() and drawn[:, 1].max() < y1


def test_per_body_and_given_ranges_and_the_size(coarse, tmp_path):
    bodies = [coarse.fields(part) for part in ("body1", "body2")]
    shown = render_fields(coarse, tmp_path / "a.png", fields=("zeta",), ranges="per-body", size=(8, 4), dpi=100)
    for (low, high), body in zip(shown["zeta"], bodies):
        assert (low, high) == pytest.approx((body.point_data["zeta"].min(), body.point_data["zeta"].max()), rel=1e-12)
    assert Image.open(tmp_path / "a.png").size == (800, 400)
    shown = render_fields(coarse, tmp_path / "b.png", fields=("sigma22", "zeta"), ranges={"sigma22": (-50.0, 10.0)},
                          magnification=0)
    assert shown["sigma22"] == (-50.0, 10.0) and shown["magnification"] == 0
    zeta = np.concatenate([body.point_data["zeta"] for body in bodies])
    assert shown["zeta"] == pytest.approx((zeta.min(), zeta.max()), rel=1e-12)  # a range given is the field's own
    sigma = np.concatenate([cell_field(body, "sigma11") for body in bodies])
    shown = render_fields(coarse, tmp_path / "d.png", fields=("sigma11",))
    assert shown["sigma11"] == pytest.approx((-np.abs(sigma).max(), np.abs(sigma).max()), rel=1e-12)  # centred on 0
    earlier = np.concatenate([coarse.fields(part, 0.5).point_data["zeta"] for part in ("body1", "body2")])
    shown = render_fields(coarse, tmp_path / "c.png", time=0.5, fields=("zeta",))
    assert shown["zeta"] == pytest.approx((earlier.min(), earlier.max()), rel=1e-12)


def test_render_draws_a_chosen_time_field_and_format(coarse, tmp_path):
    done = subprocess.run([sys.executable, "-m", "orchestrate", "render", str(coarse.folder), "--out", str(tmp_path),
                           "--time", "0.5", "--fields", "sigma11,zeta", "--format", "svg", "--cmap", "cividis"],
                          cwd=REPO, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "fields.svg").read_text().lstrip().startswith("<?xml")
    assert {p.suffix for p in tmp_path.iterdir() if p.name != RECORD} == {".svg"}
    for options, words in [(["--fields", "temperature"], ["no field temperature", "vonMises"]),
                           (["--range", "per-bod"], ["shared, per-body, or FIELD=LOW,HIGH"]),
                           (["--size", "0,0"], ["(0, 100] inches"]), (["--dpi", "0"], ["[10, 2400]"])]:
        refused = subprocess.run([sys.executable, "-m", "orchestrate", "render", str(coarse.folder), *options],
                                 cwd=REPO, capture_output=True, text=True)
        assert refused.returncode == 2 and all(word in refused.stderr for word in words), refused.stderr
    signed = subprocess.run([sys.executable, "-m", "orchestrate", "render", str(coarse.folder), "--out", str(tmp_path / "s"),
                             "--fields", "sigma22", "--range", "sigma22=-20,20", "--time", "1"],
                            cwd=REPO, capture_output=True, text=True)
    assert signed.returncode == 0, signed.stderr


@pytest.mark.parametrize("time, words", [("0.7", ["the nearest: t = 0.5 and 1"]), ("nan", ["from 0.5 to 1"]),
                                         ("-inf", ["from 0.5 to 1"]), ("1.5", ["the nearest: t = 1;"])])
def test_render_refuses_a_time_the_run_wrote_no_output_at_before_drawing(coarse, tmp_path, time, words):
    """Its outputs are at 0.5 and 1 (output.times): any other time is refused, naming the option,
    the range and the nearest output times, and no image is drawn."""
    done = subprocess.run([sys.executable, "-m", "orchestrate", "render", str(coarse.folder), "--out",
                           str(tmp_path / "images"), f"--time={time}"], cwd=REPO, capture_output=True, text=True)
    assert done.returncode == 2 and f"error: --time {time}: not an output time" in done.stderr, done.stderr
    assert all(word in done.stderr for word in words) and "Traceback" not in done.stderr, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and not (tmp_path / "images").exists()


def test_a_field_is_the_one_of_the_time_asked_or_refused(coarse, tmp_path):
    """grid(time=) gives the output at that time, to round-off (1e-9 of T), and refuses another
    (it gave the nearest: 0.47 drew the output at 0.5); an output's time is its step's t as the
    driver wrote it in history.csv, to the last digit, not the .pvd's six (1/30 there is 0.0333333)."""
    from orchestrate.freefem import InputError

    half = coarse.grid("body1", 0.5)
    assert np.array_equal(coarse.grid("body1", 0.5 * (1 + 1e-12))["u"], half["u"])
    assert not np.array_equal(coarse.grid("body1", 1.0)["u"], half["u"])
    for time in (0.47, 0.5 * (1 + 1e-6), 0.0, float("nan"), True, "half"):
        with pytest.raises(InputError, match="not an output time"):
            coarse.grid("body1", time)
    with pytest.raises(InputError, match="part 'bodyl': a run's parts are body1, body2, contact"):
        coarse.grid("bodyl", 0.5)
    with pytest.raises(InputError, match=r"time 0.47: .*2 output times run from 0.5 to 1; the nearest: t = 0.5"):
        coarse.grid("contact", 0.47)
    every = run(REPO / "scenes" / "paper.toml", tmp_path / "every",
                {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.N": 30, "output.times": "all", "output.images": False})
    assert [t for t, _ in every.outputs] == list(every.history["t"])  # the driver's t of each step, 17 digits
    first = every.fields("body2", 1 / 30).point_data["u"]
    assert np.array_equal(first, meshio.read(every.folder / "body2_0001.vtu").point_data["u"])


def test_a_history_column_on_a_log_axis_or_against_itself_is_refused(coarse, tmp_path, capsys):
    """body 2 is pressed down: its forceY2 is negative, which a log axis would drop, leaving an
    empty image; t against t means nothing. Both refused, nothing drawn."""
    force = np.genfromtxt(coarse.folder / "history.csv", delimiter=",", names=True)["forceY2"]
    assert force.min() < 0
    assert main(["plot", str(coarse.folder), "--y", "forceY2", "--log", "y", "--out", str(tmp_path / "f.png")]) == 2
    assert f"--log y: forceY2 goes down to {force.min():.6g}" in capsys.readouterr().err
    assert main(["plot", str(coarse.folder), "--y", "t", "--out", str(tmp_path / "t.png")]) == 2
    assert "--x and --y are both t" in capsys.readouterr().err
    assert main(["plot", str(coarse.folder), "--y", "forceY1", "--x", "forceY2", "--log", "x",
                 "--out", str(tmp_path / "x.png")]) == 2
    assert "--log x: forceY2 goes down" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


def test_render_out_takes_a_new_folder_and_replaces_only_its_own_images(coarse, tmp_path, capsys):
    """render --out into a folder it drew asks for --force; --force replaces its images (a link
    among them unlinked, its target kept) and refuses a folder that holds anything else."""
    out, victim = tmp_path / "images", tmp_path / "victim.png"
    victim.write_bytes(b"the user's")
    assert main(["render", str(coarse.folder), "--out", str(out), "--fields", "zeta"]) == 0
    assert main(["render", str(coarse.folder), "--out", str(out), "--fields", "zeta"]) == 2
    assert "pass --force to replace its files" in capsys.readouterr().err
    (out / "history.png").unlink()
    (out / "history.png").symlink_to(victim)
    assert main(["render", str(coarse.folder), "--out", str(out), "--fields", "zeta", "--force"]) == 0
    assert victim.read_bytes() == b"the user's" and not (out / "history.png").is_symlink()
    (out / "notes.txt").write_text("the user's")
    assert main(["render", str(coarse.folder), "--out", str(out), "--force"]) == 2
    assert "also holds notes.txt" in capsys.readouterr().err and (out / "notes.txt").exists()


@pytest.mark.unit
@pytest.mark.parametrize("options, words", [(["--cmap", "nope"], "--cmap nope: not a matplotlib colormap"),
                                            (["--magnification", "nan"], "--magnification nan: give a finite number"),
                                            (["--range", "per-body", "--range", "zeta=0,1"], "give one kind"),
                                            (["--fields", "zeta,vonMises,zeta"], "names a field twice")])
def test_a_bad_render_option_is_an_input_error_before_the_run_is_read(tmp_path, capsys, options, words):
    """Exit 2, as every other refused input (they ended as run-time errors, exit 1; a field named
    twice was drawn twice)."""
    try:
        code = main(["render", str(tmp_path / "no-run"), "--out", str(tmp_path / "images"), *options])
    except SystemExit as exit:  # argparse's own refusal
        code = exit.code
    assert code == 2
    assert words in capsys.readouterr().err and not any(tmp_path.iterdir())


@pytest.mark.unit
def test_a_field_uniform_to_round_off_is_shown_as_one_colour():
    from orchestrate.render import colour_range

    noisy = 15.085 + np.array([0.0, 3e-14, -2e-14])
    low, high = colour_range(noisy)
    assert low < noisy.min() and high > noisy.max() and high - low == pytest.approx(15.085e-6, rel=1e-9)
    assert colour_range(np.zeros(3)) == pytest.approx((-5e-7, 5e-7))
    spread = np.array([0.2, 0.9])
    assert colour_range(spread) == (0.2, 0.9)


@pytest.mark.unit
def test_the_images_label_the_scenes_units(tmp_path):
    """output.units: the solver needs none (consistent units), the images must say which."""
    from types import SimpleNamespace

    from orchestrate.render import field_titles, units_of

    def run_in(folder):  # what units_of reads of a run: its files and their bytes
        return SimpleNamespace(files=[path.name for path in folder.glob("scene.toml")],
                               read=lambda name: (folder / name).read_bytes())

    (tmp_path / "scene.toml").write_text('[output]\nunits = "mm-N-s"\n')
    units = units_of(run_in(tmp_path))
    assert units == {"length": "mm", "stress": "MPa", "force": "N/mm", "energy": "N·mm/mm", "time": "s"}
    assert field_titles(units)["vonMises"] == "von Mises stress (MPa)"
    assert units_of(run_in(tmp_path / "by-hand"))["stress"] == "N/m²"  # no scene: SI
    # a scene's own set: a stress is force/length², a force per unit thickness force/length
    (tmp_path / "scene.toml").write_text('[output.units]\nlength = "mm"\nforce = "mN"\ntime = "ms"\n')
    assert units_of(run_in(tmp_path)) == {"length": "mm", "stress": "mN/mm²", "force": "mN/mm",
                                          "energy": "mN·mm/mm", "time": "ms"}
    (tmp_path / "scene.toml").write_text('[output.units]\nlength = "m$^2$"\n')  # edited by hand: never printed
    assert units_of(run_in(tmp_path))["length"] == "m"


def test_every_history_column_of_a_quantity_is_labelled_with_its_unit(coarse):
    """plot's axes: each column of history.csv that is a physical quantity gets its title and its
    unit in the scene's units (a reaction and an interface force are forces per unit thickness,
    the energies energies per unit thickness, ‖u‖_V = (∫ε:ε)^½ a length); the step and its CPU
    time keep their names; history.png's panels say their units, ‖u‖_V's too."""
    from orchestrate.render import UNITS, column_label, history_panels

    header = (coarse.folder / "history.csv").read_text().splitlines()[0].split(",")
    counts = {"n", "stepSeconds"}  # the counts have titles of their own (edp/lib/formats.toml), no unit
    si = UNITS["SI"]
    for name in header:
        assert (column_label(name, si) == name) == (name in counts), name
    assert column_label("reactionY1_5", si) == "reaction y on body 1, label 5 (N/m)"
    assert column_label("elasticEnergy", UNITS["mm-N-s"]) == "elastic energy (N·mm/mm)"
    assert column_label("normV", si) == "‖u‖_V (m)" and column_label("t", si) == "time t (s)"
    assert column_label("betaMean", si) == "mean β over Γ_C"
    titles = [title for title, _, _ in history_panels(UNITS["mm-N-s"])]
    assert titles[0] == "‖u‖_V (mm)" and all(kind in " ".join(titles) for kind in ("MPa", "N/mm", "(mm)"))


def overlap(a, b) -> bool:
    return min(a[2], b[2]) > max(a[0], b[0]) and min(a[3], b[3]) > max(a[1], b[1])


@pytest.mark.parametrize("options", [{}, {"ranges": "per-body", "fields": ("vonMises", "sigma12", "zeta")},
                                     {"size": (6, 4)}])
def test_no_text_collides_and_every_panel_is_drawn_inside_the_image(coarse, tmp_path, options):
    """The acceptance of the figures, off screen: every text (ticks, axis and colour-bar labels,
    titles) inside the image and clear of every other text and of the panels' plotting areas
    (a panel's own tick labels sit outside it); every panel holds a picture, not a blank."""
    shown = render_fields(coarse, tmp_path / "fields.png", **options)
    image = np.asarray(Image.open(tmp_path / "fields.png").convert("RGB"), dtype=float)
    layout = shown["layout"]
    height, width = image.shape[:2]
    texts = layout["texts"]
    assert len(texts) > 10
    for index, (text, box) in enumerate(texts):
        assert box[0] >= 0 and box[1] >= 0 and box[2] <= width and box[3] <= height, f"{text!r} is cut at the edge"
        for other, other_box in texts[index + 1:]:
            assert not overlap(box, other_box), f"{text!r} and {other!r} overlap"
        for area in layout["panels"] + layout["bars"]:
            assert not overlap(box, area), f"{text!r} is drawn over a panel or a colour bar"
    for x0, y0, x1, y1 in layout["panels"]:
        panel = image[int(y0) + 2:int(y1) - 2, int(x0) + 2:int(x1) - 2].reshape(-1, 3)
        assert len(np.unique(panel, axis=0)) > 50, "a blank panel"


def test_render_removes_an_image_its_files_no_longer_give(coarse, tmp_path):
    """Two output times give no beta_xt.png (three are needed): one left by an earlier drawing
    goes, so a folder never shows a figure of another run."""
    from orchestrate.render import render_all

    (tmp_path / "beta_xt.png").write_bytes(b"stale")
    (tmp_path / "notes.png").write_bytes(b"the user's")
    drawn = render_all(coarse, tmp_path)
    assert {path.name for path in drawn} == {"fields.png", "contact_line.png", "history.png"}
    assert not (tmp_path / "beta_xt.png").exists() and (tmp_path / "notes.png").exists()
