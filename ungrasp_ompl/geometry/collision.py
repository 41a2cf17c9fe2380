"""Collision of the finger, the thumb and the object with the table and obstacles (python-fcl).

World frame: the manipulation plane is the xz-plane (G at the origin, x along
the table, z up), y is normal to it; metres. The finger and the thumb are
trapezoidal prisms of the digits' width, and the gripper's housing (when the
scene gives its size) a box behind their bases; obstacles are boxes of the plane,
extruded through it; the table fills z < 0. The scene's solids (convex bodies
fixed in the world: a frame's walls, pieces placed already) are checked in 3D.
The object is checked against the obstacles and solids only (it touches the
table at G and the digits at A and B): as a slab of the digits' width along GB,
or, when the scene has its outline, as the whole outline's convex prism, tilted
by theta about the plane's normal through G. A pincer's digits (CollisionModel.pincer) are its
own: each runs from its tip to the joint's level, the finger along its link, and the housing sits
behind the joint (mechanics.pincer); a state the pincer cannot make (its finger out of reach, its joint
angle outside its range) counts as a collision ("pincer/joint range").

A numpy broad phase (bounding boxes in the plane, vectorised over states) sends only the
state/body pairs that may touch to the narrow phase. Where a target is, within the slab a
body sweeps normal to the plane, a rectangle of the plane (every obstacle box; a solid that is
an upright prism when the plane stands upright, as a frame's walls and the placed pieces are),
the narrow phase is exact in numpy: the body's outline and the rectangle are apart exactly
when an edge normal of one separates them (touching counts as a collision). Other solids go
to FCL's narrow phase (``exact_planar=False`` sends all of them there, the test's oracle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import fcl
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..mechanics.kinematics import (DigitGeometry, digit_offsets, finger_corner, housing_centre, housing_offsets,
                                   release_travel, thumb_tip)
from ..mechanics import pincer as pincer_kinematics
from ..mechanics.pincer import PincerSpec
from ..mechanics.section import Section
from .solids import Solid, convex_shape, prism_shape

_DEPTH = 10.0  # extent of the planar obstacles normal to the plane, m
_TABLE_GAP = 1e-9  # the table's top sits this far below z = 0, m, so resting contact is not a collision
#: How far the digits may press into the table while the gripper lets go (m): robot.collision.TABLE_GAP.
RELEASE_TABLE_GAP = 5e-4
#: Most lattice states a pincer's lattice check places at once (its digits turn with every
#: coordinate, so their outlines are computed per state: a slice of theta at a time).
PINCER_LATTICE_CHUNK = 250_000


def _prism(outline: NDArray, width: float) -> fcl.Convex:
    """A convex prism: a planar quadrilateral (x, z) extruded by width along y, centred."""
    lo = np.column_stack([outline[:, 0], np.full(4, -width / 2), outline[:, 1]])
    hi = lo.copy()
    hi[:, 1] = width / 2
    verts = np.vstack([lo, hi])
    faces = [[0, 1, 2, 3], [4, 7, 6, 5]] + [[i, (i + 1) % 4, 4 + (i + 1) % 4, 4 + i] for i in range(4)]
    flat = np.concatenate([[4, *f] for f in faces]).astype(np.int64)
    return fcl.Convex(verts, len(faces), flat)


class _PlanarPose:
    """Places an FCL object by a rotation by angle in the xz-plane (turning x toward z) and a shift
    to the plane point (x, z); skips the update when the pose is the one it has.

    Turning x toward z is a rotation by -angle about y: quaternion (w, x, y, z) =
    (cos(angle/2), 0, -sin(angle/2), 0). The arrays are reused (python-fcl copies them).
    """

    def __init__(self, obj: fcl.CollisionObject):
        self.obj = obj
        self.last: tuple[float, float, float] | None = None
        self._quat = np.array([1.0, 0.0, 0.0, 0.0])
        self._shift = np.zeros(3)

    def set(self, angle: float, x: float, z: float) -> fcl.CollisionObject:
        if self.last != (angle, x, z):
            half = 0.5 * angle
            self._quat[0], self._quat[2] = math.cos(half), -math.sin(half)
            self._shift[0], self._shift[2] = x, z
            self.obj.setQuatRotation(self._quat)
            self.obj.setTranslation(self._shift)
            self.last = (angle, x, z)
        return self.obj


def _separated(outline: NDArray, lo: NDArray, hi: NDArray) -> NDArray[np.bool_]:
    """True where an edge normal of the convex outline (N, 4, 2) separates it from the box [lo, hi].

    A vectorised pre-filter of the broad phase: it only clears pairs, FCL decides the rest.
    """
    corners = ((lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1]))
    gap = np.zeros(len(outline), dtype=bool)
    for k in range(4):
        edge = outline[:, (k + 1) % 4] - outline[:, k]
        ax, az = -edge[:, 1], edge[:, 0]
        poly = [ax * outline[:, v, 0] + az * outline[:, v, 1] for v in range(4)]
        box = [ax * cx + az * cz for cx, cz in corners]
        gap |= (_min(poly) > _max(box)) | (_min(box) > _max(poly))
    return gap


def _min(xs: list[NDArray]) -> NDArray:
    return np.minimum(np.minimum(xs[0], xs[1]), np.minimum(xs[2], xs[3]))


def _max(xs: list[NDArray]) -> NDArray:
    return np.maximum(np.maximum(xs[0], xs[1]), np.maximum(xs[2], xs[3]))


def _slab_rect(foot: NDArray, heights: tuple[float, float], y_lo: float, y_hi: float) -> NDArray | None:
    """An upright prism (its foot, a convex polygon (N, 2) of (x, y), from z = heights[0] to
    heights[1]) cut by the slab y_lo <= y <= y_hi: the rectangle ((x, z) low, high) it shows in
    the xz-plane, or None when the slab misses it. The x range comes from the foot's corners
    inside the slab and its edges' crossings of the two planes."""
    xs = list(foot[(foot[:, 1] >= y_lo) & (foot[:, 1] <= y_hi), 0])
    for (x0, y0), (x1, y1) in zip(foot, np.roll(foot, -1, axis=0)):
        for y in (y_lo, y_hi):
            if (y0 - y) * (y1 - y) < 0:  # the edge crosses the plane y
                xs.append(x0 + (x1 - x0) * (y - y0) / (y1 - y0))
    if not xs:
        return None
    return np.array([[min(xs), heights[0]], [max(xs), heights[1]]])


