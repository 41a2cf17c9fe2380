"""Friction margins (or tolerances) on the secure lattice, per state and contact mode, and the
robust objectives' values built from them (docs/model.md, sections 4.4, 4.6 and 6.1).

:class:`LatticeMargins` keeps, beside a :class:`~ungrasp_ompl.planning.atlas.SecurityAtlas`, the
friction margin (rad, :func:`~ungrasp_ompl.mechanics.margin.friction_margin`) of the lattice
states in every contact mode a primitive leg makes there, computed the first time a mode is
needed and only where the atlas finds that mode secure and the state lies on some secure lattice
path from the start to the goal region (-inf elsewhere). The start counts like every state, in the
mode of the leg that leaves it, as in a plan's margin (planning.path_margin.path_friction_margin). From them:

* a lattice step's margin: the smaller of its two ends', each in the step's contact mode;
* a leg's margin: the smallest of its steps' (the lattice states it passes, in its mode);
* the lattice's bottleneck: the largest margin a secure lattice path from the start to a
  releasable goal state can keep all the way (no secure path passes more);
* a step's penalty, its weighted L1 length (reference units, docs/model.md section 6) times a
  function of its margin m (deg) that falls as m grows: for ``balanced`` 1 / max(m, 1e-6), for
  ``margin`` exp(-max(m - m*, 0) / TIE_SCALE_DEG) with m* the bottleneck (deg), a steep tie-break
  between paths with the same smallest margin (a step at or below the bottleneck weighs 1); a leg's
  or a motion's penalty is the sum over its steps;
* a margin's level below the bottleneck (level): 0 at or above m*, else its rank among the distinct
  margins below m*, 1 for the widest: the smallest margin as an integer that orders margins
  exactly, which the planners' maximin objective (planning.objective.MaximinObjective) combines
  by its maximum along a path.

For the ``tolerance`` objective every "margin" above is the state's tolerance instead
(scene.tolerance.state_tolerances: the largest scale of the `paper` error box, up to
TOLERANCE_CAP, on its ladder, with the termination at the goal region's states), in
percent of the box where the ``margin`` objective counts degrees, and the search is the same.
"""

from __future__ import annotations

import bisect
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..scene.options import Objective  # what the scene's planning.objective names
from ..mechanics import primitive_sliding_signs
from ..scene.tolerance import ToleranceOptions, state_tolerances
from .atlas import D, LEG_AXES, PSI, Leg, SecurityAtlas, reference_cost
from .edges import LatticeEdges, lattice_edges
from .margin_table import MARGIN_TABLE


#: Margins below this (deg) count as this in the balanced penalty, so that it stays finite.
MARGIN_FLOOR_DEG = 1e-6

#: The margin objective's tie-break scale (deg): a step's penalty weight falls by e for every
#: TIE_SCALE_DEG its margin lies above the bottleneck (5 deg wider: 0.0067 times). As steep as
#: keeps margins 20 deg above the bottleneck (a cone's whole half-angle) weighing more than
#: TIE_TOLERANCE (exp(-20) = 2e-9), so that the tie-break still tells them apart.
TIE_SCALE_DEG = 1.0

#: Tie-break values closer than this (relative) count as equal; the cost decides between them.
TIE_TOLERANCE = 1e-9

#: Motions whose penalty is remembered before the memory is cleared.
MOTION_CACHE = 200_000

#: The largest tolerance the tolerance objective tells apart (a scale of the error box,
#: dimensionless): a state that tolerates the whole `paper` box is as good as any other.
TOLERANCE_CAP = 1.0



#: The objectives a plan can optimise, in their order.
OBJECTIVES = tuple(Objective)


