"""One simulated trial in Drake (``simulate --engine drake``; docs/model.md 11.19): the same trial
as sim.trial.run_trial runs in MuJoCo, judged by the same rule (sim.trial.Judge).

What is shared with MuJoCo's trial, computed once and not again here: the trial's world (its
friction, mass, thickness, table height: sim.trial.trial_spec, and its bodies:
sim.world_description), and its start (sim.trial._start: the calibration error applied to the
commanded palm poses, the touch-off's probe and the shift it found, the object's perturbed start
pose in the grasp, where the hand starts from, raised above a wall or piece). The touch-off's probe
runs in MuJoCo's world of the trial (sim.probe): the arm's commands it moves are what Drake then
executes. What is Drake's own: the bodies' dynamics, the contacts, the palm's and the servo's
controllers (sim.drake_world), and the contacts the verdict reads.

The sequence is MuJoCo's trial's: the settling (the hand brought down over its first half where it
starts raised, the servo squeezing), every control period the palm's and the servo's commands of
the drive (the palm moving at a constant speed between two periods' poses), the rest after the
retreat, read off early once the world lies still during the retreat, or at a lost grip.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
from numpy.typing import NDArray

from ..scene.perturbation import TrialParams
from .outcome import Outcome, TrialResult
from .trial import (DIGIT_KINDS, TOUCH_DISTANCE, Judge, StillWindow, Touch, TrialSetup, _pose, _start, _Tick, moving,
                    read_contacts)
from .world_description import describe


#: SAP's time step (s), record 0126's: no coarser step of its study both fails, lands and spreads
#: the base trials as this one does and keeps a dropped object still (docs/model.md 11.19); None:
#: the scene's sim.timestep, MuJoCo's. SAP is implicit: MuJoCo's convergence (record 0112) is not Drake's.
DRAKE_TIME_STEP: float | None = 2.5e-5


@dataclass
class DrakeTrialResult(TrialResult):
    """A trial's result in Drake: TrialResult's fields and how closely the palm's PD joints
    tracked the commanded palm (MuJoCo's weld holds it within nanometres)."""

    #: the largest distance (mm) of the palm from its commanded pose at a control tick of the drive
    palm_tracking_mm: float = 0.0
    #: the largest angle (deg) between the palm's orientation and the commanded one, the same
    palm_tracking_deg: float = 0.0


def _schedule(setup: TrialSetup, palm: NDArray, offset: NDArray, dt: float):
    """The palm's commanded poses and the servo's commands against Drake's time (s, from the
    settling's start), as MuJoCo's trial moves its palm target and sets its control: (palm
    times (M,), palm poses (M, 4, 4), servo times (N,), servo commands (N,) m of opening, the
    drive's tick times (K,), the settling's end)."""
    drive = setup.drive
    settle = max(1, round(setup.sim.settle_time / dt))
    period = float(drive.times[1] - drive.times[0]) if len(drive.times) > 1 else 0.002
    substeps = max(1, round(period / dt))
    raised = palm[0].copy()
    raised[:3, 3] += offset
    t0 = settle * dt
    if np.any(offset):  # the hand comes down to its first pose over the first half of the settling
        times, poses = [0.0, (settle // 2) * dt, t0], [raised, palm[0], palm[0]]
    else:
        times, poses = [0.0, t0], [palm[0], palm[0]]
    ticks = t0 + np.arange(len(drive.times)) * substeps * dt
    times += list(ticks[1:])
    poses += list(palm[1:])
    end = ticks[-1] + setup.sim.rest_time
    times.append(end + 1.0)
    poses.append(palm[-1])
    command = np.clip(drive.opening - setup.servo_squeeze, 0.0, setup.spec.gripper.max_opening)
    # the servo's command over a tick is the tick's (MuJoCo's trial sets it as the tick begins)
    servo_times = np.concatenate([[0.0], ticks[:-1], [end + 1.0]])
    servo = np.concatenate([[command[0]], command[1:], [command[-1]]])
    return np.array(times), np.array(poses), servo_times, servo, ticks, t0


def run_drake_trial(setup: TrialSetup, params: TrialParams, trial: int = 0, seed: int | None = None,
                    record: list | None = None, stop_at_failure: bool = True,
                    contact_log: list | None = None) -> DrakeTrialResult:
    """Simulate one trial of a placement in Drake and judge it as sim.trial.run_trial judges
    MuJoCo's (its arguments the same). contact_log: when a list is given, (time s, the forces on
    the object by kind, _DrakeWatch.forces, averaged over the steps of the control period that
    ends then) at every control tick of the drive: the mean over a period, because SAP's forces on
    a flat face of the object vary from step to step (docs/model.md 11.19)."""
    wall = time.perf_counter()
    probed: list = []
    dw, palm, ticks, dt, t0 = _built(setup, params, probed)
    plant, ctx, simulator, obj = dw.plant, dw.plant_context, dw.simulator, dw.bodies["object"]
    drive = setup.drive
    judge = Judge(setup)
    track_m = track_rad = 0.0
    still = StillWindow()
    settled = False
    watch = _DrakeWatch(dw)
    placed = [dw.bodies[body.name] for body in dw.world.placed]
    free = [obj, *placed]  # the free bodies whose stillness settles the trial, as MuJoCo's Stillness

    def frame(name: str) -> tuple[NDArray, NDArray]:
        pose = plant.EvalBodyPoseInWorld(ctx, dw.bodies[name])
        return pose.rotation().matrix(), pose.translation()

    def look() -> _Tick:
        return watch.look(setup.b_point)

    def finish(final: NDArray, diverged_at: float | None = None) -> DrakeTrialResult:
        """The result with the object at pose final (4x4), failed as diverged at diverged_at (s) if
        given; the pieces' poses at the end (NaN where the state diverged)."""
        if diverged_at is not None:
            judge.failure = judge.lost = (Outcome.DIVERGED, diverged_at)
        others = [_body_pose(plant, ctx, body).tolist() for body in placed]
        result = judge.result(final, look, params, trial, seed, float(simulator.get_context().get_time()), wall,
                              others, probed)
        return DrakeTrialResult(**result.__dict__, palm_tracking_mm=track_m * 1000,
                                palm_tracking_deg=math.degrees(track_rad))

    final = _body_pose(plant, ctx, obj)  # the object's last finite pose, should Drake's state diverge
    if not stepped(partial(simulator.AdvanceTo, t0)):  # the settling
        return finish(final, float(drive.times[0]))
    final = _body_pose(plant, ctx, obj)
    if record is not None:
        record.append((0.0, final))
    for k in range(1, len(drive.times)):
        if judge.lost is not None and record is None and stop_at_failure:
            break
        t = float(drive.times[k])
        step = (partial(simulator.AdvanceTo, ticks[k]) if contact_log is None else
                partial(_logged_period, contact_log, t, simulator, watch, ticks[k], dt))
        if not stepped(step):
            return finish(final, t)
        final = _body_pose(plant, ctx, obj)
        rot, origin = frame("palm")
        track_m = max(track_m, float(np.linalg.norm(origin - palm[k][:3, 3])))
        track_rad = max(track_rad, _angle(rot, palm[k][:3, :3]))
        if record is not None:
            record.append((t, final))
        if record is None and t >= judge.lifting:
            if still.note(t, moving(_velocities(plant, ctx, free)), watch.digit_touches_free()):
                settled = True
                break
        judge.tick(k, t, look, frame)
    if ((judge.lost is None or not stop_at_failure) and not settled) or record is not None:
        rest = partial(simulator.AdvanceTo, simulator.get_context().get_time() + setup.sim.rest_time)
        if not stepped(rest):
            return finish(final, float(drive.times[-1]))
    final = _body_pose(plant, ctx, obj)
    if record is not None:
        record.append((float(drive.times[-1]) + setup.sim.rest_time, final))
    return finish(final)


def stepped(step: Callable[[], object]) -> bool:
    """Run step (Drake advancing); False where Drake's state became non-finite on the way (a step
    that diverged: Drake's error says so). Any other error is raised."""
    try:
        step()
    except RuntimeError as exc:
        if "non-finite" not in str(exc):
            raise
        return False
    return True


def _logged_period(log: list, t: float, simulator, watch: "_DrakeWatch", until: float, dt: float) -> None:
    """Advance to until (s) and append (t, the period's mean forces on the object) to log."""
    log.append((t, _period_forces(simulator, watch, until, dt)))


def _started(setup: TrialSetup, params: TrialParams, probed: list):
    """The trial's Drake world advanced to the drive's start from MuJoCo's trial's first state (its
    settling, the probe's shift into probed): the world (DrakeWorld), the palm's poses at the
    drive's ticks, the ticks' times in Drake (s) and Drake's step (s)."""
    dw, palm, ticks, dt, t0 = _built(setup, params, probed)
    dw.simulator.AdvanceTo(t0)
    return dw, palm, ticks, dt


def _built(setup: TrialSetup, params: TrialParams, probed: list):
    """_started's world, palm poses, ticks and step, the world initialised at MuJoCo's trial's first
    state but not yet settled, and the settling's end in Drake's time (s)."""
    from .drake_world import build, palm_angles, require_drake

    drake = require_drake()
    spec, model, data, ids, palm, offset = _start(setup, params, probed)  # MuJoCo's start, the probe's shift
    start_pose = _pose(data, ids.object_body)
    opening0 = float(data.qpos[model.jnt_qposadr[model.body_jntadr[ids.finger_jaw]]]) * 2
    world = describe(spec)
    dt = DRAKE_TIME_STEP if DRAKE_TIME_STEP else spec.timestep
    times, poses, servo_times, servo, ticks, t0 = _schedule(setup, palm, offset, dt)
    base = palm[0][:3, :3]
    angles = np.unwrap(np.array([palm_angles(base, p[:3, :3]) for p in poses]), axis=0)
    q = np.column_stack([poses[:, :3, 3], angles])
    palm_trajectory = drake.PiecewisePolynomial.FirstOrderHold(times, q.T)
    jaw_trajectory = drake.PiecewisePolynomial.ZeroOrderHold(servo_times, (servo / world.servo.gear)[None, :])
    dw = build(world, palm_trajectory, jaw_trajectory, base, dt)
    plant, ctx = dw.plant, dw.plant_context
    for joint, value in zip(dw.palm_joints, q[0]):  # the first state: MuJoCo's trial's
        joint.set_translation(ctx, value) if hasattr(joint, "set_translation") else joint.set_angle(ctx, value)
    dw.jaw_joints["thumb"].set_translation(ctx, -opening0 / 2)
    dw.jaw_joints["finger"].set_translation(ctx, opening0 / 2)
    plant.SetFreeBodyPose(ctx, dw.bodies["object"],
                          drake.RigidTransform(drake.RotationMatrix(start_pose[:3, :3]), start_pose[:3, 3]))
    dw.simulator.Initialize()
    return dw, palm, ticks, dt, t0


def _period_forces(simulator, watch: "_DrakeWatch", until: float, dt: float) -> dict[str, NDArray[np.float64]]:
    """Advance to until (s) step by step (dt s), and the forces on the object by kind averaged
    over the steps (N, world frame)."""
    now = simulator.get_context().get_time()
    steps = max(1, round((until - now) / dt))
    total: dict[str, NDArray[np.float64]] = {}
    for j in range(1, steps + 1):
        simulator.AdvanceTo(until if j == steps else now + (until - now) * j / steps)
        for kind, force in watch.forces().items():
            total[kind] = total.get(kind, np.zeros(3)) + force
    return {kind: force / steps for kind, force in total.items()}


def _angle(a: NDArray, b: NDArray) -> float:
    """The angle (rad) of the turn between two orientations."""
    return math.acos(max(-1.0, min(1.0, (float(np.trace(a.T @ b)) - 1.0) / 2.0)))


def _body_pose(plant, ctx, body) -> NDArray[np.float64]:
    return plant.EvalBodyPoseInWorld(ctx, body).GetAsMatrix4()


def _velocities(plant, ctx, bodies: list) -> NDArray[np.float64]:
    """The bodies' velocities (n, 6: linear m/s, angular rad/s; world), as sim.trial.moving reads them."""
    out = []
    for body in bodies:
        v = plant.EvalBodySpatialVelocityInWorld(ctx, body)
        out.append(np.concatenate([v.translational(), v.rotational()]))
    return np.array(out)


class _DrakeWatch:
    """The object's contacts at a control tick, from Drake's contact results, as the verdict reads
    them (sim.trial.read_contacts, which MuJoCo's sim.trial._Watch feeds too): who touches the
    object, with what normal force, where, and how deep; whether a digit touches the table."""

    def __init__(self, dw):
        self.dw = dw
        self.plant, self.ctx = dw.plant, dw.plant_context
        self.kind = dw.geoms
        self.pads = dw.pads
        self.object_id = next(g for g, k in dw.geoms.items() if k == "object")
        #: the free bodies' geometries: the object's and the pieces' down (MuJoCo's Stillness watches them all)
        self.free_ids = {self.object_id} | {g for body in dw.world.placed
                                            for g in self.plant.GetCollisionGeometriesForBody(dw.bodies[body.name])}
        self.vertices = dw.world.object.geom.shape.vertices
        self.table_height = dw.world.table_height
        self._results = None
        self._time = None
        self._forces: dict[str, NDArray[np.float64]] = {}
        self._forces_time: float | None = None

    def _contacts(self) -> tuple[list[Touch], list[float]]:
        """The object's contacts now (Touches: their depth None where a hydroelastic patch leaves it
        to _depth; on a flat finger's pad, the deepest its pressure says the object reaches into
        it), and the normal force (N) of each contact of a digit with the table."""
        t = self.ctx.get_time()
        if self._time == t:
            return self._results
        results = self.plant.get_contact_results_output_port().Eval(self.ctx)
        mine, table = [], []
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            pair = info.point_pair()
            a, b = self.kind.get(pair.id_A), self.kind.get(pair.id_B)
            force = abs(float(info.contact_force() @ pair.nhat_BA_W))
            if "object" in (a, b):
                other = b if a == "object" else a
                mine.append(Touch(other, force, np.asarray(info.contact_point())[None, :], float(pair.depth)))
            elif "table" in (a, b) and (b if a == "table" else a) in DIGIT_KINDS:
                table.append(force)
        for i in range(results.num_hydroelastic_contacts()):
            info = results.hydroelastic_contact_info(i)
            surface = info.contact_surface()
            a, b = self.kind.get(surface.id_M()), self.kind.get(surface.id_N())
            force, depth = info.F_Ac_W().translational(), None
            if "table" in (a, b):  # the table's normal is the world's z
                force = abs(float(force[2]))
                points = np.asarray(surface.centroid())[None, :]
            else:  # the patch's area-weighted normal; its vertices are where it touches
                mesh = surface.poly_mesh_W()
                normal = sum(mesh.area(f) * mesh.face_normal(f) for f in range(mesh.num_faces()))
                force = abs(float(force @ (normal / max(float(np.linalg.norm(normal)), 1e-300))))
                points = np.array([mesh.vertex(v) for v in range(mesh.num_vertices())])
                gradient = self.pads.get(surface.id_N()) or self.pads.get(surface.id_M())
                if gradient:  # a flat finger's pad: its pressure is gradient times the depth
                    pressure = surface.poly_e_MN()
                    depth = max(pressure.EvaluateAtVertex(v) for v in range(mesh.num_vertices())) / gradient
            if "object" in (a, b):
                mine.append(Touch(b if a == "object" else a, force, points, depth))
            elif "table" in (a, b) and (b if a == "table" else a) in DIGIT_KINDS:
                table.append(force)
        self._time, self._results = t, (mine, table)
        return mine, table

    def forces(self) -> dict[str, NDArray[np.float64]]:
        """The force (N, world frame, 3) each kind of geometry (table, thumb, finger, finger_tip,
        palm, solid) exerts on the object now, summed over its contacts."""
        t = self.ctx.get_time()
        if self._forces_time == t:
            return self._forces
        results = self.plant.get_contact_results_output_port().Eval(self.ctx)
        out: dict[str, NDArray[np.float64]] = {}
        pairs = []  # (geometry A, geometry B, the force on B's body)
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            pairs.append((info.point_pair().id_A, info.point_pair().id_B, np.asarray(info.contact_force())))
        for i in range(results.num_hydroelastic_contacts()):
            info = results.hydroelastic_contact_info(i)  # F_Ac_W: the force on M's body
            surface = info.contact_surface()
            pairs.append((surface.id_M(), surface.id_N(), -np.asarray(info.F_Ac_W().translational())))
        for a, b, on_b in pairs:
            if self.object_id not in (a, b):
                continue
            other, on_object = (self.kind.get(b), -on_b) if a == self.object_id else (self.kind.get(a), on_b)
            out[other] = out.get(other, np.zeros(3)) + on_object
        self._forces_time, self._forces = t, out
        return out

    def digit_touches_object(self) -> bool:
        return any(touch.kind in DIGIT_KINDS for touch in self._contacts()[0])

    def digit_touches_free(self) -> bool:
        """Whether a digit touches the object or a piece down (sim.trial.Stillness' rule)."""
        if self.digit_touches_object():
            return True
        if len(self.free_ids) == 1:
            return False
        results = self.plant.get_contact_results_output_port().Eval(self.ctx)
        pairs = [(results.point_pair_contact_info(i).point_pair().id_A, results.point_pair_contact_info(i).point_pair().id_B)
                 for i in range(results.num_point_pair_contacts())]
        pairs += [(results.hydroelastic_contact_info(i).contact_surface().id_M(),
                   results.hydroelastic_contact_info(i).contact_surface().id_N())
                  for i in range(results.num_hydroelastic_contacts())]
        return any((a in self.free_ids and self.kind.get(b) in DIGIT_KINDS)
                   or (b in self.free_ids and self.kind.get(a) in DIGIT_KINDS) for a, b in pairs)

    def _depth(self, touch: Touch) -> float:
        """How deep the object reaches into the other geometry of a hydroelastic contact (m): into
        the table, its lowest vertex's depth; into a digit's face, their signed distance."""
        if touch.kind == "table":
            pose = self.plant.EvalBodyPoseInWorld(self.ctx, self.dw.bodies["object"]).GetAsMatrix4()
            low = float(np.min(self.vertices @ pose[:3, :3].T[:, 2] + pose[2, 3]))
            return max(0.0, self.table_height - low)
        gid = next(g for g, k in self.kind.items() if k == touch.kind)
        return max(0.0, -self._query().ComputeSignedDistancePairClosestPoints(self.object_id, gid).distance)

    def _query(self):
        """SceneGraph's geometry query now."""
        return self.dw.scene_graph.get_query_output_port().Eval(self.dw.scene_graph.GetMyContextFromRoot(
            self.dw.simulator.get_context()))

    def near(self, digit: str) -> bool:
        """Whether a geometry of the digit ('thumb', or 'finger' with its tip) lies within
        TOUCH_DISTANCE of the object's (SceneGraph's signed distance, the engine's own)."""
        kinds = ("thumb",) if digit == "thumb" else ("finger", "finger_tip")
        query = self._query()
        return any(query.ComputeSignedDistancePairClosestPoints(self.object_id, g).distance < TOUCH_DISTANCE
                   for g, k in self.kind.items() if k in kinds)

    def _frame(self, name: str) -> tuple[NDArray, NDArray]:
        """A body's orientation (3, 3) and origin (3,) now (world)."""
        pose = self.plant.EvalBodyPoseInWorld(self.ctx, self.dw.bodies[name])
        return pose.rotation().matrix(), pose.translation()

    def look(self, b_point: NDArray) -> _Tick:
        """What the object's contacts are now, and whether a digit touches the table (read_contacts)."""
        touches, table = self._contacts()
        return read_contacts(touches, table, self._frame, b_point, self._depth, self.near)


@dataclass(frozen=True)
class FlatDrop:
    """The table's positive control (docs/model.md 11.19): an object let go flat above the table
    must come to rest where it fell, in either engine and at Drake's step (record 0126)."""

    #: how high (m) the object's underside starts above the table's top
    height: float = 1e-3
    #: where (m, x and y in the world) it is let go
    at: tuple[float, float] = (0.45, 0.10)
    #: how long (s) it is left to gravity and the table
    duration: float = 0.3
    #: how far (m) it may end from below where it was let go, and off the table's top
    bound: float = 5e-5

    def pose(self, height: float | None = None) -> NDArray[np.float64]:
        """The object's pose (4x4, world) when let go: flat, at ``at``, ``height`` (m; default the
        control's) above the table."""
        pose = np.eye(4)
        pose[:3, 3] = [*self.at, self.height if height is None else height]
        return pose


def settle_object(spec, pose: NDArray, duration: float, time_step: float | None = None,
                  record: list | None = None, contact_log: list | None = None,
                  placed: list | None = None) -> NDArray[np.float64]:
    """The object of spec put at pose (4x4) and left to gravity and the table for duration (s) in
    Drake, with spec's pieces down (spec.placed, each starting at its pose), the hand parked a
    metre above, still: its pose at the end (4x4). record: when a list is given, (time s, pose)
    every control period (2 ms); contact_log: (time s, the forces on the object by kind, averaged
    over the period's steps: _period_forces), as often; placed: the pieces' poses (4x4) at the end
    are appended to it, in spec.placed's order. The drop tests of tests/test_drake.py."""
    from .drake_world import build, require_drake

    drake = require_drake()
    world = describe(spec)
    dt = time_step or DRAKE_TIME_STEP or spec.timestep
    park = np.array([[0.0, 0.0, 1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0, 0.0, 0.0]]).T
    dw = build(world, drake.PiecewisePolynomial.FirstOrderHold([0.0, duration + 1.0], park),
               drake.PiecewisePolynomial.ZeroOrderHold([0.0, duration + 1.0], np.zeros((1, 2))), np.eye(3), dt)
    plant, ctx = dw.plant, dw.plant_context
    dw.palm_joints[2].set_translation(ctx, 1.0)
    obj = dw.bodies["object"]
    plant.SetFreeBodyPose(ctx, obj, drake.RigidTransform(drake.RotationMatrix(pose[:3, :3]), pose[:3, 3]))
    dw.simulator.Initialize()
    if record is None and contact_log is None:
        dw.simulator.AdvanceTo(duration)
    else:
        watch = _DrakeWatch(dw)
        for t in np.arange(1, int(round(duration / 0.002)) + 1) * 0.002:
            if contact_log is None:
                dw.simulator.AdvanceTo(float(t))
            else:
                contact_log.append((float(t), _period_forces(dw.simulator, watch, float(t), dt)))
            if record is not None:
                record.append((float(t), _body_pose(plant, ctx, obj)))
    if placed is not None:
        placed.extend(_body_pose(plant, ctx, dw.bodies[body.name]) for body in dw.world.placed)
    return _body_pose(plant, ctx, obj)
