"""The execution pipeline: plan -> palm poses -> IK -> timed joint trajectory (-> export).

Phases: approach (Ruckig, from the home configuration to the start pinch, the
object held), with robot.start_press the press (the palm straight down by
start_press, the object's end held by the table; TOPPRA), each primitive (dense
Cartesian IK, then TOPPRA along the fixed path, as much lower), the termination
maneuver (paper fig. 10d: open the gripper, or turn it about the thumb tip;
TOPPRA), the retreat (the palm lifted straight up; TOPPRA). Every
sample is checked against the joint limits and for collision of the arm and
gripper with the table and the obstacles. A pincer (robot.gripper, mechanics.pincer)
gives the trajectory its joint angle (rad) instead of the opening, and lets go by
opening its joint.
"""

from __future__ import annotations

import hashlib
import math
import pickle
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..errors import NoSolutionError
from ..mechanics.contact import Primitive
from ..mechanics.kinematics import release_travel
from ..mechanics.pincer import PincerLinks, pincer_links, release_turns
from ..planning.predicted_landing import predict_landing
from ..planning.result import Plan
from ..scene import Scene
from ..scene.options import Termination
from .collision import RobotCollisionChecker
from .ik import ik_seed_for, solve_path
from .model import GripperSpec, RobotModel, finger_tip, load_ur5e, thumb_tip
from .placement import contact_points_world, densify, palm_poses
from .timing import Samples, TimingError, Untimeable, ruckig_move, toppra_path
from .trajectory import JOINT_NAMES, PINCER_JOINT_NAMES, JointTrajectory

#: Sampling period of the exported trajectory (s); the URScript export resamples at 500 Hz.
SAMPLE_PERIOD = 0.008
#: The retreat: the palm lifted straight up in this many IK steps, at most this fast (m/s).
RETREAT_STEPS, RETREAT_SPEED = 20, 0.05
#: Poses of the start press (robot.start_press), the planned start pinch excluded.
PRESS_STEPS = 10
#: Jerk limits of the free moves: arm (rad/s^3) and gripper (m/s^3).
ARM_JERK, GRIPPER_JERK = 15.0, 2.0


class CollisionError(NoSolutionError):
    """The arm or gripper would hit the table or an obstacle: during ``phase`` (a trajectory
    segment's name), first at ``time_s`` (s from the trajectory's start), with ``pairs`` the
    colliding bodies ("link - obstacle") and ``job`` the index of the plan whose part it is
    (execute_sequence's jobs)."""

    def __init__(self, phase: str, time_s: float, pairs: tuple[str, ...], job: int = 0):
        super().__init__(f"the robot collides during the {phase} at t = {time_s:.2f} s: " + ", ".join(pairs))
        self.phase, self.time_s, self.pairs, self.job = phase, time_s, pairs, job


@dataclass
class Execution:
    """The timed trajectory and what was checked on it."""

    trajectory: JointTrajectory
    robot: RobotModel
    ik_residual_m: float
    ik_residual_rad: float
    contact_error_m: float  # largest distance of a digit tip from its planned place, at and between samples
    velocity_fraction: float  # largest |qd| / limit over samples and joints
    acceleration_fraction: float
    aims: tuple["Aim", ...] = ()  # per plan: how the hand's motion is moved from the plan's frame (robot.landing)

    def summary(self) -> str:
        """What the arm's trajectory is and how closely it follows the plan, for a person."""
        tr = self.trajectory
        return (f"arm trajectory: {tr.duration:.2f} s, {len(tr.times)} samples; the joints reach at most "
                f"{100 * self.velocity_fraction:.0f} % of their velocity limits and {100 * self.acceleration_fraction:.0f} % "
                f"of their acceleration limits; the inverse kinematics reach the planned hand poses within "
                f"{self.ik_residual_m * 1000:.4f} mm and {self.ik_residual_rad * 1000:.4f} mrad, and the digit tips stay "
                f"within {self.contact_error_m * 1000:.3f} mm of the planned contacts" + self._aimed())

    def _aimed(self) -> str:
        """The summary's clause on the aims (robot.landing), empty when no plan was aimed."""
        if not any(map(any, self.aims)):
            return ""
        if len(self.aims) == 1:
            return (f"; the hand's whole motion is moved {self.aims[0].describe()} from where the plan puts it, so that "
                    "the object lands on its target (as the scene's robot.landing asks)")
        return ("; each plan's hand motion is moved from where its plan puts it, so that its object lands on its "
                "target (as its scene's robot.landing asks): " + ", ".join(aim.describe() for aim in self.aims))


