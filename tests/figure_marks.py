"""What a matplotlib figure explains: its legends' texts, and the marks drawn that neither a
legend nor a colour bar names (read from the Figure a drawing function builds, no pixels)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure


def legend_texts(fig: Figure) -> list[str]:
    """The texts of every legend of the figure (the figure's own and each axes')."""
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    return [t.get_text() for legend in legends for t in legend.get_texts()]


def unexplained_marks(fig: Figure) -> list[str]:
    """The marks drawn in the figure's axes (lines, markers, scatters, patches, images, meshes)
    that neither have a label in one of its legends nor are shown on a colour bar, nor are an
    image of a few listed colours each of which a legend's patch shows (a map of classes); the
    colour bars' own axes are not marks. Empty: every mark is explained."""
    texts = set(legend_texts(fig))
    drawn = [(k, ax, artist) for k, ax in enumerate(fig.axes)
             for artist in [*ax.lines, *ax.collections, *ax.patches, *ax.images]]
    bars = [a.colorbar for _, _, a in drawn if getattr(a, "colorbar", None) is not None]
    marks = [(k, ax, a) for k, ax, a in drawn if not any(ax is bar.ax for bar in bars)]
    # a colour bar shows its mappable's colours, and those of any other drawn with the same map and limits
    scales = {_scale(bar.mappable) for bar in bars}
    keyed = _legend_colours(fig)
    missing = []
    for k, ax, artist in marks:
        if _scale(artist) not in scales and artist.get_label() not in texts and not _listed_in(artist, keyed):
            missing.append(f"axes {k} ({ax.get_title() or ax.get_xlabel()}): {type(artist).__name__} "
                           f"{artist.get_label()!r}")
    return missing


def _legend_colours(fig: Figure) -> list[tuple]:
    """The face colours (RGBA) of the legends' patches."""
    from matplotlib.patches import Patch

    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    return [tuple(h.get_facecolor()) for legend in legends for h in legend.legend_handles if isinstance(h, Patch)]


def _listed_in(artist, colours: list[tuple]) -> bool:
    """A mappable of a listed colour map whose every colour is one of colours."""
    from matplotlib.colors import ListedColormap, to_rgba

    cmap = getattr(artist, "get_cmap", lambda: None)()
    if not isinstance(cmap, ListedColormap):
        return False
    return all(any(np.allclose(to_rgba(c), k) for k in colours) for c in cmap.colors)


def _scale(artist) -> tuple | None:
    """The colour map's name and limits of a mappable (image, mesh, coloured scatter); None else."""
    if not hasattr(artist, "get_clim") or artist.get_array() is None:
        return None
    return artist.get_cmap().name, *artist.get_clim()


def axis_names(fig: Figure) -> list[str]:
    """Every axis name of the figure's axes (x, y, and z of a 3D axes), colour bars' included."""
    names = []
    for ax in fig.axes:
        names += [ax.get_xlabel(), ax.get_ylabel()] + ([ax.get_zlabel()] if hasattr(ax, "get_zlabel") else [])
    return [n for n in names if n]


def all_texts(fig: Figure) -> list[str]:
    """Every text the figure shows: titles, axis names, tick labels, legends, annotations."""
    from matplotlib.text import Text

    return [t.get_text() for t in fig.findobj(Text) if t.get_visible() and t.get_text()]


def drawn_extents(fig: Figure, artists) -> list:
    """The artists' boxes in display pixels, laid out as the figure is drawn."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    return [a.get_window_extent(renderer) for a in artists]


def overlap(a, b) -> bool:
    """Two display boxes share more than a pixel's edge."""
    return min(a.x1, b.x1) - max(a.x0, b.x0) > 1 and min(a.y1, b.y1) - max(a.y0, b.y0) > 1
