"""How robust a plan is along its way: the friction margin and the energy-bounded cage of the
states it passes (docs/model.md, sections 4.4 and 4.5).

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

from .mechanics import primitive_sliding_signs
from .mechanics.margin import friction_margin
from .planning.result import Plan
from .scene import Scene

if TYPE_CHECKING:  # pragma: no cover
    from .mechanics.cage import Cage, CageGrid  # scipy: loaded when a cage is computed

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
    return friction_margin(q[:, 0], q[:, 1], q[:, 2], samples.a_sign, samples.b_sign, scene.mu,
                           scene.options.sliding_model)


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


@dataclass(frozen=True)
class CageProfile:
    """The cage at each sample of a plan (see mechanics.cage.Cage)."""

    samples: PlanSamples
    cages: list[Cage]

    @property
    def escape_energy(self) -> NDArray[np.float64]:
        """Escape energy of each sample, J (inf: fully caged)."""
        return np.array([c.escape_energy for c in self.cages])

    def minimum(self) -> tuple[float, int]:
        """The smallest escape energy along the plan (J) and the sample where it occurs."""
        e = self.escape_energy
        k = int(np.argmin(e))
        return float(e[k]), k

    def counts(self) -> dict[str, int]:
        """How many samples have each outcome."""
        from .mechanics.cage import CageOutcome

        return {o.value: sum(c.outcome is o for c in self.cages) for o in CageOutcome}

    def weakest(self, plan: Plan) -> "CageMinimum":
        """Where along the plan (planned as plan) the cage is weakest: its smallest escape energy,
        at the first sample that has it."""
        energy, k = self.minimum()
        p = int(self.samples.primitive[k])
        return CageMinimum(energy, self.cages[k].outcome.value, tuple(float(x) for x in self.samples.states[k]), p,
                           plan.primitives[p].type, len(self.cages), self.counts())


@dataclass(frozen=True)
class CageMinimum:
    """The smallest escape energy along a plan and where it occurs (see CageProfile.weakest)."""

    escape_energy: float
    """The smallest escape energy of the samples, J (inf: every sample fully caged)."""
    outcome: str
    """That sample's CageOutcome value."""
    state: tuple[float, float, float]
    """The first sample that has it: theta (rad), d (over l), psi (rad)."""
    primitive: int
    """The index of the plan's primitive it lies on."""
    primitive_type: str
    """That primitive's type (P_theta, P_psi or P_dpsi)."""
    samples: int
    """How many states of the plan were examined."""
    counts: dict[str, int]
    """How many samples have each outcome."""

    def describe(self) -> str:
        """One line for a person (millijoules and degrees)."""
        theta, d, psi = self.state
        energy = "inf" if math.isinf(self.escape_energy) else f"{self.escape_energy * 1000:.4f}"
        counts = ", ".join(f"{n} {o.replace('_', ' ')}" for o, n in self.counts.items() if n)
        return (f"cage: smallest escape energy {energy} mJ ({self.outcome.replace('_', ' ')}), first at (theta "
                f"{math.degrees(theta):.1f} deg, d {d:.3f}, psi {math.degrees(psi):.1f} deg) in primitive "
                f"{self.primitive + 1} ({self.primitive_type}); {self.samples} states: {counts}")

    def to_dict(self) -> dict:
        """For plan.json: energies in millijoules (null for inf), the state in radians and over l."""
        return {"min_escape_energy_mj": None if math.isinf(self.escape_energy) else self.escape_energy * 1000,
                "outcome": self.outcome, "state": list(self.state), "primitive": self.primitive,
                "primitive_type": self.primitive_type, "samples": self.samples, "counts": dict(self.counts)}


def cage_profile(scene: Scene, plan: Plan, grid: CageGrid | None = None, squeeze: float = 0.0,
                 resolution: ArrayLike = PROFILE_RESOLUTION) -> CageProfile:
    """The energy-bounded cage along a solved plan (Scene.cage at each sample)."""
    samples = plan_samples(plan, resolution)
    return CageProfile(samples, scene.cage(samples.states, grid, squeeze))


__all__ = ["CageMinimum", "CageProfile", "PROFILE_RESOLUTION", "PathMargin", "PlanSamples", "cage_profile",
           "path_friction_margin", "plan_friction_margins", "plan_samples"]
