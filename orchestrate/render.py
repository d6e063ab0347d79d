"""Images of a run: the seed's Figure 2 (von Mises stress and damage on the deformed bodies, at
the final output time) with pyvista off screen, and matplotlib plots along Γ_C and over time."""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from orchestrate.plots import pyplot, save
from orchestrate.results import Result, load_result


def pyvista():
    """pyvista, off screen through EGL (imported when an image is made: it costs a second)."""
    # an exported but empty VTK_DEFAULT_OPENGL_WINDOW would break the EGL window
    if not os.environ.get("VTK_DEFAULT_OPENGL_WINDOW"):
        os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"
    import pyvista as pv

    pv.OFF_SCREEN = True
    return pv


# The labels of a scene's consistent units (output.units): length, stress, force per unit thickness.
UNITS = {"SI": {"length": "m", "stress": "N/m²", "force": "N/m"},
         "mm-N-s": {"length": "mm", "stress": "MPa", "force": "N/mm"}}


def units_of(result: Result) -> dict[str, str]:
    """The unit labels of a run: its scene's output.units (SI for a run of the driver by hand)."""
    import tomllib

    try:
        scene = tomllib.loads((result.folder / "scene.toml").read_text())
    except (OSError, tomllib.TOMLDecodeError):
        return UNITS["SI"]
    return UNITS.get(scene.get("output", {}).get("units", "SI"), UNITS["SI"])


def field_titles(units: dict[str, str]) -> dict[str, str]:
    # VTK's bundled font has no Greek letters and no ², so the image titles spell them out.
    stress = units["stress"].replace("²", "^2")
    return {"vonMises": f"von Mises stress ({stress})", "zeta": "damage zeta (1 = sound)"}


def nice_magnification(max_displacement: float, size: float) -> float:
    """A round factor (1, 2 or 5 × 10^k) that makes the largest displacement about 5 % of the size."""
    if max_displacement <= 0:
        return 1.0
    target = 0.05 * size / max_displacement
    exponent = math.floor(math.log10(target))
    mantissa = max(m for m in (1, 2, 5, 10) if m <= target / 10 ** exponent)
    return mantissa * 10 ** exponent


def deformed_bodies(result: Result, time: float | None = None) -> tuple[list, float]:
    """Both bodies' triangles (pyvista grids), warped by a round magnification of u; returns
    (bodies, factor)."""
    pv = pyvista()
    files = result.outputs[-1][1] if time is None else dict(result.outputs)[time]
    bodies = [pv.read(files[part]).extract_cells_by_type(pv.CellType.TRIANGLE) for part in ("body1", "body2")]
    size = max(np.ptp(np.vstack([b.points for b in bodies]), axis=0))
    largest = max(np.linalg.norm(b.point_data["u"], axis=1).max() for b in bodies)
    factor = nice_magnification(largest, size)
    return [body.warp_by_vector("u", factor=factor) for body in bodies], factor


def colour_range(values: np.ndarray, floor: float = 1e-6) -> tuple[float, float]:
    """The field's min–max, widened to at least `floor` times its magnitude: a field uniform to
    round-off (the patch test's) then shows as one colour, not as its magnified rounding noise."""
    low, high = float(values.min()), float(values.max())
    width = floor * (max(abs(low), abs(high)) or 1.0)
    if high - low >= width:
        return low, high
    middle = 0.5 * (low + high)
    return middle - 0.5 * width, middle + 0.5 * width


def label_format(low: float, high: float, labels: int = 5) -> str:
    """A printf format whose significant digits tell `labels` evenly spaced values in [low, high]
    apart (a uniform field's 1e-6 wide bar would otherwise read 15.09 five times)."""
    step = (high - low) / (labels - 1)
    size = max(abs(low), abs(high))
    if step <= 0 or size == 0:
        return "%.4g"
    return f"%.{max(4, math.ceil(math.log10(size / step)) + 2)}g"


def steady_axis(axis, values: np.ndarray, floor: float = 1e-6) -> None:
    """Plain tick labels (no '1e-11 + 14.37' offset) on a y axis, and a near-constant series shown
    over at least `floor` of its size, like the colour bars, so its round-off does not fill the panel."""
    axis.ticklabel_format(axis="y", useOffset=False)
    low, high = colour_range(np.asarray(values, dtype=float), floor)
    if high - low > float(np.ptp(values)):
        axis.set_ylim(low, high)


def render_fields(result: Result, target: Path, window=(1400, 1000)) -> dict[str, tuple[float, float]]:
    """Figure 2 of the seed: von Mises stress (left) and damage ζ (right) on both bodies.
    Returns the colour range each colour bar shows, read back from the rendered scene."""
    bodies, factor = deformed_bodies(result)
    time, titles = result.outputs[-1][0], field_titles(units_of(result))
    plotter = pyvista().Plotter(shape=(1, 2), window_size=window, off_screen=True)
    plotter.set_background("white")
    for column, field in enumerate(("vonMises", "zeta")):
        plotter.subplot(0, column)
        limits = colour_range(np.concatenate([body[field] for body in bodies]))
        bar = dict(title=titles[field], color="black", vertical=False, n_labels=5, fmt=label_format(*limits),
                   position_x=0.12, position_y=0.03, width=0.76, height=0.06, title_font_size=16,
                   label_font_size=14)
        for index, body in enumerate(bodies):
            plotter.add_mesh(body, scalars=field, cmap="viridis" if field == "vonMises" else "magma",
                             clim=limits, show_edges=False, scalar_bar_args=bar, show_scalar_bar=index == 0,
                             lighting=False)  # flat colours, as the colour bar shows them
        plotter.add_text(f"{titles[field].split(' (')[0]} at t = {time:g}, "
                         f"displacements magnified x{factor:g}", position="upper_edge", font_size=10, color="black")
        plotter.view_xy()
        plotter.camera.zoom(1.3)
    plotter.screenshot(str(target))
    shown = {field: tuple(plotter.scalar_bars[titles[field]].GetLookupTable().GetRange())
             for field in ("vonMises", "zeta")}
    plotter.close()
    return shown


