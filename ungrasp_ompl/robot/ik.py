"""Inverse kinematics of the UR5e for the palm frame: one pose, a seed, and a continuous path.

Targets are 4x4 world poses of the palm frame (``model.PALM_FRAME``, metres); solutions are the six
arm joint angles (rad) in ``ARM_JOINTS`` order. The gripper opening does not move the palm, so IK
ignores it.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Any, NamedTuple, Sequence

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from ..errors import NoSolutionError
from .model import (UR5E_REACH, RobotModel, as_pose, configuration, max_flange_distance_from_shoulder,
                    shoulder_position)
from .trajectory import ARM_JOINTS

#: Levenberg-Marquardt damping (m^2, rad^2): adaptive, starting at DAMPING_START, divided by 10
#: after a step that lowers the error down to DAMPING_MIN (Gauss-Newton, quadratic convergence near
#: a solution), multiplied by 10 after one that does not; past DAMPING_MAX no step helps and the
#: solver gives up. ERROR_DAMPING * |e|^2 is added (Sugihara's error-dependent damping): large far
#: from the target, where linearised steps mislead, vanishing near it.
DAMPING_START = 1e-6
DAMPING_MIN = 1e-10
DAMPING_MAX = 1e3
ERROR_DAMPING = 0.1
#: |log6 error| at which iterating stops: the solution is as exact as doubles allow.
ERROR_FLOOR = 1e-12
#: Largest joint change (rad) of one solver iteration: a trust region against wild steps near
#: singularities.
MAX_ITERATION_STEP = 0.5
#: Default largest joint change (rad) between consecutive path samples before a jump counts as a
#: branch flip.
MAX_PATH_STEP = 0.3

#: Seeds of ``ik_seed_for``: the UR "home" posture (elbow up, wrist down) and its elbow and wrist
#: variants, (q2, q3, q4, q5, q6) rad, each with the shoulder pan q1 at the target's azimuth in the
#: base frame plus each of _SHOULDER_OFFSETS (rad; at q1 = azimuth + pi the arm leans toward it).
_SHOULDER_OFFSETS = (np.pi, 0.0, np.pi / 2, -np.pi / 2)
_SEED_POSTURES = (
    (-np.pi / 2, np.pi / 2, -np.pi / 2, -np.pi / 2, 0.0),
    (-np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, 0.0),
    (-np.pi / 2, -np.pi / 2, -np.pi / 2, -np.pi / 2, 0.0),
    (-np.pi / 2, -np.pi / 2, -np.pi / 2, np.pi / 2, 0.0),
)


class Unreachable(Enum):
    """Why the arm cannot put the palm at a target pose (ReachabilityError.kind)."""

    OUT_OF_REACH = "out_of_reach"  #: the flange would lie farther from the shoulder than the arm reaches
    JOINT_LIMIT = "joint_limit"  #: the solver stopped with joints held at their limits
    NOT_CONVERGED = "not_converged"  #: the solver stopped with the residual above the tolerance
    BRANCH_FLIP = "branch_flip"  #: a joint jumps between consecutive path samples


class ReachabilityError(NoSolutionError):
    """The arm cannot put the palm at a target pose: out of reach, IK did not converge, a joint
    limit is in the way, or a path's solution jumps branches.

    index: the sample index along the path (None for a single target); target: the 4x4 palm pose
    (world, m); kind: why (Unreachable); evidence: its figures, by kind: OUT_OF_REACH
    ``distance_m``, ``limit_m`` (the flange from the shoulder, and the most it can be);
    JOINT_LIMIT ``joints`` (names), ``residual_m``; NOT_CONVERGED ``iterations``,
    ``residual_m``, ``residual_rad`` and ``distance_m`` when beyond the rated reach; BRANCH_FLIP
    ``joint``, ``jump_rad``, ``max_step_rad``; with ``starts`` (count) when no standard start of
    ik_seed_for converged (the figures are then the closest's). reason: all that in words.
    """

    def __init__(self, index: int | None, target: ArrayLike, kind: Unreachable, reason: str, **evidence: Any):
        self.index = index
        self.target = np.array(target, dtype=float)
        self.kind = kind
        self.evidence = evidence
        self.reason = reason
        where = "target" if index is None else f"sample {index}"
        x, y, z = 1000.0 * self.target[:3, 3]
        super().__init__(f"{where}: palm at ({x:.1f}, {y:.1f}, {z:.1f}) mm unreachable: {reason}")


class IKPath(NamedTuple):
    """Joint path of ``solve_path``: q (N, 6) rad; the palm's position (m) and rotation (rad)
    residuals (N,) against the targets."""

    q: NDArray[np.float64]
    pos_residual: NDArray[np.float64]
    rot_residual: NDArray[np.float64]


@dataclass
class _Solution:
    q6: NDArray[np.float64]
    pos_residual: float  # m
    rot_residual: float  # rad
    converged: bool
    iterations: int


def _arm_indices(robot: RobotModel) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Indices of the arm joints in q and in v."""
    joints = [robot.model.joints[j] for j in robot.arm_joint_ids]
    return np.array([j.idx_q for j in joints]), np.array([j.idx_v for j in joints])


def _wrap(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angles (rad) to [-pi, pi)."""
    return (q + np.pi) % (2 * np.pi) - np.pi


def _error(robot: RobotModel, q: NDArray[np.float64], target: pin.SE3) -> tuple[pin.SE3, NDArray, float, float]:
    """At full configuration q: the palm-to-target transform, its log (6,), and the position (m)
    and rotation (rad) residuals."""
    pin.framesForwardKinematics(robot.model, robot.data, q)
    palm = robot.data.oMf[robot.tcp_frame]
    palm_to_target = palm.actInv(target)
    pos = float(np.linalg.norm(target.translation - palm.translation))
    rot = float(np.linalg.norm(pin.log3(palm_to_target.rotation)))
    return palm_to_target, pin.log6(palm_to_target).vector, pos, rot


def _flange_distance(robot: RobotModel, target: NDArray[np.float64]) -> float:
    """Distance (m) from the shoulder point to where the flange must be for the palm at ``target``."""
    flange = target[:3, 3] - robot.gripper.palm_depth * target[:3, 2]
    return float(np.linalg.norm(flange - shoulder_position(robot)))


def _check_reach(robot: RobotModel, target: NDArray[np.float64], index: int | None) -> None:
    """ReachabilityError if the flange would be farther from the shoulder than any configuration
    puts it: a quick, exact-bound rejection before iterating."""
    distance = _flange_distance(robot, target)
    limit = max_flange_distance_from_shoulder()
    if distance > limit:
        raise ReachabilityError(index, target, Unreachable.OUT_OF_REACH, (
            f"out of reach: the flange would be {distance:.3f} m from the shoulder, the UR5e reaches "
            f"{limit:.3f} m at most ({UR5E_REACH} m rated reach)"), distance_m=distance, limit_m=limit)


def _clik(robot: RobotModel, target: pin.SE3, q0: ArrayLike, tol_pos: float, tol_rot: float,
          max_iter: int) -> _Solution:
    """Damped least squares (Levenberg-Marquardt) on the arm joints for the palm at ``target``.

    The error is e = log6(palm^-1 target) (the target seen from the palm, LOCAL); with the palm's
    LOCAL frame Jacobian J, de/dq = -Jlog6(target^-1 palm) J. Each step solves the damped normal
    equations, is capped at MAX_ITERATION_STEP, clamped to the joint limits, and kept only if it
    lowers |e|; otherwise the damping grows tenfold and the step is retried (it shrinks and turns
    toward the gradient), and on success the damping falls back toward DAMPING_MIN. Iterating
    goes on past the tolerance until |e| < ERROR_FLOOR or no step helps: near a solution the steps
    are Gauss-Newton and converge quadratically, so that costs a step or two and leaves residuals
    near 1e-12 (m, rad) instead of just under the tolerance.
    """
    iq, iv = _arm_indices(robot)
    lower, upper = robot.q_lower[iq], robot.q_upper[iq]
    q = configuration(robot, q0).copy()
    q[iq] = np.clip(q[iq], lower, upper)
    palm_to_target, err, pos, rot = _error(robot, q, target)
    damping = DAMPING_START
    iterations = 0
    for iterations in range(1, max_iter + 1):
        if pos < tol_pos and rot < tol_rot and np.linalg.norm(err) < ERROR_FLOOR:
            break
        jac = pin.computeFrameJacobian(robot.model, robot.data, q, robot.tcp_frame, pin.LOCAL)[:, iv]
        jac_err = -pin.Jlog6(palm_to_target.inverse()) @ jac
        normal = jac_err @ jac_err.T + (damping + ERROR_DAMPING * (err @ err)) * np.eye(6)
        step = -jac_err.T @ np.linalg.solve(normal, err)
        largest = np.abs(step).max()
        if largest > MAX_ITERATION_STEP:
            step *= MAX_ITERATION_STEP / largest
        trial = q.copy()
        trial[iq] = np.clip(q[iq] + step, lower, upper)
        trial_error = _error(robot, trial, target)
        if np.linalg.norm(trial_error[1]) < np.linalg.norm(err):
            q, (palm_to_target, err, pos, rot) = trial, trial_error
            damping = max(damping / 10, DAMPING_MIN)
        else:
            damping *= 10
            if damping > DAMPING_MAX:
                break
    converged = pos < tol_pos and rot < tol_rot
    return _Solution(q[iq].copy(), pos, rot, converged, iterations)


def _failure(robot: RobotModel, target: NDArray[np.float64], solution: _Solution, index: int | None
             ) -> ReachabilityError:
    """Why ``solution`` failed, as the ReachabilityError of sample ``index``: a joint held at its
    limit, or the residual left."""
    iq, _ = _arm_indices(robot)
    at_limit = [(name, value) for name, value, lo, hi in
                zip(ARM_JOINTS, solution.q6, robot.q_lower[iq], robot.q_upper[iq])
                if min(value - lo, hi - value) < 1e-9]
    if at_limit:
        held = ", ".join(f"{name} at {value:+.4f} rad" for name, value in at_limit)
        return ReachabilityError(index, target, Unreachable.JOINT_LIMIT,
                                 f"joint limit: {held} (residual {1000 * solution.pos_residual:.3f} mm)",
                                 joints=tuple(name for name, _ in at_limit), residual_m=solution.pos_residual)
    reason = (f"IK did not converge ({solution.iterations} iterations): residual "
              f"{1000 * solution.pos_residual:.3f} mm, {solution.rot_residual:.2e} rad")
    evidence: dict[str, Any] = dict(iterations=solution.iterations, residual_m=solution.pos_residual,
                                    residual_rad=solution.rot_residual)
    distance = _flange_distance(robot, target)
    if distance > UR5E_REACH:
        reason += (f"; the flange would be {distance:.3f} m from the shoulder, beyond the {UR5E_REACH} m "
                   f"rated reach")
        evidence["distance_m"] = distance
    return ReachabilityError(index, target, Unreachable.NOT_CONVERGED, reason, **evidence)


def solve_ik(robot: RobotModel, target: ArrayLike, q0: ArrayLike, tol_pos: float = 1e-5, tol_rot: float = 1e-5,
             max_iter: int = 200, index: int | None = None) -> NDArray[np.float64]:
    """Arm joints (6,) rad putting the palm frame at ``target`` (4x4, world), from the start q0
    ((6,) or (7,)), within tol_pos (m) and tol_rot (rad); the solution stays within the joint
    limits. Raises ReachabilityError (naming sample ``index`` if given) when out of reach, not
    converged or blocked by a joint limit."""
    target = as_pose(target, "ik.target")
    _check_reach(robot, target, index)
    solution = _clik(robot, pin.SE3(target), q0, tol_pos, tol_rot, max_iter)
    if not solution.converged:
        raise _failure(robot, target, solution, index)
    return solution.q6


def ik_seed_for(robot: RobotModel, target: ArrayLike, tol_pos: float = 1e-5, tol_rot: float = 1e-5,
                max_iter: int = 200, index: int | None = None) -> NDArray[np.float64]:
    """A first solution (6,) rad for the palm at ``target`` (4x4, world), without a start.

    Solves from standard UR postures (``_SEED_POSTURES`` with the shoulder turned toward, away
    from and across the target: 16 starts) and keeps the converged solution that moved least from
    its seed (Euclidean norm of the joint change, angles wrapped to [-pi, pi)): the one nearest a
    standard posture. Tolerances as in ``solve_ik``. Raises ReachabilityError.
    """
    target = as_pose(target, "ik.target")
    _check_reach(robot, target, index)
    target_in_base = np.linalg.solve(robot.base, target)
    azimuth = np.arctan2(target_in_base[1, 3], target_in_base[0, 3])
    best: tuple[float, NDArray[np.float64]] | None = None
    closest: _Solution | None = None
    for shoulder in _wrap(azimuth + np.array(_SHOULDER_OFFSETS)):
        for posture in _SEED_POSTURES:
            seed = np.array([shoulder, *posture])
            solution = _clik(robot, pin.SE3(target), seed, tol_pos, tol_rot, max_iter)
            if not solution.converged:
                if closest is None or solution.pos_residual < closest.pos_residual:
                    closest = solution
                continue
            q = _wrap(solution.q6)
            change = float(np.linalg.norm(_wrap(q - seed)))
            if best is None or change < best[0]:
                best = (change, q)
    if best is None:
        starts = len(_SHOULDER_OFFSETS) * len(_SEED_POSTURES)
        near = _failure(robot, target, closest, index)
        raise ReachabilityError(index, target, near.kind, f"no IK solution from {starts} standard starts; the closest: "
                                                          f"{near.reason}", starts=starts, **near.evidence)
    return best[1]


def solve_path(robot: RobotModel, targets: Sequence[ArrayLike], q0: ArrayLike, max_step: float = MAX_PATH_STEP,
               tol_pos: float = 1e-5, tol_rot: float = 1e-5, max_iter: int = 200) -> IKPath:
    """Arm joints along palm poses ``targets`` (each 4x4, world), each solution warm-started from
    the previous one (the first from q0, (6,) or (7,), e.g. from ``ik_seed_for``).

    Continuity: every joint moves at most ``max_step`` (rad) between consecutive samples, else
    ReachabilityError ("branch_flip"); so does the first sample from q0. Raises ReachabilityError
    naming the sample for anything unreachable. Returns IKPath(q (N, 6), pos_residual (N,) m,
    rot_residual (N,) rad).
    """
    n = len(targets)
    path = np.empty((n, 6))
    pos_res, rot_res = np.empty(n), np.empty(n)
    previous = configuration(robot, q0)[_arm_indices(robot)[0]]
    for i, target in enumerate(targets):
        target = as_pose(target, f"ik.targets[{i}]")
        _check_reach(robot, target, i)
        solution = _clik(robot, pin.SE3(target), previous, tol_pos, tol_rot, max_iter)
        if not solution.converged:
            raise _failure(robot, target, solution, i)
        jump = np.abs(solution.q6 - previous)
        if jump.max() > max_step:
            j = int(jump.argmax())
            where = "the start q0" if i == 0 else f"sample {i - 1}"
            raise ReachabilityError(i, target, Unreachable.BRANCH_FLIP, (
                f"branch flip: {ARM_JOINTS[j]} moves {jump[j]:.3f} rad from {where} "
                f"(at most {max_step} rad per sample); the path crosses a singularity or needs finer sampling"),
                joint=ARM_JOINTS[j], jump_rad=float(jump[j]), max_step_rad=max_step)
        path[i], pos_res[i], rot_res[i] = solution.q6, solution.pos_residual, solution.rot_residual
        previous = solution.q6
    return IKPath(path, pos_res, rot_res)
