"""The pincer gripper: two digits on one revolute joint (robot.gripper.kind pincer).

The planar state (theta, d, psi) is the same as the parallel gripper's (docs/model.md 2): the
thumb's face through B at theta + psi to the table, the finger's tip on the object's top face at
A. What differs is how the gripper makes it. A parallel gripper keeps its digits parallel and
slides them apart; a pincer turns them about a joint J, like a pair of pliers:

* the finger is a link from J to its tip: the centre C of its tip's rounding (the dome of radius
  r, ``DigitGeometry.finger_tip_radius``; the tip itself for a sharp tip) lies ``joint_radius``
  R from J, and the finger's contact face runs parallel to JC, r from it, on the thumb's side;
* the thumb's contact face is a straight line ``joint_offset`` h from J (J on the finger's side
  of it) and ends at the thumb's tip, L_T along it from J's foot (``thumb_reach``);
* the joint angle phi is how far the digits are turned apart from closed (the dome touching
  the thumb's face), 0 <= phi <= max_angle; the angle Phi between the thumb's face and the
  finger's link JC is phi + Phi_c, with Phi_c = asin((r - h) / R) (``closed_angle``).

Both digits turn about J, symmetrically (as the parallel gripper's two jaws slide
symmetrically): the palm (the gripper's housing and the frame the arm places, robot.model)
bisects them, its z axis turned Phi / 2 from the thumb's face toward the finger.

The map from a state to the gripper (``pincer_pose``): C is where the state puts the dome's
centre (mechanics.kinematics.dome_centre), at (c_e, c_n) from B along the digit axis e and the
thumb's normal n_B; J lies h across from the thumb's face and R from C, on the palm's side:
J = B + (c_e - k) e + h n_B with k = sqrt(R^2 - (c_n - h)^2); sin Phi = (c_n - h) / R.

Against the parallel model: the finger's tip lies k - L_T + r beyond the thumb's tip along e,
the digit asymmetry alpha of the parallel gripper; the pincer's is largest, R - L_T + r, where
the finger's link is parallel to the thumb's face (c_n = h). The thumb's reach is chosen so
that this largest asymmetry is the scene's alpha (L_T = R + r - alpha l): every other state puts
B further from the thumb's tip than the planner's s_B (by R - k), never nearer, so the planner's
check that B keeps planning.thumb_tip_margin from the tip holds on the pincer a fortiori, and the
collision check (geometry.collision) places the pincer's own digits. A start press
(kinematics.pressed_state) moves the pincer, its joint held, as it moves the parallel digits at a
held opening: either is a rigid thumb's face with the dome's centre at a fixed place beside it, so
the pressed state is the same and B keeps its margin there a fortiori too. Choose h near the
opening of the plan's last states: there the pincer's digits are where the parallel model has them.

Letting go (release_turns): the joint opens and the palm turns about J as the termination has it;
the export (robot.pipeline) and the model of the fall (mechanics.release.pincer_hand) read the
same turns, and the fall starts from the pincer's own pressed state (pincer_pressed_state).

The module sits with the mechanics (not with the robot) because the planner's collision check
and the scene's loader use it. Lengths: PincerSpec and PincerLinks are in metres; PincerPose and
the functions work in the plane over the object length l, as mechanics.kinematics does (pass
``PincerSpec.scaled(l)``). Angles in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from .kinematics import DigitGeometry, digit_axis, dome_centre, object_axis, outlines_clearance, s_b, thumb_normal


@dataclass(frozen=True)
class PincerSpec:
    """A pincer's joint (the scene's robot.gripper with kind pincer), in metres and radians."""

    joint_radius: float
    """From the joint's axis to the centre of the finger tip's rounding (the tip for a sharp tip), m."""
    joint_offset: float
    """How far the joint's axis lies from the thumb's contact face, across the gap toward the finger, m."""
    joint_torque: float
    """The joint's torque limit, N m: the pinch at joint_radius is joint_torque / joint_radius newtons."""
    max_angle: float = math.pi / 2
    """The joint's range, from closed (the finger's tip on the thumb's face) to fully open, rad."""

    def __post_init__(self) -> None:
        for name in ("joint_radius", "joint_torque", "max_angle"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise InputError(f"robot.gripper.{name}", f"must be positive, got {value!r}")
        if not (math.isfinite(self.joint_offset) and abs(self.joint_offset) < self.joint_radius):
            raise InputError("robot.gripper.joint_offset", f"must lie within the joint radius "
                             f"(+-{self.joint_radius:g} m), got {self.joint_offset!r}")

    @property
    def pinch_force(self) -> float:
        """The pinch the torque limit gives at the joint radius (N)."""
        return self.joint_torque / self.joint_radius

    def scaled(self, length: float) -> tuple[float, float]:
        """(joint_radius, joint_offset) over the object length ``length`` (m): the plane's units."""
        return self.joint_radius / length, self.joint_offset / length

    def opening_angle(self, opening: float) -> float:
        """The turn of the joint (rad) that moves the finger tip's centre by ``opening`` (m), the
        chord of its circle about the joint."""
        return chord_angle(opening, self.joint_radius)


def chord_angle(chord: float, radius: float) -> float:
    """The turn (rad) about a centre that moves a point ``radius`` from it by ``chord`` (same unit),
    at most half a turn."""
    return 2.0 * math.asin(min(1.0, chord / (2.0 * radius)))


@dataclass(frozen=True)
class PincerLinks:
    """A pincer's links as the robot model and the simulator build them (robot.model, sim.model), m
    and rad: both digits hinge on the joint, each turned half the joint angle from the palm's axis."""

    radius: float
    """From the joint's axis to the centre of the finger tip's rounding, m (PincerSpec.joint_radius)."""
    offset: float
    """From the joint's axis to the thumb's contact face, toward the finger, m (PincerSpec.joint_offset)."""
    thumb_reach: float
    """From the joint's foot on the thumb's face to the thumb's tip, m (thumb_reach)."""
    tip_radius: float
    """The finger tip's rounding, m (0 for a sharp or flat tip)."""
    closed_angle: float
    """Phi_c: the angle between the thumb's face and the finger's link when closed, rad (closed_angle)."""
    max_angle: float
    """The joint's range from closed, rad (PincerSpec.max_angle)."""
    joint_torque: float
    """The joint's torque limit, N m (PincerSpec.joint_torque)."""

    @property
    def finger_length(self) -> float:
        """The finger's face from the joint's level to its tip's end, m: the joint radius and the tip's rounding."""
        return self.radius + self.tip_radius

    @property
    def pinch_force(self) -> float:
        """The pinch the torque limit gives at the joint radius (N)."""
        return self.joint_torque / self.radius

    @property
    def levers(self) -> tuple[float, float]:
        """How far the thumb's tip and the finger's tip corner lie from the joint's axis, m: the points
        whose travel the export's timing caps at the contact speed (robot.pipeline), each moving that
        far per radian it turns about the joint."""
        return math.hypot(self.thumb_reach, self.offset), math.hypot(self.finger_length, self.tip_radius)


#: How a pincer lets go, per radian its joint opens: the palm's, the thumb's and the finger's turns
#: about the joint (rad per rad; + turns the digits' axis e toward n_B, the finger's side). Each
#: digit turns half the joint's opening from the palm, the thumb one way and the finger the other.
#: 'open' turns the palm half the opening the finger's way, so that the thumb stays on B and the
#: finger turns the whole opening; 'open_symmetric' keeps the palm still. The pincer's counterpart of
#: mechanics.kinematics.release_travel: robot.pipeline turns the palm so in the export, and the model
#: of the fall (mechanics.release.pincer_hand) moves the thumb so.
RELEASE_TURNS = {"open": {"palm": 0.5, "thumb": 0.0, "finger": 1.0},
                 "open_symmetric": {"palm": 0.0, "thumb": -0.5, "finger": 0.5}}


def release_turns(termination: str) -> dict[str, float]:
    """The palm's, the thumb's and the finger's turns about the joint per radian the joint opens as
    a pincer lets go by termination ('open' or 'open_symmetric'; RELEASE_TURNS). InputError naming
    robot.termination for any other (a pincer neither lifts its finger off by open_lift nor opens
    when it lets go by rotate)."""
    if termination not in RELEASE_TURNS:
        raise InputError("robot.termination", f"a pincer lets go by opening its joint with "
                         f"{' or '.join(RELEASE_TURNS)}, got {termination!r}")
    return dict(RELEASE_TURNS[termination])


def pincer_links(spec: PincerSpec, digits: DigitGeometry, length: float) -> PincerLinks:
    """The links of the pincer spec carrying digits (over l) on an object of length ``length`` (m)."""
    radius, offset = spec.scaled(length)
    return PincerLinks(radius=spec.joint_radius, offset=spec.joint_offset,
                       thumb_reach=thumb_reach(digits, radius) * length,
                       tip_radius=digits.finger_tip_radius * length,
                       closed_angle=closed_angle(digits, radius, offset), max_angle=spec.max_angle,
                       joint_torque=spec.joint_torque)


def thumb_reach(digits: DigitGeometry, radius: float) -> float:
    """L_T (over l): from the foot of the joint on the thumb's face to the thumb's tip, such that the
    pincer's largest digit asymmetry R - L_T + r is the scene's alpha."""
    return radius + digits.finger_tip_radius - digits.alpha


def closed_angle(digits: DigitGeometry, radius: float, offset: float) -> float:
    """Phi_c (rad): the angle between the thumb's face and the finger's link JC with the dome on the
    thumb's face (c_n = r), where the joint angle is 0."""
    return math.asin((digits.finger_tip_radius - offset) / radius)


def check_pincer(spec: PincerSpec, digits: DigitGeometry, length: float, source: str | None = None) -> None:
    """InputError naming the robot.gripper field when the pincer cannot carry the scene's digits:
    the joint must lie behind the finger's base (joint_radius at least the finger's length less the
    tip's radius: the finger's link holds the whole finger) and the closed pinch must exist."""
    radius, offset = spec.scaled(length)
    least = digits.finger_length - digits.finger_tip_radius
    if radius < least - 1e-9:
        raise InputError("robot.gripper.joint_radius", f"must be at least the finger's length less its tip's "
                         f"radius ({least * length:.6g} m): the joint lies behind the finger's base, "
                         f"got {spec.joint_radius:g}", source)
    if abs(digits.finger_tip_radius - offset) >= radius:
        raise InputError("robot.gripper.joint_offset", "puts the joint too far from the thumb's face for the "
                         f"finger to reach it (at most {spec.joint_radius:g} m)", source)


@dataclass(frozen=True)
class PincerPose:
    """The pincer at planar states, in the plane (x, z) over l; arrays broadcast over states.

    joint: J (..., 2); palm_z, palm_x: the palm's axes (..., 2), z bisecting the digits toward their
    tips, x across toward the finger; thumb_z, thumb_x: the thumb's face direction (e, toward its
    tip) and normal (n_B, toward the finger); finger_z, finger_x: the finger's link direction (J to
    C) and its normal away from the thumb; angle: the joint angle phi (...,) rad from closed;
    turn: Phi = phi + Phi_c (...,) rad; thumb_tip, finger_corner: the thumb's tip on its face and
    the finger's tip corner on its face (..., 2); dome: C (..., 2); reach: L_T; radius: R."""

    joint: NDArray[np.float64]
    palm_z: NDArray[np.float64]
    palm_x: NDArray[np.float64]
    thumb_z: NDArray[np.float64]
    thumb_x: NDArray[np.float64]
    finger_z: NDArray[np.float64]
    finger_x: NDArray[np.float64]
    angle: NDArray[np.float64]
    turn: NDArray[np.float64]
    thumb_tip: NDArray[np.float64]
    finger_corner: NDArray[np.float64]
    dome: NDArray[np.float64]
    reach: float
    radius: float


def _turned(z: NDArray, x: NDArray, angle: ArrayLike) -> tuple[NDArray, NDArray]:
    """The axes (z, x) turned by angle from z toward x (both (..., 2))."""
    c, s = np.cos(angle)[..., None], np.sin(angle)[..., None]
    return c * z + s * x, c * x - s * z


def pincer_pose(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, digits: DigitGeometry, radius: float,
                offset: float) -> PincerPose:
    """Where the pincer (joint radius R and offset h over l) puts its joint and digits for states
    (theta, d, psi) of an object with the digits' thickness and tip (the module docstring). Where
    the finger cannot reach the state (|c_n - h| > R) the arrays hold NaN."""
    theta, d, psi = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (theta, d, psi)))
    e, n = digit_axis(theta, psi), thumb_normal(theta, psi)
    b = object_axis(theta)
    r = digits.finger_tip_radius
    dome = dome_centre(theta, d, psi, digits.object_thickness, r)
    c_e, c_n = np.sum((dome - b) * e, axis=-1), np.sum((dome - b) * n, axis=-1)
    across = c_n - offset
    with np.errstate(invalid="ignore"):
        k = np.sqrt(radius * radius - across * across)
    joint = b + (c_e - k)[..., None] * e + offset * n
    turn = np.arctan2(across, k)
    finger_z, finger_x = _turned(e, n, turn)
    palm_z, palm_x = _turned(e, n, turn / 2)
    reach = thumb_reach(digits, radius)
    return PincerPose(joint=joint, palm_z=palm_z, palm_x=palm_x, thumb_z=e, thumb_x=n, finger_z=finger_z,
                      finger_x=finger_x, angle=turn - closed_angle(digits, radius, offset), turn=turn,
                      thumb_tip=joint + reach * e - offset * n, finger_corner=dome + r * (finger_z - finger_x),
                      dome=dome, reach=reach, radius=radius)