def _turned(points: NDArray, pivot: NDArray, angle: NDArray) -> NDArray:
    """Plane points (N, 2) or outlines (N, K, 2) turned by angle (N,) about pivot (N, 2), x toward z."""
    if points.ndim == 3:
        pivot, angle = pivot[:, None, :], angle[:, None]
    c, s = np.cos(angle), np.sin(angle)
    rel = points - pivot
    return pivot + np.stack([c * rel[..., 0] - s * rel[..., 1], s * rel[..., 0] + c * rel[..., 1]], axis=-1)


def object_solid(section: Section, length: float, width: float, turned: bool, samples: int = 48) -> NDArray[np.float64]:
    """The vertices (N, 3) of a curved section's solid in the object's frame (x along GB from G, y
    the plane's normal, z up from GB), m: the section (over l, scaled by length) turned about the
    vertical through its centre (turned: a round object, its outline a circle of diameter GB), or
    carried across the plane from -width/2 to width/2 (a planar scene: a slab of the digits' width).
    Its convex hull is the object (the section is convex)."""
    poly = section.polygon(samples) * length
    if not turned:
        return np.vstack([np.column_stack([poly[:, 0], np.full(len(poly), y), poly[:, 1]]) for y in (-width / 2, width / 2)])
    centre = length / 2
    out = []
    for a in np.linspace(0.0, np.pi, samples, endpoint=False):  # each half-plane's profile, both ways
        c, s_ = np.cos(a), np.sin(a)
        out.append(np.column_stack([centre + (poly[:, 0] - centre) * c, (poly[:, 0] - centre) * s_, poly[:, 1]]))
    return np.vstack(out)


