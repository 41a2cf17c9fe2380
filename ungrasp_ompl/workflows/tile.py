"""The ``tile`` command's workflow: put every piece of a layout down, and export the one trajectory.

:func:`tile_layout` tiles the layout (tiling.tile: an order, an approach and a plan per piece)
and executes the solved tiling on the arm; the :class:`TiledLayout` it returns has ``summary()``
``write(dir)`` (tiling.json, layout.png, a C-space picture per piece) and, when solved,
``export(dir)`` (the exported trajectory and the view's record). The pictures of a solved tiling
are drawn in a forked copy of this process while this one aims and executes it
(:class:`PictureDrawing`); ``write`` takes those drawn by then and draws the others itself. The
exported files are written likewise from the moment the trajectory is known (:class:`ExportAhead`),
and ``export`` moves them into place. Either makes the files this process would.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import weakref
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

from ..io import write_atomic, write_text_atomic
from ..layout.model import Layout
from ..layout.tiler import Tiling, TilingOptions, TilingProgress
from ..parallel.forked import Forked, can_fork
from ..planning.setup import LATTICE
from ..plots.cspace import draw_plan
from ..plots.layout import draw_layout
from ..robot.export import export_all
from ..robot.pipeline import Execution
from ..robot.touch_off import TouchOff, touch_off
from ..sim.tiling import ShortAim, describe_short, tile_aimed
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
    short: tuple[ShortAim, ...] = ()
    """Pieces aimed short of their landing (sim.tiling.AimedTiling.short)."""
    drawing: "PictureDrawing | None" = field(default=None, repr=False, compare=False)
    """The tiling's pictures being drawn in a forked process (tile_layout starts it when the tiling
    is found), which write takes; None: write draws them (sharing the work with a forked process)."""
    exporting: "ExportAhead | None" = field(default=None, repr=False, compare=False)
    """The execution's exported files being written in a forked process (tile_layout starts it
    once the trajectory is known), which export takes; None: export writes them."""

    def summary(self) -> str:
        """The layout's spread when it has one, the tiling's summary, then the trajectory's when there is one."""
        return "\n".join(layout_summary(self.layout, self.tiling, self.execution, self.short))

    def write(self, out: str | os.PathLike[str]) -> tuple[Path, Path, list[Path]]:
        """Write tiling.json, layout.png and cspace_K_NAME.png per piece into out, each atomically;
        returns their paths (the pictures in the order of the pieces)."""
        out = Path(out)
        doc = out / "tiling.json"
        spread = self.layout.spread
        written = {**self.tiling.to_dict(), "placed_clearance_m": self.layout.placed_clearance}
        if spread is not None:
            written["spread"] = {"gap_before_m": spread.gap_before, "gap_m": spread.gap,
                                 "shifts_m": {p.name: s.tolist() for p, s in zip(self.layout.pieces, spread.shifts)}}
        write_text_atomic(doc, json.dumps(written, indent=1) + "\n")
        drawing, self.drawing = self.drawing, None  # taken: a second write draws them again
        if drawing is None or drawing.tiling is not self.tiling:
            if drawing is not None:
                drawing.close()
            drawing = PictureDrawing(self.layout, self.tiling)
        paths = drawing.write(out)
        return doc, paths[0], paths[1:]

    def export(self, out: str | os.PathLike[str]) -> dict[str, Path]:
        """Write the exported trajectory (every format robot.export writes) and view_scene.json
        into out, atomically; returns their paths by kind."""
        if self.execution is None:
            raise ValueError("the layout has no tiling to export")
        ahead, self.exporting = self.exporting, None  # taken: a second export writes them again
        if ahead is not None and ahead.execution is not self.execution:
            ahead.close()
        elif ahead is not None and (files := ahead.moved(out)) is not None:
            return files
        return export_files(self.tiling, self.execution, out)


def export_files(tiling: Tiling, execution: Execution, out: str | os.PathLike[str]) -> dict[str, Path]:
    """TiledLayout.export's files, written here: the exported trajectory (robot.export, with the
    first piece's touch-off) and view_scene.json; their paths by kind."""
    pieces = tiling.placements
    files = export_all(execution.trajectory, out, first_touch_off(tiling, execution))
    files["view"] = write_view_record(out, [(p.scene, p.plan) for p in pieces], execution,
                                      labels=[p.name for p in pieces], kind="tiling")
    return files


class _Ahead:
    """Work of this process done ahead by a forked copy of it (where the platform forks:
    parallel.forked) into a directory of its own, spare; close() stops the child and removes the
    directory (also when this is dropped)."""

    def __init__(self, prefix: str, key: str, fn: Callable, *args, stream: bool = False):
        self._spare = Path(tempfile.mkdtemp(prefix=prefix))
        self._pool = Forked(1) if can_fork() else None
        if self._pool is not None:
            self._pool.submit(key, fn, *args, self._spare, stream=stream)
        self._closed = weakref.finalize(self, _discard, self._pool, self._spare)

    def close(self) -> None:
        """Stop the child and remove its directory."""
        self._closed()


