"""One simulated trial: the object in the pinch, the gripper driven open-loop, the outcome judged.

Sequence: the object is put at the plan's start pose (plus the trial's perturbation), the jaws
at the planned opening; where the errors put the object into the table, hand and object start
that much higher and the hand lowers it onto the table in the first half of the settling, as
the arm would have set it down (the object slides in the pinch as the contacts let it, never
through a digit); where they leave it above the table it hangs there, or, when it was handed
over at the start (sim.handed_over), it starts slid along GB in the pinch until it rests on the
table; a start press (robot.start_press) starts the hand that much higher, at the planned start
pinch, and brings it down in the same way; the world settles with the palm still (gravity, the
servo squeezing); then every control period the palm's target is moved to the drive's next pose,
a step of the way per simulation step (so the palm, welded to it, moves with the velocity the
contacts' friction sees), and the servo is commanded the planned opening less the squeeze; after
the retreat the world rests, and the outcome is read off (or, once the palm lifts away and
everything free lies still, untouched by the digits, at once: see Stillness). A calibration
error offsets the whole commanded trajectory (and the object the hand holds at the start) by
one rigid transform, and moves the table, as a miscalibrated arm and table would; where the
set-up touches the table off first (robot.touch_off), the commands are moved up or down by what
the probe found (touch_off_shift).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from .drive import GripperDrive
from .model import Keyframe, ModelIds, build_mjcf, model_ids
from .spec import SimModelSpec
from .world import Cone, World
from .outcome import FLAT_TILT_DEG, ContactTravel, Outcome, TrialResult
from .probe import TouchOffProbe, calibrate, noise_sequence, periods_within, probing
from ..mechanics.kinematics import GRAVITY
from ..scene.options import SimOptions
from ..scene.perturbation import TrialParams
from ..robot.pipeline import Aim
from ..robot.touch_off import TouchOffOptions

#: A start tilted less than this (the sine of its tilt) cannot be slid down to the table along GB: it hangs.
SLIDE_MIN_RISE = 0.1
#: No digit touching the object this long (s), or A or B absent this long when the termination
#: begins, is a lost grip (docs/model.md 11.4); it bridges ticks at which a sliding contact parts.
LOSS_WINDOW = 0.05
#: How far (m) the object may move with a contact of its pinch parted before the grip counts as
#: lost: the 1 mm shift in the grasp that the plans absorb (the `paper` errors' bound).
GRIP_SLACK = 0.001
#: The longest A or B may be absent before the termination (s): the time in which the object,
#: held by nothing but gravity where that contact was, moves GRIP_SLACK, sqrt(2 GRIP_SLACK / g),
#: 14.3 ms, seven control ticks of 2 ms (docs/model.md 11.4).
MAX_CONTACT_GAP = (2.0 * GRIP_SLACK / GRAVITY) ** 0.5
#: A digit this near the object (m) touches it though its engine reports no contact: 1 um, below the
#: roughness of the faces that meet (a printed PLA digit's, plywood's, celluloid's, chalk's) and of
#: the order of the soft contact's give under the grip's load; a thumb resting on the object at no
#: load a few nanometres off is no parted contact (docs/model.md 11.4, record 0133).
TOUCH_DISTANCE = 1e-6
#: Turned out of the manipulation plane by more than this (deg) while held: it left the plane.
LEFT_PLANE_DEG = 10.0
#: Slower than this (m/s, and STILL_SPIN rad/s) for STILL_WINDOW s, a free body on the table lies still.
STILL_SPEED = 1e-4
STILL_SPIN = 1e-3
STILL_WINDOW = 0.05


@dataclass(frozen=True)
class PlannedTravel:
    """How far the plan moves A and B over one primitive (m): net displacements on the object
    and on the digits between the primitive's first and last states (sim.setup computes them)."""

    primitive: str  #: the primitive's type
    a_on_object: float
    a_on_finger: float
    b_on_object: float
    b_on_thumb: float


@dataclass(frozen=True)
class TrialSetup:
    """What every trial of one placement shares (plain data, so it crosses to worker processes).

    start_pose: 4x4 world pose of the object's body frame at the plan's start state;
    target_pose: the same when the object lies at its target; grasp_point: the body-frame point
    (m) about which a perturbed grasp turns (A at the start); b_point: B in the body frame (m);
    sim: the scene's simulation options, whole (scene.options.SimOptions: sim.squeeze, m at the
    fingertip; sim.settle_time and sim.rest_time, s of stillness before the drive and after it;
    sim.max_error, m, the largest placement error that counts as placed; sim.handed_over: the
    object was set into the gripper at the start pose with its end on the table, so that
    perturbed_start slides it down to the table instead of leaving it hanging); the servo's own
    command is servo_squeeze, derived from sim.squeeze and the gripper (a pincer's is an angle);
    the world built from sim (its timestep, density and grip force) is spec's, which the engines read;
    planned: per primitive, how far the plan moves A and B; touch_off: the set-up measured the
    table's height under the start pinch (robot.touch_off, touch_off_shift) and runs the plan from
    what it found; aim: how the hand's motion is moved from the plan's frame (robot.pipeline.Aim),
    by which the robot corrects the landing (sim.landing), the target staying where it is; world:
    how the world the trials run in differs from the scene's (sim.world), which neither the plan
    nor its aim sees; max_contact_gap: the longest A or B may be absent before the termination (s,
    Grip), inf for the rule that let one contact part for any time; friction_draw_in_world: a
    pair's drawn friction error applies on top of the world's factor for that pair (the
    compounding rule, for comparison; by default a world that sets a pair's friction fixes it,
    docs/decisions/0100-a-world-fixes-its-friction.md).
    """

    spec: SimModelSpec  #: the trial's world as the engines build it (m, kg, s)
    drive: GripperDrive  #: the palm's poses and the openings at the control ticks (s, m)
    start_pose: NDArray[np.float64]  #: 4x4, the object's world pose at the plan's start (m)
    target_pose: NDArray[np.float64]  #: 4x4, the same at its target (m)
    grasp_point: NDArray[np.float64]  #: (3,), where a perturbed grasp turns, body frame (m)
    b_point: NDArray[np.float64]  #: (3,), B in the body frame (m)
    sim: SimOptions = SimOptions()  #: the scene's simulation options (m, s; see the class's docstring)
    planned: tuple[PlannedTravel, ...] = ()  #: per primitive, how far the plan moves A and B (m)
    touch_off: bool = False  #: the set-up touches the table off under the start pinch first
    aim: Aim = Aim()  #: how the hand's motion is moved from the plan's frame (m, rad)
    world: World = World()  #: how the trials' world differs from the scene's
    max_contact_gap: float = MAX_CONTACT_GAP  #: the longest A or B may be absent before the termination (s)
    friction_draw_in_world: bool = False  #: a drawn friction error compounds with the world's factor

    @property
    def servo_squeeze(self) -> float:
        """How far inside the planned opening the servo is commanded, in the drive's opening's unit:
        sim.squeeze (m) for jaws that slide; for a pincer (spec.gripper.hinge) the joint angle (rad)
        that turns the fingertip that far, sim.squeeze over the hinge's radius. Derived, not stored,
        so that it always matches sim and the gripper."""
        hinge = self.spec.gripper.hinge
        return self.sim.squeeze if hinge is None else self.sim.squeeze / hinge.radius

    def to_release(self) -> "TrialSetup":
        """The same trial cut at the release: its drive up to the first tick at which the termination
        opens the pinch (the last tick whose contacts a trial measures, Judge.tick), no rest after.
        Up to that tick it is the whole trial, step for step (TrialResult.max_penetration_mm and the
        contacts' figures are the same); its verdict and final pose are not a placement's. For what
        the primitives alone show, such as how deep the contacts sink (tools/sinking_bound.py)."""
        return replace(self, drive=self.drive.until(self.drive.phase_start("termination")),
                       sim=replace(self.sim, rest_time=0.0))


