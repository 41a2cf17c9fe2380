"""What the pictures share: matplotlib's pyplot on a backend that needs no display, their
resolution, PNG files written atomically, one legend for several axes, a grid of panels with its
legend below, and the cell edges of a heat map's grid values."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

import numpy as np

from ..io import write_atomic

#: The pictures' resolution (dots per inch).
DPI = 110


def pyplot():
    """matplotlib.pyplot on the Agg backend (no display needed)."""
    # matplotlib: loaded by the first picture drawn, not by importing a module that can draw one
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # matplotlib, as above

    return plt


def save_png(fig, path: str | os.PathLike[str], fast: bool = False) -> None:
    """Write the figure to path as a PNG (atomically) and close it. fast: zlib's fastest level, a
    third of the time of the default for a file about a third larger."""
    options = {"pil_kwargs": {"compress_level": 1}} if fast else {}
    write_atomic(path, lambda tmp: fig.savefig(tmp, format="png", dpi=DPI, **options))
    pyplot().close(fig)


def legend_marks(*axes) -> dict:
    """Each label of the axes' labelled marks once, with its first mark: label -> artist, for one
    legend over several axes."""
    marks: dict = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            marks.setdefault(label, handle)
    return marks


def panels(n: int, width: float = 6.0, height: float = 4.0):
    """A figure of n panels in a grid of ceil(sqrt(n)) columns (unused cells left blank), laid out
    with room for a legend below; returns it and the n axes."""
    plt = pyplot()
    cols = max(1, math.ceil(math.sqrt(n)))
    rows = max(1, math.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(width * cols, height * rows + 0.8), squeeze=False,
                             layout="constrained")
    for ax in axes.flat[n:]:
        ax.set_axis_off()
    return fig, list(axes.flat[:n])


def legend_below(fig, axes, ncol: int = 3) -> None:
    """One legend under the panels, outside the data, naming each label of the axes' marks once."""
    marks = legend_marks(*axes)
    if marks:
        fig.legend(marks.values(), marks.keys(), loc="outside lower center", ncol=ncol, fontsize=8)


def cell_edges(values: Sequence[float]) -> np.ndarray:
    """Cell edges around grid values (midpoints; a single value gets a unit-wide cell)."""
    v = np.asarray(values, dtype=float)
    if len(v) == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5]) if v[0] == 0 else np.array([v[0] * 0.9, v[0] * 1.1])
    mid = (v[1:] + v[:-1]) / 2
    return np.concatenate([[v[0] - (mid[0] - v[0])], mid, [v[-1] + (v[-1] - mid[-1])]])
