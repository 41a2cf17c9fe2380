"""The landing a scene's plan predicts: the fall of mechanics.release (docs/model.md 11.17) set up
from the scene and the plan's last state (release_setup), started where the pinch leaves the object
when it carries it through the plan's P_dpsi legs (carried_start), over the worlds of the spread
(predict_landing: plan.json's predicted_landing); and the goal states a release from which the
fall moves the object least (release_goals: planning.release least_moving, record 0128)."""

from __future__ import annotations

import math
from dataclasses import astuple

import numpy as np

from ..mechanics.kinematics import aperture, digit_axis, pressed_state, release_travel, thumb_tip
from ..mechanics.pincer import hand_s_b, pincer_links, pincer_pose, pincer_pressed_state
from ..mechanics.release import (GRIPPER_ACCELERATION, GRIPPER_SPEED, TIMING_MARGIN, HandMotion, ReleaseBody,
                                 ReleaseModelError, ReleasePrediction, ReleaseSetup, ReleaseStart, pincer_hand,
                                 predict_release)
from ..scene import Scene
from .atlas import SecurityAtlas
from .result import Plan


def release_body(scene: Scene) -> ReleaseBody:
    """The object of scene as the fall sees it: its outline's area in the plane's body frame (the
    frame at the target: x along GB from G), or a strip from G to B without an outline."""
    l, t = scene.object_length, scene.object_thickness
    if scene.object3d is None or scene.plane is None:
        return ReleaseBody.strip(l, t)
    frame = np.asarray(scene.plane.frame, dtype=float)
    outline = (scene.object3d.placed_outline() - frame[:2, 3]) @ frame[:2, :2]
    return ReleaseBody.of_outline(outline, l, t)


def release_setup(scene: Scene, state: tuple[float, float, float], start: ReleaseStart | None = None
                  ) -> ReleaseSetup:
    """The fall's set-up for scene, ending its plan at state (theta rad, d over l, psi rad): the
    state pressed by robot's final press (pressed_state; as it is where no pressed state is found),
    the thumb there (thumb_tip), the termination's travel (release_travel) and timing, the object's
    body (a pincer's press, thumb, joint and timing its own: mechanics.pincer.pincer_pressed_state,
    mechanics.release.pincer_hand); start: the object's pose when the termination begins, where it
    is known to differ from the pressed state (the thumb's face stays where the plan puts it).
    ReleaseModelError for a rotate termination."""
    robot = scene.robot
    kind = str(robot.termination)
    if kind not in ("open", "open_symmetric", "open_lift"):
        raise ReleaseModelError("only the opening terminations (open, open_symmetric, open_lift) are modelled",
                                kind)
    hand_of = _pincer_release if robot.gripper is not None else _jaws_release
    theta, hand = hand_of(scene, *(float(x) for x in state))
    frame = tuple(map(tuple, scene.plane_frame().tolist()))
    return ReleaseSetup(release_body(scene), hand, start or ReleaseStart(0.0, theta), frame)


def held_squeeze(squeeze: float, opened: float) -> float:
    """How much of the termination's opening (m; at the joint radius for a pincer) the command takes
    before the pinch lets go (record 0131): the servo's squeeze (sim.squeeze: the command starts that
    far inside the planned opening) and what the final press opened the digits beyond the plan
    (opened, m: the pressed state's opening less the planned one; negative where the press closes
    them), never less than nothing."""
    return max(squeeze + opened, 0.0)