def _rot_z(angle: float) -> NDArray[np.float64]:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def calibration_offset(drive: GripperDrive, params: TrialParams) -> NDArray[np.float64]:
    """The world transform (4x4) a miscalibrated arm applies to everything it is told: the
    trial's palm error (a turn about and a shift along the palm's own axes at the first tick)."""
    delta = np.eye(4)
    rx, ry, rz = np.radians(params.palm_turn_deg)
    cx, sx, cy, sy = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry)
    delta[:3, :3] = _rot_z(rz) @ np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]]) \
        @ np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    delta[:3, 3] = np.asarray(params.palm_shift_mm) / 1000
    palm0 = drive.palm[0]
    return palm0 @ delta @ np.linalg.inv(palm0)


def digits_lowest(model, data, ids: ModelIds, drive: GripperDrive, error: NDArray) -> float:
    """The world height (m) of the simulated digits' lowest point (their mesh vertices and the
    finger's dome) with the palm at the start pinch (where a start press begins, or the drive's
    first pose), moved by error (4x4, a world transform of everything the arm is told), and the
    jaws at the first opening. Leaves data's kinematics at that pose without the error."""
    import mujoco

    _place_hand(model, data, ids, drive.palm[0] if drive.press_from is None else drive.press_from,
                drive.opening[0], np.zeros(4))
    mujoco.mj_kinematics(model, data)
    rot, shift = error[:3, :3], error[:3, 3]
    low = math.inf
    for g in ids.thumb_geoms | ids.finger_geoms:
        at = rot @ data.geom_xpos[g] + shift
        if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            m = model.geom_dataid[g]
            verts = model.mesh_vert[model.mesh_vertadr[m]:model.mesh_vertadr[m] + model.mesh_vertnum[m]]
            low = min(low, float((verts @ (rot @ data.geom_xmat[g].reshape(3, 3)).T + at)[:, 2].min()))
        else:  # the finger's dome, a sphere
            low = min(low, float(at[2] - model.geom_size[g][0]))
    return low


def touch_off_shift(setup: TrialSetup, model, ids: ModelIds, error: NDArray, params: TrialParams) -> TouchOffProbe:
    """The trial's touch-off (robot.touch_off; sim.probe, docs/model.md 11.14): in the trial's
    world (model, the object out of it while the probe runs) the empty hand, at the start pinch's
    orientation and opening, starts TouchOffOptions.lift above the start pinch, as the arm
    commands it and its calibration error (error, calibration_offset) takes it, and is lowered
    along the arm's z until the wrist's force reading, with the sensor's noise
    (params.probe_noise_n, probe_seed), passes the threshold. Its found (m) is the calibration's
    descent (sim.probe.calibrate, on a table at the known height in the trial's world, none of the
    trial's errors drawn) less the trial's: how much higher
    than the plan has it the table stands, along the arm's z; the set-up runs the plan that much
    higher. Only the commanded descent and the readings decide it. Its error, the record, is
    found less what an exact probe would have found: how much lower than the plan has it the
    simulated digits' lowest point stands above the trial's table (at params.table_height_mm),
    error applied (digits_lowest), along the arm's z."""
    import mujoco

    drive, options = setup.drive, TouchOffOptions()
    pinch, opening = (drive.palm[0] if drive.press_from is None else drive.press_from), float(drive.opening[0])
    # calibrated once on a surface at a known height in the world the cell is (its contacts, its
    # digits), with none of the trial's errors
    calibration = calibrate(trial_spec(setup, TrialParams()), pinch, opening, options, params.probe_noise_n)
    noise = noise_sequence(params.probe_noise_n, params.probe_seed, periods_within(calibration.reach, options))
    # the arm's error as the trial's own commands take it: none at all where it is calibrated
    with probing(model, ids, pinch, opening, options, None if params.calibrated else error) as hand:
        descent = hand.descend(noise, options.threshold, calibration.reach)
    found = calibration.descent - descent.descent
    data = mujoco.MjData(model)  # the record, after the fact
    exact = (digits_lowest(model, data, ids, drive, np.eye(4)) - digits_lowest(model, data, ids, drive, error)
             + params.table_height_mm / 1000) / float(error[2, 2])
    return TouchOffProbe(found, found - exact, descent, calibration)


def perturbed_start(setup: TrialSetup, params: TrialParams, thickness: float,
                    error: NDArray) -> tuple[NDArray[np.float64], float]:
    """The object's start pose with the trial's errors, and how far (m) the hand must still lower
    it: error, the world transform the arm applies to its commands (calibration_offset, and a
    touch-off's shift; the object is in the hand, which is not quite where it is told),
    then the grasp error (a turn by yaw_deg about the normal through the grasp point and a shift
    in the object's own plane, along GB and across it). Where a corner of the prism would then
    reach into the table, the pose is raised straight up until it touches it, and the depth it
    reached is the lowering: the hand starts as much higher, holding the object as it was told to
    (touch_down lowers both). Where the prism would stay above the table, it hangs there, unless
    the object was handed over (setup.sim.handed_over): it is then slid along GB toward G in the pinch
    until its lowest corner touches the table (docs/model.md 11.3), if it is tilted enough to reach
    it so; the lowering is then 0."""
    local = np.eye(4)
    turn = _rot_z(math.radians(params.yaw_deg))
    p = setup.grasp_point
    local[:3, :3] = turn
    local[:3, 3] = p - turn @ p + np.array([params.shift_along_mm, params.shift_across_mm, 0.0]) / 1000
    pose = error @ setup.start_pose @ local
    outline = setup.spec.obj.outline
    corners = np.vstack([np.column_stack([outline, np.full(len(outline), z)]) for z in (0.0, thickness)])
    gap = float(np.min((corners @ pose[:3, :3].T + pose[:3, 3])[:, 2])) - params.table_height_mm / 1000
    rise = float(pose[2, 0])  # the height gained per metre along GB (body x, from G to B): sin of the tilt
    if setup.sim.handed_over and gap > 0.0 and rise >= SLIDE_MIN_RISE:
        pose[:3, 3] -= pose[:3, 0] * (gap / rise)
    lowering = max(-gap, 0.0)
    pose[2, 3] += lowering
    return pose, lowering


