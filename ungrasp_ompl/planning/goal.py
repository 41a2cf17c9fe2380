"""The goal region: theta at most theta_end, d and psi within ranges, sampled on the lattice."""

from __future__ import annotations

import numpy as np
from ompl import base as ob

from ..scene.options import GoalSpec
from .atlas import SecurityAtlas
from .space import set_state


class LatticeGoalRegion(ob.GoalSampleableRegion):
    """The scene's goal box, less the states the gripper cannot let go from; samples are the
    holdable lattice states inside it with room to let go (SecurityAtlas.releasable_in).

    distanceGoal is the L1 distance (in state units) to the box outside it; inside, zero at a
    goal state (by its nearest lattice state) and else the distance to the nearest goal state.
    """

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas, goal: GoalSpec, rng: np.random.Generator):
        super().__init__(si)
        self.setThreshold(1e-9)
        self.lo, self.hi = goal.box()
        self.atlas = atlas
        self.releasable = atlas.releasable_in(goal.box())
        self.states = atlas.state(np.argwhere(self.releasable))
        self.rng = rng

    def distanceGoal(self, state) -> float:
        total = 0.0
        for k in range(3):
            x = state[k]
            total += max(0.0, self.lo[k] - x) + max(0.0, x - self.hi[k])
        if total > 0.0:
            return total
        q = (state[0], state[1], state[2])
        idx = self.atlas.index(q)
        if idx is not None and self.releasable[idx]:
            return 0.0
        if not len(self.states):
            return 1.0
        return max(float(np.min(np.abs(self.states - np.asarray(q)).sum(axis=1))), 1e-6)

    def sampleGoal(self, state) -> None:
        set_state(state, self.states[self.rng.integers(len(self.states))])

    def maxSampleCount(self) -> int:
        return len(self.states)

    def couldSample(self) -> bool:
        return len(self.states) > 0
