"""Exact optimum on the primitive lattice: a Dijkstra search with the planner's cost.

Nodes are (lattice state, primitive last run); an edge is one lattice step of
a primitive (theta one step for P_theta, psi one step for P_psi, d one step,
alone or with psi one step the other way, for P_dpsi), secure in that leg's
contact mode at both ends, costing its weighted L1 length plus the mode-change
penalty when the primitive (or its direction) changes. The search uses
scipy's compiled Dijkstra, so it is the yardstick for the sampling planners
and the proof that no secure path exists at a resolution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..mechanics import primitive_sliding_signs
from .atlas import D, FORWARD, PSI, THETA, Leg, SecurityAtlas, reference_cost
from .margins import MARGIN_FLOOR_DEG, LatticeMargins


@dataclass
class LatticeResult:
    """The optimum on the lattice: cost (reference units), its legs, or None when unreachable;
    with a robust objective, the path's smallest friction margin (rad)."""

    cost: float | None
    legs: list[Leg]
    nodes: int
    edges: int
    min_margin: float | None = None

    @property
    def reachable(self) -> bool:
        return self.cost is not None


def _moves(reverse: bool):
    """(leg kind, primitive slot, index step) of every lattice move."""
    out = []
    for sign in (1, -1) if reverse else (1,):
        base = 0 if sign == 1 else 3
        t = [0, 0, 0]
        t[THETA] = sign * FORWARD[THETA]
        p = [0, 0, 0]
        p[PSI] = sign * FORWARD[PSI]
        dd = [0, 0, 0]
        dd[D] = sign * FORWARD[D]
        x = [0, 0, 0]
        x[D], x[PSI] = sign * FORWARD[D], sign * FORWARD[PSI]
        out += [("T", base + 0, t), ("P", base + 1, p), ("D", base + 2, dd), ("X", base + 2, x)]
    return out


def _move_ok(atlas: SecurityAtlas, kind: str, step: list[int]) -> NDArray[np.bool_]:
    """Per lattice state: the leg's mode is secure there (for X, in the diagonal's own B mode)."""
    if kind != "X":
        axis = {"T": THETA, "P": PSI, "D": D}[kind]
        return atlas.leg_ok(kind, step[axis])
    d, psi = np.meshgrid(atlas.axes[D], atlas.axes[PSI], indexing="ij")
    sa, sb = primitive_sliding_signs("P_dpsi", d, psi, step[D] * atlas.res[D], step[PSI] * atlas.res[PSI])
    out = np.zeros(atlas.shape, dtype=bool)
    for b in np.unique(sb):
        out |= atlas.mode_ok(int(sa.flat[0]), int(b)) & (sb == b)[None]
    return out


def moves_graph(atlas: SecurityAtlas) -> tuple[NDArray[np.int_], NDArray[np.int_]]:
    """The lattice's secure moves as edges between flat cell indices (src, dst): one lattice step of
    a primitive secure in its mode at both ends (what lattice_search searches, without the last
    primitive)."""
    opts = atlas.scene.options
    shape = atlas.shape
    cell = np.arange(int(np.prod(shape))).reshape(shape)
    rows, cols = [], []
    for kind, _, step in _moves(opts.reverse_primitives):
        if opts.forbid_partial and kind in "DX":
            continue
        ok = _move_ok(atlas, kind, step)
        src, dst = _shifted(shape, step)
        good = ok[src] & ok[dst]
        rows.append(cell[src][good])
        cols.append(cell[dst][good])
    return np.concatenate(rows), np.concatenate(cols)


def _shifted(shape: tuple[int, ...], step: list[int]) -> tuple[tuple[slice, ...], tuple[slice, ...]]:
    """Slices of the lattice for the sources and destinations of a move by step."""
    src = [slice(None)] * 3
    dst = [slice(None)] * 3
    for a in range(3):
        if step[a] > 0:
            src[a], dst[a] = slice(0, shape[a] - step[a]), slice(step[a], None)
        elif step[a] < 0:
            src[a], dst[a] = slice(-step[a], None), slice(0, shape[a] + step[a])
    return tuple(src), tuple(dst)