def touch_down(model, data, ids: ModelIds, palm: NDArray, offset: NDArray, duration: float) -> None:
    """Step the world for duration (s) while the palm, offset (3,) m from its pose palm (4x4), comes
    to it in a straight line at a constant speed over the first half and then stays (the settling of
    the trial's start: the lowering of a hand too low, a start press straight down; with offset 0
    the palm never moves). The table meets the object on the way, and the object slides in the
    pinch as its contacts let it."""
    import mujoco

    steps = max(1, round(duration / model.opt.timestep))
    if not np.any(offset):
        mujoco.mj_step(model, data, nstep=steps)
        return
    quat = _palm_quats(palm[None])[0]
    moving = steps // 2
    _move_palm(model, data, ids, (palm[:3, 3] + offset, quat), (palm[:3, 3], quat), moving)
    mujoco.mj_step(model, data, nstep=steps - moving)


def trial_spec(setup: TrialSetup, params: TrialParams) -> SimModelSpec:
    """The nominal model in the setup's world (setup.world: its friction, densities, cone, contact
    stiffness and jaw force; pyramidal cones at their own step, sim.pyramidal_timestep), with the
    trial's friction, mass, thickness and table height. The trial's drawn friction factors apply
    only to pairs whose friction the world leaves alone (unless setup.friction_draw_in_world)."""
    spec, world = setup.spec, setup.world
    fg, fa, fb = params.friction_scale
    table, digits = world.friction_factors
    if not setup.friction_draw_in_world:  # the world's factor is the pair's friction error
        table_fixed, digits_fixed = world.fixed_friction
        fg = 1.0 if table_fixed else fg
        fa, fb = (1.0, 1.0) if digits_fixed else (fa, fb)
    fr = spec.friction
    obj = replace(spec.obj, thickness=spec.obj.thickness * params.thickness_scale,
                  density=spec.obj.density * world.density * params.mass_scale / params.thickness_scale)
    placed = tuple((name, replace(other, density=other.density * world.density), pose)
                   for name, other, pose in spec.placed)
    return replace(spec, obj=obj, placed=placed, table_height=params.table_height_mm / 1000,
                   friction=replace(fr, table=fr.table * table * fg, finger=fr.finger * digits * fa,
                                    thumb=fr.thumb * digits * fb, solids=fr.solids * table * fg),
                   grip_force=spec.grip_force * world.jaw_force, cone=str(world.cone),
                   contact_time=spec.contact_time * world.time_constant_factor,
                   timestep=setup.sim.pyramidal_timestep if world.cone is Cone.PYRAMIDAL else spec.timestep)


class StillWindow:
    """Whether the free bodies have lain still, untouched by the digits, for STILL_WINDOW s
    (engine-free: an engine tells it at each control tick whether anything moves or is touched)."""

    def __init__(self):
        self.since: float | None = None

    def note(self, t: float, moving: bool, touched: bool) -> bool:
        """Note the world at time t (s); True once it has been still for STILL_WINDOW."""
        if moving or touched:
            self.since = None
            return False
        self.since = t if self.since is None else self.since
        return t - self.since >= STILL_WINDOW - 1e-9


def moving(v: NDArray) -> bool:
    """Whether any free body of velocities v (n, 6: linear m/s, angular rad/s) moves faster than
    STILL_SPEED or STILL_SPIN."""
    return bool((np.linalg.norm(v[:, :3], axis=1) > STILL_SPEED).any()
                or (np.linalg.norm(v[:, 3:], axis=1) > STILL_SPIN).any())


class Stillness(StillWindow):
    """Whether the trial's outcome is settled during the retreat: every free body (the object, the
    pieces already down) has moved slower than STILL_SPEED and STILL_SPIN, with no digit touching
    any of them, for STILL_WINDOW s. The retreat lifts the palm straight up and the rest that
    follows adds nothing, so from then on no force but gravity and the table's acts on them: the
    trial's end is read off there instead of simulating the last second and a half."""

    def __init__(self, model, ids: ModelIds):
        super().__init__()
        bodies = [ids.object_body, *ids.placed_bodies]
        self.dofs = np.concatenate([np.arange(model.body_dofadr[b], model.body_dofadr[b] + 6) for b in bodies])
        self.free = np.isin(model.geom_bodyid, bodies)
        self.digit = np.zeros(model.ngeom, bool)
        self.digit[list(ids.finger_geoms | ids.thumb_geoms)] = True

    def settled(self, data, t: float) -> bool:
        """Note the world at time t (s); True once it has been still for STILL_WINDOW."""
        g = data.contact.geom[:data.ncon]
        touched = bool(((self.digit[g[:, 0]] & self.free[g[:, 1]]) | (self.digit[g[:, 1]] & self.free[g[:, 0]])).any())
        return self.note(t, moving(data.qvel[self.dofs].reshape(-1, 6)), touched)


#: The digits' bodies as both engines' contact readers name them (Touch.kind): a rounded finger's
#: dome ('finger_tip') apart from the rest of the finger.
DIGIT_KINDS = ("thumb", "finger", "finger_tip")


class Touch(NamedTuple):
    """One contact of the object as an engine reports it (read_contacts reads it)."""

    #: what touches the object: 'table', 'solid' (a wall or a piece down) or one of DIGIT_KINDS; any other is not followed
    kind: str | None
    force: float  #: its normal force (N)
    points: NDArray  #: where it touches (n, 3), world frame, m
    #: how deep the object reaches into the other body (m); None: read_contacts' depth_of tells it
    depth: float | None


