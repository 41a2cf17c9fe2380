"""The goal region: theta at most theta_end, d and psi within ranges, sampled on the lattice."""

from __future__ import annotations

import numpy as np
from ompl import base as ob

from ..scene import GoalSpec
from .atlas import SecurityAtlas
from .space import set_state


class LatticeGoalRegion(ob.GoalSampleableRegion):
    """The scene's goal box; samples are holdable lattice states inside it.

    distanceGoal is the L1 distance (in state units) to the box, zero inside.
    """

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas, goal: GoalSpec, rng: np.random.Generator):
        super().__init__(si)
        self.setThreshold(1e-9)
        self.lo, self.hi = goal.box()
        self.states = atlas.state(np.argwhere(atlas.releasable_in(goal.box())))
        self.rng = rng

    def distanceGoal(self, state) -> float:
        total = 0.0
        for k in range(3):
            x = state[k]
            total += max(0.0, self.lo[k] - x) + max(0.0, x - self.hi[k])
        return total

    def sampleGoal(self, state) -> None:
        set_state(state, self.states[self.rng.integers(len(self.states))])

    def maxSampleCount(self) -> int:
        return len(self.states)

    def couldSample(self) -> bool:
        return len(self.states) > 0