def gripper_spec(scene: Scene) -> GripperSpec:
    """The gripper whose digits the planner assumed (scene digits, metres); a pincer's digits run
    from their tips to its joint's level (mechanics.pincer)."""
    l, dg = scene.object_length, scene.digits
    max_opening = 0.106 if math.isinf(dg.max_aperture) else dg.max_aperture * l
    links = gripper_links(scene)
    finger, thumb = (dg.finger_length * l, dg.thumb_length * l) if links is None else \
        (links.finger_length, links.thumb_reach)
    return GripperSpec(finger_length=finger, thumb_length=thumb,
                       finger_width=dg.width * l, digit_thickness=dg.thumb_tip_thickness * l,
                       palm_depth=dg.palm_length * l if dg.palm_length else scene.robot.palm_depth,
                       max_opening=max_opening,
                       palm_width=dg.palm_width * l if dg.palm_width else GripperSpec.palm_width,
                       palm_thickness=dg.palm_thickness * l if dg.palm_thickness else GripperSpec.palm_thickness)


def gripper_links(scene: Scene) -> PincerLinks | None:
    """The scene's pincer as the robot builds it (robot.gripper, m), or None for the parallel jaws."""
    if scene.robot.gripper is None:
        return None
    return pincer_links(scene.robot.gripper, scene.digits, scene.object_length)


def _tips(robot: RobotModel, poses: NDArray, openings: NDArray) -> tuple[NDArray, NDArray]:
    """Thumb and finger tips (N, 3) of palm poses and openings (the gripper's own geometry; a
    pincer's openings are its joint angles, each digit turned half of it and half the closed
    angle from the palm's z, robot.model)."""
    g = robot.gripper
    z, x, o = poses[:, :3, 2], poses[:, :3, 0], poses[:, :3, 3]
    links = robot.pincer
    if links is not None:
        half = (np.asarray(openings, dtype=float)[:, None] + links.closed_angle) / 2
        c, s = np.cos(half), np.sin(half)
        thumb_z, thumb_x = c * z - s * x, c * x + s * z
        finger_z, finger_x = c * z + s * x, c * x - s * z
        return (o - links.offset * thumb_x + links.thumb_reach * thumb_z,
                o - links.tip_radius * finger_x + links.finger_length * finger_z)
    half = openings[:, None] / 2 * x
    return o - half + g.thumb_length * z, o + half + g.finger_length * z


def _termination(scene: Scene, state: NDArray, pose: NDArray, opening: float, frame: NDArray,
                 robot: RobotModel) -> tuple[NDArray, NDArray]:
    """Palm poses and openings of the termination maneuver, from the last pinch state (planar,
    its palm pose) in the plane frame."""
    opts = scene.robot
    n = 40
    if robot.pincer is not None and opts.termination != Termination.ROTATE:
        return _pincer_termination(scene, pose, opening, robot.pincer, n)
    if opts.termination != Termination.ROTATE:
        openings = np.minimum(opening + np.linspace(0.0, opts.termination_opening, n + 1)[1:],
                              robot.gripper.max_opening)
        travel = release_travel(state[0], state[2], opts.termination)["palm"]
        poses = np.repeat(pose[None], n, axis=0)
        poses[:, :3, 3] += (openings - opening)[:, None] * (frame[:3, [0, 2]] @ travel)  # plane (x, z) to world
        return poses, openings
    # turn the palm about the thumb tip, about the plane's normal (palm y), the way that lifts the finger
    tip = _tips(robot, pose[None], np.array([opening]))[0][0]

    def turned(angle: float) -> NDArray:
        k = np.cross(np.eye(3), pose[:3, 1])  # cross-product matrix of the axis
        rot = np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k
        p = np.eye(4)
        p[:3, :3] = rot @ pose[:3, :3]
        p[:3, 3] = tip + rot @ (pose[:3, 3] - tip)
        return p

    def finger_height(angle: float) -> float:
        return float(_tips(robot, turned(angle)[None], np.array([opening]))[1][0, 2])

    sign = 1.0 if finger_height(1e-3) > finger_height(-1e-3) else -1.0
    angles = np.linspace(0.0, sign * opts.termination_angle, n + 1)[1:]
    return np.array([turned(a) for a in angles]), np.full(n, opening)