class LatticeMargins:
    """Friction margins (rad) of an atlas's lattice states per contact mode (tolerances, a scale of
    the error box, for the ``tolerance`` objective), and the penalties of a robust objective
    (``margin``, ``balanced`` or ``tolerance``; see the module docstring).
    ``computed_states`` counts the states whose values were asked for so far (a friction margin is
    computed once per state for every lattice like this one: planning.margin_table)."""

    def __init__(self, atlas: SecurityAtlas, objective: Objective = Objective.MARGIN, goal_box: ArrayLike | None = None):
        """goal_box: the goal region's (2, 3) corners (theta rad, d over l, psi rad), the scene's by
        default: margins are computed only on secure paths from the start into it."""
        if objective not in OBJECTIVES[1:]:
            raise ValueError(f"the margins serve the objectives {', '.join(OBJECTIVES[1:])}, not {objective!r}")
        self.atlas = atlas
        self.objective = Objective(objective)
        #: The penalty's unit per unit of the values: degrees per radian of margin, percent of the box
        #: per unit of tolerance.
        self.unit = 100.0 if self.objective == Objective.TOLERANCE else math.degrees(1.0)
        self._kinematic_tolerance: NDArray[np.float64] | None = None
        self.goal_box = np.asarray(atlas.scene.goal.box() if goal_box is None else goal_box, dtype=float)
        #: The start's lattice index (None outside the lattice).
        self.start = atlas.index(atlas.scene.start)
        self._mode: dict[tuple[int, int], NDArray[np.float64]] = {}
        self._move: dict[tuple, NDArray[np.float64]] = {}
        self._steps: dict[tuple, NDArray[np.float64]] = {}
        self._edges: LatticeEdges | None = None
        self._edge_margin: NDArray[np.float64] | None = None
        self._relevant: NDArray[np.bool_] | None = None
        self._bottleneck: float | None | bool = False  # False: not searched yet
        self._below: NDArray[np.float64] | None = None  # the distinct margins below the bottleneck
        self._motions: dict[tuple, tuple[float, float]] = {}
        self._unit_lengths = np.array([reference_cost(np.eye(3)[k] * atlas.res, atlas.scene.options.d_weight)
                                       for k in range(3)])  # of one lattice step along each axis
        self.computed_states = 0

    @classmethod
    def of(cls, atlas: SecurityAtlas, objective: Objective = Objective.MARGIN,
           goal_box: ArrayLike | None = None) -> "LatticeMargins":
        """The atlas's margins for objective and goal_box, made once and kept on the atlas (what they
        hold depends on these alone), so that the searches of one plan share them."""
        box = np.asarray(atlas.scene.goal.box() if goal_box is None else goal_box, dtype=float)
        key = (Objective(objective), box.tobytes())
        if key not in atlas.margins:
            atlas.margins[key] = cls(atlas, objective, box)
        return atlas.margins[key]

    # -- the lattice's secure paths --------------------------------------------------------------
    @property
    def edges(self) -> "LatticeEdges":
        """The lattice's secure moves, built once."""
        if self._edges is None:
            self._edges = lattice_edges(self.atlas)
        return self._edges

    @property
    def goal(self) -> NDArray[np.bool_]:
        """The releasable goal states in goal_box (flat, the lattice's size)."""
        return self.atlas.releasable_in(self.goal_box).ravel()

    @property
    def relevant(self) -> NDArray[np.bool_]:
        """Lattice states on some secure lattice path from the start to the goal region (the
        others lie on no plan, so their margins are never needed): reachable from the start and
        reaching a releasable goal state, by breadth-first search over the lattice's secure moves."""
        if self._relevant is None:
            n = int(np.prod(self.atlas.shape))
            start = None if self.start is None else int(np.ravel_multi_index(self.start, self.atlas.shape))
            self._relevant = on_some_path(self.edges, n, start, self.goal).reshape(self.atlas.shape)
        return self._relevant

    def prepare(self) -> None:
        """Compute now every margin, and the bottleneck, that planning and its report may need (so
        that none is computed while a planner runs)."""
        self.edge_margin()
        _ = self.bottleneck
        if self.objective.maximin:
            self._levels()

    # -- per state -------------------------------------------------------------------------------
    def mode(self, sa: int, sb: int) -> NDArray[np.float64]:
        """Friction margin (rad) in contact mode (sa, sb) of every lattice state, -inf where the
        atlas finds the mode insecure or the state lies on no plan (relevant); shape of the lattice."""
        key = (int(sa), int(sb))
        if key not in self._mode:
            ok = self.atlas.mode_ok(*key) & self.relevant
            out = np.full(self.atlas.shape, -np.inf)
            idx = np.nonzero(ok)
            if len(idx[0]):
                th, d, ps = (self.atlas.axes[a][idx[a]] for a in range(3))
                s = self.atlas.scene
                if self.objective == Objective.TOLERANCE:
                    kinematic = self.kinematic_tolerance()[idx]
                    closure = state_tolerances(s, np.column_stack([th, d, ps]), key[0], key[1],
                                               options=ToleranceOptions(max_scale=TOLERANCE_CAP), kinematic=False,
                                               upto=kinematic)  # the smaller of the two is wanted
                    # at least 0 where the atlas finds the state secure: the two checks' geometry may
                    # differ by rounding at a boundary, which must not cut a path the planner may take
                    out[idx] = np.maximum(np.minimum(closure, kinematic), 0.0)
                else:  # friction_margin(th, d, ps, *key, s.friction), each state's once for every lattice like this
                    out[idx] = MARGIN_TABLE.margins(self.atlas.axes, idx, key[0], key[1], s.friction)
                self.computed_states += len(idx[0])
            self._mode[key] = out
        return self._mode[key]

    def kinematic_tolerance(self) -> NDArray[np.float64]:
        """The tolerance of every relevant lattice state without force closure (the checks that no
        contact mode changes: B on the thumb, the digits above the table and clear of obstacles,
        the termination at the goal region's states), -inf elsewhere; shape of the lattice."""
        if self._kinematic_tolerance is None:
            out = np.full(self.atlas.shape, -np.inf)
            idx = np.nonzero(self.relevant)
            if len(idx[0]):
                q = np.column_stack([self.atlas.axes[a][idx[a]] for a in range(3)])
                out[idx] = state_tolerances(self.atlas.scene, q, 0, 0, self.goal.reshape(self.atlas.shape)[idx],
                                            options=ToleranceOptions(max_scale=TOLERANCE_CAP), closure=False)
            self._kinematic_tolerance = out
        return self._kinematic_tolerance

    def move(self, kind: str, step: tuple[int, int, int]) -> NDArray[np.float64]:
        """The margin (rad) at every lattice state in the contact mode of a leg of this kind moving
        by the index step (T, P, D along one axis; X along d and psi, one step each), -inf where
        insecure: the mode the atlas's leg_ok (and the lattice search) checks there."""
        key = (kind,) + tuple(int(x > 0) - int(x < 0) for x in step)
        if key not in self._move:
            atlas = self.atlas
            if kind == "T":
                out = self.mode(0, 0)
            elif kind == "P":
                _, sb = primitive_sliding_signs("P_psi", 1.0, 0.0, 0.0, float(step[PSI]))
                out = self.mode(0, int(sb))
            else:
                d, psi = np.meshgrid(atlas.axes[D], atlas.axes[PSI], indexing="ij")
                dpsi = step[PSI] * atlas.res[PSI] if kind == "X" else 0.0
                sa, sb = primitive_sliding_signs("P_dpsi", d, psi, step[D] * atlas.res[D], dpsi)
                out = np.full(atlas.shape, -np.inf)
                for b in np.unique(sb):
                    out = np.where((sb == b)[None], self.mode(int(sa.flat[0]), int(b)), out)
            self._move[key] = out
        return self._move[key]

    # -- edges, the bottleneck and the penalty ---------------------------------------------------
    def edge_margin(self) -> NDArray[np.float64]:
        """The margin (rad) of every edge of the lattice (``edges``): the smaller of its ends',
        each in the edge's contact mode; -inf for an edge off every plan."""
        if self._edge_margin is None:
            e = self.edges
            out = np.empty(len(e.src))
            for k, (kind, _, step) in enumerate(e.moves):
                sel = slice(e.offsets[k], e.offsets[k + 1])
                m = self.move(kind, tuple(step)).ravel()
                out[sel] = np.minimum(m[e.src[sel]], m[e.dst[sel]])
            self._edge_margin = out
        return self._edge_margin

    @property
    def bottleneck(self) -> float | None:
        """The largest margin (rad) a secure lattice path from the start to a releasable goal
        state keeps all the way, +inf when the start is a goal state, None when no secure path
        exists: a bisection over the edges' distinct margins, reachability by breadth-first search."""
        if self._bottleneck is False:
            self._bottleneck = self._search_bottleneck()
        return self._bottleneck

    def _search_bottleneck(self) -> float | None:
        n = int(np.prod(self.atlas.shape))
        goal = self.goal
        if self.start is None or not goal.any():
            return None
        start = int(np.ravel_multi_index(self.start, self.atlas.shape))
        if goal[start]:
            return math.inf
        e, m = self.edges, self.edge_margin()

        def reaches(level: float) -> bool:
            keep = m >= level
            return bool(goal[_reached(e.src[keep], e.dst[keep], n, [start])].any())

        levels = np.unique(m[np.isfinite(m)])
        if not len(levels) or not reaches(levels[0]):
            return None
        # reaching fails from some level on: the level before the first that fails
        first_fail = bisect.bisect_left(range(len(levels)), True, lo=1, key=lambda k: not reaches(levels[k]))
        return float(levels[first_fail - 1])

    def penalty(self, margin: NDArray[np.float64] | float) -> NDArray[np.float64]:
        """The objective's penalty per unit of weighted L1 length of a step with this margin
        (rad; a tolerance for ``tolerance``): 1 / max(m, 1e-6) (balanced) or exp(-max(m - m*, 0) /
        TIE_SCALE_DEG) (margin, tolerance), m and the bottleneck m* in degrees (percent of the box);
        inf for an insecure step (-inf margin). The maximin objectives rank the smallest margin
        first (level), so their penalty only breaks ties and weighs a step at or below m* as one at
        it: bounded by the path's weighted L1 length."""
        deg = np.asarray(margin, dtype=float) * self.unit
        with np.errstate(over="ignore", invalid="ignore"):
            if self.objective == Objective.BALANCED:
                out = 1.0 / np.maximum(deg, MARGIN_FLOOR_DEG)
            else:
                ref = self.bottleneck
                ref = ref * self.unit if ref is not None and math.isfinite(ref) else 0.0
                out = np.exp(-np.maximum(deg - ref, 0.0) / TIE_SCALE_DEG)
        return np.where(deg == -np.inf, np.inf, out)

    def _levels(self) -> NDArray[np.float64]:
        """The distinct finite margins (rad) below the bottleneck among those computed (every
        mode a secure lattice edge makes, once prepared), ascending."""
        if self._below is None:
            ref = self.bottleneck
            ref = ref if ref is not None else math.inf
            self.edge_margin()  # computes every mode a secure lattice edge makes
            values = [m[np.isfinite(m) & (m < ref)] for m in self._mode.values()]
            self._below = np.unique(np.concatenate(values)) if values else np.empty(0)
        return self._below

    def level(self, margin: float) -> int:
        """The margin's (rad; a tolerance for ``tolerance``) level below the bottleneck m*: 0 at or
        above m*, else 1 + the number of distinct margins of the lattice (its edges' modes) that lie
        above it and below m*, so 1 for the widest below m*. Between margins of the lattice the
        levels order margins exactly (a larger margin, a smaller level); -inf (insecure) has no level."""
        ref = self.bottleneck
        if margin >= (ref if ref is not None else math.inf):
            return 0
        below = self._levels()
        return 1 + int(len(below) - np.searchsorted(below, margin, side="right"))

    def level_margin(self, level: int) -> float:
        """The margin (rad) that a level stands for: the bottleneck for 0 (a path keeps at least it;
        no path to the goal region keeps more), else the level-th widest margin below it."""
        ref = self.bottleneck
        if level == 0:
            return ref if ref is not None else math.inf
        below = self._levels()
        return float(below[len(below) - level]) if 0 < level <= len(below) else -math.inf

    def _step_penalties(self, kind: str, direction: int) -> NDArray[np.float64]:
        """For an axis leg (T, P, D) run in a direction (+1 or -1 along its axis): the penalty of
        the lattice step from each state to the next, shape of the lattice (inf where insecure,
        nan at the lattice's end)."""
        key = (kind, direction)
        if key not in self._steps:
            axis = LEG_AXES[kind][0]
            step = [0, 0, 0]
            step[axis] = direction
            m = np.moveaxis(self.move(kind, tuple(step)), axis, -1)
            if direction < 0:
                m = m[..., ::-1]
            pair = np.minimum(m[..., :-1], m[..., 1:])
            out = np.concatenate([self._unit_lengths[axis] * self.penalty(pair), np.full(m.shape[:-1] + (1,), np.nan)], axis=-1)
            if direction < 0:
                out = out[..., ::-1]
            self._steps[key] = np.ascontiguousarray(np.moveaxis(out, -1, axis))
        return self._steps[key]

    # -- legs and motions ------------------------------------------------------------------------
    def leg_states(self, leg: Leg) -> tuple[NDArray[np.int_], NDArray[np.float64]]:
        """The lattice indices a leg passes (n, 3), in travel order, ends included, and the margin
        (rad) of each in the leg's mode there (n,)."""
        a, b = np.asarray(leg.start), np.asarray(leg.end)
        diff = b - a
        n = int(np.max(np.abs(diff)))
        if n == 0:
            return a[None], np.array([self.mode(0, 0)[tuple(a)]])
        t = np.arange(n + 1) / n
        idx = a[None] + np.rint(t[:, None] * diff[None]).astype(int)
        if leg.kind == "X":  # B's mode from the diagonal's own direction, as the atlas checks it
            d = self.atlas.axes[D][idx[:, D]]
            psi = self.atlas.axes[PSI][idx[:, PSI]]
            sa, sb = primitive_sliding_signs("P_dpsi", d, psi, diff[D] * self.atlas.res[D], diff[PSI] * self.atlas.res[PSI])
            m = np.empty(n + 1)
            for bsign in np.unique(sb):
                sel = sb == bsign
                m[sel] = self.mode(int(sa.flat[0]), int(bsign))[tuple(idx[sel].T)]
            return idx, m
        return idx, self.move(leg.kind, tuple(np.sign(diff).astype(int)))[tuple(idx.T)]

    def leg_margin(self, leg: Leg) -> float:
        """The smallest margin (rad) along a leg, in its mode."""
        if leg.kind == "X" or leg.start == leg.end:
            return float(self.leg_states(leg)[1].min())
        axis = LEG_AXES[leg.kind][0]  # a slice of the lattice along the leg's axis
        a, b = leg.start[axis], leg.end[axis]
        index: list = list(leg.start)
        index[axis] = slice(min(a, b), max(a, b) + 1)
        step = [0, 0, 0]
        step[axis] = 1 if b > a else -1
        return float(self.move(leg.kind, tuple(step))[tuple(index)].min())

    def leg_penalty(self, leg: Leg) -> float:
        """The sum over the leg's lattice steps of the step's weighted L1 length times the
        objective's penalty of its margin; inf on an insecure step."""
        if leg.start == leg.end:
            return 0.0
        if leg.kind != "X":  # a slice of the precomputed steps
            axis = LEG_AXES[leg.kind][0]
            a, b = leg.start[axis], leg.end[axis]
            index: list = list(leg.start)
            index[axis] = slice(a, b) if b > a else slice(b + 1, a + 1)
            return float(self._step_penalties(leg.kind, 1 if b > a else -1)[tuple(index)].sum())
        idx, m = self.leg_states(leg)  # an X leg's steps move d, psi or both by one lattice step
        length = np.abs(np.diff(idx, axis=0)) @ self._unit_lengths
        return float(np.sum(length * self.penalty(np.minimum(m[:-1], m[1:]))))

    def score(self, legs: list[Leg]) -> tuple[float, ...]:
        """How the objective ranks a secure leg sequence realising one motion, smaller first:
        (minus its smallest margin, its penalty) for ``margin``, (its penalty,) for ``balanced``."""
        total = sum(self.leg_penalty(leg) for leg in legs)
        if self.objective.maximin:
            return (-min((self.leg_margin(leg) for leg in legs), default=math.inf), total)
        return (total,)

    def best(self, found: list[list[Leg]]) -> list[list[Leg]]:
        """The realisations of one motion that rank first (score; penalties within TIE_TOLERANCE
        count as equal)."""
        return [r for r, _ in self._ranked_first(found)]

    def _ranked_first(self, found: list[list[Leg]]) -> list[tuple[list[Leg], tuple[float, ...]]]:
        """best's realisations, each with its score."""
        scored = [(r, self.score(r)) for r in found]
        top = min(s for _, s in scored)
        return [(r, s) for r, s in scored if s[:-1] == top[:-1] and s[-1] <= top[-1] + TIE_TOLERANCE * abs(top[-1])]

    def motion(self, a: tuple[int, int, int], b: tuple[int, int, int]) -> float:
        """The penalty of the motion from lattice index a to b: that of its best secure staircase
        (score); inf when none realises it (or it runs against the allowed directions)."""
        return self.motion_value(a, b)[1]

    def motion_value(self, a: tuple[int, int, int], b: tuple[int, int, int]) -> tuple[float, float]:
        """(smallest margin rad, penalty) of the motion from lattice index a to b: those of its best
        secure staircase (score: for the maximin objectives the widest, then the least penalised),
        every lattice state it passes counted in its leg's mode, a (the start, for the first
        motion of a path) included; (-inf, inf) when none realises it (or it runs against the
        allowed directions)."""
        key = (a, b)
        if key in self._motions:
            return self._motions[key]
        if len(self._motions) > MOTION_CACHE:
            self._motions.clear()
        found = self.atlas.realise(a, b)
        if found:
            legs, score = self._ranked_first(found)[0]  # the first best
            margin = -score[0] if self.objective.maximin else min(self.leg_margin(leg) for leg in legs)
            out = (float(margin), float(score[-1]))
        else:
            out = (-math.inf, math.inf)
        self._motions[key] = out
        return out


