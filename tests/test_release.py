"""The release model (mechanics.release, docs/model.md 11.17): physical identities of the fall, the
derivatives it pushes along, the hand's timing against the export's, the pyramid's reach against
MuJoCo's contact frames, the prediction in plan.json, and (slow) the prediction against the
simulator."""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from conftest import pick_before_0107
from ungrasp_ompl.errors import InputError
from ungrasp_ompl.mechanics.release import (
    GRAVITY,
    HandMotion,
    PyramidReach,
    ReleaseBody,
    ReleaseModelError,
    ReleaseSetup,
    ReleaseStart,
    contacts_at,
    fall,
)
from ungrasp_ompl.planning.predicted_landing import carried_start, predict_landing, release_setup

ROOT = Path(__file__).resolve().parents[1]

#: A plate like the puzzle piece (m): 35 mm from G to B, its centre of mass two thirds of the way.
PLATE = ReleaseBody(length=0.035, thickness=0.004, centre=0.0235, gyration=0.0084)
#: A segment-thin uniform strip.
STRIP = ReleaseBody.strip(0.03, 0.0)


def hand(theta: float, psi: float = math.radians(31), s_b: float = 0.0015, body: ReleaseBody = PLATE,
         **changes) -> HandMotion:
    """A thumb whose face runs through B (the object at theta about G at the origin) turned
    theta + psi, B s_b up it from the tip; the open_lift travel at the shipped objects' figures."""
    beta = theta + psi
    e = (-math.cos(beta), -math.sin(beta))
    b = (body.length * math.cos(theta), body.length * math.sin(theta))
    c = abs(math.cos(beta)) / (2 * math.cos(theta))
    palm = (math.sin(beta) / 2 - c * math.sin(theta), -math.cos(beta) / 2 + c * math.cos(theta))
    base = HandMotion(tip=(b[0] + s_b * e[0], b[1] + s_b * e[1]), axis=e, thumb_length=0.06, palm=palm,
                      opening=0.004, held=0.001, rate=0.0144, acceleration=0.18)
    return replace(base, **changes)


def setup(theta: float, body: ReleaseBody = PLATE, **changes) -> ReleaseSetup:
    """The object at theta about G at the origin; the hand carries nothing (held 0, the palm still)
    unless changes say otherwise."""
    return ReleaseSetup(body, hand(theta, body=body, **{"palm": (0.0, 0.0), "held": 0.0, **changes}),
                        ReleaseStart(0.0, theta))


def energy(states: np.ndarray, body: ReleaseBody) -> np.ndarray:
    """Kinetic and potential energy per unit mass (J/kg) along a trace."""
    t, xg, zg, th, vx, vz, om = states.T
    zc = zg + body.centre * np.sin(th) + body.thickness / 2 * np.cos(th)
    return 0.5 * (vx ** 2 + vz ** 2 + body.gyration ** 2 * om ** 2) + GRAVITY * zc


@pytest.mark.parametrize("body", [PLATE, STRIP], ids=["plate", "strip"])
@pytest.mark.parametrize("theta_deg", [3.0, 8.0, 20.0])
def test_without_friction_or_thumb_the_centre_of_mass_falls_straight_down(body, theta_deg):
    """No friction at G and no thumb: no horizontal force acts, so the centre of mass lands where it
    was: G moves by l_c cos(theta) - (t/2) sin(theta) - l_c, toward the side away from B."""
    theta = math.radians(theta_deg)
    f = fall(setup(theta, body), 0.0, 0.0, thumb=False)
    expected = body.centre * math.cos(theta) - body.thickness / 2 * math.sin(theta) - body.centre
    assert f.landed
    assert f.offset == pytest.approx(expected, abs=1e-9)
    assert f.offset < 0.0


@pytest.mark.parametrize("theta_deg", [3.0, 8.0, 20.0])
def test_with_unlimited_friction_and_no_thumb_the_object_turns_flat_about_g(theta_deg):
    """Unlimited friction at G and no thumb: the object pivots about G and lands where the plan has
    it (to a micrometre: the contacts' regularization)."""
    f = fall(setup(math.radians(theta_deg)), math.inf, 0.0, thumb=False)
    assert f.landed
    assert abs(f.offset) < 1e-6