def _jaws_release(scene: Scene, theta: float, d: float, psi: float) -> tuple[float, HandMotion]:
    """The parallel jaws' pressed theta (rad) and their hand's motion as they let go from the state."""
    robot, digits, l = scene.robot, scene.digits, scene.object_length
    t_l, r_l = digits.object_thickness, digits.finger_tip_radius
    planned = float(aperture(d, psi, t_l, r_l, digits.section))
    if robot.final_press > 0.0:
        th_p, d_p, psi_p, found = pressed_state(theta, d, psi, robot.final_press / l, digits)
        if bool(found):
            theta, d, psi = float(th_p), float(d_p), float(psi_p)
    opened = (float(aperture(d, psi, t_l, r_l, digits.section)) - planned) * l
    tip = thumb_tip(theta, d, psi, digits.alpha, t_l, r_l) * l
    axis = digit_axis(theta, psi)
    travel = release_travel(theta, psi, str(robot.termination))
    fastest = max(float(np.linalg.norm(travel["thumb"])), float(np.linalg.norm(travel["finger"])))
    rate = TIMING_MARGIN * GRIPPER_SPEED
    if fastest > 0.0:
        rate = min(rate, robot.contact_speed / fastest)
    return theta, HandMotion(tip=(float(tip[0]), float(tip[1])), axis=(float(axis[0]), float(axis[1])),
                             thumb_length=digits.thumb_length * l,
                             palm=(float(travel["palm"][0]), float(travel["palm"][1])),
                             opening=robot.termination_opening,
                             held=min(held_squeeze(scene.sim.squeeze, opened), robot.termination_opening), rate=rate,
                             acceleration=TIMING_MARGIN * GRIPPER_ACCELERATION, retreat=robot.retreat_height)


def _pincer_release(scene: Scene, theta: float, d: float, psi: float) -> tuple[float, HandMotion]:
    """A pincer's pressed theta (rad) and its hand's motion as it lets go from the state: its own
    press, its thumb and joint there, its joint's timing."""
    robot, digits, l = scene.robot, scene.digits, scene.object_length
    radius, offset = robot.gripper.scaled(l)
    links = pincer_links(robot.gripper, digits, l)
    planned = float(pincer_pose(theta, d, psi, digits, radius, offset).angle)
    if robot.final_press > 0.0:
        th_p, d_p, psi_p, found = pincer_pressed_state(theta, d, psi, robot.final_press / l, digits, radius, offset)
        if found:
            theta, d, psi = th_p, d_p, psi_p
    pose = pincer_pose(theta, d, psi, digits, radius, offset)
    squeeze = held_squeeze(scene.sim.squeeze, (float(pose.angle) - planned) * links.radius)
    return theta, pincer_hand(pose, links, l, str(robot.termination), robot.termination_opening, squeeze,
                              robot.contact_speed, robot.retreat_height)


def carried_start(scene: Scene, plan: Plan, setup: ReleaseSetup) -> ReleaseStart:
    """Where the object is when the termination begins if the pinch carries it through the plan's
    P_dpsi legs instead of sliding over it (the simulated execution does: docs/model.md 11.13, 11.17):
    B keeps its place on the thumb over each P_dpsi (s_B does not shrink as the plan has it, and the
    finger does not slide either), so that G slides on the table with the hand; the other primitives
    go as planned (B slides in P_psi, nothing slides in P_theta; B's place by
    mechanics.pincer.hand_s_b, a pincer's and a curved section's their own). At the end the thumb is
    where setup's hand puts it, B lies the kept s_B up its face and G on the table: theta =
    asin(B_z / l), G = B_x - l cos(theta). The plan's own start (setup.start) for a plan without a
    P_dpsi."""
    kept = [p for p in plan.primitives if str(p.type) == "P_dpsi"]
    if not kept:
        return setup.start
    l = scene.object_length
    pincer = None if scene.robot.gripper is None else scene.robot.gripper.scaled(l)

    def sb(q) -> float:  # B's distance from the thumb's tip
        return float(hand_s_b(*q, scene.digits, pincer)) * l

    hand, body = setup.hand, setup.body
    bx0, bz0 = setup.start.g + l * math.cos(setup.start.theta), l * math.sin(setup.start.theta)
    planned = (bx0 - hand.tip[0]) * -hand.axis[0] + (bz0 - hand.tip[1]) * -hand.axis[1]
    s_kept = planned + sum(sb(p.start) - sb(p.end) for p in kept)
    bx, bz = hand.tip[0] - s_kept * hand.axis[0], hand.tip[1] - s_kept * hand.axis[1]
    if not 0.0 <= bz < body.length:
        raise ReleaseModelError(f"the carried object's end B would lie {bz * 1000:.3f} mm up: out of its reach")
    theta = math.asin(bz / body.length)
    return ReleaseStart(bx - body.length * math.cos(theta), theta)