def _pincer_termination(scene: Scene, pose: NDArray, angle: float, links: PincerLinks, n: int
                        ) -> tuple[NDArray, NDArray]:
    """A pincer's palm poses and joint angles as it lets go from its last pose and angle: the joint
    opens by the turn that moves the finger's tip by robot.termination_opening (at most to its
    range's end), the palm turning about the joint as mechanics.pincer.release_turns has it (the
    model of the fall reads the same): staying ('open_symmetric') or turning by half the opening, the
    way of the finger, so that the thumb stays on B ('open'); docs/model.md 7, mechanics.pincer."""
    spec = scene.robot.gripper
    angles = np.minimum(angle + np.linspace(0.0, spec.opening_angle(scene.robot.termination_opening), n + 1)[1:],
                        links.max_angle)
    poses = np.repeat(pose[None], n, axis=0)
    turn = release_turns(scene.robot.termination)["palm"]
    if turn:
        for k, a in enumerate((angles - angle) * turn):  # about palm y: z toward x
            c, s = math.cos(a), math.sin(a)
            poses[k, :3, :3] = pose[:3, :3] @ np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return poses, angles


def modelled_aim(scene: Scene, plan: Plan) -> Aim:
    """The aim of robot.landing modelled: the hand moved back along GB by the middle of the range
    over which the model of the fall (planning.predicted_landing.predict_landing) lands the object
    with the friction's range and both cones (record 0123), and by robot.landing_offset beyond it,
    in the world's x, y (m); no turn (the planar model has none)."""
    prediction = predict_landing(scene, plan)
    return aim_along(prediction.middle + scene.robot.landing_offset, prediction.direction)


def aim_along(along: float, direction: tuple[float, float]) -> Aim:
    """The aim that moves the hand back by along (m) in the direction (a unit vector in the world's
    x, y): undoes a landing that far along it; no turn."""
    return Aim(-float(along * direction[0]), -float(along * direction[1]), 0.0)


def execute(scene: Scene, plan: Plan, aim: Aim | None = None) -> Execution:
    """Turn a solved plan into a timed, limit-checked joint trajectory of the UR5e and its gripper;
    aim: the whole motion turned and shifted from where the plan puts it (the landing's correction,
    sim.landing), the obstacles staying where they are."""
    return execute_sequence([(scene, plan)], aims=[aim or Aim()])


def execute_sequence(jobs: list[tuple[Scene, Plan]], labels: list[str] | None = None,
                     aims: list[Aim] | None = None, kept: dict | None = None) -> Execution:
    """One trajectory for several solved plans in turn (a layout's pieces), from the first scene's
    home configuration: per plan the approach, its primitives, the termination and the retreat;
    between plans a move back home, where the next piece is handed over (not planned here).
    Segment names carry the label of their plan ('square/P_psi') when labels are given; aims
    moves each plan's motion as execute's aim does (none: as planned; (x, y) pairs are shifts). Each plan's
    part is checked for collision against its own scene (whose solids hold the pieces put down
    before it). The robot and gripper are those of the first scene. kept, when given, keeps each
    plan's own timed part (its IK and timing: a function of the robot, its scene, plan and aim)
    across calls, under a digest of them, and takes it from there when the same plan comes again
    (sim.tiling executes a layout's pieces again with other aims, or in another order)."""
    aims = [Aim()] * len(jobs) if aims is None else [Aim(*map(float, aim)) for aim in aims]
    first = jobs[0][0]
    spec = gripper_spec(first)
    links = gripper_links(first)
    robot = load_ur5e(spec, np.array(first.robot.base), pincer=links)
    robot_key = (spec, tuple(np.ravel(first.robot.base))) if links is None else \
        (spec, tuple(np.ravel(first.robot.base)), links)
    v_max, a_max = robot.v_max, robot.a_max
    j_max = np.append(np.full(6, ARM_JERK), GRIPPER_JERK if links is None else GRIPPER_JERK / links.radius)
    home_arm = np.asarray(first.robot.home, dtype=float)
    pieces: list[tuple[str, Samples]] = []
    owners: list[int] = []  # the job of each piece
    res_m, res_rad, contact_error = 0.0, 0.0, 0.0
    current = None
    for k, (scene, plan) in enumerate(jobs):
        prefix = f"{labels[k]}/" if labels else ""
        if kept is None:
            parts, start, checks = _job(scene, plan, robot, aims[k])
        else:
            key = hashlib.sha256(pickle.dumps((robot_key, scene, plan, aims[k]))).hexdigest()
            if key not in kept:
                kept[key] = _job(scene, plan, robot, aims[k])
            parts, start, checks = kept[key]
        res_m, res_rad = max(res_m, checks[0]), max(res_rad, checks[1])
        contact_error = max(contact_error, checks[2])
        if current is None:
            current = np.append(home_arm, start[-1])
        else:  # back home with the gripper as it was left
            home = np.append(home_arm, current[-1])
            pieces.append((prefix + "return", ruckig_move(current, home, v_max, a_max, j_max, SAMPLE_PERIOD)))
            owners.append(k)
            current = home
        pieces.append((prefix + "approach", ruckig_move(current, start, v_max, a_max, j_max, SAMPLE_PERIOD)))
        owners.append(k)
        for name, samples in parts:
            pieces.append((prefix + name, samples))
            owners.append(k)
        current = parts[-1][1].q[-1]
    trajectory = _concatenate(pieces, JOINT_NAMES if links is None else PINCER_JOINT_NAMES)
    for k, (scene, _) in enumerate(jobs):
        spans = [seg for seg, owner in zip(trajectory.segments, owners) if owner == k]
        lo, hi = spans[0][1], spans[-1][2]
        hit = RobotCollisionChecker(robot, scene, scene.plane_frame()).first_collision(trajectory.positions[lo:hi + 1])
        if hit is not None:
            i, pairs = hit
            i += lo
            phase = next(name for name, a, b in spans if a <= i <= b)
            raise CollisionError(phase, float(trajectory.times[i]), tuple(pairs), k)
    ex = Execution(trajectory, robot, res_m, res_rad, contact_error,
                   float(np.max(np.abs(trajectory.velocities) / v_max)),
                   float(np.max(np.abs(trajectory.accelerations) / a_max)), tuple(aims))
    violations = check_limits(trajectory, robot)
    if violations:
        raise TimingError(Untimeable.LIMITS, "the trajectory leaves the robot's limits: "
                          + "; ".join(map(str, violations[:3])), violations=tuple(violations))
    return ex


