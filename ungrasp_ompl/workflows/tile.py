"""The ``tile`` command's workflow: put every piece of a layout down, and export the one trajectory.

:func:`tile_layout` tiles the layout (tiling.tile: an order, an approach and a plan per piece)
and executes the solved tiling on the arm; the :class:`TiledLayout` it returns has ``summary()``
and ``write(dir)`` (tiling.json, layout.png, a C-space picture per piece, and the exported
trajectory with the view's record when solved).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ..io import write_text_atomic
from ..layout import Layout
from ..planning.setup import PlannerOptions
from ..plotting import draw_layout, draw_plan
from ..robot.export import export_all
from ..robot.pipeline import Execution, execute_sequence
from ..tiling import Tiling, TilingOptions, TilingProgress, tile
from ..view.record import write_view_record


@dataclass
class TiledLayout:
    """A layout's tiling and, when solved, the arm's trajectory putting every piece down."""

    layout: Layout
    """The layout tiled."""
    tiling: Tiling
    """The order, approaches and plans (unsolved: no trajectory)."""
    execution: Execution | None = None
    """The one trajectory of every piece in order (None: the tiling is not solved)."""

    def summary(self) -> str:
        """The tiling's summary, then the trajectory's when there is one."""
        return self.tiling.summary() + ("" if self.execution is None else "\n" + self.execution.summary())

    def write(self, out: str | os.PathLike[str]) -> dict[str, Path]:
        """Write tiling.json, layout.png and cspace_K_NAME.png per piece, and when solved the
        exported trajectory and view_scene.json, into out, each atomically; returns the paths."""
        out = Path(out)
        files = {"tiling": out / "tiling.json", "layout": out / "layout.png"}
        write_text_atomic(files["tiling"], json.dumps(self.tiling.to_dict(), indent=1) + "\n")
        draw_layout(self.layout, self.tiling, files["layout"])
        for p in self.tiling.placements:
            files[f"cspace {p.name}"] = out / f"cspace_{p.order}_{p.name}.png"
            draw_plan(p.scene, p.plan, files[f"cspace {p.name}"])
        if self.execution is not None:
            files.update(export_all(self.execution.trajectory, out))
            pieces = self.tiling.placements
            files["view"] = write_view_record(out, [(p.scene, p.plan) for p in pieces], self.execution,
                                              labels=[p.name for p in pieces], kind="tiling")
        return files


def check_tiling_options(options: TilingOptions) -> TilingOptions:
    """The options, their planner's checked as plan checks them; InputError naming the field otherwise."""
    if options.planner != "lattice":
        PlannerOptions(planner=options.planner, time=options.time, seed=options.seed, range=options.range).validated()
    return options


def tile_layout(layout: Layout, options: TilingOptions,
                progress: Callable[[TilingProgress], None] | None = None) -> TiledLayout:
    """Tile the layout with options (InputError naming the field for a bad planner option) and
    execute the solved tiling on the arm, every piece in order."""
    check_tiling_options(options)
    tiling = tile(layout, options, progress)
    if not tiling.solved:
        return TiledLayout(layout, tiling)
    execution = execute_sequence([(p.scene, p.plan) for p in tiling.placements],
                                 labels=[p.name for p in tiling.placements])
    return TiledLayout(layout, tiling, execution)


__all__ = ["TiledLayout", "check_tiling_options", "tile_layout"]
