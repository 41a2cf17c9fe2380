"""One simulated trial: the object in the pinch, the gripper driven open-loop, the outcome judged.

Sequence: the object is put at the plan's start pose (plus the trial's perturbation, lifted
clear of the table if it would reach into it), the jaws at the planned opening; the world
settles with the palm still (gravity, the servo squeezing); then every control period the
palm is moved to the drive's next pose and the servo is commanded the planned opening less
the squeeze; after the retreat the world rests, and the outcome is read off.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from .drive import GripperDrive
from .model import ModelIds, SimModelSpec, build_mjcf, model_ids
from .outcome import FLAT_TILT_DEG, Outcome, TrialResult
from .perturb import TrialParams

#: A contact at A or B absent this long (s) before the termination is a loss of grip.
LOSS_WINDOW = 0.05
#: Turned out of the manipulation plane by more than this (deg) while held: it left the plane.
LEFT_PLANE_DEG = 10.0


@dataclass(frozen=True)
class TrialSetup:
    """What every trial of one placement shares (plain data, so it crosses to worker processes).

    start_pose: 4x4 world pose of the object's body frame at the plan's start state;
    target_pose: the same when the object lies at its target; grasp_point: the body-frame point
    (m) about which a perturbed grasp turns (A at the start); b_point: B in the body frame (m);
    squeeze: how far inside the planned opening the servo is commanded (m); settle_time and
    rest_time: s of stillness before the drive and after it.
    """

    spec: SimModelSpec
    drive: GripperDrive
    start_pose: NDArray[np.float64]
    target_pose: NDArray[np.float64]
    grasp_point: NDArray[np.float64]
    b_point: NDArray[np.float64]
    squeeze: float = 0.001
    settle_time: float = 0.3
    rest_time: float = 0.5


def _rot_z(angle: float) -> NDArray[np.float64]:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def perturbed_start(setup: TrialSetup, params: TrialParams, thickness: float) -> NDArray[np.float64]:
    """The object's start pose with the trial's grasp error: a turn by yaw_deg about the normal
    through the grasp point and a shift in the object's own plane (along GB and across it),
    then lifted straight up if any corner of the prism would reach into the table."""
    local = np.eye(4)
    turn = _rot_z(math.radians(params.yaw_deg))
    p = setup.grasp_point
    local[:3, :3] = turn
    local[:3, 3] = p - turn @ p + np.array([params.shift_along_mm, params.shift_across_mm, 0.0]) / 1000
    pose = setup.start_pose @ local
    outline = setup.spec.obj.outline
    corners = np.vstack([np.column_stack([outline, np.full(len(outline), z)]) for z in (0.0, thickness)])
    lowest = float(np.min((corners @ pose[:3, :3].T + pose[:3, 3])[:, 2]))
    if lowest < 0.0:
        pose[2, 3] -= lowest
    return pose


def trial_spec(setup: TrialSetup, params: TrialParams) -> SimModelSpec:
    """The nominal model with the trial's friction, mass and thickness."""
    spec = setup.spec
    fg, fa, fb = params.friction_scale
    fr = spec.friction
    obj = replace(spec.obj, thickness=spec.obj.thickness * params.thickness_scale,
                  density=spec.obj.density * params.mass_scale / params.thickness_scale)
    return replace(spec, obj=obj, friction=replace(fr, table=fr.table * fg, finger=fr.finger * fa,
                                                   thumb=fr.thumb * fb, solids=fr.solids * fg))


class _Watch:
    """Contacts of the object per control tick."""

    def __init__(self, ids: ModelIds):
        self.ids = ids

    def flags(self, data) -> tuple[bool, bool, bool, bool]:
        """(A, B, solid, any digit) touching the object now."""
        n = data.ncon
        if n == 0:
            return False, False, False, False
        geoms = data.contact.geom[:n]
        ids = self.ids
        other = np.where(geoms[:, 0] == ids.object_geom, geoms[:, 1],
                         np.where(geoms[:, 1] == ids.object_geom, geoms[:, 0], -1))
        touching = set(other[other >= 0].tolist())
        a = bool(touching & ids.finger_geoms)
        b = bool(touching & ids.thumb_geoms)
        return a, b, bool(touching & ids.solid_geoms), a or b


def _pose(data, body: int) -> NDArray[np.float64]:
    pose = np.eye(4)
    pose[:3, :3] = data.xmat[body].reshape(3, 3)
    pose[:3, 3] = data.xpos[body]
    return pose


def _set_palm(data, ids: ModelIds, pose: NDArray, quat: NDArray) -> None:
    import mujoco

    data.mocap_pos[ids.palm_mocap] = pose[:3, 3]
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(pose[:3, :3]).ravel())
    data.mocap_quat[ids.palm_mocap] = quat