def read_contacts(touches: list[Touch], table_pushes: list[float], frame: Callable[[str], tuple[NDArray, NDArray]],
                  b_point: NDArray, depth_of: Callable[[Touch], float] | None = None,
                  near: Callable[[str], bool] | None = None) -> _Tick:
    """The object's contacts at one control tick (a _Tick) from what an engine reports: touches,
    the object's contacts; table_pushes, the normal force (N) of each contact of a digit with the
    table; frame(name), the orientation (3, 3) and origin (3,) of the body 'object' or 'finger'
    now (world); b_point, B in the object's body frame (m); depth_of(touch), a contact's depth (m)
    where the engine left it None; near(digit), whether the 'thumb' or the 'finger' (its tip
    included) lies within TOUCH_DISTANCE of the object, asked only of a digit no touch reports:
    such a digit touches the object, at no force. A is the finger's pressing contact point nearest its tip (the
    farthest along the finger's axis); B is recorded as the thumb's pressing contact points and
    the object's end (where a face lies along the object, psi near 0, an engine spreads the
    contact over the corners of the overlap, and the plan's B is the end: _Travel reduces them).
    Engine-free: MuJoCo's trial (_Watch) and Drake's (sim.drake_trial._DrakeWatch) read their
    engines' contacts into Touches, and the rule that sorts them is this one."""
    tick = _Tick()
    if table_pushes:
        tick.digit_on_table = True
        tick.table_push = max([0.0, *table_pushes])
    if not touches:
        return _near(tick, near)
    tick.touched = True
    pressing_a, pressing_b = [], []
    for touch in touches:
        kind, force = touch.kind, touch.force
        if kind == "solid":
            tick.solid = True
            continue
        if kind != "table" and kind not in DIGIT_KINDS:
            continue
        tick.sinking = max(tick.sinking, touch.depth if touch.depth is not None else depth_of(touch))
        if kind == "table":
            continue
        if kind == "thumb":
            tick.b = True
            if force > 0:
                pressing_b.append(touch.points)
            continue
        tick.a = True
        if kind == "finger_tip":
            tick.on_dome += force
        else:
            tick.off_dome += force
        if force > 0:
            pressing_a.append(touch.points)
    if pressing_a and pressing_b:
        rot, origin = frame("finger")
        axis, far = rot[:, 2], -math.inf
        for points in pressing_a:
            for p in points:
                if (along := float((p - origin) @ axis)) > far:
                    tick.a_point, far = p, along
        tick.a_point = tick.a_point.copy()
        tick.b_points = np.vstack(pressing_b)
        rot, origin = frame("object")
        tick.b_end = rot @ b_point + origin
    return _near(tick, near)


def _near(tick: _Tick, near: Callable[[str], bool] | None) -> _Tick:
    """tick with the thumb or the finger counted touching where no touch reported it but near does."""
    if near is not None:
        if not tick.b and near("thumb"):
            tick.b = tick.touched = True
        if not tick.a and near("finger"):
            tick.a = tick.touched = True
    return tick


class _Watch:
    """The object's contacts per control tick from MuJoCo's contact list (read_contacts judges
    them). One pass over the list as plain Python values: with a handful of contacts a tick,
    numpy's per-call overhead would cost more than the arithmetic (a trial looks at over a
    thousand ticks)."""

    def __init__(self, model, ids: ModelIds):
        import mujoco

        self.object = ids.object_geom
        self.table = ids.table_geom
        kind: list[str | None] = [None] * model.ngeom
        for g in ids.finger_geoms:
            kind[g] = "finger_tip" if g == ids.finger_dome else "finger"
        for g in ids.thumb_geoms:
            kind[g] = "thumb"
        for g in ids.solid_geoms:
            kind[g] = "solid"
        kind[ids.table_geom] = "table"
        self.kind = kind
        self.model = model
        self.digits = {"thumb": sorted(ids.thumb_geoms), "finger": sorted(ids.finger_geoms)}  #: near's geoms
        # a contact's normal force: its first constraint row under elliptic cones; under pyramidal
        # ones the sum of its 2 (condim - 1) edge forces (each edge is the normal plus mu times a
        # tangent, so their normal parts add up)
        self.rows = 1 if model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC else 2 * (3 - 1)

    def forces(self, model, data) -> dict[str, NDArray[np.float64]]:
        """The force (N, world frame, 3) each kind of geometry (table, thumb, finger, finger_tip,
        solid) exerts on the object now, summed over its contacts, as Drake's watch gives it
        (sim.drake_trial)."""
        import mujoco

        out: dict[str, NDArray[np.float64]] = {}
        f6 = np.zeros(6)
        for i, (g1, g2) in enumerate(data.contact.geom.tolist()):
            if self.object not in (g1, g2):
                continue
            kind = self.kind[g2 if g1 == self.object else g1]
            if kind is None:
                continue
            mujoco.mj_contactForce(model, data, i, f6)
            on_g2 = data.contact.frame[i].reshape(3, 3).T @ f6[:3]  # along the normal from geom1 to geom2
            out[kind] = out.get(kind, np.zeros(3)) + (-on_g2 if g1 == self.object else on_g2)
        return out

    def _normal(self, force, adr: int) -> float:
        """The normal force (N) of the contact whose constraint rows start at adr (-1: none)."""
        if adr < 0:
            return 0.0
        return float(force[adr]) if self.rows == 1 else float(force[adr:adr + self.rows].sum())

    def look(self, data, object_body: int, finger_body: int, b_point: NDArray) -> _Tick:
        """What the object's contacts are now, and whether a digit touches the table (read_contacts)."""
        if data.ncon == 0:
            return _near(_Tick(), partial(self.near, data))
        con, kind, obj, table = data.contact, self.kind, self.object, self.table
        dist, adr, force, pos = con.dist.tolist(), con.efc_address.tolist(), data.efc_force, con.pos
        touches, pushes = [], []
        for i, (g1, g2) in enumerate(con.geom.tolist()):
            if g1 == obj or g2 == obj:
                touches.append(Touch(kind[g2 if g1 == obj else g1], self._normal(force, adr[i]), pos[i:i + 1], -dist[i]))
            elif (g1 == table or g2 == table) and kind[g2 if g1 == table else g1] in DIGIT_KINDS:
                pushes.append(self._normal(force, adr[i]))
        bodies = {"object": object_body, "finger": finger_body}

        def frame(name: str) -> tuple[NDArray, NDArray]:
            return data.xmat[bodies[name]].reshape(3, 3), data.xpos[bodies[name]]

        return read_contacts(touches, pushes, frame, b_point, near=partial(self.near, data))

    def near(self, data, digit: str) -> bool:
        """Whether a geom of the digit ('thumb' or 'finger') lies within TOUCH_DISTANCE of the object
        (mj_geomDistance, the engine's own distance)."""
        import mujoco

        return any(mujoco.mj_geomDistance(self.model, data, g, self.object, TOUCH_DISTANCE, None) < TOUCH_DISTANCE
                   for g in self.digits[digit])


