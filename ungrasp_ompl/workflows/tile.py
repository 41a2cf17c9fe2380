"""The ``tile`` command's workflow: put every piece of a layout down, and export the one trajectory.

:func:`tile_layout` tiles the layout (tiling.tile: an order, an approach and a plan per piece)
and executes the solved tiling on the arm; the :class:`TiledLayout` it returns has ``summary()``
``write(dir)`` (tiling.json, layout.png, a C-space picture per piece) and, when solved,
``export(dir)`` (the exported trajectory and the view's record).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..io import write_text_atomic
from ..layout.model import Layout
from ..layout.tiler import Tiling, TilingOptions, TilingProgress
from ..planning.setup import LATTICE
from ..plots.cspace import draw_plan
from ..plots.layout import draw_layout
from ..robot.export import export_all
from ..robot.pipeline import Execution
from ..robot.touch_off import TouchOff, touch_off
from ..sim.tiling import describe_short, tile_aimed
from ..view.record import write_view_record


@dataclass
class TiledLayout:
    """A layout's tiling and, when solved, the arm's trajectory putting every piece down."""

    layout: Layout
    """The layout tiled."""
    tiling: Tiling
    """The order, approaches and plans (unsolved: no trajectory)."""
    execution: Execution | None = None
    """The one trajectory of every piece in order, each aimed by its landing where its scene says
    so (robot.landing; None: the tiling is not solved)."""
    short: tuple[tuple[str, float, float], ...] = ()
    """Pieces aimed short of their landing (sim.tiling.AimedTiling.short)."""

    def summary(self) -> str:
        """The layout's spread when it has one, the tiling's summary, then the trajectory's when there is one."""
        return "\n".join(layout_summary(self.layout, self.tiling, self.execution, self.short))

    def write(self, out: str | os.PathLike[str]) -> tuple[Path, Path, list[Path]]:
        """Write tiling.json, layout.png and cspace_K_NAME.png per piece into out, each atomically;
        returns their paths (the pictures in the order of the pieces)."""
        out = Path(out)
        doc, picture = out / "tiling.json", out / "layout.png"
        spread = self.layout.spread
        written = self.tiling.to_dict() if spread is None else {**self.tiling.to_dict(), "spread": {
            "gap_before_m": spread.gap_before, "gap_m": spread.gap,
            "shifts_m": {p.name: s.tolist() for p, s in zip(self.layout.pieces, spread.shifts)}}}
        write_text_atomic(doc, json.dumps(written, indent=1) + "\n")
        draw_layout(self.layout, self.tiling, picture)
        cspaces = []
        for p in self.tiling.placements:
            cspaces.append(out / f"cspace_{p.order}_{p.name}.png")
            draw_plan(p.scene, p.plan, cspaces[-1])
        return doc, picture, cspaces

    def export(self, out: str | os.PathLike[str]) -> dict[str, Path]:
        """Write the exported trajectory (every format robot.export writes) and view_scene.json
        into out, atomically; returns their paths by kind."""
        if self.execution is None:
            raise ValueError("the layout has no tiling to export")
        pieces = self.tiling.placements
        files = export_all(self.execution.trajectory, out, first_touch_off(self.tiling, self.execution))
        files["view"] = write_view_record(out, [(p.scene, p.plan) for p in pieces], self.execution,
                                          labels=[p.name for p in pieces], kind="tiling")
        return files


def layout_summary(layout: Layout, tiling: Tiling, execution: Execution | None,
                   short: tuple[tuple[str, float, float], ...]) -> list[str]:
    """The lines `tile` and `simulate LAYOUT` begin with: the layout's spread when its file asks for
    one, the tiling's summary, the trajectory's when there is one, and the pieces aimed short of
    their landing."""
    spread = [] if layout.spread is None else [
        f"targets spread: the narrowest gap {layout.spread.gap_before * 1000:.1f} mm -> {layout.spread.gap * 1000:.1f} mm "
        f"(pieces moved up to {abs(layout.spread.shifts).max() * 1000:.1f} mm)"]
    return spread + [tiling.summary()] + ([] if execution is None else [execution.summary()]) + describe_short(short)


def first_touch_off(tiling: Tiling, execution: Execution) -> TouchOff | None:
    """The touch-off before a layout's first piece (robot.touch_off; None when its robot makes none):
    the table is found once, under the first start pinch."""
    first = tiling.placements[0]
    return touch_off(first.scene, first.plan, execution.trajectory, prefix=f"{first.name}/")


def check_tiling_options(options: TilingOptions) -> TilingOptions:
    """The options, their planner's checked as plan checks them; InputError naming the field otherwise."""
    if options.planner.planner != LATTICE:
        options.planner.validated()
    return options


def tile_layout(layout: Layout, options: TilingOptions,
                progress: Callable[[TilingProgress], None] | None = None) -> TiledLayout:
    """Tile the layout with options (InputError naming the field for a bad planner option) and
    execute the solved tiling on the arm, every piece in order, each aimed by its landing where its
    scene says so (sim.tiling.tile_aimed)."""
    check_tiling_options(options)
    tiling, aimed = tile_aimed(layout, options, progress)
    if aimed is None:
        return TiledLayout(layout, tiling)
    return TiledLayout(layout, tiling, aimed.execution, aimed.short)