def test_more_friction_at_g_moves_g_less_without_a_thumb():
    """Without the thumb the table's friction is all that holds G against the fall's push away from
    B, so G's landed place rises monotonically toward the plan's (0) as mu_G grows."""
    mus = [0.0, 0.05, 0.1, 0.2, 0.4, 0.8, math.inf]
    offsets = [fall(setup(math.radians(8.0)), mu, 0.0, thumb=False).offset for mu in mus]
    assert all(b >= a - 1e-9 for a, b in zip(offsets, offsets[1:])), offsets
    assert offsets[0] < -1e-4 and abs(offsets[-1]) < 1e-6


@pytest.mark.parametrize("mu", [0.0, 0.3, math.inf])
@pytest.mark.parametrize("thumb", [False, True], ids=["no thumb", "still thumb"])
def test_the_fall_creates_no_energy(mu, thumb):
    """With nothing moving but the object (no thumb, or a thumb that stays where it is: the command
    never takes up the squeeze), its kinetic and potential energy never grow along the fall."""
    s = setup(math.radians(10.0), held=0.004, retreat=0.0, s_b=0.004)
    f = fall(s, mu, 0.4, trace=True, thumb=thumb)
    e = energy(f.states[:-1], PLATE)  # the last row is the object flat after the landing
    assert np.max(np.diff(e)) < 1e-9
    assert f.energy_gain < 1e-9


def _gap(body: ReleaseBody, motion: HandMotion, q: np.ndarray, t: float, key: str) -> float:
    found = [c for c in contacts_at(body, motion, q[0], q[1], q[2], t, 0.3, 0.4, 1.0)[0] if c.key == key]
    assert found, key
    return found[0].gap