@dataclass(frozen=True)
class Box:
    """An obstacle: an axis-aligned box in the plane, extruded normal to it (metres)."""

    name: str
    lo: tuple[float, float]  # (x, z) of the lower-left corner
    hi: tuple[float, float]  # (x, z) of the upper-right corner


@dataclass(frozen=True)
class CollisionModel:
    """What collision checking needs to know of a scene (Scene.collision_model builds it).

    Plane coordinates: x along GB from G, z up, y the plane's normal; metres."""

    #: The object length l, m: the unit of the digits' dimensions.
    length: float
    #: The object's thickness, m (0: a segment, checked as a slab 1 um thick).
    thickness: float
    #: The digits' geometry, over l.
    digits: DigitGeometry
    #: Planar obstacles, extruded through the plane.
    boxes: tuple[Box, ...] = ()
    #: The object's outline at its target pose in plane coordinates (x, y), m, shape (N, 2); None:
    #: the object is the segment GB (a slab of the digits' width).
    section: NDArray[np.float64] | None = None
    #: Convex bodies fixed in the world (a frame's walls, pieces placed already).
    solids: tuple[Solid, ...] = ()
    #: The manipulation plane's pose in the world (4 x 4); needed with solids.
    frame: NDArray[np.float64] | None = None
    #: How much lower than planned the hand runs (robot.start_press), m: the digits and the housing
    #: are checked there against obstacles, solids and the release's table; the planned digits
    #: keep the scene's clearance over the table.
    lowered: float = 0.0
    #: The gripper's joint when it is a pincer (robot.gripper, m; mechanics.pincer): its digits turn
    #: about it, and the housing sits behind it; None: the parallel jaws.
    pincer: PincerSpec | None = None


