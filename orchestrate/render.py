"""Images of a run, with matplotlib: the seed's Figure 2 (von Mises stress and damage on the
deformed bodies), the contact line along Γ_C, β over position and time, and the history."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from orchestrate.formats import HISTORY, REACTION
from orchestrate.outputs import write_figure
from orchestrate.plots import pyplot, save
from orchestrate.results import Result
from orchestrate.scene import Units


# The labels of a scene's consistent units (output.units): length, stress, force and energy per
# unit thickness, time; a scene's own table names length, force and time, and the others follow.
UNITS = {"SI": {"length": "m", "stress": "N/m²", "force": "N/m", "energy": "J/m", "time": "s"},
         "mm-N-s": {"length": "mm", "stress": "MPa", "force": "N/mm", "energy": "N·mm/mm", "time": "s"}}


def unit_labels(units) -> dict[str, str]:
    """The labels of output.units: a preset's name, or a table {length, force, time} of names."""
    if isinstance(units, str):
        return UNITS.get(units, UNITS["SI"])
    try:
        named = Units.model_validate(units)
    except ValueError:  # a hand-edited table: the labels are never guessed
        return UNITS["SI"]
    return {"length": named.length, "stress": f"{named.force}/{named.length}²", "force": f"{named.force}/{named.length}",
            "energy": f"{named.force}·{named.length}/{named.length}", "time": named.time}




def column_label(name: str, units: dict[str, str], when: str = "") -> str:
    """A history column's axis label with its unit, `when` after the title (" at T": a sweep's final
    values); the column's name itself when it is not one of the history's quantities (counts, and
    columns of other files)."""
    reaction = REACTION.fullmatch(name)
    if reaction:
        axis, body, label = reaction.groups()
        title, kind = f"reaction {axis.lower()} on body {body}, label {label}", "force"
    elif name in HISTORY:
        title, kind = HISTORY[name]
    else:
        return name
    return f"{title}{when} ({units[kind]})" if kind else f"{title}{when}"


def units_of(result: Result) -> dict[str, str]:
    """The unit labels of a run: its scene's output.units (SI for a run of the driver by hand)."""
    import tomllib

    if "scene.toml" not in result.files:  # a run of the driver by hand
        return UNITS["SI"]
    try:
        scene = tomllib.loads(result.read("scene.toml").decode())
    except (UnicodeDecodeError, tomllib.TOMLDecodeError):
        return UNITS["SI"]
    return unit_labels(scene.get("output", {}).get("units", "SI"))


# What the body files hold that a figure can show: title, unit kind (a key of UNITS, or None),
# whether it is a cell field (P0, per triangle) or a point field (P1), and its colormap.
FIELDS = {
    "vonMises": ("von Mises stress", "stress", "cell", "viridis"),
    "sigma11": ("σ11", "stress", "cell", "RdBu_r"),  # signed: a diverging map, centred on 0 (symmetric)
    "sigma22": ("σ22", "stress", "cell", "RdBu_r"),
    "sigma12": ("σ12", "stress", "cell", "RdBu_r"),
    "sigma33": ("σ33", "stress", "cell", "RdBu_r"),
    "zeta": ("damage ζ (1 = sound)", None, "point", "magma"),
}


def field_titles(units: dict[str, str]) -> dict[str, str]:
    """Each field's colour-bar label with its unit."""
    return {name: f"{title} ({units[kind]})" if kind else title for name, (title, kind, _, _) in FIELDS.items()}


def nice_magnification(max_displacement: float, size: float) -> float:
    """A round factor (1, 2 or 5 × 10^k, at least 1) that makes the largest displacement about 5 %
    of the size: displacements are never drawn smaller than they are."""
    if max_displacement <= 0 or max_displacement >= 0.05 * size:
        return 1.0
    target = 0.05 * size / max_displacement
    exponent = math.floor(math.log10(target))
    mantissa = max(m for m in (1, 2, 5, 10) if m <= target / 10 ** exponent)
    return mantissa * 10 ** exponent


def bodies_at(result: Result, time: float | None = None) -> tuple[float, list]:
    """The output time `time` (default: the last; Result.output_at) and both bodies' meshes there."""
    chosen, _ = result.output_at(time, ("body1", "body2"))
    return chosen, [result.fields(part, chosen) for part in ("body1", "body2")]


UNIFORM = 1e-12  # a damage field that varies less than this never moved from its ζ⁰


