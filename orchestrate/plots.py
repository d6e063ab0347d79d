"""The matplotlib set-up and the saving that the images, the studies and the benchmark share."""
from __future__ import annotations

from pathlib import Path

from orchestrate.outputs import write_figure


def pyplot():
    """matplotlib.pyplot on the Agg backend: plots go to files, never to a screen."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plain(text: str) -> str:
    """`text` drawn as written: a sweep's keys and values are expressions, not TeX, and matplotlib
    would parse any text between two dollar signs as mathtext (and fail on `$x^$`)."""
    return text.replace("$", r"\$")


def log_axes(axis, xlabel: str, ylabel: str, **legend_options) -> None:
    """The labels, a grid at every decade line and the legend of a log–log plot (legend_options: matplotlib's)."""
    axis.set_xlabel(xlabel)
    axis.set_ylabel(ylabel)
    axis.grid(True, which="both", alpha=0.3)
    legend(axis, **legend_options)


def legend(axis, **options) -> None:
    """The axis's legend, if anything on it has a label (a study run at a small size may leave a panel empty)."""
    if axis.get_legend_handles_labels()[0]:
        axis.legend(**options)


def save(figure, target: Path, dpi: int = 110) -> None:
    """Lay out, write and close a figure (closed, so that a long sweep does not pile them up)."""
    figure.tight_layout()
    write_figure(figure, target, dpi=dpi)
    pyplot().close(figure)