class CollisionChecker:
    """Collision checks of states (theta, d, psi) of one scene, vectorised over states."""

    def __init__(self, model: CollisionModel, exact_planar: bool = True):
        self.model = model
        l = model.length
        dg = model.digits
        self._length = l
        #: The pincer's joint radius and offset over l (None: the parallel jaws).
        self._pincer = None if model.pincer is None else model.pincer.scaled(l)
        thumb_length, finger_length = dg.thumb_length, dg.finger_length
        if self._pincer is not None:  # each digit runs from its tip to the joint's level
            thumb_length = pincer_kinematics.thumb_reach(dg, self._pincer[0])
            finger_length = self._pincer[0] + dg.finger_tip_radius
        # Digit outlines in their own frame (x from tip toward palm, z along n_B), metres.
        thumb = np.array([[0, 0], [thumb_length, 0], [thumb_length, -dg.thumb_base_thickness],
                          [0, -dg.thumb_tip_thickness]]) * l
        finger = np.array([[0, 0], [finger_length, 0], [finger_length, dg.finger_base_thickness],
                           [0, dg.finger_tip_thickness]]) * l
        t = max(model.thickness, 1e-6)
        width = dg.width * l
        self._bodies = {
            "thumb": fcl.CollisionObject(_prism(thumb, width)),
            "finger": fcl.CollisionObject(_prism(finger, width)),
        }
        self._object_extent = None  # (x_min, x_max) of the outline's prism along GB, m
        # extent of each body normal to the plane (y, m)
        self._y_range = {name: (-width / 2, width / 2) for name in ("thumb", "finger", "object")}
        curved = dg.section is not None and not dg.section.is_slab
        #: The curved section's extent in the object's frame ((x, z) low, high), m: its broad phase box.
        self._section_box = None
        if curved:  # the true solid: the section turned about its centre (an outline) or across the digits' width
            solid = object_solid(dg.section, l, width, model.section is not None)
            self._bodies["object"] = fcl.CollisionObject(convex_shape(solid))
            self._section_box = np.array([[solid[:, 0].min(), solid[:, 2].min()], [solid[:, 0].max(), solid[:, 2].max()]])
            self._y_range["object"] = (float(solid[:, 1].min()), float(solid[:, 1].max()))
        elif model.section is not None:
            pts = model.section
            self._bodies["object"] = fcl.CollisionObject(prism_shape(pts, 0.0, t))
            self._object_extent = (float(pts[:, 0].min()), float(pts[:, 0].max()))
            self._y_range["object"] = (float(pts[:, 1].min()), float(pts[:, 1].max()))
        else:
            body = np.array([[0, -t / 2], [l, -t / 2], [l, t / 2], [0, t / 2]])
            self._bodies["object"] = fcl.CollisionObject(_prism(body, width))
        if dg.palm_width > 0 and dg.palm_length > 0:  # the housing, centred on its own frame
            depth = dg.palm_thickness * l if dg.palm_thickness > 0 else width
            self._bodies["palm"] = fcl.CollisionObject(fcl.Box(dg.palm_length * l, depth, dg.palm_width * l))
            self._y_range["palm"] = (-depth / 2, depth / 2)
        self._targets: list[tuple[str, NDArray, fcl.CollisionObject]] = []
        #: Per target and body: the target's rectangle ((x, z) low, high) in the body's slab normal
        #: to the plane, when exact there (None: the slab misses it); bodies absent: FCL decides.
        self._rect: dict[str, dict[str, NDArray | None]] = {}
        self._target_y: dict[str, tuple[float, float]] = {}  # y extent of the solids (others: through the plane)
        self._add_targets(model, exact_planar)
        #: How far a digit, where the hand runs (model.lowered below its plan), may reach below the
        #: table's top (m): the lowering less the scene's clearance over it.
        self._table_gap = _TABLE_GAP - dg.table_clearance * l + model.lowered
        self._request = fcl.CollisionRequest()
        self._placers = {name: _PlanarPose(obj) for name, obj in self._bodies.items()}

    def _add_targets(self, model: CollisionModel, exact_planar: bool) -> None:
        """The scene's boxes and solids as collision targets, each with its broad-phase rectangle in
        the plane and, where exact_planar allows, its exact rectangle in each prism body's slab."""
        # the digits and the housing are prisms normal to the plane; the object's outline is not
        prisms = [body for body in self._bodies if body != "object"]
        for box in model.boxes:
            lo, hi = np.array(box.lo), np.array(box.hi)
            size, centre = hi - lo, (hi + lo) / 2
            obj = fcl.CollisionObject(fcl.Box(size[0], _DEPTH, size[1]), fcl.Transform(np.array([centre[0], 0.0, centre[1]])))
            self._targets.append((box.name, np.array([lo, hi]), obj))
            self._rect[box.name] = dict.fromkeys(prisms, np.array([lo, hi])) if exact_planar else {}
        if model.solids:
            if model.frame is None:
                raise ValueError("solids need the scene's manipulation plane (an object outline)")
            for solid in model.solids:
                local = solid.transformed(model.frame)  # plane frame: x along GB, y its normal, z up
                xz = local[:, [0, 2]]
                self._target_y[solid.name] = (float(local[:, 1].min()), float(local[:, 1].max()))
                self._targets.append((solid.name, np.array([xz.min(axis=0), xz.max(axis=0)]),
                                      solid.in_frame(model.frame)))
                foot = solid.upright_foot() if exact_planar and abs(model.frame[2, 2] - 1.0) < 1e-12 else None
                self._rect[solid.name] = {}
                if foot is not None:  # the plane stands upright: the foot turns in the plane's (x, y)
                    hull, bottom, top = foot
                    frame = model.frame
                    local_foot = (hull - frame[:2, 3]) @ frame[:2, :2]
                    heights = (bottom - frame[2, 3], top - frame[2, 3])
                    self._rect[solid.name] = {body: _slab_rect(local_foot, heights, *self._y_range[body])
                                              for body in prisms}

    def _frames(self, theta: NDArray, d: NDArray, psi: NDArray) -> dict[str, tuple[NDArray, NDArray, NDArray]]:
        """Per body but the object, for states that theta, d and psi (rad, over l, rad) broadcast to:
        its frame angle, its reference point (..., 2) (the thumb's and the finger's tips, the
        housing's centre) and its outline relative to that point (..., 4, 2), over l. The
        reference points are where the hand runs: CollisionModel.lowered below the plan's."""
        dg = self.model.digits
        if self._pincer is not None:
            frames = self._pincer_frames(theta, d, psi)
            if self.model.lowered:
                down = np.array([0.0, self.model.lowered / self._length])
                frames = {body: (angle, ref - down, offsets) for body, (angle, ref, offsets) in frames.items()}
            return frames
        beta = theta + psi
        thumb, finger = digit_offsets(theta, psi, dg)
        frames = {
            "thumb": (beta, thumb_tip(theta, d, psi, dg.alpha, dg.object_thickness, dg.finger_tip_radius, dg.section),
                      thumb),
            "finger": (beta, finger_corner(theta, d, psi, dg.object_thickness, dg.finger_tip_radius, dg.section),
                       finger),
        }
        if "palm" in self._bodies:
            frames["palm"] = (beta, housing_centre(theta, d, psi, dg, frames["thumb"][1]), housing_offsets(theta, psi, dg))
        if self.model.lowered:
            down = np.array([0.0, self.model.lowered / self._length])
            frames = {body: (angle, ref - down, offsets) for body, (angle, ref, offsets) in frames.items()}
        return frames

    def _pincer_pose(self, theta: NDArray, d: NDArray, psi: NDArray) -> pincer_kinematics.PincerPose:
        """The pincer at states (theta, d, psi), over l (mechanics.pincer.pincer_pose)."""
        return pincer_kinematics.pincer_pose(theta, d, psi, self.model.digits, *self._pincer)

    def _pincer_frames(self, theta: NDArray, d: NDArray, psi: NDArray
                       ) -> dict[str, tuple[NDArray, NDArray, NDArray]]:
        """_frames for a pincer: its thumb at its own tip along its face, its finger along its link
        from the joint to its tip, the housing behind the joint (mechanics.pincer), over l, where the
        plan has them."""
        dg = self.model.digits
        pose = self._pincer_pose(theta, d, psi)
        thumb, finger = pincer_kinematics.digit_outlines(pose, dg)
        frames = {"thumb": (pincer_kinematics.plane_angle(-pose.thumb_z), pose.thumb_tip, thumb),
                  "finger": (pincer_kinematics.plane_angle(-pose.finger_z), pose.finger_corner, finger)}
        if "palm" in self._bodies:
            centre, outline = pincer_kinematics.housing(pose, dg)
            frames["palm"] = (pincer_kinematics.plane_angle(-pose.palm_z), centre, outline)
        return frames

    def out_of_reach(self, q: ArrayLike) -> NDArray[np.bool_]:
        """For each state q (N, 3): whether a pincer cannot make it (its finger does not reach the
        state, or its joint angle lies outside 0 to max_angle); all False for the parallel jaws,
        whose opening the kinematic checks bound."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        if self._pincer is None:
            return np.zeros(len(q), dtype=bool)
        return self._beyond_joint(q[:, 0], q[:, 1], q[:, 2])

    def _beyond_joint(self, theta: NDArray, d: NDArray, psi: NDArray) -> NDArray[np.bool_]:
        angle = self._pincer_pose(theta, d, psi).angle
        with np.errstate(invalid="ignore"):
            inside = (angle >= -1e-12) & (angle <= self.model.pincer.max_angle + 1e-12)
        return ~inside  # NaN (out of the finger's reach) is outside

    def _object_pose(self, theta: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """The object's frame angle (N,), frame origin (N, 2) and outline (N, 4, 2), metres, at the
        tilts theta (N,) rad: its pose depends on theta alone."""
        l = self._length
        u = np.stack([np.cos(theta), np.sin(theta)], axis=-1)
        t = max(self.model.thickness, 1e-6) / l
        nrm = np.stack([-u[:, 1], u[:, 0]], axis=-1)
        if self._section_box is not None:  # a curved section's solid: the box about it in its frame
            (x0, z0), (x1, z1) = self._section_box / l
            obj = np.stack([x0 * u + z0 * nrm, x1 * u + z0 * nrm, x1 * u + z1 * nrm, x0 * u + z1 * nrm], axis=1)
        elif self._object_extent is None:  # the slab along GB, centred on it
            obj = np.stack([-nrm * t / 2, u - nrm * t / 2, u + nrm * t / 2, nrm * t / 2], axis=1)
        else:  # the outline's prism on the table, tilted about G: its section in the plane
            x0, x1 = (x / l for x in self._object_extent)
            obj = np.stack([x0 * u, x1 * u, x1 * u + t * nrm, x0 * u + t * nrm], axis=1)
        return theta, np.zeros((len(theta), 2)), obj * l

    def _digit_poses(self, q: NDArray) -> dict[str, tuple[NDArray, NDArray, NDArray]]:
        """Per body but the object: frame angle (N,), frame origin (N, 2), world outline (N, 4, 2); metres."""
        l = self._length
        return {body: (angle, ref * l, (ref[:, None, :] + offsets) * l)
                for body, (angle, ref, offsets) in self._frames(q[:, 0], q[:, 1], q[:, 2]).items()}

    def _poses(self, q: NDArray) -> dict[str, tuple[NDArray, NDArray, NDArray]]:
        """Per body: frame angle (N,), frame origin (N, 2), world outline (N, 4, 2); metres."""
        return {"object": self._object_pose(q[:, 0]), **self._digit_poses(q)}

    def _pairs(self, poses: dict[str, tuple[NDArray, NDArray, NDArray]]):
        """Broad phase over the bodies of poses: yields (body, target name, state indices that may
        touch it, whether they do touch it (exact), the target's FCL object)."""
        for body, (angle, origin, outline) in poses.items():
            corners = [outline[:, v] for v in range(4)]
            lo, hi = _min(corners), _max(corners)
            blo, bhi = self._y_range[body]
            for name, box, target in self._targets:
                tyl, tyh = self._target_y.get(name, (-np.inf, np.inf))
                if tyl > bhi or tyh < blo:  # apart normal to the plane
                    continue
                exact = body in self._rect[name]
                rect = self._rect[name][body] if exact else box
                if rect is None:
                    continue
                tlo, thi = rect
                near = (lo[:, 0] <= thi[0]) & (hi[:, 0] >= tlo[0]) & (lo[:, 1] <= thi[1]) & (hi[:, 1] >= tlo[1])
                idx = np.flatnonzero(near)
                if len(idx):
                    yield body, name, idx[~_separated(outline[idx], tlo, thi)], exact, target

    def _fcl_hits(self, body: str, poses: dict[str, tuple[NDArray, NDArray, NDArray]], idx: NDArray,
                  target: fcl.CollisionObject) -> NDArray[np.bool_]:
        """FCL's narrow phase for body against target at the states idx."""
        angle, origin, _ = poses[body]
        return np.array([self._collide(body, a, x, z, target) for a, x, z in
                         zip(angle[idx].tolist(), origin[idx, 0].tolist(), origin[idx, 1].tolist())], dtype=bool)

    @staticmethod
    def _below_table(outline: NDArray, gap: float) -> NDArray[np.bool_]:
        """Bodies (N, 4, 2) reaching into the table (z < -gap): exact for prisms normal to the plane."""
        return outline[:, :, 1].min(axis=1) < -gap

    def _collide(self, body: str, angle: float, x: float, z: float, target: fcl.CollisionObject) -> bool:
        obj = self._placers[body].set(angle, x, z)
        return fcl.collide(obj, target, self._request, fcl.CollisionResult()) > 0

    def in_collision(self, q: ArrayLike) -> NDArray[np.bool_]:
        """True for each state (row of q, shape (N, 3)) where a digit or the object collides.

        The table is checked in closed form (the digits and housing are prisms normal to
        the plane); the object, whose pose depends on theta alone, once per distinct theta.
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        hit = np.zeros(len(q), dtype=bool)
        if not len(q):
            return hit
        if self._pincer is not None:
            hit |= self.out_of_reach(q)
        if self._targets:
            thetas, which = np.unique(q[:, 0], return_inverse=True)
            hit |= self._hits({"object": self._object_pose(thetas)})[which]
        rest = np.flatnonzero(~hit)
        hit[rest] = self._hits(self._digit_poses(q[rest]))
        return hit

    def in_collision_lattice(self, axes: tuple[ArrayLike, ArrayLike, ArrayLike],
                             where: NDArray[np.bool_] | None = None) -> NDArray[np.bool_]:
        """in_collision at every state of the lattice with these axes (theta rad, d over l, psi
        rad), shape (n0, n1, n2); with where (that shape), only there (False elsewhere).

        The same answers as in_collision, computed the way the lattice allows: a body's outline is
        its reference point plus an outline that turns with theta + psi alone, so its lowest point
        (the table) and its bounding box cost one pass over the states; only states whose boxes
        meet an obstacle's or a solid's go through in_collision's narrow phase.
        """
        th, d, ps = (np.asarray(a, dtype=float).reshape(s) for a, s in zip(axes, ((-1, 1, 1), (1, -1, 1), (1, 1, -1))))
        shape = (th.shape[0], d.shape[1], ps.shape[2])
        l = self._length
        if self._pincer is not None:  # the pincer's digits turn with every coordinate: a slice of theta at a time
            step = max(1, PINCER_LATTICE_CHUNK // (shape[1] * shape[2]))
            if shape[0] > step:
                return np.concatenate([self.in_collision_lattice(
                    (th.ravel()[i:i + step], d.ravel(), ps.ravel()), None if where is None else where[i:i + step])
                    for i in range(0, shape[0], step)])
        todo = np.ones(shape, dtype=bool) if where is None else where.copy()
        frames = self._frames(th, d, ps)
        hit = np.zeros(shape, dtype=bool)
        if self._pincer is not None:
            hit |= self._beyond_joint(th, d, ps)
        for _, ref, offsets in frames.values():
            hit |= (ref[..., 1] + offsets[..., 1].min(axis=-1)) * l < -self._table_gap
        hit &= todo
        if self._targets:
            todo &= ~hit
            obj = np.broadcast_to(self._hits({"object": self._object_pose(th.ravel())})[:, None, None], shape)
            hit |= obj & todo
            todo &= ~obj
            near = np.zeros(shape, dtype=bool)
            for body, (_, ref, offsets) in frames.items():
                lo, hi = (ref + offsets.min(axis=-2)) * l, (ref + offsets.max(axis=-2)) * l
                blo, bhi = self._y_range[body]
                for name, (tlo, thi), _ in self._targets:
                    tyl, tyh = self._target_y.get(name, (-np.inf, np.inf))
                    if tyl <= bhi and tyh >= blo:
                        near |= (lo[..., 0] <= thi[0]) & (hi[..., 0] >= tlo[0]) & (lo[..., 1] <= thi[1]) & (hi[..., 1] >= tlo[1])
            idx = np.flatnonzero(todo & near)
            if len(idx):
                i, j, k = np.unravel_index(idx, shape)
                q = np.column_stack([th.ravel()[i], d.ravel()[j], ps.ravel()[k]])
                hit.flat[idx] = self._hits(self._digit_poses(q))
        return hit

    def _hits(self, poses: dict[str, tuple[NDArray, NDArray, NDArray]], table_gap: float | None = None
              ) -> NDArray[np.bool_]:
        """Per state of poses (bodies in the plane, as _poses gives them): any body in collision;
        a body reaching more than table_gap (m; default: the scene's clearance over the table)
        below the table's top collides with the table."""
        table_gap = self._table_gap if table_gap is None else table_gap
        n = len(next(iter(poses.values()))[0])
        hit = np.zeros(n, dtype=bool)
        for body, (_, _, outline) in poses.items():
            if body != "object":
                hit |= self._below_table(outline, table_gap)
        for body, _, idx, exact, target in self._pairs(poses):
            idx = idx[~hit[idx]]
            hit[idx] = True if exact else self._fcl_hits(body, poses, idx, target)
        return hit

    def termination_collides(self, q: ArrayLike, kind: str, amount: float, steps: int = 6) -> NDArray[np.bool_]:
        """Whether the gripper hits something while it lets go from states q (N, 3) (paper fig. 10d).

        kinds 'open', 'open_symmetric' and 'open_lift': the gripper opens by amount (m), its
        bodies moving as mechanics.release_travel has them; a pincer's joint opens instead by the
        turn that moves its finger's tip by amount (PincerSpec.opening_angle), its digits and
        housing turning about the joint: with 'open' the thumb stays and the housing turns half as
        far as the finger, with 'open_symmetric' the housing stays and the digits turn half of it
        each (mechanics.pincer; a pincer has no 'open_lift'). kind 'rotate': the
        gripper turns by amount (rad) about the thumb tip, the way that lifts the finger. Checked
        at steps poses along the way, where the hand runs (CollisionModel.lowered below the plan);
        the digits may press into the table by RELEASE_TABLE_GAP, as the robot's own check allows.
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        poses = self._digit_poses(q)
        pivot = poses["thumb"][1]  # the thumb tip
        lift = np.where(poses["finger"][1][:, 0] < pivot[:, 0], -1.0, 1.0)  # turning sign that raises the finger
        opens = self._pincer is not None and kind != "rotate"
        travel = None if kind == "rotate" or opens else release_travel(q[:, 0], q[:, 2], kind)
        if opens:  # the pincer's joint opens: its digits turn about it (mechanics.pincer)
            pose = self._pincer_pose(q[:, 0], q[:, 1], q[:, 2])
            joint = pose.joint * self._length - np.array([0.0, self.model.lowered])  # where the hand runs
            sense = np.sign(pose.palm_z[:, 0] * pose.palm_x[:, 1] - pose.palm_z[:, 1] * pose.palm_x[:, 0])
            share = {"open": {"thumb": 0.0, "finger": 1.0, "palm": 0.5},
                     "open_symmetric": {"thumb": -0.5, "finger": 0.5, "palm": 0.0}}[kind]
            opening = self.model.pincer.opening_angle(amount)
            about = pincer_kinematics.turn_about
        hit = np.zeros(len(q), dtype=bool)
        for f in np.linspace(0.0, 1.0, steps + 1)[1:]:
            moved = {}
            turn = lift * amount * f
            for body, (angle, origin, outline) in poses.items():
                if opens:
                    a = np.full(len(q), share[body] * opening * f)
                    moved[body] = (angle + sense * a, about(origin, joint, a, pose.palm_z, pose.palm_x),
                                   about(outline, joint, a, pose.palm_z, pose.palm_x))
                elif kind == "rotate":
                    moved[body] = (angle + turn, _turned(origin, pivot, turn), _turned(outline, pivot, turn))
                else:
                    shift = travel[body] * (amount * f)
                    moved[body] = (angle, origin + shift, outline + shift[:, None, :])
            hit |= self._hits(moved, RELEASE_TABLE_GAP)
        return hit

    def contacts(self, q: ArrayLike) -> list[str]:
        """The colliding (body, target) pairs of one state, as 'body/target' names."""
        q = np.atleast_2d(np.asarray(q, dtype=float))[:1]
        if self.out_of_reach(q)[0]:
            return ["pincer/joint range"]
        poses = self._poses(q)
        out = [f"{body}/table" for body, (_, _, outline) in poses.items()
               if body != "object" and self._below_table(outline, self._table_gap)[0]]
        return out + [f"{body}/{name}" for body, name, idx, exact, target in self._pairs(poses)
                      if len(idx) and (exact or self._fcl_hits(body, poses, idx, target)[0])]