def colour_range(values: np.ndarray, floor: float = 1e-6) -> tuple[float, float]:
    """The field's min–max, widened to at least `floor` times its magnitude: a field uniform to
    round-off (the patch test's) then shows as one colour, not as its magnified rounding noise."""
    low, high = float(values.min()), float(values.max())
    width = floor * (max(abs(low), abs(high)) or 1.0)
    if high - low >= width:
        return low, high
    middle = 0.5 * (low + high)
    return middle - 0.5 * width, middle + 0.5 * width


def steady_axis(axis, values: np.ndarray, floor: float = 1e-6) -> None:
    """Plain tick labels (no '1e-11 + 14.37' offset) on a y axis, and a near-constant series shown
    over at least `floor` of its size, like the colour bars, so its round-off does not fill the panel."""
    axis.ticklabel_format(axis="y", useOffset=False)
    values = np.asarray(values, dtype=float)
    if not values.any():  # all 0 (no glue, no contact): an axis of plain numbers around it
        axis.set_ylim(-1, 1)
        return
    low, high = colour_range(values, floor)
    if high - low > float(np.ptp(values)):
        axis.set_ylim(low, high)


def centred(limits: tuple[float, float]) -> tuple[float, float]:
    """A range symmetric about 0 that holds `limits` (for a signed field's diverging map)."""
    reach = max(abs(limits[0]), abs(limits[1]))
    return -reach, reach


def outline(axis, body, drawn: np.ndarray) -> None:
    """The body's boundary edges (the line cells of its file) as thin lines at their drawn place."""
    from matplotlib.collections import LineCollection

    edges = body.cells_dict.get("line")
    if edges is not None:
        axis.add_collection(LineCollection(drawn[edges], colors="black", linewidths=0.4))


def field_values(mesh, field: str) -> np.ndarray:
    """A body's values of `field`: per triangle (cell fields) or per node (point fields)."""
    held = mesh.cell_data_dict if FIELDS[field][2] == "cell" else mesh.point_data
    if field not in held:
        raise FileNotFoundError(f"the body files have no field {field} (the stresses need output.fields 'stress', "
                                "sigma33 plane strain)")
    values = held[field]["triangle"] if FIELDS[field][2] == "cell" else held[field]
    return np.asarray(values, dtype=float).ravel()


def initial_gap_in(result: Result) -> bool:
    """Whether the bodies start apart somewhere (the contact line holds initialGap)."""
    files = result.outputs[-1][1] if result.outputs else {}
    return "contact" in files and "initialGap" in result.fields("contact").point_data