def lattice_search(atlas: SecurityAtlas, goal_box: NDArray[np.float64], objective: str = "cost",
                   margins: LatticeMargins | None = None) -> LatticeResult:
    """Best secure primitive path on the atlas's lattice from the start to any holdable
    lattice state inside goal_box ((2, 3) corners), for an objective (docs/model.md, section 6):

    - ``cost``: the cheapest, with the scene's cost weights;
    - ``margin``: the largest smallest friction margin along the path (a bottleneck search over
      the edges' margins, the smaller of their ends' in the edge's mode), then the fewest
      primitive changes, then the cheapest;
    - ``balanced``: the cheapest with every edge also charged planning.margin_weight times its
      weighted L1 length over its margin in degrees.

    margins (a LatticeMargins of this atlas) is needed for the last two; the result's min_margin
    (rad) is the path's smallest margin then, the start state left out (LatticeMargins)."""
    if objective not in ("cost", "margin", "balanced"):
        raise ValueError(f"objective must be cost, margin or balanced, not {objective!r}")
    if objective != "cost" and margins is None:
        raise ValueError(f"the {objective} objective needs the lattice's margins")
    scene = atlas.scene
    opts = scene.options
    shape = atlas.shape
    n_cells = int(np.prod(shape))
    moves = [m for m in _moves(opts.reverse_primitives) if not (opts.forbid_partial and m[0] in "DX")]
    n_prim = 6 if opts.reverse_primitives else 3
    start_node = n_cells * n_prim
    cell = np.arange(n_cells).reshape(shape)
    rows, cols, costs = [], [], []
    lengths, edge_margins, changed = [], [], []  # per edge, for the robust objectives
    start_cell = atlas.index(scene.start)
    for kind, prim, step in moves:
        ok = _move_ok(atlas, kind, step)
        src = [slice(None)] * 3
        dst = [slice(None)] * 3
        for a in range(3):
            if step[a] > 0:
                src[a], dst[a] = slice(0, shape[a] - step[a]), slice(step[a], None)
            elif step[a] < 0:
                src[a], dst[a] = slice(-step[a], None), slice(0, shape[a] + step[a])
        good = ok[tuple(src)] & ok[tuple(dst)]
        a_cell = cell[tuple(src)][good]
        b_cell = cell[tuple(dst)][good]
        w = float(reference_cost(np.asarray(step) * atlas.res, opts.d_weight))
        if objective != "cost":  # an edge's margin: the smaller of its ends' (the start left out)
            em = margins.move(kind, tuple(step))
            em_src = em[tuple(src)][good]
            if start_cell is not None:
                em_src = np.where(a_cell == cell[start_cell], np.inf, em_src)
            em = np.minimum(em_src, em[tuple(dst)][good])
        for prev in range(n_prim):
            rows.append(a_cell * n_prim + prev)
            cols.append(b_cell * n_prim + prim)
            costs.append(np.full(a_cell.shape, w + (opts.mode_change_penalty if prev != prim else 0.0)))
            if objective != "cost":
                lengths.append(np.full(a_cell.shape, w))
                edge_margins.append(em)
                changed.append(np.full(a_cell.shape, prev != prim))
    if start_cell is not None:  # the start enters with any primitive, at no cost
        rows.append(np.full(n_prim, start_node))
        cols.append(cell[start_cell] * n_prim + np.arange(n_prim))
        costs.append(np.zeros(n_prim))
        if objective != "cost":
            lengths.append(np.zeros(n_prim))
            edge_margins.append(np.full(n_prim, np.inf))
            changed.append(np.zeros(n_prim, dtype=bool))
    rows_a, cols_a, costs_a = (np.concatenate(x) for x in (rows, cols, costs))
    n_nodes = start_node + 1
    from scipy.sparse import coo_matrix  # here, not at import: only the lattice search needs scipy
    from scipy.sparse.csgraph import dijkstra

    in_goal = atlas.releasable_in(goal_box).ravel()
    bottleneck = None
    if objective == "balanced":
        length_a, margin_a = np.concatenate(lengths), np.concatenate(edge_margins)
        costs_a = costs_a + opts.margin_weight * length_a / np.maximum(np.degrees(margin_a), MARGIN_FLOOR_DEG)
    elif objective == "margin":
        margin_a = np.concatenate(edge_margins)
        bottleneck = _bottleneck(rows_a, cols_a, margin_a, n_prim, n_cells, start_node, in_goal)
        if bottleneck is not None:  # then the fewest changes, then the cost, on the edges as wide
            keep = margin_a >= bottleneck
            rows_a, cols_a = rows_a[keep], cols_a[keep]
            costs_a = costs_a[keep] + CHANGE_WEIGHT * np.concatenate(changed)[keep]
    graph = coo_matrix((costs_a, (rows_a, cols_a)), shape=(n_nodes, n_nodes)).tocsr()
    dist, pred = dijkstra(graph, indices=start_node, return_predecessors=True)

    goal_nodes = (np.flatnonzero(in_goal)[:, None] * n_prim + np.arange(n_prim)).ravel()
    best_cost = None
    legs: list[Leg] = []
    if start_cell is not None and in_goal[cell[start_cell]]:
        best_cost = 0.0
    elif len(goal_nodes):
        g = goal_nodes[np.argmin(dist[goal_nodes])]
        if np.isfinite(dist[g]):
            best_cost = float(dist[g])
            chain = []
            node = g
            while node != start_node and node >= 0:
                chain.append(node)
                node = pred[node]
            chain.reverse()
            kinds = {prim: kind for kind, prim, _ in moves if kind != "X"}
            prev_idx = start_cell
            for node in chain[1:]:  # chain[0] is the start state itself
                c, prim = divmod(int(node), n_prim)
                idx = tuple(int(x) for x in np.unravel_index(c, shape))
                kind = "X" if idx[D] != prev_idx[D] and idx[PSI] != prev_idx[PSI] else kinds[prim]
                legs.append(Leg(kind, prev_idx, idx))
                prev_idx = idx
    min_margin = None
    if objective != "cost" and best_cost is not None:  # the path's own cost and smallest margin
        best_cost = _path_cost(atlas, legs)
        min_margin = min((margins.leg_margin(leg) for leg in legs), default=math.inf)
    return LatticeResult(best_cost, legs, n_nodes, int(graph.nnz), min_margin)


