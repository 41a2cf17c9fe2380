"""The states a path of motion primitives passes, each in its primitive's contact mode
(docs/model.md, sections 3 and 4.4): what a plan's friction margin, cage profile and tolerance are
taken over.

A path's primitives are sampled along their waypoints (each straight leg at least every
``resolution`` in theta, d and psi: rad, over l, rad), and every sample keeps the contact mode of
the leg it lies on (contact.primitive_sliding_signs), the mode the planner checked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .contact import primitive_sliding_signs


class PathPrimitive(Protocol):
    """One primitive of a path: its type (contact.Primitive's name) and its waypoints (k, 3)."""

    type: str
    waypoints: Sequence[Sequence[float]]


class PrimitivePath(Protocol):
    """A path of primitives, as planning.result.Plan holds it."""

    primitives: Sequence[PathPrimitive]


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


def plan_samples(plan: PrimitivePath, resolution: ArrayLike = PROFILE_RESOLUTION, both_modes: bool = False) -> PlanSamples:
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
