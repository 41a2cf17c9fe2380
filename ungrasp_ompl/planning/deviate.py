"""Plans the scene's model may reject, as the paper's experiments run them: the plan with its start
turned (a larger psi, the caging experiment's deviated start) or pivoted up (a steeper theta), and
why the model rejects a plan, primitive by primitive (planning.verify's typed failures). Angles in
radians; states (theta, d over l, psi)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError
from ..geometry.collision import CollisionChecker
from ..mechanics.contact import Primitive
from ..scene import Scene
from .result import Plan, PrimitiveStep
from .verify import LegFailure, verify_leg


def check_psi_offset(psi_offset: float) -> None:
    """Raises InputError unless psi_offset (rad) is a deviation of the start's psi in (0, 90) deg."""
    if not (math.isfinite(psi_offset) and 0.0 < psi_offset < math.pi / 2):
        raise InputError("start_psi_offset", f"must lie in (0, 90) deg, got {math.degrees(psi_offset):g}")


def deviated_plan(plan: Plan, psi_offset: float) -> Plan:
    """The plan started with psi larger by psi_offset (rad): its states keep at least the
    deviated start's psi (the forward primitives only raise psi), and primitives that
    shrink to nothing are dropped. The paper's caging experiment (sec. 6.2.3) runs such a
    plan: the start lies outside force closure."""
    check_psi_offset(psi_offset)
    floor = plan.states[0][2] + psi_offset

    def lifted(q: list[float]) -> list[float]:
        return [q[0], q[1], max(q[2], floor)]

    steps = []
    for p in plan.primitives:
        ways = [lifted(w) for w in p.waypoints]
        ways = [w for k, w in enumerate(ways) if k == 0 or w != ways[k - 1]]
        if len(ways) >= 2:
            steps.append(replace(p, start=ways[0], end=ways[-1], waypoints=ways))
    if not steps:
        raise InputError("start_psi_offset", "leaves nothing of the plan to execute")
    return replace(plan, solution=replace(plan.solution, states=[lifted(plan.states[0])] + [lifted(q) for q in plan.states[1:]],
                                          primitives=steps))


def steeper_start(plan: Plan, theta_offset: float) -> Plan:
    """The plan started with theta larger by theta_offset (rad): a pivot (P_theta, all contacts
    sticking) from the steeper start down to the plan's own start comes first. Where the
    steeper start lies outside force closure, this is the paper's caging experiment (sec.
    6.2.3) in scenes whose larger psi stays inside it."""
    if not (math.isfinite(theta_offset) and 0.0 < theta_offset < math.pi / 2):
        raise InputError("theta_offset", f"must lie in (0, 90) deg, got {math.degrees(theta_offset):g}")
    start = list(plan.states[0])
    steep = [start[0] + theta_offset, start[1], start[2]]
    pivot = PrimitiveStep(Primitive.THETA, "forward", steep, start, {}, "full", [steep, start])
    return replace(plan, solution=replace(plan.solution, states=[steep] + list(plan.states),
                                          primitives=[pivot] + list(plan.primitives)))


@dataclass(frozen=True)
class PlanProblem:
    """Why the scene's model rejects a plan's primitive (plan_problems)."""

    primitive: int
    """The primitive, counted from 1 as a person reads the plan."""
    type: str
    """Its type (P_theta, P_psi, P_dpsi, ...)."""
    failure: LegFailure
    """The first failing check and the state where it fails."""

    def __str__(self) -> str:
        return f"primitive {self.primitive} ({self.type}): {self.failure}"


def plan_problems(scene: Scene, plan: Plan) -> list[PlanProblem]:
    """Why the scene's model would reject the plan, primitive by primitive (empty: every leg is
    secure): kinematics, collision and force closure in each leg's contact mode (planning.verify);
    the first failure of each failing primitive."""
    checker = CollisionChecker(scene.collision_model())
    resolution = np.asarray(scene.options.resolution) / 2
    out = []
    for k, p in enumerate(plan.primitives):
        for a, b in zip(p.waypoints[:-1], p.waypoints[1:]):
            failure = verify_leg(scene, p.type, a, b, resolution, checker)
            if failure:
                out.append(PlanProblem(k + 1, p.type, failure))
                break
    return out
