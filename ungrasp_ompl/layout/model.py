"""Layouts: thin pieces put down one after another into a frame on the table (YAML files).

A layout file holds:

* ``frame``: ``center`` (world x, y of the frame's inner centre, m), ``yaw_deg``,
  ``inner_size`` ([width, depth] or one number for a square, m), ``wall_height`` and
  ``wall_thickness`` (m). The frame's own coordinates have their origin at the inner
  corner, x along the inner width and y along the inner depth.
* ``pieces``: a list of ``name``, ``thickness`` (m), ``outline`` (as a scene's
  ``object.outline``, in the piece's own coordinates), ``target``
  (``position`` [x, y] of the outline's origin in frame coordinates, m; ``yaw_deg``) and, for a
  curved piece, ``section`` (as a scene's ``object.section``; its outline a circle); optional
  ``landing_offset`` (m along GB, + toward B): the piece's ``robot.landing_offset``, where the
  shared ``robot`` section gives the default (pieces differ in how they land beyond the model of
  the fall as objects do; docs/model.md 11.17).
* the sections every piece's scene shares: ``friction`` (or ``friction_angle_deg``),
  ``digits``, ``start``, ``goal``, ``bounds``, ``planning``, ``stability``, ``robot``, ``sim``
  (see ungrasp_ompl.scene). Without a ``goal`` a piece's goal is theta at most 3 deg
  with d and psi free; without ``planning.resolution`` the lattice step is
  1 deg / 0.01 / 1 deg.

* ``spread`` (optional, default false): true moves the targets (not their headings) so that the
  smallest gap between two pieces, or a piece and a wall, is as large as the frame allows
  (ungrasp_ompl.geometry.spread); ``Layout.spread`` then holds the shifts and the gaps.
* ``placed_clearance`` (optional, m, default 0): how far every plan keeps its digits, housing and
  piece from a piece already down, beyond touching (its solid grown so: Solid.grown); the walls
  are not grown.

Pieces must lie inside the frame and not overlap (touching is fine); each is
treated by its convex hull in collision checks, a piece put down already by its outline's prism
up to its thickness (a curved piece's dome lies inside it: the check is conservative). Every bad field raises
:class:`~ungrasp_ompl.errors.InputError` naming it (``pieces[2].target.position``).
"""

from __future__ import annotations

import copy
import math
import os
from dataclasses import dataclass, field, replace
from typing import Any, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from ..geometry.solids import Solid, box, polygons_overlap, prism
from ..geometry.spread import Spread, spread
from ..scene import Scene
from ..scene.loader import MAX_LANDING_OFFSET, SceneReader, read_yaml
from ..scene.options import Object3D
from ..shipped import resolve, shipped_names

#: Scene sections a layout shares among its pieces.
SHARED_SECTIONS = ("friction", "friction_angle_deg", "digits", "start", "goal", "bounds", "planning",
                   "stability", "robot", "sim")
#: A piece's goal when the layout gives none: put down (theta <= 3 deg), the grasp free.
DEFAULT_GOAL = {"theta_max_deg": 3.0, "d": [0.0, 1.0], "psi_deg": [0.0, 120.0]}
DEFAULT_RESOLUTION = {"theta_deg": 1.0, "d": 0.01, "psi_deg": 1.0}


@dataclass(frozen=True)
class Frame:
    """The frame on the table: inner centre (world, m), yaw (rad), inner size (m), walls (m)."""

    center: tuple[float, float]
    yaw: float
    inner: tuple[float, float]
    wall_height: float
    wall_thickness: float

    def to_world(self, xy: ArrayLike) -> NDArray[np.float64]:
        """Frame coordinates (origin at the inner corner) (N, 2) -> world (x, y) (N, 2), metres."""
        p = np.atleast_2d(np.asarray(xy, dtype=float)) - np.asarray(self.inner) / 2
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return p @ np.array([[c, s], [-s, c]]) + np.asarray(self.center)

    def walls(self) -> list[Solid]:
        """The four walls as boxes standing on the table (world frame)."""
        w, d = self.inner
        t, h = self.wall_thickness, self.wall_height
        # centre (frame coordinates) and size along the frame's x and y of each wall
        specs = {"wall_south": ((w / 2, -t / 2), (w + 2 * t, t)), "wall_north": ((w / 2, d + t / 2), (w + 2 * t, t)),
                 "wall_west": ((-t / 2, d / 2), (t, d)), "wall_east": ((w + t / 2, d / 2), (t, d))}
        out = []
        for name, (c, size) in specs.items():
            cw = self.to_world(c)[0]
            out.append(box(name, (cw[0], cw[1], h / 2), (size[0], size[1], h), self.yaw))
        return out

    def inner_corners(self) -> NDArray[np.float64]:
        w, d = self.inner
        return self.to_world([[0, 0], [w, 0], [w, d], [0, d]])


