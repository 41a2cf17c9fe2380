"""The states a plan's legs pass, each in its leg's contact mode, and the plan's friction margin
over them (docs/model.md, section 4.4): one definition behind `plan`, `bench`, `cage` and the API.

A plan's primitives are sampled along their waypoints (each straight leg at least every
``resolution`` in theta, d and psi: rad, over l, rad), and every sample keeps the contact mode of
the leg it lies on (mechanics.contact.primitive_sliding_signs), the mode the planner checked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..mechanics import primitive_sliding_signs
from ..mechanics.margin import friction_margin
from .result import Plan

if TYPE_CHECKING:  # pragma: no cover
    from ..scene import Scene


#: Default sampling of a plan's legs: 2 deg of theta or psi, 0.02 of d (over l).
PROFILE_RESOLUTION = (math.radians(2.0), 0.02, math.radians(2.0))


@dataclass(frozen=True)
class PlanSamples:
    """States along a plan (N, 3) (theta rad, d over l, psi rad), the index of the primitive each
    lies on (N,), and the sliding signs at A and B of that primitive's leg there (N,) each."""

    states: NDArray[np.float64]
    primitive: NDArray[np.int64]
    a_sign: NDArray[np.int8]
    b_sign: NDArray[np.int8]


def plan_samples(plan: Plan, resolution: ArrayLike = PROFILE_RESOLUTION, both_modes: bool = False) -> PlanSamples:
    """Sample a solved plan's legs, ends included. A corner shared by two legs appears once, in the
    mode of the leg that leaves it (the last state in the last leg's mode), or with both_modes
    once in each leg's mode (as the planner checks a leg: every state it passes, in its mode)."""
    res = np.asarray(resolution, dtype=float)
    states, prims, sa_all, sb_all = [], [], [], []
    for k, step in enumerate(plan.primitives):
        ways = np.asarray(step.waypoints, dtype=float)
        for a, b in zip(ways[:-1], ways[1:]):
            delta = b - a
            n = max(1, int(math.ceil(float(np.max(np.abs(delta) / res)) - 1e-9)))
            q = a + np.arange(n + 1 if both_modes else n)[:, None] / n * delta
            n = len(q)
            sa, sb = primitive_sliding_signs(step.type, q[:, 1], q[:, 2], delta[1], delta[2])
            states.append(q)
            prims.append(np.full(n, k))
            sa_all.append(np.asarray(sa, dtype=np.int8))
            sb_all.append(np.asarray(sb, dtype=np.int8))
    if not states:
        raise ValueError("the plan has no primitive to sample")
    last = np.asarray(plan.primitives[-1].waypoints[-1], dtype=float)
    states.append(last[None])
    prims.append(np.array([len(plan.primitives) - 1]))
    sa_all.append(sa_all[-1][-1:])
    sb_all.append(sb_all[-1][-1:])
    return PlanSamples(np.vstack(states), np.concatenate(prims), np.concatenate(sa_all), np.concatenate(sb_all))


def plan_friction_margins(scene: Scene, samples: PlanSamples) -> NDArray[np.float64]:
    """The friction margin (rad) of each sample in its leg's contact mode."""
    q = samples.states
    return friction_margin(q[:, 0], q[:, 1], q[:, 2], samples.a_sign, samples.b_sign, scene.friction)


@dataclass(frozen=True)
class PathMargin:
    """A solved plan's friction margin (path_friction_margin): its samples and each one's margin."""

    samples: PlanSamples
    margins: NDArray[np.float64]
    """The friction margin (rad) of each sample, in its leg's contact mode."""

    @property
    def smallest(self) -> float:
        """The smallest along the path (rad), the start included."""
        return float(self.margins.min())

    def of_primitives(self) -> list[float]:
        """The smallest of each primitive (rad), in order."""
        n = int(self.samples.primitive.max()) + 1
        return [float(self.margins[self.samples.primitive == k].min()) for k in range(n)]


def path_friction_margin(scene: Scene, plan: Plan) -> PathMargin:
    """The friction margin of a solved plan, as `plan`, `bench`, `cage` and the API report it
    (docs/model.md, section 4.4): every state its legs pass at the plan's lattice resolution
    (plan.resolution, else the scene's: the states the planner checked), each in the contact mode of the leg it lies
    on, a corner once in each leg's mode, the start included (in its first leg's mode)."""
    samples = plan_samples(plan, plan.resolution or scene.options.resolution, both_modes=True)
    return PathMargin(samples, plan_friction_margins(scene, samples))


__all__ = ["PROFILE_RESOLUTION", "PathMargin", "PlanSamples", "path_friction_margin", "plan_friction_margins",
           "plan_samples"]