def on_some_path(edges, n_cells: int, start: int | None, goal: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Per cell (flat): it lies on some path of the edges (LatticeEdges) from the start cell (flat
    index, None off the lattice) to a goal cell (goal: flat mask), by a breadth-first search each way."""
    on = np.zeros(n_cells, dtype=bool)
    if start is None or not goal.any():
        return on
    on[_reached(edges.src, edges.dst, n_cells, [start])] = True
    back = np.zeros(n_cells, dtype=bool)
    back[_reached(edges.dst, edges.src, n_cells, np.flatnonzero(goal))] = True
    return on & back


def _reached(src: NDArray[np.int_], dst: NDArray[np.int_], n: int, seeds) -> NDArray[np.int_]:
    """The nodes (of n) reached from any of the seeds along the directed edges src -> dst, the seeds
    included: breadth-first search from a virtual node n that leads to each seed."""
    from scipy.sparse import coo_matrix  # here, not at import: only the margins need scipy
    from scipy.sparse.csgraph import breadth_first_order

    seeds = np.asarray(seeds, dtype=np.int64)
    rows = np.concatenate([src, np.full(len(seeds), n)])
    cols = np.concatenate([dst, seeds])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n + 1, n + 1)).tocsr()
    order = breadth_first_order(graph, n, directed=True, return_predecessors=False)
    return order[order < n]