@dataclass
class Grip:
    """Whether the digits still hold the object, from whether A and B touch it at each control
    tick before the termination (docs/model.md 11.4). The grip is lost when A or B has
    been absent for max_gap (s), when no digit has touched the object for LOSS_WINDOW, or when the
    termination begins with A or B absent for the shorter of the two. Times are s from the first
    primitive's start; max_gap inf is the rule of 11.4 alone (one contact may part for any time).
    """

    max_gap: float = MAX_CONTACT_GAP  #: the longest A or B may be absent (s)
    a_off: float | None = None  #: since when (s) the finger's contact A has been absent; None while it touches
    b_off: float | None = None  #: the same for the thumb's contact B
    a_gap: float = 0.0  #: the longest A has been absent so far (s), first tick without it to the last
    b_gap: float = 0.0  #: the same for B
    last: float = 0.0  #: the last tick noted (s)

    def note(self, t: float, a: bool, b: bool) -> float | None:
        """Note the tick at t (s) with A and B touching or not; return when the grip was lost (s,
        the first tick of the absence that lost it) once A or B has been absent for max_gap or no
        digit has touched the object for LOSS_WINDOW, else None."""
        self.a_off = None if a else (t if self.a_off is None else self.a_off)
        self.b_off = None if b else (t if self.b_off is None else self.b_off)
        if self.a_off is not None:
            self.a_gap = max(self.a_gap, t - self.a_off)
        if self.b_off is not None:
            self.b_gap = max(self.b_gap, t - self.b_off)
        self.last = t
        gone = [off for off in (self.a_off, self.b_off) if off is not None and t - off >= self.max_gap]
        if self.a_off is not None and self.b_off is not None:
            free = max(self.a_off, self.b_off)
            if t - free >= LOSS_WINDOW:
                gone.append(free)
        return min(gone) if gone else None

    def pinch_lost(self) -> float | None:
        """At the termination's start: when (s) the contact that has been absent for the last
        LOSS_WINDOW (or max_gap, the shorter) before it went (the earlier of A and B), or None if
        the pinch is there."""
        window = min(LOSS_WINDOW, self.max_gap)
        gone = [off for off in (self.a_off, self.b_off) if off is not None and self.last - off >= window]
        return min(gone) if gone else None


@dataclass
class _Tick:
    """The object's contacts at one control tick."""

    touched: bool = False  #: anything touches the object
    a: bool = False  #: the finger touches it
    b: bool = False  #: the thumb touches it
    solid: bool = False  #: a wall or a piece touches it
    digit_on_table: bool = False  #: a digit touches the table
    table_push: float = 0.0  #: the largest normal force (N) of a digit's contact on the table
    sinking: float = 0.0  #: deepest into a digit or the table (m)
    on_dome: float = 0.0  #: A's normal force on a rounded tip's dome (N)
    off_dome: float = 0.0  #: A's normal force on the rest of the finger (N)
    a_point: NDArray | None = None  #: A (world, m), where both A and B press
    b_points: NDArray | None = None  #: the thumb's contact points (world, m)
    b_end: NDArray | None = None  #: the object's end B (world, m)


class _Travel:
    """Where A and B were on the object and on their digits at a primitive's first and last
    ticks with both contacts held (body-frame points, m; B on the object as the thumb's
    contact points, reduced to one point at the end)."""

    def __init__(self, b_end: NDArray):
        self.b_end = b_end  #: the object's end B in its body frame (m)
        self.first: dict[int, tuple[NDArray, NDArray]] = {}
        self.last: dict[int, tuple[NDArray, NDArray]] = {}

    def note(self, k: int, points: NDArray, b_on_object: NDArray) -> None:
        self.first.setdefault(k, (points, b_on_object))
        self.last[k] = (points, b_on_object)

    def _b(self, contacts: NDArray) -> NDArray:
        return np.append(_nearest_in_hull(contacts[:, :2], self.b_end[:2]), 0.0)

    def travels(self, planned: tuple[PlannedTravel, ...]) -> list[ContactTravel]:
        out = []
        for k, plan in enumerate(planned):
            if k in self.first:
                (p0, b0), (p1, b1) = self.first[k], self.last[k]
                p0, p1 = p0.copy(), p1.copy()
                p0[2], p1[2] = self._b(b0), self._b(b1)
                moved = np.linalg.norm(p1 - p0, axis=1) * 1000
            else:
                moved = np.full(4, math.nan)
            out.append(ContactTravel(plan.primitive, float(moved[0]), plan.a_on_object * 1000, float(moved[1]),
                                     plan.a_on_finger * 1000, float(moved[2]), plan.b_on_object * 1000,
                                     float(moved[3]), plan.b_on_thumb * 1000))
        return out


def _nearest_in_hull(points: NDArray, q: NDArray) -> NDArray[np.float64]:
    """The point of the convex hull of 2D points nearest q (q itself when inside)."""
    pts = sorted(map(tuple, np.round(points, 12)))
    if len(pts) > 2:  # Andrew's monotone chain
        def half(seq):
            h: list = []
            for p in seq:
                while len(h) >= 2 and (h[-1][0] - h[-2][0]) * (p[1] - h[-2][1]) - (h[-1][1] - h[-2][1]) * (p[0] - h[-2][0]) <= 0:
                    h.pop()
                h.append(p)
            return h[:-1]
        pts = half(pts) + half(pts[::-1])
    hull = np.array(pts)
    if len(hull) > 2:
        edges = np.roll(hull, -1, axis=0) - hull
        if np.all(edges[:, 0] * (q[1] - hull[:, 1]) - edges[:, 1] * (q[0] - hull[:, 0]) >= 0):
            return np.asarray(q, dtype=float)
    if len(hull) == 1:
        return hull[0]
    ends = np.roll(hull, -1, axis=0) if len(hull) > 2 else hull[1:]
    starts = hull if len(hull) > 2 else hull[:1]
    seg = ends - starts
    s = np.clip(np.sum((q - starts) * seg, axis=1) / np.maximum(np.sum(seg * seg, axis=1), 1e-30), 0.0, 1.0)
    near = starts + s[:, None] * seg
    return near[int(np.argmin(np.sum((near - q) ** 2, axis=1)))]


def _pose(data, body: int) -> NDArray[np.float64]:
    pose = np.eye(4)
    pose[:3, :3] = data.xmat[body].reshape(3, 3)
    pose[:3, 3] = data.xpos[body]
    return pose


def _frame_pose(rot: NDArray, origin: NDArray) -> NDArray[np.float64]:
    """The 4x4 pose of a body's orientation (3, 3) and origin (3,)."""
    pose = np.eye(4)
    pose[:3, :3] = rot
    pose[:3, 3] = origin
    return pose


def _in_frame(frame: tuple[NDArray, NDArray], point: NDArray) -> NDArray[np.float64]:
    """A world point in a body's frame (orientation (3, 3), origin (3,)), m."""
    return frame[0].T @ (point - frame[1])


