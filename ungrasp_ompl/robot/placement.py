"""From a planar plan to gripper poses in the world (paper sec. 6: holistic arm-gripper control).

Plane coordinates (x along GB, z up, metres) map to the world through the
manipulation plane's frame. The gripper's palm frame (see robot.model): z
along the digits from the palm toward the tips (the digit axis e), x across
the gap from the thumb's face toward the finger's (n_B), y = z x x, the
plane's normal; its origin midway between the digit faces (a symmetric
parallel gripper), the thumb's face at x = -opening/2 through the thumb tip,
the finger's at +opening/2; the finger is alpha * l longer.

Every state of the plan fixes the palm pose and the opening exactly. The
planar model treats the object as its bottom face (G and B are its bottom
edge); the robot puts the finger on the top face, so the finger's tip touches
the object at A lifted by the thickness t, and the thumb's face passes through
B. With a flat tip the finger's tip corner is that point; a rounded tip of
radius r touches it with its dome, so the corner sits r(n_top - n_B + e) away.
The opening is then l d sin(psi) + t cos(psi) (+ the dome's share), not the
planar l d sin(psi), and the thumb tip is alpha l short of the finger's corner
along e. Legs are sampled densely so that contacts stay within 0.1 mm of their
planned places between samples.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..mechanics.kinematics import digit_axis, finger_tip, object_axis, thumb_normal
from ..planning.result import Plan
from ..scene import Scene


def densify(plan: Plan, angle_step: float = math.radians(0.25), d_step: float = 0.0025
            ) -> tuple[NDArray[np.float64], list[tuple[str, int, int]]]:
    """Dense planar states along the plan's legs, and the (primitive, first, last) index of each primitive.

    Each straight leg between waypoints is cut so that no step exceeds angle_step
    (theta, psi, rad) or d_step (d, over l).
    """
    states = [np.asarray(plan.states[0], dtype=float)]
    segments = []
    for prim in plan.primitives:
        first = len(states) - 1
        pts = np.asarray(prim.waypoints, dtype=float)
        for a, b in zip(pts[:-1], pts[1:]):
            step = b - a
            n = max(1, int(math.ceil(max(abs(step[0]) / angle_step, abs(step[2]) / angle_step, abs(step[1]) / d_step))))
            for k in range(1, n + 1):
                states.append(a + step * (k / n))
        segments.append((prim.type, first, len(states) - 1))
    return np.array(states), segments


def plane_points(scene: Scene, q: ArrayLike) -> dict[str, NDArray[np.float64]]:
    """Where the robot puts the digits for planar states q (N, 3), plane coordinates (metres).

    thumb: the thumb's tip on its face; finger: the finger's tip corner on its face; a: the
    contact A on the object's top face; b: B; e: the digit axis; n: the gap direction n_B
    (unit vectors, (N, 2) each); opening: the distance between the digit faces (N,), m.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    th, d, ps = q.T
    l, t = scene.object_length, scene.object_thickness
    e, n, u = digit_axis(th, ps), thumb_normal(th, ps), object_axis(th)
    top = np.stack([-u[:, 1], u[:, 0]], axis=-1)  # the top face's outward normal
    b = u * l
    a = finger_tip(th, d) * l + t * top
    corner = a + scene.digits.finger_tip_radius * l * (top - n + e)
    opening = np.sum((corner - b) * n, axis=-1)
    thumb = corner - opening[:, None] * n - scene.digits.alpha * l * e
    return {"thumb": thumb, "finger": corner, "a": a, "b": b, "e": e, "n": n, "opening": opening}


def to_world(frame: NDArray, xz: NDArray) -> NDArray[np.float64]:
    """Plane points (N, 2) as world points (N, 3) through the plane frame (4x4)."""
    local = np.column_stack([xz[:, 0], np.zeros(len(xz)), xz[:, 1]])
    return local @ frame[:3, :3].T + frame[:3, 3]


def palm_poses(scene: Scene, q: ArrayLike, frame: NDArray, thumb_length: float
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """World poses (N, 4, 4) of the palm frame and the openings (N,) in metres for planar states q.

    thumb_length: the gripper's thumb, metres (palm to tip).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    pts = plane_points(scene, q)
    rot = frame[:3, :3]
    z_axis = np.column_stack([pts["e"][:, 0], np.zeros(len(q)), pts["e"][:, 1]]) @ rot.T
    x_axis = np.column_stack([pts["n"][:, 0], np.zeros(len(q)), pts["n"][:, 1]]) @ rot.T
    y_axis = np.cross(z_axis, x_axis)
    openings = pts["opening"]
    origin = to_world(frame, pts["thumb"] - thumb_length * pts["e"] + openings[:, None] / 2 * pts["n"])
    poses = np.tile(np.eye(4), (len(q), 1, 1))
    poses[:, :3, 0], poses[:, :3, 1], poses[:, :3, 2], poses[:, :3, 3] = x_axis, y_axis, z_axis, origin
    return poses, openings


def contact_points_world(scene: Scene, q: ArrayLike, frame: NDArray) -> dict[str, NDArray[np.float64]]:
    """Planned world positions (N, 3) of the thumb tip, the finger's tip corner, A and B."""
    pts = plane_points(scene, q)
    return {k: to_world(frame, pts[k]) for k in ("thumb", "finger", "a", "b")}


def default_plane_frame(position: ArrayLike = (0.45, 0.10), yaw: float = 0.0) -> NDArray[np.float64]:
    """A plane frame for scenes without an outline: G at position on the table, x at yaw, z up."""
    c, s = math.cos(yaw), math.sin(yaw)
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1] = [c, s, 0.0], [-s, c, 0.0]
    frame[:2, 3] = position
    return frame