def _centre(body: ReleaseBody, g: tuple[float, float], theta: float) -> np.ndarray:
    """(X, Z, theta) of the object with its corner G at g."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([g[0] + body.centre * c - body.thickness / 2 * s, g[1] + body.centre * s + body.thickness / 2 * c,
                     theta])


@pytest.mark.parametrize("case", ["G", "B on the face"])
def test_contact_rows_are_the_gaps_derivatives(case):
    """The rows the integrator pushes along are the derivatives of the gaps (central differences
    in the centre of mass's place and the tilt), and the other body's normal velocity is minus the
    gap's rate at a fixed pose; the tangent row moves the object's material point at the contact
    along the contact's tangent."""
    theta = math.radians(9.0)
    motion = hand(theta, s_b=0.003, held=0.0)
    q = _centre(PLATE, (0.0, 2e-6), theta)
    key = "G" if case == "G" else "thumb"
    t = 0.03  # the thumb moving
    contact = next(c for c in contacts_at(PLATE, motion, *q, t, 0.3, 0.4, 1.0)[0] if c.key == key)
    h = 1e-7
    rows = [(_gap(PLATE, motion, q + h * np.eye(3)[k], t, key) - _gap(PLATE, motion, q - h * np.eye(3)[k], t, key))
            / (2 * h) for k in range(3)]
    assert np.allclose(contact.normal, rows, atol=1e-6)
    rate = (_gap(PLATE, motion, q, t + 1e-5, key) - _gap(PLATE, motion, q, t - 1e-5, key)) / 2e-5
    assert contact.wall_normal == pytest.approx(-rate, abs=1e-6)
    # the tangent row: the object's material point at the contact (fixed in the body) moved along the tangent
    corner = {"G": (0.0, 0.0), "B on the face": (PLATE.length, 0.0)}[case]
    a = np.array(corner) - (PLATE.centre, PLATE.thickness / 2)  # the corner, in the body from its centre of mass

    def point(qq):
        cc, ss = math.cos(qq[2]), math.sin(qq[2])
        return np.array(qq[:2]) + np.array([[cc, -ss], [ss, cc]]) @ a

    tangent = np.array(contact.tangent[:2])
    moved = [(point(q + h * np.eye(3)[k]) - point(q - h * np.eye(3)[k])) @ tangent / (2 * h) for k in range(3)]
    assert np.allclose(contact.tangent, moved, atol=1e-6)
    wall = (np.array(motion.thumb_at(t + 1e-5)[:2]) - motion.thumb_at(t - 1e-5)[:2]) / 2e-5 if key == "thumb" else 0.0
    assert contact.wall_tangent == pytest.approx(float(wall @ tangent) if key == "thumb" else 0.0, abs=1e-6)


def test_the_thumbs_velocity_is_its_positions_rate():
    """HandMotion.thumb_at's velocity is the derivative of its position (central differences)
    through the opening's ramps, the pinch's letting go, the cruise and the retreat; the opening
    reaches the squeeze when the pinch lets go and the whole opening when the termination ends."""
    m = hand(math.radians(8.0))
    for t in np.linspace(0.001, m.end - 0.001, 40):
        h = 1e-6
        a, b = np.array(m.thumb_at(t - h)[:2]), np.array(m.thumb_at(t + h)[:2])
        assert np.allclose(m.thumb_at(t)[2:], (b - a) / (2 * h), atol=1e-6), t
    assert m.palm_at(m.released)[4] == pytest.approx(m.held, abs=1e-12)
    assert m.palm_at(m.duration)[4] == pytest.approx(m.opening, abs=1e-12)
    # a trapezoid: 4 mm at 14.4 mm/s after 80 ms of ramp each way
    assert m.duration == pytest.approx(2 * 0.0144 / 0.18 + (0.004 - 0.0144 ** 2 / 0.18) / 0.0144, rel=1e-12)


def test_the_hands_timing_is_the_exports():
    """The constants of the hand's timing are the export's: TOPPRA's share of the limits, the
    gripper's limits, the retreat's speed."""
    from ungrasp_ompl.mechanics import release
    from ungrasp_ompl.robot import model, pipeline, timing

    assert release.TIMING_MARGIN == timing.TOPPRA_MARGIN
    assert (release.GRIPPER_SPEED, release.GRIPPER_ACCELERATION) == (model.GRIPPER_VEL_LIMIT, model.GRIPPER_ACCEL_LIMIT)
    assert release.RETREAT_SPEED == pipeline.RETREAT_SPEED


def test_the_pinch_holds_until_the_command_reaches_the_pressed_opening():
    """Record 0131: the command starts the squeeze inside the planned opening, and the final press,
    turning the object about G to meet the lowered hand, opens the digits further; the pinch holds
    until the command has taken up both. The opening is measured here from B across the thumb's face
    to the finger's corner (not mechanics.kinematics.aperture's closed form); without a press the
    hold is the squeeze alone."""
    from ungrasp_ompl import Scene
    from ungrasp_ompl.mechanics.kinematics import finger_corner, object_axis, pressed_state, thumb_normal

    scene = Scene.from_file(ROOT / "scenes" / "fabric_chalk.yaml")
    digits, l = scene.digits, scene.object_length
    state = (math.radians(8.0), 0.65, math.radians(33.5))

    def opening(theta: float, d: float, psi: float) -> float:
        corner = finger_corner(theta, d, psi, digits.object_thickness, digits.finger_tip_radius)
        return float((corner - object_axis(theta)) @ thumb_normal(theta, psi)) * l

    theta, d, psi, found = pressed_state(*state, scene.robot.final_press / l, digits)
    assert found and scene.robot.final_press > 0.0
    pressed = opening(float(theta), float(d), float(psi))
    assert pressed > opening(*state)
    held = release_setup(scene, state).hand.held
    assert held == pytest.approx(scene.sim.squeeze + pressed - opening(*state), abs=1e-12)
    unpressed = replace(scene, robot=replace(scene.robot, end_press=0.0))
    assert release_setup(unpressed, state).hand.held == pytest.approx(scene.sim.squeeze, abs=1e-15)


COS30 = math.cos(math.radians(30.0))


@pytest.mark.parametrize("yaw_deg, table", [(0.0, (1.0, 1.0)), (90.0, (1.0, 1.0)), (45.0, (2 ** -0.5, 2 ** -0.5)),
                                            (30.0, (1 / (COS30 + 0.5), COS30))])
def test_the_pyramids_reach_along_gb(yaw_deg, table):
    """A slip along GB at yaw to the table's pyramid axes (the world's x and y) meets between
    mu / (|cos| + |sin|) and mu max(|cos|, |sin|) of friction: mu along an axis, mu / sqrt(2) between."""
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1] = [c, s, 0.0], [-s, c, 0.0]
    reach = PyramidReach.of(frame, (-math.cos(0.7), -math.sin(0.7)))
    assert reach.table == pytest.approx(table, abs=1e-12)
    assert reach.table[0] <= reach.table[1] and reach.thumb[0] <= reach.thumb[1]


