"""What a matplotlib figure explains: its legends' texts, and the marks drawn that neither a
legend nor a colour bar names (read from the Figure a drawing function builds, no pixels)."""

from __future__ import annotations

from matplotlib.figure import Figure


def legend_texts(fig: Figure) -> list[str]:
    """The texts of every legend of the figure (the figure's own and each axes')."""
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    return [t.get_text() for legend in legends for t in legend.get_texts()]


def unexplained_marks(fig: Figure) -> list[str]:
    """The marks drawn in the figure's axes (lines, markers, scatters, patches, images, meshes)
    that neither have a label in one of its legends nor are shown on a colour bar; the colour
    bars' own axes are not marks. Empty: every mark is explained."""
    texts = set(legend_texts(fig))
    drawn = [(k, ax, artist) for k, ax in enumerate(fig.axes)
             for artist in [*ax.lines, *ax.collections, *ax.patches, *ax.images]]
    bars = [a.colorbar for _, _, a in drawn if getattr(a, "colorbar", None) is not None]
    marks = [(k, ax, a) for k, ax, a in drawn if not any(ax is bar.ax for bar in bars)]
    # a colour bar shows its mappable's colours, and those of any other drawn with the same map and limits
    scales = {_scale(bar.mappable) for bar in bars}
    missing = []
    for k, ax, artist in marks:
        if _scale(artist) not in scales and artist.get_label() not in texts:
            missing.append(f"axes {k} ({ax.get_title() or ax.get_xlabel()}): {type(artist).__name__} "
                           f"{artist.get_label()!r}")
    return missing


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