def hand_offsets(scene: Scene, segments: list[tuple[str, int, int]], count: int) -> NDArray[np.float64]:
    """World translations (count, 3) of the hand from where the plan puts it, at each of count dense
    states whose primitives segments gives (densify): straight down by robot.start_press, so that
    a push the object's end feels lies inside the table's friction cone (docs/model.md 11.8); when
    the plan's last primitive is a P_theta, let out to robot.end_press along it, linearly in theta
    (docs/model.md 11.11). Zero without a press."""
    r = scene.robot
    depth = np.full(count, r.start_press)
    if segments and segments[-1][0] == Primitive.THETA and r.final_press != r.start_press:
        _, first, last = segments[-1]
        depth[first:last + 1] = np.linspace(r.start_press, r.final_press, last - first + 1)
    offsets = np.zeros((count, 3))
    offsets[:, 2] = -depth
    return offsets


class Aim(NamedTuple):
    """How the hand's whole motion is moved from where the plan puts it, the table and the obstacles
    staying where they are (robot.landing: the landing's correction, sim.landing): turned by turn
    (rad, counter-clockwise seen from above) about the vertical through the origin of the plan's
    frame (G where the object lies at its target), then shifted by (x, y) (world, m)."""

    x: float = 0.0
    y: float = 0.0
    turn: float = 0.0

    @property
    def shift(self) -> float:
        """The length of the shift (m)."""
        return math.hypot(self.x, self.y)

    def scaled(self, share: float) -> "Aim":
        """That share of the aim: the shift and the turn each times share."""
        return Aim(self.x * share, self.y * share, self.turn * share)

    def transform(self, origin: NDArray[np.float64]) -> NDArray[np.float64]:
        """The aim as a world transform (4 x 4), origin (3,) being the plan frame's origin."""
        c, s = math.cos(self.turn), math.sin(self.turn)
        out = np.eye(4)
        out[:2, :2] = [[c, -s], [s, c]]
        out[:2, 3] = np.asarray(origin[:2]) - out[:2, :2] @ np.asarray(origin[:2]) + (self.x, self.y)
        return out

    def describe(self) -> str:
        """'0.97 mm' or '0.97 mm and turned 3.68 deg'."""
        turn = f" and turned {math.degrees(abs(self.turn)):.2f} deg" if round(math.degrees(self.turn), 2) else ""
        return f"{1000 * self.shift:.2f} mm{turn}"


def aimed_frame(scene: Scene, aim: Aim | None = None) -> NDArray[np.float64]:
    """The plane's frame in the world (plane_frame) moved by aim: where the hand runs the plan."""
    frame = scene.plane_frame()
    return frame.copy() if aim is None or not any(aim) else aim.transform(frame[:3, 3]) @ frame


