"""The picture of a tiled layout: its top view, each piece where and in which order it was put down
(matplotlib)."""

from __future__ import annotations

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Polygon as PolygonPatch  # noqa: E402

from .common import legend_marks, save_png  # noqa: E402


def draw_layout(layout, tiling, path: str | os.PathLike[str]) -> None:
    """Write layout_figure's picture to path (PNG)."""
    save_png(layout_figure(layout, tiling), path, fast=True)


def layout_figure(layout, tiling):
    """Top view of a layout after tiling (world x, y in mm): the frame's walls, every piece at its
    target numbered in placement order, its G (dot) and B (square), the ungrasp direction G -> B
    (the B end is the one put down last), and the thumb's width at B. A piece that could not be
    placed is hatched red; pieces not reached are outlined only. One legend names every mark.
    Returns the matplotlib Figure."""
    fig, ax = plt.subplots(figsize=(8, 8.4), constrained_layout=True)
    for wall in layout.frame.walls():
        ax.add_patch(PolygonPatch(wall.vertices[:4, :2] * 1000, closed=True, color="#969696", label="frame wall"))
    placed = {p.index: p for p in tiling.placements}
    cmap = plt.get_cmap("viridis")
    n = len(layout.pieces)
    for i, piece in enumerate(layout.pieces):
        pts = layout.footprint(i) * 1000
        centre = pts.mean(axis=0)
        if i in placed:
            p = placed[i]
            ax.add_patch(PolygonPatch(pts, closed=True, facecolor=cmap(0.15 + 0.7 * (p.order - 1) / max(n - 1, 1)),
                                      edgecolor="k", alpha=0.55, label="piece placed (number and shade: order)"))
            frame = p.scene.plane.frame
            g, b = frame[:2, 3] * 1000, (frame[:2, 3] + frame[:2, 0] * p.scene.object_length) * 1000
            ax.annotate("", xy=b, xytext=g, arrowprops={"arrowstyle": "->", "color": "#d7301f", "lw": 1.6})
            ax.plot(*g, "o", color="#08519c", ms=6, label="G (on the table)")
            ax.plot(*b, "s", color="#d7301f", ms=6, label="B (thumb)")
            half = p.scene.digits.width * p.scene.object_length / 2 * 1000
            side = frame[:2, 1] * half
            ax.plot(*np.array([b - side, b + side]).T, color="#d7301f", lw=3, alpha=0.6, label="the thumb's width at B")
            ax.text(*centre, f"{p.order}\n{piece.name}", ha="center", va="center", fontsize=7)
        else:
            failed = piece.name == tiling.failed_piece
            ax.add_patch(PolygonPatch(pts, closed=True, fill=False, edgecolor="#d7301f" if failed else "k",
                                      hatch="///" if failed else None, lw=1.5 if failed else 0.8,
                                      label="piece that cannot be placed" if failed else "piece not placed"))
            ax.text(*centre, f"{piece.name}\n{'cannot be placed' if failed else 'not placed'}", ha="center",
                    va="center", fontsize=7, color="#d7301f" if failed else "k")
    marks = legend_marks(ax)
    if placed:
        marks["ungrasp direction G -> B (arrow)"] = plt.Line2D([], [], color="#d7301f", lw=1.6)
    fig.legend(marks.values(), marks.keys(), loc="outside lower center", ncol=3, fontsize=8)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xlabel("world x (mm)")
    ax.set_ylabel("world y (mm)")
    status = "all pieces placed" if tiling.solved else f"{tiling.failed_piece} cannot be placed"
    fig.suptitle(f"{layout.name}: top view, {len(tiling.placements)} of {n} pieces ({status})")
    return fig