def _set_palm(data, ids: ModelIds, pose: NDArray, quat: NDArray) -> None:
    """Put the palm's target at pose (4x4) at once (quat: a (4,) scratch array)."""
    import mujoco

    data.mocap_pos[ids.palm_mocap] = pose[:3, 3]
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(pose[:3, :3]).ravel())
    data.mocap_quat[ids.palm_mocap] = quat


def _place_hand(model, data, ids: ModelIds, pose: NDArray, opening: float, quat: NDArray) -> None:
    """Put the palm itself (the free body) at pose (4x4) and its jaws at opening (m), in data.qpos
    (quat: a (4,) scratch array, left holding the palm's unit quaternion)."""
    import mujoco

    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(pose[:3, :3]).ravel())
    palm_q = model.jnt_qposadr[model.body_jntadr[ids.palm_body]]
    data.qpos[palm_q:palm_q + 3], data.qpos[palm_q + 3:palm_q + 7] = pose[:3, 3], quat
    for jaw, side in ((ids.thumb_jaw, -1.0), (ids.finger_jaw, 1.0)):
        data.qpos[model.jnt_qposadr[model.body_jntadr[jaw]]] = side * opening / 2


def _palm_quats(poses: NDArray) -> NDArray[np.float64]:
    """Unit quaternions (K, 4) of the palm poses (K, 4, 4), each in the hemisphere of the one before
    (so that interpolating two neighbours turns the short way)."""
    import mujoco

    out = np.zeros((len(poses), 4))
    for k, pose in enumerate(poses):
        mujoco.mju_mat2Quat(out[k], np.ascontiguousarray(pose[:3, :3]).ravel())
        if k and out[k] @ out[k - 1] < 0:
            out[k] = -out[k]
    return out


def _move_palm(model, data, ids: ModelIds, start: tuple[NDArray, NDArray], end: tuple[NDArray, NDArray],
               nstep: int) -> None:
    """Step the world nstep times while the palm's target goes from start to end ((position (3,) m,
    unit quaternion (4,)) each) at a constant speed, one step of the way per step: the palm moves
    as smoothly as the arm does between two control periods, with the velocity MuJoCo's friction
    sees (a target that jumped once a period would leave the palm still between the jumps)."""
    import mujoco

    frac = np.arange(1, nstep + 1)[:, None] / nstep
    pos = start[0] + frac * (end[0] - start[0])
    quat = start[1] + frac * (end[1] - start[1])
    quat /= np.linalg.norm(quat, axis=1)[:, None]
    mpos, mquat, m = data.mocap_pos, data.mocap_quat, ids.palm_mocap
    for i in range(nstep):
        mpos[m] = pos[i]
        mquat[m] = quat[i]
        mujoco.mj_step(model, data)


#: Where the object, held at its start, would reach into a wall or a piece down, the hand and the
#: object start this much higher at a time (m), and at most START_RAISE_MAX higher, and come down
#: together in the settling (touch_down), meeting that wall or piece on the way as a hand lowering
#: a held object would: the simulator cannot start two bodies inside each other.
START_RAISE_STEP, START_RAISE_MAX = 2.5e-4, 0.01


def _start(setup: TrialSetup, params: TrialParams, probed: list | None = None):
    """The trial's compiled world at its first state (before the settling): model, data, ids,
    the commanded palm poses (K, 4, 4) with the calibration error applied (and moved by what a
    touch-off found: touch_off_shift), and where the hand starts from the first of them (3,) m:
    perturbed_start's lowering above it, a start press's depth (GripperDrive.press_from), and as
    much more as keeps the object and the hand out of the walls and the pieces down
    (START_RAISE_STEP). probed: when a list is given, the touch-off's probe is appended to it."""
    import mujoco

    spec = trial_spec(setup, params)
    model = mujoco.MjModel.from_xml_string(build_mjcf(spec))
    data = mujoco.MjData(model)
    ids = model_ids(model)
    drive = setup.drive
    error = calibration_offset(drive, params)  # the identity up to rounding where calibrated (trials are
    # chaotic enough that the rounding shows: where calibrated, the palm's own poses are used as they are)
    probe = touch_off_shift(setup, model, ids, error, params) if setup.touch_off else None
    if probe is not None and probed is not None:
        probed.append(probe)
    moved = probe is not None and probe.found != 0.0
    if moved:
        error[:3, 3] += error[:3, 2] * probe.found  # error @ a lift along the arm's z
    exact = params.calibrated and not moved  # nothing moves the commands: they are used as they are
    palm = drive.palm if exact else error @ drive.palm
    start, lowering = perturbed_start(setup, params, spec.obj.thickness, error)
    offset = np.array([0.0, 0.0, lowering])
    if drive.press_from is not None:
        offset += (drive.press_from if exact else error @ drive.press_from)[:3, 3] - palm[0][:3, 3]
    quat = np.zeros(4)
    obj_q = model.jnt_qposadr[model.body_jntadr[ids.object_body]]
    data.ctrl[ids.actuator] = max(drive.opening[0] - setup.servo_squeeze, 0.0)
    while True:  # raised straight up, hand and object, until clear of the walls and pieces down
        raised = palm[0].copy()
        raised[:3, 3] += offset
        _set_palm(data, ids, raised, quat)
        _place_hand(model, data, ids, raised, drive.opening[0], quat)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(start[:3, :3]).ravel())
        data.qpos[obj_q:obj_q + 3], data.qpos[obj_q + 3:obj_q + 7] = start[:3, 3], quat
        mujoco.mj_forward(model, data)
        if not ids.solid_geoms or not _in_solid(data, ids) or offset[2] >= START_RAISE_MAX:
            return spec, model, data, ids, palm, offset
        start = start.copy()
        start[2, 3] += START_RAISE_STEP
        offset = offset + np.array([0.0, 0.0, START_RAISE_STEP])


def _in_solid(data, ids: ModelIds) -> bool:
    """Whether the object or the hand reaches into a wall or a piece down by more than 10 um (the
    pieces down rest on the table and may lean on the walls: those contacts do not count)."""
    for c in data.contact[:data.ncon]:
        g1, g2 = int(c.geom[0]), int(c.geom[1])
        one = (g1 in ids.solid_geoms) != (g2 in ids.solid_geoms)
        if one and ids.table_geom not in (g1, g2) and c.dist < -1e-5:
            return True
    return False


def trial_mjcf(setup: TrialSetup, params: TrialParams) -> str:
    """The MJCF of a trial's world with a keyframe 'start' holding its first state and controls
    (the object's pose, the jaws, the palm and the servo's command), for MuJoCo's viewer."""
    spec, model, data, ids, _, _ = _start(setup, params)
    key = Keyframe("start", data.qpos.copy(), data.ctrl.copy(), data.mocap_pos.copy(), data.mocap_quat.copy())
    return build_mjcf(spec, key)