@pytest.mark.parametrize("normal", [(0.0, 0.0, 1.0), (0.25, 0.433, 0.866), (0.0, -0.6, 0.8), (0.9, 0.3, 0.316)])
def test_the_contact_axes_are_mujocos(normal):
    """The tangent axes the pyramid's reach is taken from are those MuJoCo gives a contact of that
    normal (a sphere resting on a box turned so that its face has that normal, pyramidal cones)."""
    import mujoco
    from scipy.spatial.transform import Rotation

    from ungrasp_ompl.mechanics.release import _contact_axes

    n = np.array(normal) / np.linalg.norm(normal)
    rot, _ = Rotation.align_vectors([n], [[0.0, 0.0, 1.0]])
    quat = rot.as_quat()[[3, 0, 1, 2]]
    p = 0.01 * n + 0.0039 * n
    xml = f"""<mujoco><option cone="pyramidal" gravity="0 0 0"/><worldbody>
      <body quat="{' '.join(map(str, quat))}"><geom type="box" size="0.05 0.05 0.01"/></body>
      <body pos="{' '.join(map(str, p))}"><freejoint/><geom type="sphere" size="0.004"/></body>
    </worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    assert d.ncon >= 1
    frame = d.contact[0].frame.reshape(3, 3)
    t1, t2 = _contact_axes(frame[0])
    assert np.allclose(abs(frame[0] @ n), 1.0, atol=1e-6)
    assert np.allclose(t1, frame[1], atol=1e-9) and np.allclose(t2, frame[2], atol=1e-9)


# --- the prediction of a plan ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def pick():
    """The guitar pick from its start before decision 0107, as planned (no aim), and its RRT*
    plan of seed 1, which passes through a P_dpsi (the carry these tests read)."""
    from ungrasp_ompl import Scene
    from ungrasp_ompl.planning import plan
    from ungrasp_ompl.scene.options import Landing

    scene = Scene.from_dict(pick_before_0107())
    scene = replace(scene, robot=replace(scene.robot, landing=Landing.PLANNED))
    return scene, plan(scene, planner="RRTstar", time=1.0, seed=1)


def test_the_carried_start_keeps_b_on_the_thumb_and_g_on_the_table(pick):
    """Carried through the plan's P_dpsi, the object ends with G on the table and B on the thumb's
    face (where the plan puts the thumb), as far up it as the plan's P_dpsi would have slid it
    down; a plan without a P_dpsi starts where its last state puts it."""
    scene, plan = pick
    base = release_setup(scene, tuple(plan.states[-1]))
    start = carried_start(scene, plan, base)
    l, (tx, tz), (ex, ez) = scene.object_length, base.hand.tip, base.hand.axis
    b = np.array([start.g + l * math.cos(start.theta), l * math.sin(start.theta)])
    assert (b - (tx, tz)) @ (ez, -ex) == pytest.approx(0.0, abs=1e-12)  # on the face
    from ungrasp_ompl.mechanics.kinematics import s_b

    dg = scene.digits
    slid = sum(float(s_b(p.start[1], p.start[2], dg.alpha, dg.object_thickness, dg.finger_tip_radius)
                     - s_b(p.end[1], p.end[2], dg.alpha, dg.object_thickness, dg.finger_tip_radius)) * l
               for p in plan.primitives if p.type == "P_dpsi")
    assert slid > 0.001
    b0 = np.array([l * math.cos(base.start.theta), l * math.sin(base.start.theta)])
    up = np.array([-ex, -ez])
    assert (b - (tx, tz)) @ up == pytest.approx((b0 - (tx, tz)) @ up + slid, abs=1e-12)
    assert start.g > 0.001  # G slid toward B with the hand
    without = replace(plan, solution=replace(plan.solution, primitives=[p for p in plan.primitives
                                                                          if p.type != "P_dpsi"]))
    assert carried_start(scene, without, base) == base.start


def test_the_prediction_of_a_plan(pick):
    """predict_landing over the spread's worlds: the mean is the worlds' weighted mean, the spread
    their range, the nominal world's landing is the nominal one, the world offset runs along the
    plane's x; with the carry and without it; a rotate termination is not modelled."""
    scene, plan = pick
    p = predict_landing(scene, plan)
    alongs = [w.along for w in p.worlds]
    assert p.spread == pytest.approx(max(alongs) - min(alongs), abs=1e-15) and p.low <= p.along <= p.high
    # the middle: no world's landing lies further from it than half the spread, and both ends that far
    assert max(abs(a - p.middle) for a in alongs) == pytest.approx(p.spread / 2, abs=1e-15)
    nominal = [w for w in p.worlds if w.friction == 1.0 and w.cone == "elliptic"]
    assert nominal and nominal[0].along == p.nominal
    assert all(w.landed for w in p.worlds)
    frame = scene.plane.frame
    assert np.allclose(p.world, frame[:2, 0] * p.along, atol=1e-15) and p.across == 0.0
    planned = predict_landing(scene, plan, carried=False)
    assert planned.start.g == 0.0 and p.start.g > 0.0
    assert -0.005 < p.nominal < 0.002 and -0.005 < planned.nominal < 0.002  # millimetres, not centimetres
    rotating = replace(scene, robot=replace(scene.robot, termination="rotate"))
    with pytest.raises(ReleaseModelError):
        predict_landing(rotating, plan)