#: The margin objective's weight of a primitive change against the cost: larger than any cost.
CHANGE_WEIGHT = 1e7


def _path_cost(atlas: SecurityAtlas, legs: list[Leg]) -> float:
    """A lattice path's cost as the search counts it: weighted L1 plus the penalty per change of
    primitive slot (primitive and direction) between consecutive steps."""
    opts = atlas.scene.options
    total, last = 0.0, None
    for leg in legs:
        step = np.subtract(leg.end, leg.start)
        slot = (leg.primitive, bool(np.any(step * FORWARD > 0)))
        total += float(reference_cost(step * atlas.res, opts.d_weight))
        if last is not None and slot != last:
            total += opts.mode_change_penalty
        last = slot
    return total


def _bottleneck(rows: NDArray, cols: NDArray, margin: NDArray, n_prim: int, n_cells: int, start_node: int,
                in_goal: NDArray[np.bool_]) -> float | None:
    """The largest m such that the start reaches a goal cell over edges of margin >= m (None when
    no goal cell is reachable at all): a bisection over the edges' margins, reachability on the
    graph of cells (the last primitive does not change which edges exist)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order

    src = np.where(rows == start_node, n_cells, rows // n_prim)
    dst = cols // n_prim
    first = np.ones(len(src), dtype=bool)  # one copy of each cell edge (the n_prim copies share a margin)
    key = src.astype(np.int64) * (n_cells + 1) + dst
    _, first_idx = np.unique(key, return_index=True)
    first[:] = False
    first[first_idx] = True
    src, dst, margin = src[first], dst[first], margin[first]
    goal = np.flatnonzero(in_goal)

    def reaches(m: float) -> bool:
        keep = margin >= m
        g = coo_matrix((np.ones(int(keep.sum())), (src[keep], dst[keep])), shape=(n_cells + 1, n_cells + 1)).tocsr()
        seen = breadth_first_order(g, n_cells, directed=True, return_predecessors=False)
        return bool(np.isin(goal, seen).any())

    levels = np.unique(margin[np.isfinite(margin)])
    if not len(levels) or not reaches(-np.inf):
        return None
    lo, hi = 0, len(levels) - 1  # reaches at levels[lo] (every finite edge), maybe not above
    if reaches(levels[hi]):
        return float(levels[hi])
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if reaches(levels[mid]):
            lo = mid
        else:
            hi = mid
    return float(levels[lo])