def render_fields(result: Result, target: Path, *, time: float | None = None, fields=("vonMises", "zeta"),
                  magnification: float | None = None, ranges: str | dict = "shared",
                  cmap: str | None = None, size: tuple[float, float] | None = None, dpi: int = 150) -> dict:
    """Figure 2 of the seed: each field on both bodies, deformed by a stated magnification of u,
    one panel per field with axes in the scene's length unit, every body whole in view, its
    boundary outlined. The default magnification is a round factor ≥ 1 that makes the largest
    displacement 5 % of the scene, and 1 when the bodies start apart somewhere (magnifying would
    draw the closed gap as an overlap); 0 draws them undeformed. ranges: "shared" (one colour bar
    for both bodies), "per-body" (a colour bar each), or {field: (low, high)} (the others shared).
    Signed stresses take a diverging map centred on 0. Returns the colour range each colour bar
    shows ({field: (low, high)}, or per body {field: [(…), (…)]}), and "view" (x0, x1, y0, y1),
    "magnification" and "time" as drawn, and "layout" (drawn_boxes: where the panels and texts are
    in the image)."""
    import matplotlib.tri as mtri

    plt = pyplot()
    unknown = [field for field in fields if field not in FIELDS]
    if unknown:
        raise ValueError(f"no field {', '.join(unknown)} (fields: {', '.join(FIELDS)})")
    chosen, bodies = bodies_at(result, time)
    units = units_of(result)
    points = [body.points[:, :2].astype(float) for body in bodies]
    moved = [np.asarray(body.point_data["u"], dtype=float)[:, :2] for body in bodies]
    extent = np.ptp(np.vstack(points), axis=0).max()
    if magnification is not None:
        factor = magnification
    elif initial_gap_in(result):
        factor = 1.0
    else:
        factor = nice_magnification(max(np.linalg.norm(u, axis=1).max() for u in moved), extent)
    shapes = [mtri.Triangulation(*(p + factor * u).T, body.cells_dict["triangle"])
              for p, u, body in zip(points, moved, bodies)]
    corners = np.vstack([np.column_stack([shape.x, shape.y]) for shape in shapes])
    low, high = corners.min(axis=0), corners.max(axis=0)
    margin = 0.03 * (high - low).max()
    aspect = (high[0] - low[0] + 2 * margin) / (high[1] - low[1] + 2 * margin)
    panel_height = min(4.0, 7.5 / aspect)  # a wide scene gets a lower panel, not a narrow strip
    panel_width = max(panel_height * aspect, 1.8)
    bars = 2 if ranges == "per-body" else 1
    given = ranges if isinstance(ranges, dict) else {}
    stacked = aspect > 1.3  # wide scenes one panel under the other, tall ones side by side
    across = (panel_width + 1.4 * bars + 0.4, len(fields) * (panel_height + 0.8) + 0.3) if stacked else \
        (len(fields) * (panel_width + 1.4 * bars) + 0.4, panel_height + 1.0)
    width, height = size or across
    figure, axes = plt.subplots(len(fields) if stacked else 1, 1 if stacked else len(fields), figsize=(width, height),
                                squeeze=False, constrained_layout=True, dpi=dpi)
    titles, shown = field_titles(units), {}
    for axis, field in zip(axes.flat, fields):
        values = [field_values(body, field) for body in bodies]
        signed = FIELDS[field][3] == "RdBu_r" and cmap is None
        if field in given:
            limits = [given[field]] * 2
        elif ranges == "per-body":
            limits = [centred(colour_range(v)) if signed else colour_range(v) for v in values]
        elif field == "zeta" and np.ptp(np.concatenate(values)) <= UNIFORM:
            limits = [(0.0, 1.0)] * 2  # undamaged (or uniformly damaged): on the whole scale of ζ
        else:
            whole = colour_range(np.concatenate(values))
            limits = [centred(whole) if signed else whole] * 2
        colours = cmap or FIELDS[field][3]
        drawn = []
        for shape, value, (vmin, vmax), body, p, u in zip(shapes, values, limits, bodies, points, moved):
            if FIELDS[field][2] == "cell":
                image = axis.tripcolor(shape, facecolors=value, cmap=colours, vmin=vmin, vmax=vmax)
            else:
                image = axis.tripcolor(shape, value, shading="gouraud", cmap=colours, vmin=vmin, vmax=vmax)
            image.set_rasterized(True)  # a vector file keeps its axes and text, not 10⁴ gradient patches
            drawn.append(image)
            outline(axis, body, p + factor * u)
        for index in reversed(range(bars)):  # matplotlib puts the last bar made next to the panel
            image = drawn[index]
            label = titles[field] + (f", body {index + 1}" if bars == 2 else "")
            bar = figure.colorbar(image, ax=axis, shrink=0.9, pad=0.02)
            bar.set_label(label)
            bar.formatter.set_useOffset(False)
            bar.update_ticks()
        shown[field] = [tuple(d.get_clim()) for d in drawn] if bars == 2 else tuple(drawn[0].get_clim())
        axis.set_xlim(low[0] - margin, high[0] + margin)
        axis.set_ylim(low[1] - margin, high[1] + margin)
        axis.set_aspect("equal")
        axis.set_xlabel(f"x ({units['length']})")
        axis.set_ylabel(f"y ({units['length']})")
        axis.set_title(f"{FIELDS[field][0].split(' (')[0]} at t = {chosen:g} s", fontsize=10)
    shown["view"] = (*axis.get_xlim(), *axis.get_ylim())
    shown["magnification"], shown["time"] = factor, chosen
    stated = "undeformed" if factor == 0 else f"displacements magnified ×{factor:g}"
    figure.suptitle(f"{stated} (bodies drawn at x + {factor:g}·u)" if factor else stated, fontsize=9)
    write_figure(figure, target, dpi=dpi)
    shown["layout"] = drawn_boxes(figure, [axis for axis in axes.flat])
    plt.close(figure)
    return shown


def drawn_boxes(figure, panels) -> dict:
    """The boxes (x0, y0, x1, y1 in pixels of the image, y downwards) of the panels and of every
    text drawn: tick labels, axis labels, titles, of the panels and of the colour bars."""
    renderer = figure.canvas.get_renderer()
    height = figure.bbox.height

    def box(artist):
        extent = artist.get_window_extent(renderer)
        return (extent.x0, height - extent.y1, extent.x1, height - extent.y0)

    def within(value, limits):  # matplotlib keeps labels of ticks beyond the view, undrawn
        return min(limits) - 1e-9 * abs(np.ptp(limits)) <= value <= max(limits) + 1e-9 * abs(np.ptp(limits))

    texts = list(figure.texts)  # the suptitle
    for axis in figure.axes:
        texts += [axis.title, axis.xaxis.label, axis.yaxis.label]
        texts += [label for label in axis.get_xticklabels() if within(label.get_position()[0], axis.get_xlim())]
        texts += [label for label in axis.get_yticklabels() if within(label.get_position()[1], axis.get_ylim())]
    drawn = [text for text in texts if text.get_visible() and text.get_text()]
    return {"panels": [box(panel) for panel in panels],
            "bars": [box(axis) for axis in figure.axes if axis not in panels],
            "texts": [(text.get_text(), box(text)) for text in drawn]}