def line_position(points: np.ndarray, length_unit: str) -> tuple[np.ndarray, str]:
    """The position of the contact line's nodes and its axis label: x (or y) when Γ_C is parallel
    to that axis, as users place things, else the distance from its first node."""
    for axis, name in ((0, "x"), (1, "y")):
        other = points[:, 1 - axis]
        if np.ptp(other) <= 1e-9 * max(np.ptp(points[:, axis]), 1e-300):
            return points[:, axis], f"{name} ({length_unit})"
    return np.linalg.norm(points - points[0], axis=1), f"position along Γ_C ({length_unit})"


def plot_contact_line(result: Result, target: Path) -> Path:
    """β, the gap and the contact pressure along Γ_C at the final output time; with an initial gap
    g0 the gap is shown as g_h − π1 g0, so that 0 is closed there too."""
    line = result.fields("contact")
    units = units_of(result)
    s, position_label = line_position(line.points, units["length"])
    beta = line.cell_data["beta"][0]
    figure, axes = pyplot().subplots(3, 1, figsize=(7, 7.5), sharex=True)
    axes[0].stairs(beta, s, baseline=None, color="tab:green")
    steady_axis(axes[0], beta)
    axes[0].set_ylabel("bonding β")
    initial = line.point_data.get("initialGap")
    opening = line.point_data["gap"] - (initial if initial is not None else 0)
    axes[1].plot(s, opening, "o-", ms=3)
    axes[1].axhline(0, color="grey", lw=0.8)
    axes[1].set_ylabel(f"{'g_h − π1 g0' if initial is not None else 'gap g_h'} ({units['length']})\n(< 0: open)")
    axes[2].plot(s, line.point_data["pressure"], "o-", ms=3, color="tab:red")
    steady_axis(axes[2], line.point_data["pressure"])
    axes[2].set_ylabel(f"contact pressure ({units['stress']})")
    axes[2].set_xlabel(position_label)
    figure.suptitle(f"Contact line at t = {result.outputs[-1][0]:g}")
    save(figure, target, dpi=120)
    return target


def plot_history(result: Result, target: Path) -> Path:
    """The history.csv series over time."""
    h, units = result.history, units_of(result)
    panels = [("‖u‖_V", ["normV"]), (f"max von Mises ({units['stress']})", ["vmMax1", "vmMax2"]),
              ("min damage ζ", ["zetaMin1", "zetaMin2"]), ("bonding β", ["betaMin", "betaMean"]),
              (f"forces on body 1 across Γ_C ({units['force']})", ["contactForce", "forceX1", "forceY1"]),
              (f"closed length ({units['length']})", ["contactLength"])]
    figure, axes = pyplot().subplots(3, 2, figsize=(10, 8), sharex=True)
    for axis, (title, columns) in zip(axes.flat, panels):
        for column in columns:
            axis.plot(h["t"], h[column], label=column)
        steady_axis(axis, np.concatenate([h[column] for column in columns]))
        axis.set_title(title, fontsize=10)
        if len(columns) > 1:
            axis.legend(fontsize=8)
    for axis in axes[-1]:
        axis.set_xlabel("t (s)")
    save(figure, target)
    return target


def plot_bonding_evolution(result: Result, target: Path) -> Path:
    """β over the position along Γ_C and the time, from every contact-line output."""
    import meshio

    times, rows, edges = [], [], None
    for time, files in result.outputs:
        if "contact" in files:
            line = meshio.read(files["contact"])
            edges, position_label = line_position(line.points, units_of(result)["length"])
            rows.append(line.cell_data["beta"][0])
            times.append(time)
    times = np.array(times)
    time_edges = np.concatenate([[times[0] - (times[1] - times[0]) / 2], (times[1:] + times[:-1]) / 2,
                                 [times[-1] + (times[-1] - times[-2]) / 2]])
    figure, axis = pyplot().subplots(figsize=(7, 4.2))
    image = axis.pcolormesh(edges, time_edges, np.array(rows), cmap="viridis", vmin=0, vmax=1, shading="flat")
    figure.colorbar(image, ax=axis, label="bonding β")
    axis.set_xlabel(position_label)
    axis.set_ylabel("t (s)")
    axis.set_title("Bonding β along Γ_C over time")
    save(figure, target)
    return target


def render_all(result: Result, folder: Path) -> list[Path]:
    """Every image the run's files allow: fields (body files), contact line, history."""
    folder.mkdir(parents=True, exist_ok=True)
    parts = set(result.outputs[-1][1]) if result.outputs else set()
    images = []
    if {"body1", "body2"} <= parts:
        render_fields(result, folder / "fields.png")
        images.append(folder / "fields.png")
    if "contact" in parts:
        images.append(plot_contact_line(result, folder / "contact_line.png"))
    if sum("contact" in files for _, files in result.outputs) >= 3:
        images.append(plot_bonding_evolution(result, folder / "beta_xt.png"))
    return images + [plot_history(result, folder / "history.png")]


# --- command line ---------------------------------------------------------------------------

NAME, HELP = "render", "images of a run folder"


def add_arguments(parser) -> None:
    parser.add_argument("folder", help="a run folder (with history.csv and .vtu files)")
    parser.add_argument("--out", help="where to write the images (default: the run folder)")


def command(options) -> int:
    result = load_result(options.folder)
    for path in render_all(result, Path(options.out or options.folder)):
        print(f"wrote {path}")
    return 0
