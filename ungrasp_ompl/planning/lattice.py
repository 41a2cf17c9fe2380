"""Exact optimum on the primitive lattice: a Dijkstra search with the planners' cost.

Nodes are (lattice state, primitive under way); an edge is one lattice step of
a primitive (theta one step for P_theta, psi one step for P_psi, d one step,
alone or with psi one step the other way, for P_dpsi), secure in that leg's
contact mode at both ends, costing its weighted L1 length plus the mode-change
penalty when the primitive (or its direction) changes, as a plan's cost counts
its merged primitives (docs/model.md, sections 6 and 8.2). For the cost objective a
P_dpsi may also turn psi alone by a step once under way or before its first d
step (a Y step: the lattice steps of a steep X leg, whose B mode is the
P_dpsi's), its states secure in some mode a P_dpsi makes there, and it must
slide d before another primitive starts: every path a planner can return (its
legs rasterised on the lattice) is a path of this graph, so the optimum is a
lower bound of every planner's cost, and the path found is realised by
straight X and D legs between its states (lattice_search). The search uses
scipy's compiled Dijkstra, so it is the yardstick for the sampling planners
and the proof that no secure path exists at a resolution. The robust
objectives (docs/model.md, section 6.1) search the one-step graph without Y
steps: balanced with the margin penalty added to the cost, margin over the
edges as wide as the lattice's bottleneck with one Dijkstra per criterion in
turn (primitive changes, tie-break, cost). Where only the cost optimum's value is
wanted (a planner's stop there, tiling's proof), optimum_cost finds it by a sweep
over the same graph, which has no cycle when the primitives run forward only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .atlas import D, FORWARD, PSI, THETA, Leg, SecurityAtlas, reference_cost
from .edges import LatticeEdges, lattice_edges, lattice_moves, moved_from
from .margins import OBJECTIVES, TIE_TOLERANCE, LatticeMargins, Objective, on_some_path


@dataclass
class LatticeResult:
    """The optimum on the lattice: cost (reference units), its legs (planner legs, T, P, D and X,
    realising it), or None when unreachable; legs_cost: the legs' cost, the optimum's unless no
    straight legs realise its Y steps (then the best path without them); with a robust objective,
    the path's smallest friction margin (rad; tolerance for the tolerance objective) and its penalty (the sum over its edges of LatticeMargins.leg_penalty: the tie-break for margin, the margin penalty
    for balanced, reference units)."""

    cost: float | None
    legs: list[Leg]
    nodes: int
    edges: int
    min_margin: float | None = None
    penalty: float | None = None
    legs_cost: float | None = None

    @property
    def reachable(self) -> bool:
        return self.cost is not None


def lattice_search(atlas: SecurityAtlas, goal_box: NDArray[np.float64], objective: Objective = Objective.COST,
                   margins: LatticeMargins | None = None) -> LatticeResult:
    """Best secure primitive path on the atlas's lattice from the start to any releasable lattice
    state inside goal_box ((2, 3) corners), for an objective (docs/model.md, sections 6 and 6.1):

    - ``cost``: the cheapest, with the scene's cost weights;
    - ``margin``: the largest smallest friction margin along the path (the bottleneck), then, over
      the edges no narrower than it, the fewest primitive changes, then the smallest tie-break
      penalty (LatticeMargins.penalty), then the cheapest;
    - ``balanced``: the cheapest with every edge also charged planning.margin_weight times its
      weighted L1 length over its margin in degrees;
    - ``tolerance``: as ``margin``, with each state's tolerance of the `paper` errors
      (LatticeMargins, section 4.6) in place of its friction margin.

    An edge's margin is the smaller of its ends' in the edge's mode, the start's too. margins (the
    LatticeMargins of this atlas, objective and goal_box) is needed for the last two; the
    result's min_margin (rad) and penalty are the path's then."""
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {', '.join(OBJECTIVES)}, not {objective!r}")
    objective = Objective(objective)
    if objective != Objective.COST and (margins is None or margins.objective != objective or margins.atlas is not atlas
                                or not np.array_equal(margins.goal_box, goal_box)):
        raise ValueError(f"the {objective} objective needs the margins of this lattice, objective and goal box")
    if objective == Objective.COST:
        key = tuple(np.asarray(goal_box, dtype=float).ravel().round(12))
        if key in atlas.cost_optima:
            return atlas.cost_optima[key]
        found = _search(atlas, lattice_edges(atlas, turns=True), goal_box, objective, margins)
        legs = _realise(atlas, found.legs)
        if legs is None:  # no straight legs through its states: the best path of planner legs
            fallback = _search(atlas, lattice_edges(atlas), goal_box, objective, margins)
            legs, found.legs_cost = fallback.legs, fallback.cost
        found.legs = legs
        atlas.cost_optima[key] = found
        return found
    return _search(atlas, margins.edges, goal_box, objective, margins)


def optimum_cost(atlas: SecurityAtlas, goal_box: NDArray[np.float64]) -> float | None:
    """lattice_search's cost optimum alone (reference units; None when no secure path reaches the
    goal box), without its path: what a planner's stop at the optimum and a failure's explanation
    need. With the primitives forward only, every lattice step moves on by one level (the sum of
    its index steps, each counted in its axis's forward sense), so the graph of lattice_search
    has no cycle and its optimum is a sweep over the levels in order (each state's best cost per
    primitive slot, from the states one or two levels before): a sixth of the search's time, without
    importing scipy's sparse graphs (about 0.3 s). The same graph, costs and start and goal states
    as lattice_search; reversed primitives make cycles and go to lattice_search itself."""
    key = tuple(np.asarray(goal_box, dtype=float).ravel().round(12))
    scene = atlas.scene
    if key in atlas.cost_optima or scene.options.reverse_primitives:
        return lattice_search(atlas, goal_box).cost
    if key not in atlas.optimum_costs:
        atlas.optimum_costs[key] = _sweep(atlas, goal_box)
    return atlas.optimum_costs[key]


#: optimum_cost's sweep: what a state offers a move out of it, by the move's kind (a Y step twice:
#: for the P_dpsi under way and for one yet to slide d): (kind, the slot it arrives in, the row of
#: the sweep's table holding the least over the slots it continues without a primitive change, and
#: the row for those it changes from). The table's rows: the slots 0 P_theta, 1 P_psi, 2 P_dpsi,
#: 3 a P_dpsi before its first d step; 4 none (inf); then the least of slots 2 and 3, 1 and 2, 0 and
#: 2, 0 and 1.
_OFFERS = (("T", 0, 0, 6), ("P", 1, 1, 7), ("D", 2, 5, 8), ("X", 2, 5, 8), ("Y", 2, 2, 4), ("Y", 3, 3, 8))
_PAIRS = ((5, 2, 3), (6, 1, 2), (7, 0, 2), (8, 0, 1))


def _sweep(atlas: SecurityAtlas, goal_box: NDArray[np.float64]) -> float | None:
    """optimum_cost's sweep over the levels of a lattice with forward primitives.

    The states the start can reach (each index at or past the start's in its forward sense, with a
    secure edge in) are numbered by level, so that a level is a run of rows. A row's best cost per
    primitive slot is the least of what its predecessors offer it; a row's offer for a move is its
    cost on arriving by that move (the step, then the penalty where the primitive changes, added in
    _path_cost's order), taken once for all its successors. A level then costs a gather and a few
    minima, whatever its moves."""
    scene = atlas.scene
    start = atlas.index(scene.start)
    in_goal = atlas.releasable_in(goal_box).ravel()
    if start is None or not in_goal.any():
        return None
    shape = atlas.shape
    if in_goal[np.ravel_multi_index(start, shape)]:
        return 0.0
    fwd = [FORWARD[a] * np.arange(shape[a]) for a in range(3)]  # each axis's index in its forward sense
    level = (fwd[0][:, None, None] + fwd[1][None, :, None] + fwd[2][None, None, :]).ravel()
    ahead = ((fwd[0] >= fwd[0][start[0]])[:, None, None] & (fwd[1] >= fwd[1][start[1]])[None, :, None]
             & (fwd[2] >= fwd[2][start[2]])[None, None, :]).ravel()
    start = int(np.ravel_multi_index(start, shape))
    ahead[start] = False
    moves = {m.kind: m for m in lattice_moves(atlas, turns=True)}
    arrives = np.zeros(len(level), dtype=bool)
    for m in moves.values():
        arrives |= m.arrives.ravel()
    ahead = np.flatnonzero(ahead & arrives)
    key = level[ahead] - level[start] - 1
    key = key.astype(np.int16 if len(key) and key.max() < 2 ** 15 else np.int32)  # int16: a radix sort
    ahead = ahead[np.argsort(key, kind="stable")]
    cuts = 1 + np.concatenate([[0], np.cumsum(np.bincount(key))])  # each level's rows
    rows = len(ahead) + 1  # row 0: the start, then the states ahead by level; row `rows`: none
    row = np.full(shape, rows, dtype=np.int32)
    row.flat[start] = 0
    row.flat[ahead] = np.arange(1, rows, dtype=np.int32)
    offers = [o for o in _OFFERS if o[0] in moves]
    reads = np.empty((len(offers), rows - 1), dtype=np.int32)  # per offer and row: its predecessor's offer, flat
    for k, (kind, _, _, _) in enumerate(offers):
        came = moved_from(shape, moves[kind].step, row, rows).ravel()
        came[~moves[kind].arrives.ravel()] = rows
        reads[k] = came[ahead] + k * (rows + 1)
    slots = [o[1] for o in offers]  # grouped: each slot's offers are a run
    arrive = [(slot, slice(slots.index(slot), len(slots) - slots[::-1].index(slot))) for slot in dict.fromkeys(slots)]
    own = [o[2] for o in offers]
    change = [o[3] for o in offers]
    length = np.array([[moves[o[0]].length] for o in offers])
    penalty = scene.options.mode_change_penalty
    best = np.full((9, rows), np.inf)  # the sweep's table
    best[[0, 1, 3], 0] = 0.0  # the start enters any primitive but a P_dpsi past its first d step
    offer = np.empty((len(offers), rows + 1))
    offer[:, rows] = np.inf
    for lo, hi in zip(np.concatenate([[0], cuts[:-1]]), cuts):  # the start's row, then each level's
        if lo > 0:
            got = offer.ravel()[reads[:, lo - 1:hi - 1]]
            for slot, ks in arrive:
                best[slot, lo:hi] = got[ks].min(axis=0) if ks.stop - ks.start > 1 else got[ks.start]
        for pair, one, other in _PAIRS:
            np.minimum(best[one, lo:hi], best[other, lo:hi], out=best[pair, lo:hi])
        b = best[:, lo:hi]
        offer[:, lo:hi] = np.minimum(b[own] + length, (b[change] + length) + penalty)
    goal = row.ravel()[in_goal]
    cost = best[:3, goal[goal < rows]].min(initial=np.inf)
    return float(cost) if np.isfinite(cost) else None


def _search(atlas: SecurityAtlas, edges: LatticeEdges, goal_box: NDArray[np.float64], objective: Objective,
            margins: LatticeMargins | None) -> LatticeResult:
    """lattice_search over a graph's edges (its legs one lattice step each, Y steps included).

    Size: Dijkstra's loop over (lattice state, primitive under way) with its heap, labels and the
    objective's tie-breaks, which its steps share as they go."""
    scene = atlas.scene
    opts = scene.options
    shape = atlas.shape
    n_cells = int(np.prod(shape))
    n_prim = 6 if opts.reverse_primitives else 3
    # slots: the primitives (and directions), then per direction a P_dpsi that has not slid d yet
    # (entered by a Y step or at the start; it may not end nor give way before it does)
    n_slot = n_prim + n_prim // 3
    plain = range(n_prim)
    start_cell = atlas.index(scene.start)
    start_flat = None if start_cell is None else int(np.ravel_multi_index(start_cell, shape))
    in_goal = atlas.releasable_in(goal_box).ravel()
    # the cells on some path from the start to the goal, numbered compactly (the others cannot be
    # on the optimum; leaving them out makes the search several times faster)
    cells = np.flatnonzero(on_some_path(edges, n_cells, start_flat, in_goal))
    compact = np.full(n_cells, -1)
    compact[cells] = np.arange(len(cells))
    start_node = len(cells) * n_slot
    keep = (compact[edges.src] >= 0) & (compact[edges.dst] >= 0)
    if objective.maximin:  # only edges as wide as the bottleneck
        bottleneck = margins.bottleneck
        keep &= margins.edge_margin() >= (bottleneck if bottleneck is not None else np.inf)
    # the graph over (lattice state, primitive under way): per edge its cell edge and whether it changes
    rows, cols, of_edge, changed, cost = [], [], [], [], []

    def link(sel: NDArray[np.int_], prev: int, slot: int, change: bool) -> None:
        rows.append(compact[edges.src[sel]] * n_slot + prev)
        cols.append(compact[edges.dst[sel]] * n_slot + slot)
        of_edge.append(sel)
        changed.append(np.full(len(sel), change))
        cost.append(edges.length[sel] + (opts.mode_change_penalty if change else 0.0))

    for k, (kind, prim, _) in enumerate(edges.moves):
        sel = np.flatnonzero(keep[edges.offsets[k]:edges.offsets[k + 1]]) + edges.offsets[k]
        pending = n_prim + prim // 3
        if kind == "Y":  # within a P_dpsi, or starting one that slides d later
            link(sel, prim, prim, False)
            link(sel, pending, pending, False)
            for prev in plain:
                if prev != prim:
                    link(sel, prev, pending, True)
            continue
        for prev in plain:
            link(sel, prev, prim, prev != prim)
        if kind in "DX":
            link(sel, pending, prim, False)
    entries = [s for s in plain if s % 3 != 2] + list(range(n_prim, n_slot))  # a P_dpsi enters pending
    if len(cells):  # the start enters with any primitive, at no cost
        rows.append(np.full(len(entries), start_node))
        cols.append(compact[start_flat] * n_slot + np.array(entries))
        of_edge.append(np.full(len(entries), -1))
        changed.append(np.zeros(len(entries), dtype=bool))
        cost.append(np.zeros(len(entries)))
    rows, cols, of_edge, changed, cost = (np.concatenate(x) for x in (rows, cols, of_edge, changed, cost))
    on_lattice = of_edge >= 0

    def per_edge(values: NDArray[np.float64]) -> NDArray[np.float64]:  # cell-edge values, 0 from the start
        out = np.zeros(len(of_edge))
        out[on_lattice] = values[of_edge[on_lattice]]  # (a lattice may have no secure edge at all)
        return out

    if objective == Objective.BALANCED:
        criteria = [cost + opts.margin_weight * per_edge(edges.length * margins.penalty(margins.edge_margin()))]
    elif objective.maximin:
        criteria = [changed.astype(float), per_edge(edges.length * margins.penalty(margins.edge_margin())), cost]
    else:
        criteria = [cost]
    goal_nodes = (compact[cells[in_goal[cells]]][:, None] * n_slot + np.arange(n_prim)).ravel()
    goal, pred, n_edges = _lexicographic_dijkstra(rows, cols, criteria, start_node, goal_nodes)

    best_cost = None
    legs: list[Leg] = []
    if start_flat is not None and in_goal[start_flat]:
        best_cost = 0.0
    elif goal is not None:
        chain = []
        node = goal
        while node != start_node and node >= 0:
            chain.append(node)
            node = pred[node]
        chain.reverse()
        prev_idx = start_cell
        for node in chain[1:]:  # chain[0] is the start state itself
            c, slot = divmod(int(node), n_slot)
            idx = tuple(int(x) for x in np.unravel_index(cells[c], shape))
            moved = [a for a in range(3) if idx[a] != prev_idx[a]]
            kind = "T" if moved == [THETA] else "X" if len(moved) == 2 else "D" if moved == [D] else \
                "P" if slot < n_prim and slot % 3 == 1 else "Y"
            legs.append(Leg(kind, prev_idx, idx))
            prev_idx = idx
        best_cost = _path_cost(atlas, legs)
    min_margin = penalty = None
    if objective != Objective.COST and best_cost is not None:  # the path's smallest margin and penalty
        min_margin = min((margins.leg_margin(leg) for leg in legs), default=math.inf)
        penalty = sum(margins.leg_penalty(leg) for leg in legs)
    return LatticeResult(best_cost, legs, start_node + 1, n_edges, min_margin, penalty, best_cost)


def _realise(atlas: SecurityAtlas, legs: list[Leg]) -> list[Leg] | None:
    """The search's one-step legs as planner legs: every P_dpsi with Y steps as the fewest straight
    X and D legs between its states, each secure as the atlas checks a planner's leg (the same
    primitives, hence the same cost); None when some P_dpsi has no such legs."""
    out: list[Leg] = []
    k = 0
    while k < len(legs):
        j = k + 1
        if legs[k].primitive == "P_dpsi":
            while j < len(legs) and _slot(legs[j]) == _slot(legs[k]):
                j += 1
        run = legs[k:j]
        if any(leg.kind == "Y" for leg in run):
            run = _straight_legs(atlas, [run[0].start] + [leg.end for leg in run])
            if run is None:
                return None
        out += run
        k = j
    return out


def _straight_legs(atlas: SecurityAtlas, states: list[tuple[int, int, int]]) -> list[Leg] | None:
    """Secure straight D or X legs from states[0] to states[-1], each between two of the states
    (in order) and sliding d: each as long as it can be, else the fewest; None when there are none."""
    n = len(states) - 1

    def leg(a: int, b: int) -> Leg | None:
        p, q = states[a], states[b]
        kind = "D" if p[PSI] == q[PSI] else "X"
        return Leg(kind, p, q) if p[D] != q[D] and atlas.leg_secure(kind, p, q) else None

    out, a = [], 0
    while a < n:  # greedily, the longest leg first (usually one leg does)
        found = next(((b, x) for b in range(n, a, -1) if (x := leg(a, b)) is not None), None)
        if found is None:
            break
        a, x = found
        out.append(x)
    if a == n:
        return out
    fewest, after = [math.inf] * n + [0], [(n, None)] * (n + 1)
    for a in range(n - 1, -1, -1):
        for b in range(n, a, -1):
            if fewest[b] + 1 < fewest[a] and (x := leg(a, b)) is not None:
                fewest[a], after[a] = fewest[b] + 1, (b, x)
    if not math.isfinite(fewest[0]):
        return None
    out, a = [], 0
    while a < n:
        a, x = after[a]
        out.append(x)
    return out


def _lexicographic_dijkstra(rows: NDArray[np.int_], cols: NDArray[np.int_], criteria: list[NDArray[np.float64]],
                            source: int, goals: NDArray[np.int_]) -> tuple[int | None, NDArray[np.int_], int]:
    """A path from source to the best of goals over the directed edges rows -> cols, minimising the
    criteria (per-edge weights, >= 0) in order: Dijkstra on the first; then, on the edges of least
    paths (dist[u] + w <= dist[v], within TIE_TOLERANCE) toward the goals least by it, on the next.
    Returns the goal reached (None when none is), the predecessors of the last search and the
    edges of the first graph."""
    from scipy.sparse import coo_matrix  # here, not at import: only the lattice search needs scipy
    from scipy.sparse.csgraph import dijkstra

    n = source + 1
    n_edges = len(rows)
    for k in range(len(criteria)):
        weight = criteria[k]
        graph = coo_matrix((weight, (rows, cols)), shape=(n, n)).tocsr()
        dist, pred = dijkstra(graph, indices=source, return_predecessors=True)
        best = np.min(dist[goals], initial=np.inf)
        if not np.isfinite(best):
            return None, pred, n_edges
        if k == len(criteria) - 1:
            return int(goals[np.argmin(dist[goals])]), pred, n_edges
        slack = TIE_TOLERANCE * np.abs(dist)
        goals = goals[dist[goals] <= best + slack[goals]]
        tight = dist[rows] + weight <= dist[cols] + slack[cols]
        rows, cols, criteria = rows[tight], cols[tight], [c[tight] for c in criteria]
    raise ValueError("no criterion to minimise")


def _path_cost(atlas: SecurityAtlas, legs: list[Leg]) -> float:
    """A lattice path's cost as the search counts it: weighted L1 plus the penalty per change of
    primitive slot (primitive and direction) between consecutive steps."""
    opts = atlas.scene.options
    total, last = 0.0, None
    for leg in legs:
        slot = _slot(leg)
        total += float(reference_cost(np.subtract(leg.end, leg.start) * atlas.res, opts.d_weight))
        if last is not None and slot != last:
            total += opts.mode_change_penalty
        last = slot
    return total


def _slot(leg: Leg) -> tuple[str, bool]:
    """A leg's primitive and whether it runs forward (the paper's direction)."""
    return leg.primitive, bool(np.any(np.subtract(leg.end, leg.start) * FORWARD > 0))