class ExportAhead(_Ahead):
    """TiledLayout.export's files (export_files) written ahead by a forked copy of this process
    (_Ahead) from the moment this is made; moved() moves them into place. They are the files
    export_files writes here."""

    def __init__(self, tiling: Tiling, execution: Execution):
        self.execution = execution
        """The execution exported."""
        super().__init__("ungrasp_ompl_export_", "export", export_files, tiling, execution)

    def moved(self, out: str | os.PathLike[str]) -> dict[str, Path] | None:
        """Wait for the files and move each into out (atomically); their paths by kind, or None
        when the forked process wrote none (export_files then writes them)."""
        try:
            ok, files = (False, None) if self._pool is None else self._pool.result("export")
            if not ok:
                return None
            out = Path(out)
            out.mkdir(parents=True, exist_ok=True)
            moved = {kind: out / Path(spare).name for kind, spare in files.items()}
            for kind, spare in files.items():
                _move(Path(spare), moved[kind])
            return moved
        finally:
            self.close()


def _move(source: Path, target: Path) -> None:
    """Move a file into place atomically: renamed within a file system, else copied beside target first."""
    try:
        os.replace(source, target)
    except OSError:
        write_atomic(target, partial(shutil.copyfile, source))


def pictures(layout: Layout, tiling: Tiling) -> list[tuple[str, Callable[[Path], None]]]:
    """The pictures TiledLayout.write writes, in order: (file name, a function drawing it to a
    path): layout.png, then cspace_K_NAME.png per piece in order."""
    out: list[tuple[str, Callable[[Path], None]]] = [("layout.png", partial(draw_layout, layout, tiling))]
    out += [(f"cspace_{p.order}_{p.name}.png", partial(draw_plan, p.scene, p.plan)) for p in tiling.placements]
    return out


class PictureDrawing(_Ahead):
    """A tiling's pictures (pictures()), drawn one after the other, in order, ahead by a forked copy
    of this process (_Ahead) from the moment this is made; write() moves those drawn into place and
    draws the others itself, from the last, so that the two processes share what is left. The
    pictures are the same files whichever process draws them."""

    def __init__(self, layout: Layout, tiling: Tiling):
        self.tiling = tiling
        """The tiling drawn."""
        self.pictures = pictures(layout, tiling)
        super().__init__("ungrasp_ompl_pictures_", "pictures", _draw_each, self.pictures, stream=True)

    def write(self, out: str | os.PathLike[str]) -> list[Path]:
        """Write every picture into out (each atomically); returns their paths, in order."""
        out = Path(out)
        paths = [out / name for name, _ in self.pictures]
        todo = list(range(len(paths)))  # a range: the child draws from its first, this process from its last
        pool, seen = self._pool, 0
        try:
            while todo:
                if pool is not None:
                    pool.poll()
                    drawn = pool.items("pictures")
                    for k in drawn[seen:]:
                        if k in todo:
                            todo.remove(k)
                            _move(self._spare / self.pictures[k][0], paths[k])
                    seen = len(drawn)
                    if len(todo) == 1 and not pool.finished("pictures"):
                        pool.poll(None)  # the one left is the child's: wait for it
                        continue
                if todo:
                    k = todo.pop()
                    self.pictures[k][1](paths[k])
        finally:
            self.close()
        return paths


def _draw_each(drawn: list[tuple[str, Callable[[Path], None]]], into: Path) -> Iterator[int]:
    """In the forked child: draw each picture into the directory into, in order, yielding its index."""
    for k, (name, draw) in enumerate(drawn):
        draw(into / name)
        yield k


def _discard(pool: Forked | None, spare: Path) -> None:
    """_Ahead's end: its child killed, its directory removed."""
    if pool is not None:
        pool.close()
    shutil.rmtree(spare, ignore_errors=True)


def layout_summary(layout: Layout, tiling: Tiling, execution: Execution | None,
                   short: tuple[ShortAim, ...]) -> list[str]:
    """The lines `tile` and `simulate LAYOUT` begin with: the layout's spread when its file asks for
    one, the clearance its plans keep from the pieces down when it has one, the tiling's summary,
    the trajectory's when there is one, and the pieces aimed short of their landing."""
    lines = [] if layout.spread is None else [
        f"targets spread: the narrowest gap {layout.spread.gap_before * 1000:.1f} mm -> {layout.spread.gap * 1000:.1f} mm "
        f"(pieces moved up to {abs(layout.spread.shifts).max() * 1000:.1f} mm)"]
    if layout.placed_clearance > 0:
        lines.append(f"plans keep {layout.placed_clearance * 1000:.1f} mm from the pieces down (placed_clearance)")
    return lines + [tiling.summary()] + ([] if execution is None else [execution.summary()]) + describe_short(short)


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
    drawings: list[PictureDrawing] = []  # each solved tiling's pictures, drawn while it is aimed
    tiling, aimed = tile_aimed(layout, options, progress, solved=lambda t: drawings.append(PictureDrawing(layout, t)))
    drawing = next((d for d in drawings if d.tiling is tiling), None)
    for d in drawings:
        if d is not drawing:
            d.close()
    if aimed is None:
        return TiledLayout(layout, tiling, drawing=drawing)
    return TiledLayout(layout, tiling, aimed.execution, aimed.short, drawing,
                       ExportAhead(tiling, aimed.execution))