def pincer_s_b(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, digits: DigitGeometry, radius: float,
               offset: float) -> NDArray[np.float64]:
    """How far B lies from the pincer's thumb tip along its face, over l, at states (theta, d, psi):
    the pincer's s_B, R - k more than the parallel model's (the module docstring)."""
    theta = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (theta, d, psi)))[0]
    pose = pincer_pose(theta, d, psi, digits, radius, offset)
    return np.sum((pose.thumb_tip - object_axis(theta)) * pose.thumb_z, axis=-1)


def hand_s_b(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, digits: DigitGeometry,
             pincer: tuple[float, float] | None = None) -> NDArray[np.float64]:
    """How far B lies from the thumb's tip along its face, over l, at states (theta, d, psi): a
    pincer's (pincer_s_b; pincer its joint's radius and offset over l) or, without one, the
    parallel jaws' (kinematics.s_b, on the digits' curved section where they have one)."""
    if pincer is not None:
        return pincer_s_b(theta, d, psi, digits, *pincer)
    return s_b(d, psi, digits.alpha, digits.object_thickness, digits.finger_tip_radius, digits.section)


def pincer_pressed_state(theta: float, d: float, psi: float, depth: float, digits: DigitGeometry, radius: float,
                         offset: float, iterations: int = 30) -> tuple[float, float, float, bool]:
    """Where the object lies when a pincer's palm is held depth (over l; negative: higher) straight
    below the pose the state (theta rad, d, psi rad) gives it, turned the same, with G where it is:
    the state whose joint J lies that much lower with the palm's axis kept, the joint angle free (the
    digits, coupled about the palm, turn apart as the object pushes them: the pincer's counterpart
    of mechanics.kinematics.pressed_state, which keeps the parallel jaws' palm and lets their opening
    go). Newton's method on J and the palm's direction from the state itself (central differences);
    returns theta, d, psi and whether such a state was found with 0 < theta < pi/2 and 0 < d <= 1."""

    def palm(q: NDArray[np.float64]) -> NDArray[np.float64]:
        pose = pincer_pose(q[0], q[1], q[2], digits, radius, offset)
        return np.array([pose.joint[0], pose.joint[1], math.atan2(pose.palm_z[1], pose.palm_z[0])])

    q = np.array([theta, d, psi], dtype=float)
    target = palm(q) - (0.0, depth, 0.0)
    found = False
    with np.errstate(invalid="ignore"):
        for _ in range(iterations):
            residual = palm(q) - target
            if not np.isfinite(residual).all():
                break
            if np.abs(residual).max() < 1e-13:
                found = True
                break
            h = 1e-7
            jac = np.column_stack([(palm(q + h * e) - palm(q - h * e)) / (2 * h) for e in np.eye(3)])
            try:
                q = q - np.linalg.solve(jac, residual)
            except np.linalg.LinAlgError:
                break
    th, dd, ps = (float(x) for x in q)
    return th, dd, ps, bool(found and 0.0 < th < math.pi / 2 and 0.0 < dd <= 1.0)


