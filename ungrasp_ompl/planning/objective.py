"""The planners' objectives as OMPL optimisation objectives: the reference planner's cost, and the
robust ones, the friction margin (min-combining) and the balanced sum (docs/model.md, section 6)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ompl import base as ob

from .atlas import D, PSI, THETA, SecurityAtlas

if TYPE_CHECKING:  # pragma: no cover
    from .margins import LatticeMargins


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


class MarginObjective(ob.OptimizationObjective):
    """Maximise the smallest friction margin along the path (deg; docs/model.md, section 6).

    A min-combining objective in the manner of OMPL's MaximizeMinClearanceObjective: a motion's
    cost is its smallest margin (the best secure staircase's, each leg in its own contact mode,
    the start state left out; planning.margins.LatticeMargins), a path's is the smallest of its
    motions', larger is better, the identity is +inf and the worst (infinite) cost -inf, which a
    motion against the allowed directions or with no secure staircase gets. Asymmetric, like
    PrimitiveCostObjective, and never satisfied (the planner runs its whole budget).
    """

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas, margins: "LatticeMargins"):
        super().__init__(si)
        self.atlas = atlas
        self.margins = margins
        self.setCostThreshold(ob.Cost(math.inf))

    def isSymmetric(self) -> bool:
        return False

    def isSatisfied(self, cost) -> bool:
        return False

    def stateCost(self, state) -> ob.Cost:
        a = self.atlas.index((state[0], state[1], state[2]))
        if a is None or a == self.margins.start:
            return self.identityCost()
        return ob.Cost(math.degrees(float(self.margins.mode(0, 0)[a])))

    def motionCost(self, s1, s2) -> ob.Cost:
        index = self.atlas.index
        a = index((s1[0], s1[1], s1[2]))
        b = index((s2[0], s2[1], s2[2]))
        if a is None or b is None:
            return self.infiniteCost()
        return ob.Cost(math.degrees(self.margins.motion(a, b)[0]))

    def combineCosts(self, c1, c2) -> ob.Cost:
        return ob.Cost(min(c1.value(), c2.value()))

    def isCostBetterThan(self, c1, c2) -> bool:
        return c1.value() > c2.value()

    def identityCost(self) -> ob.Cost:
        return ob.Cost(math.inf)

    def infiniteCost(self) -> ob.Cost:
        return ob.Cost(-math.inf)

    def motionCostHeuristic(self, s1, s2) -> ob.Cost:
        return self.identityCost()


class MarginPenaltyObjective(ob.OptimizationObjective):
    """The margin penalty of a motion: the sum over its lattice steps of the step's weighted L1
    length over its friction margin in degrees (planning.margins; the best secure staircase's),
    infinite for a motion against the allowed directions or with no secure staircase. Additive
    and asymmetric; the balanced objective adds it, weighted, to PrimitiveCostObjective."""

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas, margins: "LatticeMargins"):
        super().__init__(si)
        self.atlas = atlas
        self.margins = margins

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
        return ob.Cost(self.margins.motion(a, b)[1])

    def motionCostHeuristic(self, s1, s2) -> ob.Cost:
        return self.identityCost()


class BalancedObjective(ob.MultiOptimizationObjective):
    """Cost plus planning.margin_weight times the margin penalty (OMPL's weighted sum of
    objectives), asymmetric like its parts (MultiOptimizationObjective would report itself
    symmetric, and RRT* would then reuse motions backwards)."""

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas, margins: "LatticeMargins"):
        super().__init__(si)
        self.cost_part = PrimitiveCostObjective(si, atlas)
        self.penalty_part = MarginPenaltyObjective(si, atlas, margins)
        self.addObjective(self.cost_part, 1.0)
        self.addObjective(self.penalty_part, atlas.scene.options.margin_weight)
        self.lock()

    def isSymmetric(self) -> bool:
        return False

    def motionCostHeuristic(self, s1, s2) -> ob.Cost:
        return self.cost_part.motionCostHeuristic(s1, s2)