@dataclass(frozen=True)
class Piece:
    """One piece: its outline (own coordinates, m), thickness (m) and target pose in frame coordinates."""

    name: str
    object3d: Object3D  # position and yaw here are in the frame's coordinates
    outline_spec: dict  # the outline as the file gives it, for the piece's scene
    section_spec: Any = None  # the section as the file gives it (None: a slab), for the piece's scene
    landing_offset: float | None = None  # its robot.landing_offset, m (None: the shared robot section's)


@dataclass
class Layout:
    """A frame and the pieces to put into it, with the scene sections they share."""

    name: str
    frame: Frame
    pieces: list[Piece]
    shared: dict[str, Any]
    source: str | None = None
    spread: Spread | None = None  # the shifts the file's spread: true moved the targets by (None: as given)
    #: How far every plan keeps the digits, the housing and its piece from a piece already down, m
    #: (Solid.grown): a piece down lies where its ungrasp put it, not at its target.
    placed_clearance: float = 0.0
    #: scene(i, contacts) with the walls as its only solids, by (i, contacts as floats or None)
    _parsed: dict[tuple, Scene] = field(default_factory=dict, repr=False)
    _walls: tuple[Solid, ...] = field(default=(), repr=False)  # the frame's walls, once asked for
    _solids: dict[int, Solid] = field(default_factory=dict, repr=False)  # solid(j), by j

    # -- loading -------------------------------------------------------------------
    @classmethod
    def from_file(cls, path: str | os.PathLike[str]) -> "Layout":
        """Load and validate a layout file, or the shipped layout of that name ("tangram"); raises
        InputError naming the bad field."""
        path = resolve(path, "layout")
        data = read_yaml(path, "layout")
        return cls.from_dict(data, source=shipped_names(str(path)), default_name=path.stem)

    @classmethod
    def from_dict(cls, data: Any, source: str | None = None, default_name: str = "layout") -> "Layout":
        r = SceneReader(source)
        top = r.mapping(data, "layout")
        r.known(top, "", {"name", "description", "frame", "pieces", "spread", "placed_clearance", *SHARED_SECTIONS})
        fr = r.mapping(r.require(top, "frame"), "frame")
        r.known(fr, "frame", {"center", "yaw_deg", "inner_size", "wall_height", "wall_thickness"})
        if "inner_size" not in fr:
            raise InputError("frame.inner_size", "is missing", source)
        inner = r.pair(fr, "frame.inner_size", "inner_size") if isinstance(fr["inner_size"], list) else \
            (r.length(fr, "frame.inner_size", "inner_size"),) * 2
        if min(inner) <= 0:
            raise InputError("frame.inner_size", f"must be positive, got {list(inner)}", source)
        frame = Frame(center=r.pair(fr, "frame.center", "center"),
                      yaw=math.radians(r.angle(fr, "frame.yaw_deg", "yaw_deg", -360.0, 360.0, default=0.0)),
                      inner=inner, wall_height=r.length(fr, "frame.wall_height", "wall_height"),
                      wall_thickness=r.length(fr, "frame.wall_thickness", "wall_thickness"))

        items = r.require(top, "pieces")
        if not isinstance(items, list) or not items:
            raise InputError("pieces", "must be a non-empty list of pieces", source)
        pieces, names = [], set()
        for i, item in enumerate(items):
            key = f"pieces[{i}]"
            p = r.mapping(item, key)
            r.known(p, key, {"name", "thickness", "outline", "target", "section", "landing_offset"})
            name = r.name(p, f"{key}.name", f"piece{i + 1}")
            if name in names:
                raise InputError(f"{key}.name", f"{name!r} is used twice", source)
            names.add(name)
            thickness = r.length(p, f"{key}.thickness", "thickness")
            if "outline" not in p:
                raise InputError(f"{key}.outline", "is missing", source)
            obj = r.object3d(p["outline"], p.get("target", {}), thickness, prefix=key)
            offset = r.number(p, f"{key}.landing_offset", "landing_offset", minimum=-MAX_LANDING_OFFSET,
                              maximum=MAX_LANDING_OFFSET, unit=" m") if "landing_offset" in p else None
            pieces.append(Piece(name, obj, copy.deepcopy(p["outline"]), copy.deepcopy(p.get("section")), offset))

        shared = {k: copy.deepcopy(top[k]) for k in SHARED_SECTIONS if k in top}
        shared.setdefault("goal", dict(DEFAULT_GOAL))
        planning = shared.setdefault("planning", {})
        if isinstance(planning, dict):
            planning.setdefault("resolution", dict(DEFAULT_RESOLUTION))
        layout = cls(r.name(top, "name", default_name), frame, pieces, shared, source,
                     placed_clearance=r.length(top, "placed_clearance", "placed_clearance", zero=True, default=0.0))
        layout._check_placement()
        if r.flag(top, "spread", "spread"):
            layout = layout._spread_out()
        for i in range(len(pieces)):  # each piece's scene: shared sections and the piece itself
            layout.scene(i)
        return layout

    def _spread_out(self) -> "Layout":
        """This layout with its targets spread (geometry.spread), recorded in .spread."""
        moved = spread([self.footprint(i, world=False) for i in range(len(self.pieces))], self.frame.inner)
        pieces = [replace(p, object3d=replace(p.object3d, position=tuple(float(x) for x in p.object3d.position + s)))
                  for p, s in zip(self.pieces, moved.shifts)]
        return replace(self, pieces=pieces, spread=moved)

    def _check_placement(self) -> None:
        inner = self.frame.inner
        tol = 1e-6
        local = [self.footprint(i, world=False) for i in range(len(self.pieces))]
        for i, pts in enumerate(local):
            out = (pts < -tol) | (pts > np.asarray(inner) + tol)
            if out.any():
                k = int(np.flatnonzero(out.any(axis=1))[0])
                raise InputError(f"pieces[{i}].target", f"puts {self.pieces[i].name!r} outside the frame: vertex at "
                                 f"({pts[k, 0] * 1000:.1f}, {pts[k, 1] * 1000:.1f}) mm of the inner "
                                 f"{inner[0] * 1000:.1f} x {inner[1] * 1000:.1f} mm", self.source)
            for j in range(i):
                if polygons_overlap(pts, local[j]):
                    raise InputError(f"pieces[{i}].target", f"{self.pieces[i].name!r} overlaps "
                                     f"{self.pieces[j].name!r} (pieces[{j}])", self.source)

    # -- geometry ------------------------------------------------------------------
    def footprint(self, i: int, world: bool = True) -> NDArray[np.float64]:
        """Outline of piece i at its target (N, 2): world (x, y) or frame coordinates, metres."""
        local = self.pieces[i].object3d.placed_outline()  # object3d's pose is in frame coordinates
        return self.frame.to_world(local) if world else local

    def solid(self, i: int) -> Solid:
        """Piece i lying at its target, as a solid (world frame), grown by placed_clearance."""
        return prism(self.pieces[i].name, self.footprint(i), 0.0,
                     self.pieces[i].object3d.thickness).grown(self.placed_clearance)

    def world_pose(self, i: int) -> tuple[tuple[float, float], float]:
        """World position (x, y) of piece i's outline origin and its world yaw (rad)."""
        obj = self.pieces[i].object3d
        p = self.frame.to_world(obj.position)[0]
        return (float(p[0]), float(p[1])), self.frame.yaw + obj.yaw

    def scene(self, i: int, contacts: tuple[ArrayLike, ArrayLike] | None = None,
              placed: Sequence[int] = ()) -> Scene:
        """The planning scene of piece i: the shared sections, the piece at its world target, G and B
        (own coordinates; None chooses them as for a single object), and as solids the frame's
        walls and the pieces placed already.

        The file's sections are read once per piece and contacts: each call returns a new Scene
        whose other fields it shares with the scenes of that piece and contacts (read them, do not
        change them in place)."""
        pair = None if contacts is None else tuple(tuple(float(x) for x in c) for c in contacts)
        key = (i, pair)
        if key not in self._parsed:
            if not self._walls:
                self._walls = tuple(self.frame.walls())
            self._parsed[key] = replace(self._read_scene(i, pair), solids=self._walls)
        for j in placed:
            if j not in self._solids:
                self._solids[j] = self.solid(j)
        scene = self._parsed[key]
        return replace(scene, solids=scene.solids + tuple(self._solids[j] for j in placed))

    def _read_scene(self, i: int, contacts: tuple[tuple[float, ...], tuple[float, ...]] | None) -> Scene:
        """Piece i's scene from the file's sections, without solids; InputError names the piece."""
        piece = self.pieces[i]
        position, yaw = self.world_pose(i)
        data = copy.deepcopy(self.shared)
        data["name"] = piece.name
        data["object"] = {"thickness": piece.object3d.thickness, "outline": copy.deepcopy(piece.outline_spec),
                          "target": {"position": list(position), "yaw_deg": math.degrees(yaw)}}
        if piece.section_spec is not None:
            data["object"]["section"] = copy.deepcopy(piece.section_spec)
        if contacts is not None:
            data["contacts"] = {"G": list(contacts[0]), "B": list(contacts[1])}
        robot = data.get("robot", {})
        if piece.landing_offset is not None and isinstance(robot, dict):  # else the scene names the bad robot
            data["robot"] = {**robot, "landing_offset": piece.landing_offset}
        try:
            return Scene.from_dict(data, source=self.source)
        except InputError as exc:
            if exc.field == "robot.landing_offset" and piece.landing_offset is not None:
                raise InputError(f"pieces[{i}].landing_offset", exc.reason, self.source) from None
            if exc.field.startswith("object") or exc.field in ("friction", "contacts"):
                raise InputError(f"pieces[{i}]", f"{piece.name!r}: {exc.field}: {exc.reason}", self.source) from None
            raise
