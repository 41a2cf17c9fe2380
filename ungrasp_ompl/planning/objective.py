"""The reference planner's cost as an OMPL optimisation objective."""

from __future__ import annotations

import math

from ompl import base as ob

from .atlas import D, PSI, THETA, SecurityAtlas


class PrimitiveCostObjective(ob.OptimizationObjective):
    """Weighted L1 length (degrees of theta and psi + d_weight * d) plus a penalty per primitive leg.

    Asymmetric: a motion against the allowed primitive directions costs
    infinity, so RRT* never reuses a motion backwards when it rewires. The
    penalty counts the fewest legs that can realise the motion (one per moving
    coordinate; d and psi moving oppositely make one P_dpsi leg); the plan's
    reported cost counts the changes between the legs actually merged.
    """

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas):
        super().__init__(si)
        self.atlas = atlas
        opts = atlas.scene.options
        self.d_weight = opts.d_weight
        self.penalty = opts.mode_change_penalty
        self._res = tuple(float(x) for x in atlas.res)

    def isSymmetric(self) -> bool:
        return False

    def stateCost(self, state) -> ob.Cost:
        return self.identityCost()

    def motionCost(self, s1, s2) -> ob.Cost:
        index = self.atlas.index
        a = index((s1[0], s1[1], s1[2]))
        b = index((s2[0], s2[1], s2[2]))
        if a is None or b is None:
            return self.infiniteCost()
        step = (b[THETA] - a[THETA], b[D] - a[D], b[PSI] - a[PSI])
        if not self.atlas.allowed(step):
            return self.infiniteCost()
        legs = (step[THETA] != 0) + (step[D] != 0) + (step[PSI] != 0) - (step[D] * step[PSI] < 0)
        res = self._res
        return ob.Cost(_l1(step[0] * res[0], step[1] * res[1], step[2] * res[2], self.d_weight) + self.penalty * legs)

    def motionCostHeuristic(self, s1, s2) -> ob.Cost:
        return ob.Cost(_l1(s2[0] - s1[0], s2[1] - s1[1], s2[2] - s1[2], self.d_weight) * 0.99)


def _l1(dtheta: float, dd: float, dpsi: float, d_weight: float) -> float:
    """reference_cost of one step in plain floats (the same arithmetic; no arrays, as it is
    called for every edge a planner weighs)."""
    return math.degrees(abs(dtheta) + abs(dpsi)) + d_weight * abs(dd)
