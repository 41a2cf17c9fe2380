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

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..mechanics import primitive_sliding_signs
from .atlas import D, FORWARD, PSI, THETA, Leg, SecurityAtlas, reference_cost


@dataclass
class LatticeResult:
    """The optimum on the lattice: cost (reference units), its legs, or None when unreachable."""

    cost: float | None
    legs: list[Leg]
    nodes: int
    edges: int

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


def lattice_search(atlas: SecurityAtlas, goal_box: NDArray[np.float64]) -> LatticeResult:
    """Cheapest secure primitive path on the atlas's lattice from the start to any holdable
    lattice state inside goal_box ((2, 3) corners), with the scene's cost weights."""
    scene = atlas.scene
    opts = scene.options
    shape = atlas.shape
    n_cells = int(np.prod(shape))
    moves = [m for m in _moves(opts.reverse_primitives) if not (opts.forbid_partial and m[0] in "DX")]
    n_prim = 6 if opts.reverse_primitives else 3
    start_node = n_cells * n_prim
    cell = np.arange(n_cells).reshape(shape)
    rows, cols, costs = [], [], []
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
        for prev in range(n_prim):
            rows.append(a_cell * n_prim + prev)
            cols.append(b_cell * n_prim + prim)
            costs.append(np.full(a_cell.shape, w + (opts.mode_change_penalty if prev != prim else 0.0)))
    if start_cell is not None:  # the start enters with any primitive, at no cost
        rows.append(np.full(n_prim, start_node))
        cols.append(cell[start_cell] * n_prim + np.arange(n_prim))
        costs.append(np.zeros(n_prim))
    rows_a, cols_a, costs_a = (np.concatenate(x) for x in (rows, cols, costs))
    n_nodes = start_node + 1
    from scipy.sparse import coo_matrix  # here, not at import: only the lattice search needs scipy
    from scipy.sparse.csgraph import dijkstra

    graph = coo_matrix((costs_a, (rows_a, cols_a)), shape=(n_nodes, n_nodes)).tocsr()
    dist, pred = dijkstra(graph, indices=start_node, return_predecessors=True)

    in_goal = atlas.releasable_in(goal_box).ravel()
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
    return LatticeResult(best_cost, legs, n_nodes, int(graph.nnz))