def line_position(points: np.ndarray, length_unit: str) -> tuple[np.ndarray, str]:
    """The position of the contact line's nodes and its axis label: x (or y) when Γ_C is parallel
    to that axis, as users place things, else the distance from its first node."""
    for axis, name in ((0, "x"), (1, "y")):
        other = points[:, 1 - axis]
        if np.ptp(other) <= 1e-9 * max(np.ptp(points[:, axis]), 1e-300):
            return points[:, axis], f"{name} ({length_unit})"
    return np.linalg.norm(points - points[0], axis=1), f"position along Γ_C ({length_unit})"


def segment_edges(line, s: np.ndarray) -> np.ndarray:
    """The positions of the contact line's segment ends (β's cells), in order: each cell's first
    two points are its ends (a line, or a quadratic edge of degree 2 with its middle third)."""
    ends = line.cells[0].data[:, :2]
    return s[np.concatenate([ends[:, 0], ends[-1:, 1]])]


def glued(result: Result) -> bool:
    """Whether the run has glue: bonds (β⁰ > 0 somewhere, or rebonding) that exert forces
    (γ_ν or p_τ > 0). Without, β is 0 or does nothing, and its panels would show noise."""
    p = result.params
    bonds = p.get("beta0") != 0 or p.get("gammaR", 0) > 0
    return bool(bonds and (p.get("gammaNu", 0) > 0 or p.get("pTau", 0) > 0))


def plot_contact_line(result: Result, target: Path, time: float | None = None, dpi: int = 120) -> Path:
    """β (when there is glue), the gap and the contact pressure along Γ_C at an output time
    (default: the last; Result.output_at); with an initial gap g0 the gap is shown as
    g_h − π1 g0, so that 0 is closed there too, and a gap within contactTol of 0 as 0."""
    chosen, _ = result.output_at(time, ("contact",))
    line = result.fields("contact", chosen)
    units = units_of(result)
    s, position_label = line_position(line.points, units["length"])
    glue = glued(result)
    figure, axes = pyplot().subplots(2 + glue, 1, figsize=(7, 5.2 + 2.3 * glue), sharex=True)
    if glue:
        beta = line.cell_data["beta"][0]
        axes[0].stairs(beta, segment_edges(line, s), baseline=None, color="tab:green")
        steady_axis(axes[0], beta)
        axes[0].set_ylabel("bonding β")
    axes = axes[glue:]
    initial = line.point_data.get("initialGap")
    opening = line.point_data["gap"] - (initial if initial is not None else 0)
    # closed to within the solver's tolerance is closed: its 1e-17 round-off would fill the panel
    opening = np.where(np.abs(opening) <= result.params.get("contactTol", 0.0), 0.0, opening)
    axes[0].plot(s, opening, "o-", ms=3)
    steady_axis(axes[0], opening)
    axes[0].axhline(0, color="grey", lw=0.8)
    axes[0].set_ylabel(f"{'g_h − π1 g0' if initial is not None else 'gap g_h'} ({units['length']})\n(< 0: open)")
    if "segmentPressure" in line.cell_data:  # degree 2: the nodal tractions alternate, each segment's force does not
        pressure = line.cell_data["segmentPressure"][0]
        axes[1].stairs(pressure, segment_edges(line, s), baseline=None, color="tab:red")
        axes[1].set_ylabel(f"contact pressure ({units['stress']})\nper segment")
    else:
        pressure = line.point_data["pressure"]
        axes[1].plot(s, pressure, "o-", ms=3, color="tab:red")
        axes[1].set_ylabel(f"contact pressure ({units['stress']})")
    steady_axis(axes[1], pressure)
    axes[1].set_xlabel(position_label)
    figure.suptitle(f"Contact line at t = {chosen:g} s")
    save(figure, target, dpi=dpi)
    return target