def test_plan_json_holds_the_predicted_landing(pick):
    """The prediction rides in plan.json (predicted_landing) and back, every key of it named on
    docs/plan-json.md; a plan without one holds null, and one that is not a mapping is refused."""
    from ungrasp_ompl.planning.result import Plan

    scene, plan = pick
    doc = predict_landing(scene, plan).to_dict()
    with_it = replace(plan, predicted_landing=doc)
    back = Plan.from_dict(json.loads(with_it.to_json()))
    assert back.predicted_landing == json.loads(json.dumps(doc))
    assert json.loads(plan.to_json())["predicted_landing"] is None
    named = set(re.findall(r"`(\w+)`", (ROOT / "docs" / "plan-json.md").read_text()))
    keys = set(doc) | {k for w in doc["worlds"] for k in w} | {"predicted_landing"}
    assert keys <= named, sorted(keys - named)
    bad = json.loads(plan.to_json())
    bad["predicted_landing"] = 3
    with pytest.raises(InputError) as err:
        Plan.from_dict(bad)
    assert err.value.field == "predicted_landing"


@pytest.mark.slow
@pytest.mark.parametrize("world", ["nominal", "friction x1.3"])
def test_the_prediction_is_the_simulated_landing(world):
    """The puzzle piece's RRT* plan of seed 1 to anywhere in its goal region (planning.release
    objective), the hand as planned, released with no error drawn in the simulator: the landing
    along GB lies within 0.5 mm of the model's (carried through the plan's P_dpsi, in that world's
    friction), and across GB within 0.2 mm of the plane."""
    from ungrasp_ompl import Scene
    from ungrasp_ompl.scene.perturbation import TrialParams
    from ungrasp_ompl.planning import plan as make_plan
    from ungrasp_ompl.scene.options import Landing, Release
    from ungrasp_ompl.sim.landing import landing_offset
    from ungrasp_ompl.sim.plan_trials import placement
    from ungrasp_ompl.sim.trial import run_trial
    from ungrasp_ompl.sim.world import World

    factor = {"nominal": 1.0, "friction x1.3": 1.3}[world]
    scene = Scene.from_file(ROOT / "scenes" / "puzzle_piece.yaml")
    scene = replace(scene, robot=replace(scene.robot, landing=Landing.PLANNED)).with_options(release=Release.OBJECTIVE)
    plan = make_plan(scene, planner="RRTstar", time=1.0, seed=1)
    base = release_setup(scene, tuple(plan.states[-1]))
    carried = replace(base, start=carried_start(scene, plan, base))
    mu_g, _, mu_b = scene.mu_contacts
    model = fall(carried, factor * mu_g, factor * mu_b).offset
    _, trial_setup = placement(scene, plan)
    trial_setup = replace(trial_setup, world=World(friction=factor))
    result = run_trial(trial_setup, TrialParams())
    assert result.placed
    offset = landing_offset(trial_setup, np.array(result.final_pose))
    frame = scene.plane.frame
    assert abs(offset @ frame[:2, 0] - model) < 0.0005
    assert abs(offset @ frame[:2, 1]) < 0.0002