def run_trial(setup: TrialSetup, params: TrialParams, trial: int = 0, seed: int | None = None,
              record: list | None = None) -> TrialResult:
    """Simulate one trial of a placement and judge it (see Outcome). record: when a list is given,
    (time s from the drive's start, 4x4 world pose of the object) is appended after the settling
    (time 0), after every control tick, and once after the rest (the 3D view shows it)."""
    import mujoco

    wall = time.perf_counter()
    spec = trial_spec(setup, params)
    model = mujoco.MjModel.from_xml_string(build_mjcf(spec))
    data = mujoco.MjData(model)
    ids = model_ids(model)
    drive = setup.drive
    quat = np.zeros(4)

    # the start: palm, jaws at the planned opening, the object in the pinch
    _set_palm(data, ids, drive.palm[0], quat)
    thumb_q = model.jnt_qposadr[model.body_jntadr[ids.thumb_body]]
    finger_q = model.jnt_qposadr[model.body_jntadr[ids.finger_body]]
    obj_q = model.jnt_qposadr[model.body_jntadr[ids.object_body]]
    data.qpos[thumb_q], data.qpos[finger_q] = -drive.opening[0] / 2, drive.opening[0] / 2
    start = perturbed_start(setup, params, spec.obj.thickness)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(start[:3, :3]).ravel())
    data.qpos[obj_q:obj_q + 3], data.qpos[obj_q + 3:obj_q + 7] = start[:3, 3], quat
    mujoco.mj_forward(model, data)

    period = float(drive.times[1] - drive.times[0]) if len(drive.times) > 1 else 0.002
    substeps = max(1, round(period / spec.timestep))
    data.ctrl[ids.actuator] = max(drive.opening[0] - setup.squeeze, 0.0)
    mujoco.mj_step(model, data, nstep=max(1, round(setup.settle_time / spec.timestep)))
    if record is not None:
        record.append((0.0, _pose(data, ids.object_body)))

    watch = _Watch(ids)
    plane_y = setup.target_pose[:3, 1]
    release = drive.phase_start("termination")
    missing_since: float | None = None
    solid_seen_at = -math.inf
    roll = 0.0
    failure: tuple[Outcome, float] | None = None
    for k in range(1, len(drive.times)):
        _set_palm(data, ids, drive.palm[k], quat)
        data.ctrl[ids.actuator] = max(drive.opening[k] - setup.squeeze, 0.0)
        mujoco.mj_step(model, data, nstep=substeps)
        t = float(drive.times[k])
        if record is not None:
            record.append((t, _pose(data, ids.object_body)))
        if t >= release or failure is not None:
            continue
        a, b, solid, _ = watch.flags(data)
        if solid:
            solid_seen_at = t
        obj = _pose(data, ids.object_body)
        roll = max(roll, _roll(obj, plane_y))
        if roll > LEFT_PLANE_DEG:  # held still, but turned out of the plane: the contact modes are lost
            failure = (Outcome.LEFT_PLANE, t)
            continue
        if a and b:
            missing_since = None
            continue
        missing_since = t if missing_since is None else missing_since
        if t - missing_since >= LOSS_WINDOW:
            failure = (_loss_cause(data, ids, setup, obj, plane_y, solid_seen_at >= missing_since - 0.2),
                       missing_since)
    mujoco.mj_step(model, data, nstep=max(1, round(setup.rest_time / spec.timestep)))

    final = _pose(data, ids.object_body)
    if record is not None:
        record.append((float(drive.times[-1]) + setup.rest_time, final))
    others = [_pose(data, body).tolist() for body in ids.placed_bodies]
    tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(final[2, 2])))))
    pos_err, yaw_err = _placement_error(final, setup.target_pose, spec.obj.outline)
    if failure is None:
        _, _, solid, digit = watch.flags(data)
        if tilt > FLAT_TILT_DEG:
            failure = (Outcome.HIT_SOLID if solid else Outcome.NOT_FLAT, float(drive.times[-1]))
        elif digit:
            failure = (Outcome.DIGIT_TOUCHING, float(drive.times[-1]))
    outcome, when = failure if failure is not None else (Outcome.SUCCESS, None)
    phase_index, phase = drive.phase_at(when) if when is not None else (None, None)
    return TrialResult(outcome, phase, phase_index, when, pos_err, yaw_err, tilt, roll, params.to_dict(),
                       trial, seed, float(data.time), time.perf_counter() - wall, final.tolist(), others)


def _loss_cause(data, ids: ModelIds, setup: TrialSetup, obj: NDArray, plane_y: NDArray, solid: bool) -> Outcome:
    """Why the grip was lost: the object turned out of the plane, its end B went past the
    thumb's tip, a wall or piece pushed it, or (none of these) it slipped out."""
    if _roll(obj, plane_y) > LEFT_PLANE_DEG:
        return Outcome.LEFT_PLANE
    import mujoco

    palm_rot = np.zeros(9)
    mujoco.mju_quat2Mat(palm_rot, data.mocap_quat[ids.palm_mocap])
    digit_axis = palm_rot.reshape(3, 3)[:, 2]  # palm z: from the palm toward the tips
    b_world = obj[:3, :3] @ setup.b_point + obj[:3, 3]
    if float((b_world - data.mocap_pos[ids.palm_mocap]) @ digit_axis) > setup.spec.gripper.thumb_length:
        return Outcome.B_PAST_THUMB_TIP
    if solid:
        return Outcome.HIT_SOLID
    return Outcome.GRIP_LOST


def _roll(obj: NDArray, plane_y: NDArray) -> float:
    """How far (deg) the object has turned out of the manipulation plane: the angle between its
    body y axis (normal to the plane when it only tilts about G) and the plane's normal."""
    return math.degrees(math.acos(min(1.0, abs(float(obj[:3, 1] @ plane_y)))))


def _placement_error(final: NDArray, target: NDArray, outline: NDArray) -> tuple[float, float]:
    """(mm, deg): the outline centroid's distance in the table's plane from its target's, and
    the turn of the object's x axis about the vertical against the target's."""
    centre = np.append(outline.mean(axis=0), 0.0)
    got = final[:3, :3] @ centre + final[:3, 3]
    want = target[:3, :3] @ centre + target[:3, 3]
    err = float(np.linalg.norm((got - want)[:2])) * 1000
    yaw = math.atan2(final[1, 0], final[0, 0]) - math.atan2(target[1, 0], target[0, 0])
    return err, abs(math.degrees(math.atan2(math.sin(yaw), math.cos(yaw))))
