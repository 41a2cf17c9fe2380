"""The planners' objectives as OMPL optimisation objectives (docs/model.md, sections 6 and 6.1):
the reference planner's cost; ``balanced``, the weighted sum of it and a margin penalty; and the
maximin objectives ``margin`` and ``tolerance``, a bottleneck (the path's smallest margin, combined
by its minimum along the path) ranked before an additive tie-break, encoded in one OMPL cost."""

from __future__ import annotations

import math

from ompl import base as ob
from ompl import geometric as og

from .atlas import D, PSI, THETA, SecurityAtlas
from .margins import LatticeMargins, Objective



class LatticeObjective(ob.OptimizationObjective):
    """An objective over the security atlas's lattice: asymmetric, no state cost, and a motion's cost
    from the lattice indices of its two states (lattice_cost), infinite where either lies off the
    lattice (OMPL states: theta rad, d over l, psi rad)."""

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas):
        super().__init__(si)
        self.atlas = atlas

    def isSymmetric(self) -> bool:
        return False

    def stateCost(self, state) -> ob.Cost:
        return self.identityCost()

    def motionCost(self, s1, s2) -> ob.Cost:
        a = self.atlas.index((s1[0], s1[1], s1[2]))
        b = self.atlas.index((s2[0], s2[1], s2[2]))
        return self.infiniteCost() if a is None or b is None else self.lattice_cost(a, b, s1, s2)

    def lattice_cost(self, a, b, s1, s2) -> ob.Cost:
        """The cost of the motion from lattice index a to b (the OMPL states s1, s2 beside them)."""
        raise NotImplementedError


class PrimitiveCostObjective(LatticeObjective):
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
        super().__init__(si, atlas)
        opts = atlas.scene.options
        self.d_weight = opts.d_weight
        self.length_weight = length_weight
        self.penalty = opts.mode_change_penalty if penalty is None else penalty
        self._res = tuple(float(x) for x in atlas.res)

    def lattice_cost(self, a, b, s1, s2) -> ob.Cost:
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


class MarginPenaltyObjective(LatticeObjective):
    """The margin penalty of a motion (LatticeMargins.motion): the sum over its lattice steps of
    the step's weighted L1 length times the objective's penalty of its friction margin (the best
    secure staircase's), infinite for a motion against the allowed directions or with no secure
    staircase. Additive and asymmetric."""

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas, margins: LatticeMargins):
        super().__init__(si, atlas)
        self.margins = margins

    def lattice_cost(self, a, b, s1, s2) -> ob.Cost:
        return ob.Cost(self.margins.motion(a, b))

    def motionCostHeuristic(self, s1, s2) -> ob.Cost:
        return self.identityCost()


#: The maximin objectives' tie-break weights: of a primitive leg, and of the L1 length (reference
#: units), against the tie-break penalty (at most 1 per unit of length).
MARGIN_LEG_WEIGHT = 100.0
MARGIN_LENGTH_WEIGHT = 1e-6

#: MaximinObjective's encoding: a cost is level * LEVEL_SCALE + tie-break, the tie-break below
#: TIE_BREAK_CAP (a power of two, so that the split is exact).
LEVEL_SCALE = 2.0 ** 24
TIE_BREAK_CAP = LEVEL_SCALE - 1.0


class RobustObjective(ob.MultiOptimizationObjective):
    """The ``balanced`` objective as OMPL's weighted sum of PrimitiveCostObjective and
    MarginPenaltyObjective (docs/model.md, section 6.1): the cost plus planning.margin_weight times
    the penalty 1 / margin (deg); asymmetric like its parts (MultiOptimizationObjective would report
    itself symmetric, and RRT* would then reuse motions backwards). The maximin objectives are not
    sums: MaximinObjective."""

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas, margins: LatticeMargins):
        super().__init__(si)
        if margins.objective != Objective.BALANCED:
            raise ValueError(f"RobustObjective is the balanced objective; {margins.objective} is MaximinObjective")
        self.cost_part = PrimitiveCostObjective(si, atlas)
        self.penalty_part = MarginPenaltyObjective(si, atlas, margins)
        self.addObjective(self.cost_part, 1.0)
        self.addObjective(self.penalty_part, atlas.scene.options.margin_weight)
        self.lock()

    def isSymmetric(self) -> bool:
        return False

    def motionCostHeuristic(self, s1, s2) -> ob.Cost:
        return self.cost_part.motionCostHeuristic(s1, s2)


