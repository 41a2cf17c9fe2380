"""Collision of the finger, the thumb and the object with the table and obstacles (python-fcl).

World frame: the manipulation plane is the xz-plane (G at the origin, x along
the table, z up), y is normal to it; metres. The finger and the thumb are
trapezoidal prisms of the digits' width, and the gripper's housing (when the
scene gives its size) a box behind their bases; obstacles are boxes of the plane,
extruded through it; the table fills z < 0. The object is checked against the
obstacles only (it touches the table at G and the digits at A and B).

A numpy broad phase (bounding boxes in the plane, vectorised over states)
sends only the state/body pairs that may touch to FCL's narrow phase.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import math

import fcl
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..mechanics.kinematics import aperture, digit_axis, digit_polygons, thumb_normal

if TYPE_CHECKING:
    from ..scene import Scene

_DEPTH = 10.0  # extent of table and obstacles normal to the plane, m
_TABLE_GAP = 1e-9  # the table's top sits this far below z = 0, m, so resting contact is not a collision


def _prism(outline: NDArray, width: float) -> fcl.Convex:
    """A convex prism: a planar quadrilateral (x, z) extruded by width along y, centred."""
    lo = np.column_stack([outline[:, 0], np.full(4, -width / 2), outline[:, 1]])
    hi = lo.copy()
    hi[:, 1] = width / 2
    verts = np.vstack([lo, hi])
    faces = [[0, 1, 2, 3], [4, 7, 6, 5]] + [[i, (i + 1) % 4, 4 + (i + 1) % 4, 4 + i] for i in range(4)]
    flat = np.concatenate([[4, *f] for f in faces]).astype(np.int64)
    return fcl.Convex(verts, len(faces), flat)


def _planar_transform(angle: float, x: float, z: float) -> fcl.Transform:
    """Rotation by angle in the xz-plane (turning x toward z) and a shift to the plane point (x, z).

    Turning x toward z is a rotation by -angle about y: quaternion (w, x, y, z) =
    (cos(angle/2), 0, -sin(angle/2), 0).
    """
    half = 0.5 * angle
    return fcl.Transform([math.cos(half), 0.0, -math.sin(half), 0.0], [x, 0.0, z])


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


class CollisionChecker:
    """Collision checks of states (theta, d, psi) of one scene, vectorised over states."""

    def __init__(self, scene: "Scene"):
        self.scene = scene
        l = scene.object_length
        dg = scene.digits
        self._length = l
        # Digit outlines in their own frame (x from tip toward palm, z along n_B), metres.
        thumb = np.array([[0, 0], [dg.thumb_length, 0], [dg.thumb_length, -dg.thumb_base_thickness],
                          [0, -dg.thumb_tip_thickness]]) * l
        finger = np.array([[0, 0], [dg.finger_length, 0], [dg.finger_length, dg.finger_base_thickness],
                           [0, dg.finger_tip_thickness]]) * l
        t = max(scene.object_thickness, 1e-6)
        body = np.array([[0, -t / 2], [l, -t / 2], [l, t / 2], [0, t / 2]])
        width = dg.width * l
        self._bodies = {
            "thumb": fcl.CollisionObject(_prism(thumb, width)),
            "finger": fcl.CollisionObject(_prism(finger, width)),
            "object": fcl.CollisionObject(_prism(body, width)),
        }
        if dg.palm_width > 0 and dg.palm_length > 0:  # the housing, centred on its own frame
            self._bodies["palm"] = fcl.CollisionObject(fcl.Box(dg.palm_length * l, width, dg.palm_width * l))
        self._targets: list[tuple[str, NDArray, fcl.CollisionObject]] = []
        big = 1000.0
        table = fcl.CollisionObject(fcl.Box(2 * big, _DEPTH, big), fcl.Transform(np.array([0.0, 0.0, -big / 2 - _TABLE_GAP])))
        self._targets.append(("table", np.array([[-big, -big], [big, -_TABLE_GAP]]), table))
        for box in scene.obstacles:
            lo, hi = np.array(box.lo), np.array(box.hi)
            size, centre = hi - lo, (hi + lo) / 2
            obj = fcl.CollisionObject(fcl.Box(size[0], _DEPTH, size[1]), fcl.Transform(np.array([centre[0], 0.0, centre[1]])))
            self._targets.append((box.name, np.array([lo, hi]), obj))
        self._request = fcl.CollisionRequest()

    def _poses(self, q: NDArray) -> dict[str, tuple[NDArray, NDArray, NDArray]]:
        """Per body: frame angle (N,), frame origin (N, 2), world outline (N, 4, 2); metres."""
        th, d, ps = q[:, 0], q[:, 1], q[:, 2]
        l = self._length
        thumb, finger = digit_polygons(th, d, ps, self.scene.digits)
        u = np.stack([np.cos(th), np.sin(th)], axis=-1)
        t = max(self.scene.object_thickness, 1e-6) / l
        nrm = np.stack([-u[:, 1], u[:, 0]], axis=-1)
        obj = np.stack([-nrm * t / 2, u - nrm * t / 2, u + nrm * t / 2, nrm * t / 2], axis=1)
        beta = th + ps
        poses = {
            "thumb": (beta, thumb[:, 0] * l, thumb * l),
            "finger": (beta, finger[:, 0] * l, finger * l),
            "object": (th, np.zeros((len(q), 2)), obj * l),
        }
        if "palm" in self._bodies:
            dg = self.scene.digits
            back = -digit_axis(th, ps)  # from the tips toward the palm
            across = thumb_normal(th, ps)
            centre = thumb[:, 0] + (dg.thumb_length + dg.palm_length / 2) * back + (aperture(d, ps) / 2)[:, None] * across
            a, c = dg.palm_length / 2 * back, dg.palm_width / 2 * across
            outline = np.stack([centre - a - c, centre + a - c, centre + a + c, centre - a + c], axis=1)
            poses["palm"] = (beta, centre * l, outline * l)
        return poses

    def _pairs(self, q: NDArray):
        """Broad phase: yields (state index, body name, target name, angle, origin, target object)."""
        for body, (angle, origin, outline) in self._poses(q).items():
            corners = [outline[:, v] for v in range(4)]
            lo, hi = _min(corners), _max(corners)
            for name, (tlo, thi), target in self._targets:
                if body == "object" and name == "table":
                    continue
                near = (lo[:, 0] <= thi[0]) & (hi[:, 0] >= tlo[0]) & (lo[:, 1] <= thi[1]) & (hi[:, 1] >= tlo[1])
                idx = np.flatnonzero(near)
                idx = idx[~_separated(outline[idx], tlo, thi)]
                for i, a, x, z in zip(idx.tolist(), angle[idx].tolist(), origin[idx, 0].tolist(), origin[idx, 1].tolist()):
                    yield i, body, name, a, x, z, target

    def _collide(self, body: str, angle: float, x: float, z: float, target: fcl.CollisionObject) -> bool:
        obj = self._bodies[body]
        obj.setTransform(_planar_transform(angle, x, z))
        return fcl.collide(obj, target, self._request, fcl.CollisionResult()) > 0

    def in_collision(self, q: ArrayLike) -> NDArray[np.bool_]:
        """True for each state (row of q, shape (N, 3)) where a digit or the object collides."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        hit = np.zeros(len(q), dtype=bool)
        for i, body, _, angle, x, z, target in self._pairs(q):
            if not hit[i] and self._collide(body, angle, x, z, target):
                hit[i] = True
        return hit

    def contacts(self, q: ArrayLike) -> list[str]:
        """The colliding (body, target) pairs of one state, as 'body/target' names."""
        q = np.atleast_2d(np.asarray(q, dtype=float))[:1]
        return [f"{body}/{name}" for _, body, name, angle, x, z, target in self._pairs(q)
                if self._collide(body, angle, x, z, target)]