def history_panels(units: dict[str, str]) -> list[tuple[str, list[str], tuple[float, float] | None]]:
    """history.png's panels: each one's title (with its unit), the columns drawn in it, and the
    range to show when they never moved (a quantity of [0, 1]; None: the data's own)."""
    return [(column_label("normV", units), ["normV"], None),
            (f"max von Mises ({units['stress']})", ["vmMax1", "vmMax2"], None),
            ("min damage ζ", ["zetaMin1", "zetaMin2"], (-0.05, 1.05)), ("bonding β", ["betaMin", "betaMean"], None),
            (f"forces on body 1 across Γ_C ({units['force']})", ["contactForce", "forceX1", "forceY1"], None),
            (f"closed length ({units['length']})", ["contactLength"], None)]


def plot_history(runs: Result | dict[str, Result], target: Path, dpi: int = 110) -> Path:
    """The history.csv series over time; several runs ({label: result}) are drawn over each other,
    a line style per run and a colour per series."""
    runs = runs if isinstance(runs, dict) else {"": runs}
    figure, axes = pyplot().subplots(3, 2, figsize=(10, 8), sharex=True)
    units = units_of(next(iter(runs.values())))
    for axis, (title, columns, whole) in zip(axes.flat, history_panels(units)):
        for colour, column in enumerate(columns):
            for style, (label, result) in zip(("-", "--", ":", "-."), runs.items()):
                h = result.history
                axis.plot(h["t"], h[column], style, color=f"C{colour}", label=f"{column} ({label})" if label else column)
        series = np.concatenate([result.history[column] for column in columns for result in runs.values()])
        if whole and np.ptp(series) <= UNIFORM:
            axis.set_ylim(*whole)  # a ζ that never moved: on its whole scale, not its round-off's
        else:
            steady_axis(axis, series)
        axis.set_title(title, fontsize=10)
        if len(columns) > 1 or len(runs) > 1:
            axis.legend(fontsize=8)
    for axis in axes[-1]:
        axis.set_xlabel(f"t ({units['time']})")
    save(figure, target, dpi=dpi)
    return target


def plot_bonding_evolution(result: Result, target: Path, dpi: int = 110) -> Path:
    """β over the position along Γ_C and the time, from every contact-line output."""
    times, rows, edges = [], [], None
    for time, files in result.outputs:
        if "contact" in files:
            line = result.fields("contact", time)
            position, position_label = line_position(line.points, units_of(result)["length"])
            edges = segment_edges(line, position)
            rows.append(line.cell_data["beta"][0])
            times.append(time)
    times = np.array(times)
    time_edges = np.concatenate([[times[0] - (times[1] - times[0]) / 2], (times[1:] + times[:-1]) / 2,
                                 [times[-1] + (times[-1] - times[-2]) / 2]])
    figure, axis = pyplot().subplots(figsize=(7, 4.2))
    low, high = colour_range(np.array(rows))  # the data's range: β within 1e-4 of 1 is no solid block
    image = axis.pcolormesh(edges, time_edges, np.array(rows), cmap="viridis", vmin=low, vmax=high, shading="flat")
    bar = figure.colorbar(image, ax=axis, label="bonding β")
    bar.formatter.set_useOffset(False)
    bar.update_ticks()
    axis.set_xlabel(position_label)
    axis.set_ylabel("t (s)")
    axis.set_title("Bonding β along Γ_C over time")
    save(figure, target, dpi=dpi)
    return target


IMAGES = ("fields", "contact_line", "beta_xt", "history")  # what render_all may draw, by file name


def render_all(result: Result, folder: Path, image_format: str = "png", dpi: int | None = None,
               *, announce=None, **fields_options) -> list[Path]:
    """Every image the run's files allow: fields (body files), contact line, β over x and t (with
    glue), history, in `image_format` (png, pdf, svg) at `dpi` (default: each image's own);
    announce(name) is told each image's file name before it is drawn (a run's progress);
    fields_options (time among them) go to render_fields. Returns the paths written."""
    folder.mkdir(parents=True, exist_ok=True)
    own = {} if dpi is None else {"dpi": dpi}
    images = []

    def drawn(name: str, draw, *arguments, **options) -> None:
        target = folder / f"{name}.{image_format}"
        if announce:
            announce(target.name)
        draw(result, target, *arguments, **own, **options)
        images.append(target)

    if any({"body1", "body2"} <= set(files) for _, files in result.outputs):
        drawn("fields", render_fields, **fields_options)
    if any("contact" in files for _, files in result.outputs):
        drawn("contact_line", plot_contact_line, fields_options.get("time"))
    if sum("contact" in files for _, files in result.outputs) >= 3 and glued(result):
        drawn("beta_xt", plot_bonding_evolution)
    drawn("history", plot_history)
    for name in IMAGES:  # an older drawing the files no longer give
        stale = folder / f"{name}.{image_format}"
        if stale not in images:
            stale.unlink(missing_ok=True)
    return images