def _job(scene: Scene, plan: Plan, robot: RobotModel, aim: Aim
         ) -> tuple[list[tuple[str, Samples]], NDArray, tuple]:
    """One plan on the robot, moved by aim: the timed press (robot.start_press),
    primitives, termination and retreat; the joints and opening (7,) the approach ends at; and (IK
    residual m, rad, contact error m)."""
    opts = scene.robot
    frame = aimed_frame(scene, aim)
    states, segments = densify(plan)
    offsets = hand_offsets(scene, segments, len(states))  # the plan is run as much lower as the press took it
    poses, openings = palm_poses(scene, states, frame, robot.gripper.thumb_length)
    poses[:, :3, 3] += offsets
    term_poses, term_openings = _termination(scene, states[-1], poses[-1], openings[-1], frame, robot)
    all_poses = np.concatenate([poses, term_poses])
    all_open = np.concatenate([openings, term_openings])
    q_arm, res_m, res_rad = solve_path(robot, list(all_poses), ik_seed_for(robot, all_poses[0]))

    path = np.column_stack([q_arm, all_open])
    parts: list[tuple[str, Samples]] = []
    v_max, a_max = robot.v_max, robot.a_max
    start = path[0]
    shift = offsets[0]
    if shift.any():  # the press: from the planned start pinch straight down, solved back from the plan's start
        back = np.repeat(all_poses[:1], PRESS_STEPS, axis=0)
        back[:, :3, 3] -= np.linspace(1.0, PRESS_STEPS, PRESS_STEPS)[:, None] / PRESS_STEPS * shift
        q_back, back_m, back_rad = solve_path(robot, list(back), q_arm[0])
        res_m, res_rad = np.append(res_m, back_m), np.append(res_rad, back_rad)
        q_press = np.column_stack([np.vstack([q_back[::-1], q_arm[:1]]), np.full(PRESS_STEPS + 1, openings[0])])
        down = np.linspace(0.0, float(np.linalg.norm(shift)), PRESS_STEPS + 1)
        parts.append(("press", toppra_path(q_press, down, v_max, a_max, opts.contact_speed, SAMPLE_PERIOD)))
        start = q_press[0]
    thumb, finger = _tips(robot, all_poses, all_open)
    travel = np.concatenate([[0.0], np.cumsum(np.maximum(np.linalg.norm(np.diff(thumb, axis=0), axis=1),
                                                         np.linalg.norm(np.diff(finger, axis=0), axis=1)))])
    for name, first, last in segments + [("termination", len(states) - 1, len(path) - 1)]:
        # a primitive that bends (a P_dpsi's corners) is timed leg by leg, at rest at each corner:
        # a time-optimal pass through a corner would need a jump in the joint velocities
        cuts = _corners(states, first, min(last, len(states) - 1)) + [last]
        legs = [toppra_path(path[a:b + 1], travel[a:b + 1] - travel[a], v_max, a_max, opts.contact_speed, SAMPLE_PERIOD)
                for a, b in zip([first] + cuts[:-1], cuts)]
        parts.append((name, _joined(legs)))
    if opts.retreat_height > 0:  # the palm straight up, so the digits leave the pieces around without a sideways slip
        lift = np.linspace(0.0, opts.retreat_height, RETREAT_STEPS + 1)
        up = np.repeat(all_poses[-1][None], len(lift), axis=0)
        up[:, 2, 3] += lift
        q_up, up_m, up_rad = solve_path(robot, list(up[1:]), q_arm[-1])
        res_m, res_rad = np.append(res_m, up_m), np.append(res_rad, up_rad)
        q_up = np.column_stack([np.vstack([q_arm[-1], q_up]), np.full(len(lift), all_open[-1])])
        parts.append(("retreat", toppra_path(q_up, lift, v_max, a_max, RETREAT_SPEED, SAMPLE_PERIOD)))
    contact_error = _contact_error(scene, robot, states, frame, offsets, q_arm[: len(states)], openings)
    return parts, start, (float(np.max(res_m)), float(np.max(res_rad)), contact_error)


def _corners(states: NDArray, first: int, last: int) -> list[int]:
    """Indices strictly between first and last where the planar path turns."""
    steps = np.diff(states[first:last + 1], axis=0)
    if len(steps) < 2:
        return []
    unit = steps / np.maximum(np.linalg.norm(steps, axis=1, keepdims=True), 1e-15)
    turn = np.linalg.norm(np.diff(unit, axis=0), axis=1) > 1e-6
    return [first + 1 + int(k) for k in np.flatnonzero(turn)]


