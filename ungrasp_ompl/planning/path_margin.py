"""A plan's friction margin over the states its legs pass, each in its leg's contact mode
(mechanics.path.plan_samples; docs/model.md, section 4.4): one definition behind `plan`, `bench`,
`cage` and the API."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..mechanics.margin import friction_margin
from ..mechanics.path import PlanSamples, plan_samples
from ..scene import Scene
from .result import Plan


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