def run_trial(setup: TrialSetup, params: TrialParams, trial: int = 0, seed: int | None = None,
              record: list | None = None, stop_at_failure: bool = True,
              contact_log: list | None = None) -> TrialResult:
    """Simulate one trial of a placement and judge it (see Outcome). record: when a list is given,
    (time s from the drive's start, 4x4 world pose of the object) is appended after the settling
    (time 0), after every control tick, and once after the rest (the 3D view shows it).
    contact_log: when a list is given, (time s from the drive's start, the forces on the object by
    kind at the end of the tick, _Watch.forces) after every control tick, as Drake's trial logs
    them (sim.drake_trial.run_drake_trial). A trial that records or logs runs to its end; without
    either it stops once its grip is lost, since nothing after it can change the verdicts (a failed
    trial's final pose is where the object was then; stop_at_failure=False goes on, as a
    benchmark of a whole trial does), and once the world is still during the retreat
    (Stillness), where nothing after it can either. A failure of the strict verdict alone (a
    digit on the table, a turn out of the plane while held) does not stop it: the paper's
    criterion (paper_outcome) is decided by what follows."""
    import mujoco

    wall = time.perf_counter()
    probed: list = []  # the touch-off's probe, for the record
    spec, model, data, ids, palm, offset = _start(setup, params, probed)
    drive = setup.drive
    quats = _palm_quats(palm)
    period = float(drive.times[1] - drive.times[0]) if len(drive.times) > 1 else 0.002
    substeps = max(1, round(period / spec.timestep))
    touch_down(model, data, ids, palm[0], offset, setup.sim.settle_time)
    if record is not None:
        record.append((0.0, _pose(data, ids.object_body)))

    watch = _Watch(model, ids)
    stillness = Stillness(model, ids)
    settled = False
    judge = Judge(setup)
    bodies = {"object": ids.object_body, "finger": ids.finger_body, "thumb": ids.thumb_body, "palm": ids.palm_body}

    def frame(name: str) -> tuple[NDArray, NDArray]:
        """A body's orientation and origin now (world)."""
        return data.xmat[bodies[name]].reshape(3, 3), data.xpos[bodies[name]]

    def look() -> _Tick:
        return watch.look(data, ids.object_body, ids.finger_body, setup.b_point)

    watching = record is not None or contact_log is not None  # a trial that records runs to its end
    for k in range(1, len(drive.times)):
        if judge.lost is not None and not watching and stop_at_failure:  # nothing after it changes either verdict
            break
        data.ctrl[ids.actuator] = max(drive.opening[k] - setup.servo_squeeze, 0.0)
        _move_palm(model, data, ids, (palm[k - 1][:3, 3], quats[k - 1]), (palm[k][:3, 3], quats[k]), substeps)
        t = float(drive.times[k])
        if record is not None:
            record.append((t, _pose(data, ids.object_body)))
        if contact_log is not None:
            contact_log.append((t, watch.forces(model, data)))
        if not watching and t >= judge.lifting and stillness.settled(data, t):
            settled = True  # nothing left can move what lies on the table
            break
        judge.tick(k, t, look, frame)
    if ((judge.lost is None or not stop_at_failure) and not settled) or watching:
        mujoco.mj_step(model, data, nstep=max(1, round(setup.sim.rest_time / spec.timestep)))

    final = _pose(data, ids.object_body)
    if record is not None:
        record.append((float(drive.times[-1]) + setup.sim.rest_time, final))
    others = [_pose(data, body).tolist() for body in ids.placed_bodies]
    return judge.result(final, look, params, trial, seed, float(data.time), wall, others, probed)