def forward(joint: ArrayLike, palm_z: ArrayLike, palm_x: ArrayLike, angle: ArrayLike, digits: DigitGeometry,
            radius: float, offset: float) -> dict[str, NDArray[np.float64]]:
    """Forward kinematics of the pincer from its palm (joint J (..., 2), axes palm_z and palm_x
    (..., 2)) and joint angle phi (rad): each digit turned Phi / 2 = (phi + Phi_c) / 2 from the
    palm's z, the thumb toward -x and the finger toward +x. Returns, over l (..., 2): thumb_foot
    (the joint's foot on the thumb's face), thumb_z (its direction toward the tip), thumb_x (its
    normal toward the finger), thumb_tip, dome (C, the finger tip's centre), finger_corner."""
    joint, palm_z, palm_x = (np.asarray(x, dtype=float) for x in (joint, palm_z, palm_x))
    half = (np.asarray(angle, dtype=float) + closed_angle(digits, radius, offset)) / 2
    thumb_z, thumb_x = _turned(palm_z, palm_x, -half)
    finger_z, finger_x = _turned(palm_z, palm_x, half)
    foot = joint - offset * thumb_x
    r = digits.finger_tip_radius
    dome = joint + radius * finger_z
    return {"thumb_foot": foot, "thumb_z": thumb_z, "thumb_x": thumb_x,
            "thumb_tip": foot + thumb_reach(digits, radius) * thumb_z, "dome": dome,
            "finger_corner": dome + r * (finger_z - finger_x)}