class MaximinObjective(LatticeObjective):
    """The ``margin`` (or ``tolerance``) objective for OMPL's planners: lexicographic, the path's
    smallest margin first (larger is better), then the tie-break (docs/model.md, section 6.1).

    A cost is the pair (level, tie-break) in one OMPL cost, level * LEVEL_SCALE + tie-break:

    - level: LatticeMargins.level of the smallest margin along the path, 0 where it keeps the
      lattice's bottleneck m*, else the rank of that margin below m* (the widest 1), so that a
      larger smallest margin is a smaller level, exactly. It combines along a path by its maximum
      (a bottleneck, not a sum);
    - tie-break: additive, MARGIN_LEG_WEIGHT per primitive leg, the margin penalty
      exp(-max(m - m*, 0) / TIE_SCALE_DEG) per unit of length, MARGIN_LENGTH_WEIGHT times the L1
      length: the lattice's order after the margin (changes, tie-break, cost) as one sum, capped at
      TIE_BREAK_CAP (a path's is at most a few thousand).

    A motion's cost is its best secure staircase's (LatticeMargins.motion_value: the widest, then
    the least penalised), every lattice state it passes counted in its leg's mode, its first state
    (the start, for a path's first motion) included; infinite for a motion against the allowed
    directions or that no secure staircase realises. The encoding is monotone in the lexicographic
    order, so OMPL's own comparison of costs (isCostBetterThan: the smaller value), its identity
    (0: no motion, level 0) and its infinite cost are the objective's, and only combineCosts is the
    objective's own: the larger level, the tie-breaks added. Tie-breaks lose precision on deep
    levels (on level n about n * 4e-9), never the level. Asymmetric, like the cost: RRT* never
    reuses a motion backwards. OMPL's default cost threshold (0) is never met, so a planner runs its
    whole budget.
    """

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas, margins: LatticeMargins):
        super().__init__(si, atlas)
        if not margins.objective.maximin:
            raise ValueError(f"MaximinObjective serves the maximin objectives, not {margins.objective}")
        self.margins = margins
        self.cost_part = PrimitiveCostObjective(si, atlas, MARGIN_LENGTH_WEIGHT, MARGIN_LEG_WEIGHT)

    def lattice_cost(self, a, b, s1, s2) -> ob.Cost:
        margin, penalty = self.margins.motion_value(a, b)
        if not math.isfinite(penalty):
            return self.infiniteCost()
        cost = self.cost_part.motionCost(s1, s2).value()
        if not math.isfinite(cost):
            return self.infiniteCost()
        return ob.Cost(encode(self.margins.level(margin), cost + penalty))

    def combineCosts(self, c1, c2) -> ob.Cost:
        v1, v2 = c1.value(), c2.value()
        if not (math.isfinite(v1) and math.isfinite(v2)):
            return self.infiniteCost()
        l1, t1 = decode(v1)
        l2, t2 = decode(v2)
        return ob.Cost(encode(max(l1, l2), t1 + t2))

    def motionCostHeuristic(self, s1, s2) -> ob.Cost:
        return self.cost_part.motionCostHeuristic(s1, s2)  # level 0, the least tie-break: admissible

    def smallest_margin(self, cost: ob.Cost) -> float:
        """The smallest margin (rad) that a finite cost's level stands for (LatticeMargins.level_margin:
        the bottleneck for level 0)."""
        return self.margins.level_margin(decode(cost.value())[0])


def encode(level: int, tie_break: float) -> float:
    """MaximinObjective's cost of a level and a tie-break."""
    return level * LEVEL_SCALE + min(max(tie_break, 0.0), TIE_BREAK_CAP)


def decode(value: float) -> tuple[int, float]:
    """The (level, tie-break) of a finite MaximinObjective cost."""
    level = math.floor(value / LEVEL_SCALE)
    return level, value - level * LEVEL_SCALE


def make_objective(si: ob.SpaceInformation, atlas: SecurityAtlas, margins: LatticeMargins) -> ob.OptimizationObjective:
    """The OMPL objective of a robust objective's margins: MaximinObjective for margin and
    tolerance, RobustObjective for balanced."""
    return (MaximinObjective if margins.objective.maximin else RobustObjective)(si, atlas, margins)


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