# --- a pincer's release (mechanics.release.pincer_hand, docs/model.md 7) ----------------------------------

#: A pincer's last state, like the pincer puzzle piece's plans': theta 8 deg, d 0.675, psi 34.5 deg.
PINCER_STATE = (math.radians(8.0), 0.675, math.radians(34.5))


def pincer_setup(termination: str = "open") -> ReleaseSetup:
    """The pincer puzzle piece's release from PINCER_STATE, letting go by termination."""
    from ungrasp_ompl import Scene

    scene = Scene.from_file(ROOT / "scenes" / "pincer_puzzle_piece.yaml")
    scene = replace(scene, robot=replace(scene.robot, termination=termination))
    return release_setup(scene, PINCER_STATE)


def _face_angle(m: HandMotion, t: float) -> float:
    ex, ez, _ = m.face_at(t)
    return math.atan2(ez, ex)


@pytest.mark.parametrize("termination", ["open", "open_symmetric"])
def test_a_pincers_digits_turn_about_its_joint_at_the_rates_they_move(termination):
    """A pincer's hand: the thumb's tip, the finger's dome and the face's direction have velocities
    that are their positions' rates (central differences) through the opening's ramps, the pinch's
    letting go and the retreat; until the retreat both digits keep their distance from J (they turn
    about it) and J stays; once the pinch has let go, the open termination holds the thumb still
    (its tip and its face) while the finger turns the rest of the opening, and open_symmetric turns
    the thumb back by half of it; the finger's dome moves by the chord of its turn."""
    m = pincer_setup(termination).hand
    assert m.joint is not None and m.finger is not None
    h = 1e-6
    for t in np.linspace(0.001, m.end - 0.001, 60):
        for at in (m.thumb_at, m.finger_at):
            a, b = np.array(at(t - h)[:2]), np.array(at(t + h)[:2])
            assert np.allclose(at(t)[2:], (b - a) / (2 * h), atol=1e-6), (t, at.__name__)
        rate = (_face_angle(m, t + h) - _face_angle(m, t - h)) / (2 * h)
        assert m.face_at(t)[2] == pytest.approx(-rate, abs=1e-6)  # + turns e toward n_B: clockwise in (x, z)
        if t <= m.duration:
            assert m.palm_at(t)[:4] == (0.0, 0.0, 0.0, 0.0)
            for at, point in ((m.thumb_at, m.tip), (m.finger_at, m.finger)):
                assert math.dist(at(t)[:2], m.joint) == pytest.approx(math.dist(point, m.joint), abs=1e-15)
    after = np.linspace(m.released + 1e-4, m.duration, 20)
    thumb = np.array([m.thumb_at(t) for t in after])
    faces = np.array([_face_angle(m, t) for t in after])
    if termination == "open":
        assert np.ptp(thumb[:, :2], axis=0).max() < 1e-15 and np.abs(thumb[:, 2:]).max() == 0.0
        assert np.ptp(faces) < 1e-15
    else:  # the thumb turns back (counterclockwise in (x, z)) by half of what the joint opens
        assert faces[-1] - faces[0] == pytest.approx((m.opening - m.palm_at(after[0])[4]) / 2, abs=1e-12)
    # the finger turns with the palm while the pinch holds, then by its own turn: the chord of it
    palm, finger = m.turns[0], m.turns[2]
    turn = palm * m.opening + (finger - palm) * (m.opening - m.held)
    moved = math.dist(m.finger_at(m.duration)[:2], m.finger)
    assert moved == pytest.approx(2 * math.dist(m.finger, m.joint) * math.sin(turn / 2), abs=1e-15)


