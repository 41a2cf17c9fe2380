"""The energy-bounded cage along a plan: the cage of the states it passes (docs/model.md, section
4.5). Its friction margin along the way is planning.path_margin's; the tolerance of its states,
planning.plan_tolerance's.

A plan's primitives are sampled along their waypoints (each straight leg at least every
``resolution`` in theta, d and psi: rad, over l, rad), and every sample keeps the contact mode of
the leg it lies on (mechanics.contact.primitive_sliding_signs), the mode the planner checked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..mechanics.cage import Cage, CageGrid, CageOutcome
from ..mechanics.contact import Primitive
from ..mechanics.path import PROFILE_RESOLUTION, PlanSamples, plan_samples
from ..scene import Scene
from .result import Plan


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

    def counts(self) -> dict[CageOutcome, int]:
        """How many samples have each outcome."""
        return {o: sum(c.outcome is o for c in self.cages) for o in CageOutcome}

    def weakest(self, plan: Plan) -> "CageMinimum":
        """Where along the plan (planned as plan) the cage is weakest: its smallest escape energy,
        at the first sample that has it."""
        energy, k = self.minimum()
        p = int(self.samples.primitive[k])
        return CageMinimum(energy, self.cages[k].outcome, tuple(float(x) for x in self.samples.states[k]), p,
                           Primitive(plan.primitives[p].type), len(self.cages), self.counts())


@dataclass(frozen=True)
class CageMinimum:
    """The smallest escape energy along a plan and where it occurs (see CageProfile.weakest)."""

    escape_energy: float
    """The smallest escape energy of the samples, J (inf: every sample fully caged)."""
    outcome: CageOutcome
    """That sample's outcome."""
    state: tuple[float, float, float]
    """The first sample that has it: theta (rad), d (over l), psi (rad)."""
    primitive: int
    """The index of the plan's primitive it lies on."""
    primitive_type: Primitive
    """That primitive's type."""
    samples: int
    """How many states of the plan were examined."""
    counts: dict[CageOutcome, int]
    """How many samples have each outcome."""

    def describe(self) -> str:
        """One line for a person (millijoules and degrees)."""
        theta, d, psi = self.state
        energy = "infinite" if math.isinf(self.escape_energy) else f"{self.escape_energy * 1000:.4f} mJ"
        counts = ", ".join(f"{n} {o.label}" for o, n in self.counts.items() if n)
        return (f"energy-bounded cage (docs/model.md 4.5): the least energy the object needs to escape the digits "
                f"and the table along the plan is {energy}, first at theta {math.degrees(theta):.1f} deg, d {d:.3f}, "
                f"psi {math.degrees(psi):.1f} deg in primitive {self.primitive + 1} ({self.primitive_type}), where it is "
                f"{self.outcome.describe()}; of the {self.samples} states checked: {counts}")

    def to_dict(self) -> dict:
        """For plan.json: energies in millijoules (null for inf), the state in radians and over l."""
        return {"min_escape_energy_mj": None if math.isinf(self.escape_energy) else self.escape_energy * 1000,
                "outcome": self.outcome.value, "state": list(self.state), "primitive": self.primitive,
                "primitive_type": self.primitive_type, "samples": self.samples,
                "counts": {o.value: n for o, n in self.counts.items()}}


def cage_profile(scene: Scene, plan: Plan, grid: CageGrid | None = None, squeeze: float = 0.0,
                 resolution: ArrayLike = PROFILE_RESOLUTION) -> CageProfile:
    """The energy-bounded cage along a solved plan (Scene.cage at each sample)."""
    samples = plan_samples(plan, resolution)
    return CageProfile(samples, scene.cage(samples.states, grid, squeeze))