def digit_outlines(pose: PincerPose, digits: DigitGeometry) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The thumb's and the finger's outlines relative to their tips (thumb_tip, finger_corner),
    each (..., 4, 2) over l, in mechanics.kinematics.digit_polygons' vertex order (tip on the
    face, base on the face, base back corner, tip back corner): each digit runs from its tip to
    the joint's level (its link included), tapering from its tip's thickness to its base's."""

    def outline(z, x, length, t_tip, t_base, side):
        base = -length * z
        return np.stack([np.zeros_like(z), base, base + side * t_base * x, side * t_tip * x], axis=-2)

    return (outline(pose.thumb_z, pose.thumb_x, pose.reach, digits.thumb_tip_thickness,
                    digits.thumb_base_thickness, -1.0),
            outline(pose.finger_z, pose.finger_x, pose.radius + digits.finger_tip_radius,
                    digits.finger_tip_thickness, digits.finger_base_thickness, 1.0))


def pincer_clearance(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, digits: DigitGeometry, radius: float,
                     offset: float) -> NDArray[np.float64]:
    """Height of the pincer's digits' lowest point above the table at states (theta, d, psi), over
    l (radius and offset: PincerSpec.scaled): kinematics.outlines_clearance of its digits' outlines
    (digit_outlines), the finger ball-nosed along its link, as digits_clearance has the parallel
    digits. A touch-off (robot.touch_off) lowers the empty hand by this much before a digit meets
    the table."""
    pose = pincer_pose(theta, d, psi, digits, radius, offset)
    thumb, finger = digit_outlines(pose, digits)
    return outlines_clearance(pose.thumb_tip[..., None, :] + thumb, pose.finger_corner[..., None, :] + finger,
                              pose.finger_z, pose.dome, digits.finger_tip_radius)