def test_without_friction_or_thumb_no_horizontal_force_acts_on_a_pincers_piece():
    """The pincer's pinch carries the piece (turning it about J with the palm) until the command has
    taken up the squeeze; after it, with no friction at G and no thumb, no horizontal force acts:
    the centre of mass keeps the horizontal velocity the carry gave it (not zero) and its place
    moves along in a straight line, to 1e-12, until the piece lies flat."""
    s = pincer_setup()
    assert s.hand.held > 0.0
    f = fall(s, 0.0, 0.0, thumb=False, trace=True)
    assert f.landed and f.carried != 0.0
    t, xg, zg, th, vx, vz, om = f.states[:-1].T  # the last row is the object flat after the landing
    x = xg + s.body.centre * np.cos(th) - s.body.thickness / 2 * np.sin(th)
    assert abs(vx[0]) > 1e-3
    assert np.ptp(vx) < 1e-12
    assert np.abs(x - (x[0] + vx[0] * (t - t[0]))).max() < 1e-12


@pytest.mark.parametrize("mu", [0.0, 0.3, math.inf])
def test_a_pincers_open_termination_does_no_work_on_the_piece(mu):
    """The pincer's open termination holds its thumb still (the palm turns half the joint's turn
    about J): with the squeeze taken up at once and no retreat, nothing but the piece moves where it
    touches, and its energy never grows along the fall, the thumb's face touching it."""
    s = pincer_setup()
    s = replace(s, hand=replace(s.hand, held=0.0, retreat=0.0))
    f = fall(s, mu, 0.4, trace=True)
    assert f.thumb_left is not None and f.thumb_left > s.hand.released  # the face held the piece a while
    e = energy(f.states[:-1], s.body)
    assert np.max(np.diff(e)) < 1e-9
    assert f.energy_gain < 1e-9


@pytest.mark.parametrize("t", [0.05, 0.3])
def test_a_turning_faces_contact_rows_are_the_gaps_derivatives(t):
    """A pincer's thumb face turning about J (open_symmetric, the pinch let go: the thumb turns back
    half the joint's opening): the face's normal velocity at B is minus the gap's rate at a fixed
    pose, and its tangential velocity there is that of the face's material point at B (the face's
    point at B's place along it, carried by the tip's move and the face's turn: central
    differences), so that the turn counts as well as the tip's move."""
    s = pincer_setup("open_symmetric")
    m = replace(s.hand, held=0.0)
    assert m.face_at(t)[2] != 0.0
    q = _centre(s.body, (0.0, 2e-6), s.start.theta)
    contact = next(c for c in contacts_at(s.body, m, *q, t, 0.3, 0.4, 1.0)[0] if c.key == "thumb")
    rate = (_gap(s.body, m, q, t + 1e-6, "thumb") - _gap(s.body, m, q, t - 1e-6, "thumb")) / 2e-6
    assert contact.wall_normal == pytest.approx(-rate, abs=1e-7)
    b = q[:2] + np.array([[math.cos(q[2]), -math.sin(q[2])], [math.sin(q[2]), math.cos(q[2])]]) @ (
        np.array([s.body.length, 0.0]) - (s.body.centre, s.body.thickness / 2))
    tip, (ex, ez, _) = np.array(m.thumb_at(t)[:2]), m.face_at(t)
    along, across = (b - tip) @ (-ex, -ez), (b - tip) @ (ez, -ex)

    def material(tt):
        fx, fz, _ = m.face_at(tt)
        return np.array(m.thumb_at(tt)[:2]) + along * np.array([-fx, -fz]) + across * np.array([fz, -fx])

    velocity = (material(t + 1e-6) - material(t - 1e-6)) / 2e-6
    assert contact.wall_tangent == pytest.approx(float(velocity @ (-ex, -ez)), abs=1e-7)
    assert contact.wall_normal == pytest.approx(float(velocity @ (ez, -ex)), abs=1e-7)
