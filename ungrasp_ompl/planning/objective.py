"""The planners' objectives as OMPL optimisation objectives: the reference planner's cost, and the
robust ones, margin and balanced, as weighted sums of it and a margin penalty (docs/model.md,
section 6)."""

from __future__ import annotations

import math

from ompl import base as ob
from ompl import geometric as og

from .atlas import D, PSI, THETA, SecurityAtlas
from .margins import LatticeMargins, Objective


class PrimitiveCostObjective(ob.OptimizationObjective):
    """Weighted L1 length (degrees of theta and psi + d_weight * d) plus a penalty per primitive leg.

    Asymmetric: a motion against the allowed primitive directions costs
    infinity, so RRT* never reuses a motion backwards when it rewires. The
    penalty counts the fewest legs that can realise the motion (one per moving
    coordinate; d and psi moving oppositely make one P_dpsi leg); the plan's
    reported cost counts the changes between the legs actually merged.
    """

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas, length_weight: float = 1.0,
                 penalty: float | None = None):
        """length_weight: the weight of the L1 length; penalty: the cost of a leg (the scene's
        planning.mode_change_penalty when None)."""
        super().__init__(si)
        self.atlas = atlas
        opts = atlas.scene.options
        self.d_weight = opts.d_weight
        self.length_weight = length_weight
        self.penalty = opts.mode_change_penalty if penalty is None else penalty
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
        length = _l1(step[0] * res[0], step[1] * res[1], step[2] * res[2], self.d_weight)
        return ob.Cost(self.length_weight * length + self.penalty * legs)

    def motionCostHeuristic(self, s1, s2) -> ob.Cost:
        return ob.Cost(self.length_weight * _l1(s2[0] - s1[0], s2[1] - s1[1], s2[2] - s1[2], self.d_weight) * 0.99)


def _l1(dtheta: float, dd: float, dpsi: float, d_weight: float) -> float:
    """reference_cost of one step in plain floats (the same arithmetic; no arrays, as it is
    called for every edge a planner weighs)."""
    return math.degrees(abs(dtheta) + abs(dpsi)) + d_weight * abs(dd)


class MarginPenaltyObjective(ob.OptimizationObjective):
    """The margin penalty of a motion (LatticeMargins.motion): the sum over its lattice steps of
    the step's weighted L1 length times the objective's penalty of its friction margin (the best
    secure staircase's), infinite for a motion against the allowed directions or with no secure
    staircase. Additive and asymmetric."""

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas, margins: LatticeMargins):
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
        return ob.Cost(self.margins.motion(a, b))

    def motionCostHeuristic(self, s1, s2) -> ob.Cost:
        return self.identityCost()


#: The margin objective's weights in OMPL's sum: of a primitive leg, and of the L1 length (reference
#: units), against the tie-break penalty (at most 1 per unit of length at the bottleneck).
MARGIN_LEG_WEIGHT = 100.0
MARGIN_LENGTH_WEIGHT = 1e-6


class RobustObjective(ob.MultiOptimizationObjective):
    """A robust objective as OMPL's weighted sum of PrimitiveCostObjective and
    MarginPenaltyObjective (docs/model.md, section 6.1), asymmetric like its parts
    (MultiOptimizationObjective would report itself symmetric, and RRT* would then reuse motions
    backwards):

    - ``balanced``: the cost plus planning.margin_weight times the penalty 1 / margin (deg);
    - ``margin``: the tie-break penalty exp(-(margin - bottleneck) / TIE_SCALE_DEG), BELOW_BOTTLENECK
      times more below the lattice's bottleneck, plus MARGIN_LEG_WEIGHT per primitive leg and
      MARGIN_LENGTH_WEIGHT times the L1 length: the lattice's order (the smallest margin, the
      primitive changes, the tie-break, the cost) as one additive cost.
    """

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas, margins: LatticeMargins):
        super().__init__(si)
        if margins.objective == Objective.BALANCED:
            self.cost_part = PrimitiveCostObjective(si, atlas)
            penalty_weight = atlas.scene.options.margin_weight
        else:
            self.cost_part = PrimitiveCostObjective(si, atlas, MARGIN_LENGTH_WEIGHT, MARGIN_LEG_WEIGHT)
            penalty_weight = 1.0
        self.penalty_part = MarginPenaltyObjective(si, atlas, margins)
        self.addObjective(self.cost_part, 1.0)
        self.addObjective(self.penalty_part, penalty_weight)
        self.lock()

    def isSymmetric(self) -> bool:
        return False

    def motionCostHeuristic(self, s1, s2) -> ob.Cost:
        return self.cost_part.motionCostHeuristic(s1, s2)


def reduce_vertices(si: ob.SpaceInformation, objective: ob.OptimizationObjective,
                    path: og.PathGeometric) -> og.PathGeometric:
    """The subsequence of the path's states, its ends kept, that the objective ranks best when
    each state is joined to the next by a valid motion: a shortest path over the path's states
    (every state to every later one), so never worse than the path itself. OMPL's
    PathSimplifier.reduceVertices drops states whenever the shortcut is valid, whatever it costs:
    for a robust objective that can trade a wide path for a narrow one."""
    states = [path.getState(k) for k in range(path.getStateCount())]
    best = [objective.identityCost()] + [objective.infiniteCost()] * (len(states) - 1)
    prev = [0] * len(states)
    for j in range(1, len(states)):
        for i in range(j):
            if i + 1 < j and not si.checkMotion(states[i], states[j]):
                continue
            via = objective.combineCosts(best[i], objective.motionCost(states[i], states[j]))
            if objective.isCostBetterThan(via, best[j]) or (i + 1 == j and not math.isfinite(best[j].value())):
                best[j], prev[j] = via, i
    chain = [len(states) - 1]
    while chain[-1]:
        chain.append(prev[chain[-1]])
    out = og.PathGeometric(si)
    for k in reversed(chain):
        out.append(states[k])
    return out