def _joined(pieces: list[Samples]) -> Samples:
    """Timed pieces one after another (each starts where the previous stopped, at rest)."""
    if len(pieces) == 1:
        return pieces[0]
    t, q, qd, qdd = [pieces[0].t], [pieces[0].q], [pieces[0].qd], [pieces[0].qdd]
    offset = float(pieces[0].t[-1])
    for s in pieces[1:]:
        t.append(s.t[1:] + offset), q.append(s.q[1:]), qd.append(s.qd[1:]), qdd.append(s.qdd[1:])
        offset += float(s.t[-1])
    return Samples(np.concatenate(t), np.concatenate(q), np.concatenate(qd), np.concatenate(qdd))


def _concatenate(pieces: list[tuple[str, Samples]], names: tuple[str, ...] = JOINT_NAMES) -> JointTrajectory:
    t, q, qd, qdd, segs = [], [], [], [], []
    offset, count = 0.0, 0
    for k, (name, s) in enumerate(pieces):
        skip = 1 if k else 0  # a piece starts where the previous one stopped, at rest
        t.append(s.t[skip:] + offset)
        q.append(s.q[skip:]), qd.append(s.qd[skip:]), qdd.append(s.qdd[skip:])
        start = max(count - 1, 0)
        count += len(s.t) - skip
        segs.append((name, start, count - 1))
        offset += float(s.t[-1])
    return JointTrajectory(np.concatenate(t), np.concatenate(q), np.concatenate(qd), np.concatenate(qdd),
                           names, segs)


def _contact_error(scene: Scene, robot: RobotModel, states: NDArray, frame: NDArray, offsets: NDArray,
                   q_arm: NDArray, openings: NDArray) -> float:
    """Largest distance of the digit tips (forward kinematics) from their planned places moved by the
    hand's offsets, at each sample and halfway between samples (joints interpolated linearly, plan
    interpolated in state)."""
    def halves(x: NDArray) -> NDArray:
        return np.concatenate([x, (x[:-1] + x[1:]) / 2])

    q_all, o_all, moved = halves(q_arm), halves(openings), halves(offsets)
    planned = contact_points_world(scene, halves(states), frame)
    worst = 0.0
    for i in range(len(q_all)):
        q7 = np.append(q_all[i], o_all[i])
        worst = max(worst, float(np.linalg.norm(thumb_tip(robot, q7) - planned["thumb"][i] - moved[i])),
                    float(np.linalg.norm(finger_tip(robot, q7) - planned["finger"][i] - moved[i])))
    return worst


@dataclass(frozen=True)
class LimitViolation:
    """A joint beyond one of its limits somewhere on a trajectory: where it is furthest beyond."""

    joint: str
    """The joint's name (the trajectory's joint_names: JOINT_NAMES, or PINCER_JOINT_NAMES)."""
    quantity: str
    """position, velocity or acceleration."""
    value: float
    """Its value there (rad, rad/s, rad/s^2; m, m/s, m/s^2 for the gripper)."""
    low: float
    """The limit's low end, in the same unit."""
    high: float
    """The limit's high end, in the same unit."""
    time_s: float
    """When (s from the trajectory's start)."""

    def __str__(self) -> str:
        return (f"{self.joint} {self.quantity} {self.value:.4g} outside [{self.low:.4g}, {self.high:.4g}] "
                f"at t = {self.time_s:.3f} s")


def check_limits(traj: JointTrajectory, robot: RobotModel, tol: float = 1e-6) -> list[LimitViolation]:
    """The joints leaving their position, velocity or acceleration limits on the trajectory (velocity and
    acceleration with the relative tolerance tol), each where it is furthest beyond; empty within them."""
    out = []
    v, a = robot.v_max, robot.a_max
    for name, values, lo, hi, slack in (("position", traj.positions, robot.q_lower, robot.q_upper, 1e-9),
                                        ("velocity", traj.velocities, -v, v, v * tol + 1e-12),
                                        ("acceleration", traj.accelerations, -a, a, a * tol + 1e-12)):
        beyond = np.maximum(values - hi, lo - values)
        for j in np.flatnonzero((beyond > slack).any(axis=0)):
            k = int(np.argmax(beyond[:, j]))
            out.append(LimitViolation(traj.joint_names[j], name, float(values[k, j]), float(lo[j]), float(hi[j]),
                                      float(traj.times[k])))
    return out