def predict_landing(scene: Scene, plan: Plan, carried: bool = True) -> ReleasePrediction:
    """Where the release at the end of a solved plan puts the object, against the plan's landing (the
    last state turned flat about G), by the planar model of the fall (release_setup, fall) with the
    scene's contact friction (mu_G on the table, mu_B on the thumb) over the worlds of the spread.
    carried: the fall starts where the pinch leaves the object if it carries it through the plan's
    P_dpsi legs (carried_start), as the simulated execution does; False: where the plan's last state
    puts it. ReleaseModelError when the plan is not solved or the termination is not an opening one."""
    if not plan.solved or not plan.states:
        raise ReleaseModelError("the plan is not solved")
    mu_g, _, mu_b = scene.mu_contacts
    setup = release_setup(scene, tuple(plan.states[-1]))
    if carried:
        setup = ReleaseSetup(setup.body, setup.hand, carried_start(scene, plan, setup), setup.frame)
    return _predicted(setup, float(mu_g), float(mu_b), str(scene.robot.termination), carried)


#: How many predictions _predicted keeps (the oldest is dropped first).
KEPT_PREDICTIONS = 256

_kept: dict[tuple, ReleasePrediction] = {}


def _predicted(setup: ReleaseSetup, mu_g: float, mu_b: float, termination: str, carried: bool) -> ReleasePrediction:
    """mechanics.release.predict_release of these arguments, made once for the last KEPT_PREDICTIONS
    distinct ones: a scene's plans often end alike (the planner's, the margin objective's and their
    replans without P_dpsi end in the same state through the same P_dpsi legs, or none), and a
    prediction is a function of these values alone. Kept by their exact values (each float by its
    bits), never by object."""
    key = _exact((astuple(setup), mu_g, mu_b, termination, carried))
    found = _kept.get(key)
    if found is None:
        found = predict_release(setup, mu_g, mu_b, termination, carried)
        if len(_kept) >= KEPT_PREDICTIONS:
            del _kept[next(iter(_kept))]
        _kept[key] = found
    return found


def _exact(value: object) -> object:
    """value (nested tuples of floats and other hashable values) with every float as its exact
    hexadecimal form, so that keys that differ in a bit (0.0 and -0.0) differ."""
    if isinstance(value, (float, np.floating)):
        return float(value).hex()
    if isinstance(value, tuple):
        return tuple(_exact(v) for v in value)
    return value


def landing_of_state(scene: Scene, state: tuple[float, float, float]) -> ReleasePrediction:
    """Where a release from state (theta rad, d over l, psi rad) puts the object, unaimed, by the model
    of the fall from the state itself (not carried through a P_dpsi), over the worlds of the spread.
    ReleaseModelError where the termination is not an opening one."""
    mu_g, _, mu_b = scene.mu_contacts
    return _predicted(release_setup(scene, tuple(float(x) for x in state)), float(mu_g), float(mu_b),
                      str(scene.robot.termination), False)


def farthest_landing(p: ReleasePrediction) -> float:
    """How far (m) from the plan's landing the release's farthest landing over the worlds lies."""
    return max(abs(p.low), abs(p.high))


def release_goals(scene: Scene, reachable: bool = True
                  ) -> list[tuple[tuple[float, float, float], ReleasePrediction]]:
    """The goal states at the goal's largest theta that the gripper can let go from
    (SecurityAtlas.releasable_in), each with the landing of a release from it (landing_of_state),
    the state whose farthest landing over the worlds is least first. reachable: only those the start
    reaches (d at or below the start's, at it where planning.forbid_partial leaves no P_dpsi to move
    d; psi at or above the start's). Empty where there is none, or the termination is not modelled."""
    lo, hi = (np.asarray(c, dtype=float) for c in scene.goal.box())
    box = np.array([[hi[0], lo[1], lo[2]], [hi[0], hi[1], hi[2]]])
    if reachable:
        start = np.asarray(scene.start, dtype=float)
        low_d = start[1] if scene.options.forbid_partial else lo[1]
        box = np.array([[hi[0], max(lo[1], low_d), max(lo[2], start[2])], [hi[0], min(hi[1], start[1]), hi[2]]])
    if np.any(box[0] > box[1] + 1e-12):
        return []
    atlas = SecurityAtlas(scene, box)
    states = [tuple(float(x) for x in atlas.state(idx)) for idx in np.argwhere(atlas.releasable_in(box))]
    try:
        found = [(s, landing_of_state(scene, s)) for s in states]
    except ReleaseModelError:
        return []
    return sorted(found, key=lambda f: (farthest_landing(f[1]), f[0]))
