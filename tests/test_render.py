"""Images of a run: Figure 2 of the seed (von Mises and damage on the deformed bodies) with its
colour bars spanning the data, and the contact-line and history plots."""
import numpy as np
import pytest
from PIL import Image

from orchestrate import run
from orchestrate.freefem import REPO
from orchestrate.render import render_fields
from orchestrate.results import cell_field


@pytest.fixture(scope="module")
def coarse(tmp_path_factory):
    return run(REPO / "scenes" / "paper.toml", tmp_path_factory.mktemp("render") / "run",
               {"body1.mesh.n": 6, "body2.mesh.n": 8, "time.N": 20})


def test_images_exist_with_the_expected_size_and_are_not_blank(coarse):
    for name, size in [("fields.png", (1400, 1000)), ("contact_line.png", None), ("history.png", None)]:
        image = np.asarray(Image.open(coarse.folder / name).convert("RGB"), dtype=float)
        if size:
            assert image.shape[1::-1] == size
        colours = np.unique(image.reshape(-1, 3), axis=0)
        assert len(colours) > 50, f"{name} looks blank"


def test_colour_bars_span_the_data(coarse, tmp_path):
    shown = render_fields(coarse, tmp_path / "fields.png")
    bodies = [coarse.fields(part) for part in ("body1", "body2")]
    von_mises = np.concatenate([cell_field(body, "vonMises") for body in bodies])
    zeta = np.concatenate([body.point_data["zeta"] for body in bodies])
    assert shown["vonMises"] == pytest.approx((von_mises.min(), von_mises.max()), rel=1e-12, abs=1e-300)
    assert shown["zeta"] == pytest.approx((zeta.min(), zeta.max()), rel=1e-12)
    assert von_mises.max() > 0 and zeta.min() < 1


def test_a_field_uniform_to_round_off_is_shown_as_one_colour():
    from orchestrate.render import colour_range

    noisy = 15.085 + np.array([0.0, 3e-14, -2e-14])
    low, high = colour_range(noisy)
    assert low < noisy.min() and high > noisy.max() and high - low == pytest.approx(15.085e-6, rel=1e-9)
    assert colour_range(np.zeros(3)) == pytest.approx((-5e-7, 5e-7))
    spread = np.array([0.2, 0.9])
    assert colour_range(spread) == (0.2, 0.9)


def test_the_images_label_the_scenes_units(tmp_path):
    """output.units: the solver needs none (consistent units), the images must say which."""
    from types import SimpleNamespace

    from orchestrate.render import field_titles, units_of

    (tmp_path / "scene.toml").write_text('[output]\nunits = "mm-N-s"\n')
    units = units_of(SimpleNamespace(folder=tmp_path))
    assert units == {"length": "mm", "stress": "MPa", "force": "N/mm"}
    assert field_titles(units)["vonMises"] == "von Mises stress (MPa)"
    assert units_of(SimpleNamespace(folder=tmp_path / "by-hand"))["stress"] == "N/m²"  # no scene: SI
