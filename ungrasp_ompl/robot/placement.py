"""From a planar plan to gripper poses in the world (paper sec. 6: holistic arm-gripper control).

Plane coordinates (x along GB, z up, metres) map to the world through the
manipulation plane's frame. The gripper's palm frame (see robot.model): z
along the digits from the palm toward the tips (the digit axis e), x across
the gap from the thumb's face toward the finger's (n_B), y = z x x, the
plane's normal; its origin midway between the digit faces (a symmetric
parallel gripper), the thumb's face at x = -opening/2 through the thumb tip,
the finger's at +opening/2; the finger is alpha * l longer.

Every state of the plan fixes the palm pose and the opening exactly
(mechanics.kinematics): the finger's tip corner where its tip touches the
object's top face at A (finger_corner: the thickness and a rounded tip's dome
move it, and the dome rolls on the object as the digits turn against it), the
thumb's face through B, the thumb tip alpha l short of the finger's corner
along e. Legs are sampled densely so that contacts stay
within 0.1 mm of their planned places between samples.

A pincer (scene.robot.gripper, mechanics.pincer) makes the same states by its joint: the palm frame's
origin is then on the joint's axis, z bisecting the digits toward their tips and x toward the
finger, and the gripper's coordinate is the joint angle (rad) instead of the opening; its thumb's
tip and its finger's tip corner are its own (mechanics.pincer.pincer_pose).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import NoSolutionError
from ..mechanics.kinematics import (aperture, contact_point, digit_axis, finger_corner, object_axis,
                                   thumb_normal, thumb_tip)
from ..mechanics.pincer import PincerPose, pincer_pose
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
    contact A on the object's top face (a rounded tip's rolled: contact_point); b: B; e: the digit
    axis; n: the gap direction n_B (unit vectors, (N, 2) each); opening: the distance between the
    digit faces (N,), m.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    th, d, ps = q.T
    l, dg = scene.object_length, scene.digits
    t, r, sec = dg.object_thickness, dg.finger_tip_radius, dg.section  # sec: a curved section's rolling finger
    u = object_axis(th)
    pts = {"thumb": thumb_tip(th, d, ps, dg.alpha, t, r, sec) * l, "finger": finger_corner(th, d, ps, t, r, sec) * l,
           "a": contact_point(th, d, ps, t, r, sec) * l, "b": u * l,
           "e": digit_axis(th, ps), "n": thumb_normal(th, ps), "opening": aperture(d, ps, t, r, sec) * l}
    pincer = scene_pincer(scene, q)
    if pincer is not None:  # the pincer's own digits (the opening between the faces is the state's)
        pts["thumb"], pts["finger"] = pincer.thumb_tip * l, pincer.finger_corner * l
    return pts


class PincerRangeError(NoSolutionError):
    """A state the scene's pincer cannot make (its finger does not reach it, or its joint angle lies
    outside its range): a plan made for other digits or another gripper, or a deviated start. index:
    the state's index; state: (theta rad, d, psi rad); angle: the joint angle it would need (rad, NaN
    out of reach)."""

    def __init__(self, index: int, state: ArrayLike, angle: float, max_angle: float):
        self.index, self.state, self.angle = index, tuple(float(x) for x in state), float(angle)
        th, d, ps = self.state
        need = "out of the finger's reach" if math.isnan(angle) else f"a joint angle of {math.degrees(angle):.3f} deg"
        super().__init__(f"the pincer cannot make state {index} (theta {math.degrees(th):.3f} deg, d {d:.4f}, psi "
                         f"{math.degrees(ps):.3f} deg): {need}, its joint turning 0 to "
                         f"{math.degrees(max_angle):.3f} deg")


def scene_pincer(scene: Scene, q: ArrayLike) -> PincerPose | None:
    """The scene's pincer (robot.gripper) at planar states q (N, 3), over l; None for the parallel
    jaws. Raises PincerRangeError for the first state the pincer cannot make (its finger out of
    reach or its joint outside its range), which the planner's collision check refuses."""
    spec = scene.robot.gripper
    if spec is None:
        return None
    q = np.atleast_2d(np.asarray(q, dtype=float))
    pose = pincer_pose(q[:, 0], q[:, 1], q[:, 2], scene.digits, *spec.scaled(scene.object_length))
    with np.errstate(invalid="ignore"):
        bad = ~((pose.angle >= -1e-9) & (pose.angle <= spec.max_angle + 1e-9))
    if bad.any():
        i = int(np.argmax(bad))
        raise PincerRangeError(i, q[i], float(pose.angle[i]), spec.max_angle)
    return pose


def to_world(frame: NDArray, xz: NDArray) -> NDArray[np.float64]:
    """Plane points (N, 2) as world points (N, 3) through the plane frame (4x4)."""
    local = np.column_stack([xz[:, 0], np.zeros(len(xz)), xz[:, 1]])
    return local @ frame[:3, :3].T + frame[:3, 3]


def palm_poses(scene: Scene, q: ArrayLike, frame: NDArray, thumb_length: float
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """World poses (N, 4, 4) of the palm frame and the openings (N,) in metres for planar states q
    (a pincer's: the palm on its joint, and its joint angles in radians).

    thumb_length: the gripper's thumb, metres (palm to tip; a pincer's comes from its joint).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    pincer = scene_pincer(scene, q)
    if pincer is not None:
        return _pincer_palms(pincer, frame, scene.object_length)
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


def _pincer_palms(pose: PincerPose, frame: NDArray, length: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """World poses (N, 4, 4) of a pincer's palm frame (on its joint, robot.model) and its joint
    angles (N,) rad, from its pose in the plane (over l) through the plane frame (4x4)."""
    rot = frame[:3, :3]

    def world(v: NDArray) -> NDArray:
        return np.column_stack([v[:, 0], np.zeros(len(v)), v[:, 1]]) @ rot.T

    z_axis, x_axis = world(pose.palm_z), world(pose.palm_x)
    poses = np.tile(np.eye(4), (len(z_axis), 1, 1))
    poses[:, :3, 0], poses[:, :3, 1], poses[:, :3, 2] = x_axis, np.cross(z_axis, x_axis), z_axis
    poses[:, :3, 3] = to_world(frame, pose.joint * length)
    return poses, pose.angle.copy()


def contact_points_world(scene: Scene, q: ArrayLike, frame: NDArray) -> dict[str, NDArray[np.float64]]:
    """Planned world positions (N, 3) of the thumb tip, the finger's tip corner, A and B."""
    pts = plane_points(scene, q)
    return {k: to_world(frame, pts[k]) for k in ("thumb", "finger", "a", "b")}