class Judge:
    """The verdicts of one trial (see run_trial and Outcome) from what an engine reports at each
    control tick: whether A, B, a wall or piece touch the object and how (a _Tick), and where the
    object, the digits and the palm are. Engine-free: MuJoCo's trial (run_trial) and Drake's
    (sim.drake_trial) feed it the same quantities, so both are judged by the same rule."""

    def __init__(self, setup: TrialSetup):
        drive = setup.drive
        self.setup = setup
        self.primitive = _primitive_of_ticks(drive)
        self.plane_y = setup.target_pose[:3, 1]
        self.release = drive.phase_start("termination")
        #: when the retreat begins (s; inf without one): from then on a still world settles the trial
        self.lifting = drive.phase_start("retreat") if any(name == "retreat" for name, _, _ in drive.phases) else math.inf
        self.grip = Grip(setup.max_contact_gap)
        self.travel = _Travel(setup.b_point)
        self.solid_seen_at = -math.inf
        self.roll = self.sinking = self.dome = self.off_dome = self.table_push = 0.0
        self.failure: tuple[Outcome, float] | None = None  # the strict verdict's first failure
        self.lost: tuple[Outcome, float] | None = None  # a grip lost before the termination: the paper's criterion fails too

    def _loss(self, since: float, obj: NDArray, frame: Callable) -> tuple[Outcome, float]:
        """The lost grip dated since (s), named by its cause with the object at pose obj."""
        return _loss_cause(frame("palm"), self.setup, obj, self.plane_y, self.solid_seen_at >= since - 0.2), since

    def tick(self, k: int, t: float, look: Callable[[], "_Tick"], frame: Callable[[str], tuple[NDArray, NDArray]]) -> None:
        """Note control tick k at time t (s): look() is the object's contacts now (a _Tick), frame(name)
        the orientation (3, 3) and origin (3,) of the body 'object', 'finger', 'thumb' or 'palm'."""
        drive = self.setup.drive
        if self.lost is None and drive.times[k - 1] < self.release <= t:  # the termination opens the pinch: is it there?
            if (since := self.grip.pinch_lost()) is not None:
                self.lost = self._loss(since, _frame_pose(*frame("object")), frame)
                self.failure = self.failure or self.lost
        if t >= self.release or self.lost is not None:  # after a loss of grip (a falling object) nothing is measured
            return
        now = look()
        if self.failure is None:  # the contacts' figures are those of the plan's contact modes, until they are lost
            self.sinking, self.dome, self.off_dome = (max(self.sinking, now.sinking), self.dome + now.on_dome,
                                                      self.off_dome + now.off_dome)
            if now.a_point is not None and self.primitive[k] >= 0:
                rot, origin = frame("object")
                self.travel.note(int(self.primitive[k]), np.array([
                    _in_frame(frame("object"), now.a_point), _in_frame(frame("finger"), now.a_point),
                    np.zeros(3), _in_frame(frame("thumb"), now.b_end)]), (now.b_points - origin) @ rot)
        if now.solid:
            self.solid_seen_at = t
        self.table_push = max(self.table_push, now.table_push)
        if now.digit_on_table and self.failure is None:  # a collision: a real arm stops (or the plan's clearance was not there)
            self.failure = (Outcome.DIGIT_HIT_TABLE, t)
        obj = _frame_pose(*frame("object"))
        self.roll = max(self.roll, _roll(obj, self.plane_y))
        if self.roll > LEFT_PLANE_DEG and self.failure is None:  # held, but turned out of the plane: the contact modes are lost
            self.failure = (Outcome.LEFT_PLANE, t)
        if (since := self.grip.note(t, now.a, now.b)) is not None:
            self.lost = self._loss(since, obj, frame)
            self.failure = self.failure or self.lost

    def result(self, final: NDArray, look: Callable[[], "_Tick"], params: TrialParams, trial: int, seed: int | None,
               sim_time: float, wall: float, others: list, probed: list) -> TrialResult:
        """The trial's result with the object at pose final (4x4) at its end: the checks after the
        retreat, which both verdicts make (look() the object's contacts then), where no grip was lost.
        sim_time: the simulated time (s); wall: time.perf_counter() at the trial's start; others: the
        poses of the objects already down; probed: the touch-off's probe, if any, in a list.

        Size: each engine's trial loop calls it once with what that loop holds at its end (the pose,
        the contacts' reader, the draw, the clocks, the other objects, the probe)."""
        setup, drive = self.setup, self.setup.drive
        failure, lost = self.failure, self.lost
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(final[2, 2])))))
        off_m, yaw_err, (along, across) = _placement_error(final, setup.target_pose, setup.spec.obj.outline)
        if lost is None:  # the checks after the retreat, which both verdicts make
            now = look()
            if tilt > FLAT_TILT_DEG:
                lost = (Outcome.HIT_SOLID if now.solid else Outcome.NOT_FLAT, float(drive.times[-1]))
            elif now.a or now.b:
                lost = (Outcome.DIGIT_TOUCHING, float(drive.times[-1]))
            elif off_m > setup.sim.max_error:
                lost = (Outcome.OFF_TARGET, None)
            failure = failure or lost
        outcome, when = failure if failure is not None else (Outcome.SUCCESS, None)
        paper = lost[0] if lost is not None else Outcome.SUCCESS
        phase_index, phase = drive.phase_at(when) if when is not None else (None, None)
        dome, off_dome = self.dome, self.off_dome
        share = off_dome / (dome + off_dome) if setup.spec.gripper.finger_tip_radius > 0.0 and dome + off_dome > 0 else None
        return TrialResult(outcome, paper, phase, phase_index, when, off_m * 1000, yaw_err, tilt, self.roll, params.to_dict(),
                           trial, seed, sim_time, time.perf_counter() - wall, final.tolist(), others,
                           self.sinking * 1000, share, self.travel.travels(setup.planned), self.table_push,
                           self.grip.a_gap, self.grip.b_gap, along * 1000, across * 1000,
                           **(probed[0].result_fields() if probed else {}))


def _primitive_of_ticks(drive: GripperDrive) -> NDArray[np.int64]:
    """Per control tick, the index of the primitive running (counting primitives only), -1
    in the termination and the retreat."""
    out = np.full(len(drive.times), -1)
    k = 0
    for name, a, b in drive.phases:
        if name.startswith("P_"):
            out[(drive.times > a) & (drive.times <= b)] = k
            k += 1
    return out


def _loss_cause(palm: tuple[NDArray, NDArray], setup: TrialSetup, obj: NDArray, plane_y: NDArray,
                solid: bool) -> Outcome:
    """Why the grip was lost: the object turned out of the plane, its end B went past the
    thumb's tip, a wall or piece pushed it, or (none of these) it slipped out. palm: the palm's
    orientation (3, 3) and origin (3,) now."""
    if _roll(obj, plane_y) > LEFT_PLANE_DEG:
        return Outcome.LEFT_PLANE
    digit_axis = palm[0][:, 2]  # palm z: from the palm toward the tips
    b_world = obj[:3, :3] @ setup.b_point + obj[:3, 3]
    if float((b_world - palm[1]) @ digit_axis) > setup.spec.gripper.thumb_length:
        return Outcome.B_PAST_THUMB_TIP
    if solid:
        return Outcome.HIT_SOLID
    return Outcome.GRIP_LOST


def _roll(obj: NDArray, plane_y: NDArray) -> float:
    """How far (deg) the object has turned out of the manipulation plane: the angle between its
    body y axis (normal to the plane when it only tilts about G) and the plane's normal."""
    return math.degrees(math.acos(min(1.0, abs(float(obj[:3, 1] @ plane_y)))))


def placement_offset(final: NDArray, target: NDArray, outline: NDArray) -> NDArray[np.float64]:
    """World (x, y) of the outline (N, 2, body frame) centroid of the object at pose final (4 x 4)
    less its centroid's at pose target (m, shape (2,))."""
    centre = np.append(outline.mean(axis=0), 0.0)
    return ((final[:3, :3] @ centre + final[:3, 3]) - (target[:3, :3] @ centre + target[:3, 3]))[:2]


def placement_offset_in_plane(final: NDArray, target: NDArray, outline: NDArray) -> tuple[float, float]:
    """placement_offset in the manipulation plane's frame at the target, seen from above (m): along
    GB (the target pose's x axis, + toward B) and across it (its y axis, GB turned a quarter left)."""
    return _in_plane(placement_offset(final, target, outline), target)


def _in_plane(offset: NDArray, target: NDArray) -> tuple[float, float]:
    """A world (x, y) offset (m) along the target pose's x axis (GB) and its y axis."""
    return float(offset @ target[:2, 0]), float(offset @ target[:2, 1])


def placement_turn(final: NDArray, target: NDArray) -> float:
    """The turn (rad, counter-clockwise, in (-pi, pi]) of the object's x axis about the vertical at
    pose final (4 x 4) against pose target's."""
    yaw = math.atan2(final[1, 0], final[0, 0]) - math.atan2(target[1, 0], target[0, 0])
    return math.atan2(math.sin(yaw), math.cos(yaw))


def _placement_error(final: NDArray, target: NDArray,
                     outline: NDArray) -> tuple[float, float, tuple[float, float]]:
    """(m, deg, (m, m)): the outline centroid's distance in the table's plane from its target's,
    the turn of the object's x axis about the vertical against the target's, and the offset along
    GB and across it (placement_offset_in_plane), the offset computed once."""
    offset = placement_offset(final, target, outline)
    return float(np.linalg.norm(offset)), abs(math.degrees(placement_turn(final, target))), _in_plane(offset, target)