def housing(pose: PincerPose, digits: DigitGeometry) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The housing behind the joint: its centre (..., 2) and its outline relative to it (..., 4, 2),
    over l, palm_length deep along -palm_z from the joint and palm_width across, centred on the
    palm's axis (the parallel housing's order: -a - c, a - c, a + c, -a + c)."""
    a = digits.palm_length / 2 * -pose.palm_z
    c = digits.palm_width / 2 * pose.palm_x
    centre = pose.joint - digits.palm_length / 2 * pose.palm_z
    return centre, np.stack([-a - c, a - c, a + c, -a + c], axis=-2)


def plane_angle(direction: NDArray) -> NDArray[np.float64]:
    """The frame angle (rad) that turns a body's local x onto the plane direction (..., 2) (x
    toward z, as geometry.collision places bodies)."""
    return np.arctan2(direction[..., 1], direction[..., 0])


def turn_about(points: NDArray, pivot: NDArray, angle: ArrayLike, z: NDArray, x: NDArray) -> NDArray[np.float64]:
    """Plane points (N, 2) or outlines (N, K, 2) turned about pivot (N, 2) by angle (N,) rad from
    the direction z toward x (N, 2): the sense is that of z x x in the plane."""
    sense = np.sign(z[:, 0] * x[:, 1] - z[:, 1] * x[:, 0])
    a = sense * np.asarray(angle, dtype=float)
    if points.ndim == 3:
        pivot, a = pivot[:, None, :], a[:, None]
    c, s = np.cos(a), np.sin(a)
    rel = points - pivot
    return pivot + np.stack([c * rel[..., 0] - s * rel[..., 1], s * rel[..., 0] + c * rel[..., 1]], axis=-1)
