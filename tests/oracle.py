"""Independent oracles for the tests: force closure by linear programming (scipy HiGHS); the friction
margin by plain bisection on the shrink angle; the cage's escape level by bisection with
scipy.ndimage labelling."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linprog
from scipy.sparse import coo_matrix

from ungrasp_ompl.mechanics.cage import _component
from ungrasp_ompl.mechanics.force_closure import REFERENCE_FRICTION, Friction
from ungrasp_ompl.mechanics.margin import _fails, _limits, _prepared


def lp_force_closure(w: np.ndarray, mask: np.ndarray, batch: int = 500) -> np.ndarray:
    """Force closure of each state from its contact wrenches w (N, 6, 3) and slot mask (N, 6).

    The wrenches positively span R^3 iff they have rank 3 and some combination
    with every coefficient >= 1 sums to zero. Many states go into one LP as
    independent blocks: minimise the residual |sum_i lambda_i w_i| (split into
    non-negative slacks) with lambda_i >= 1; a state is force-closed iff its
    block's residual is zero and its wrenches have rank 3.
    """
    n = len(w)
    out = np.zeros(n, dtype=bool)
    ranks = np.linalg.matrix_rank(np.where(mask[..., None], w, 0.0).transpose(0, 2, 1), tol=1e-10)
    for lo in range(0, n, batch):
        ws, ms = w[lo : lo + batch], mask[lo : lo + batch]
        k = len(ws)
        # [block_diag(W_i^T) | I | -I] (3k, 12k): state i's rows 3i..3i+2, its lambdas 6i..6i+5
        i, c, r = np.meshgrid(np.arange(k), np.arange(6), np.arange(3), indexing="ij")
        eye = np.arange(3 * k)
        rows = np.concatenate([(3 * i + r).ravel(), eye, eye])
        cols = np.concatenate([(6 * i + c).ravel(), 6 * k + eye, 9 * k + eye])
        vals = np.concatenate([np.where(ms[..., None], ws, 0.0).ravel(), np.ones(3 * k), -np.ones(3 * k)])
        a_eq = coo_matrix((vals, (rows, cols)), shape=(3 * k, 12 * k)).tocsr()
        c_obj = np.concatenate([np.zeros(6 * k), np.ones(6 * k)])
        lam = ms.ravel()
        bounds = np.column_stack([np.concatenate([np.where(lam, 1.0, 0.0), np.zeros(6 * k)]),
                                  np.concatenate([np.where(lam, np.inf, 0.0), np.full(6 * k, np.inf)])])
        res = linprog(c_obj, A_eq=a_eq, b_eq=np.zeros(3 * k), bounds=bounds, method="highs")
        assert res.status == 0, res.message
        slack = res.x[6 * k :].reshape(2, k, 3).sum(axis=(0, 2))
        out[lo : lo + k] = (slack <= 1e-9) & (ranks[lo : lo + k] == 3)
    return out


def friction_margin_bisection(
    theta: ArrayLike,
    d: ArrayLike,
    psi: ArrayLike,
    a_sign: ArrayLike = 0,
    b_sign: ArrayLike = 0,
    friction: Friction = REFERENCE_FRICTION,
    tol: float = 1e-12,
) -> NDArray[np.float64]:
    """The friction margin by plain bisection on the shrink angle (rad, to tol): the reference
    for :func:`friction_margin`, with the same limits and sign convention."""
    w, v, mask, fc0, _ = _prepared(theta, d, psi, a_sign, b_sign, friction)
    d_lo, d_hi = _limits(friction.mu)
    lo = np.where(fc0, 0.0, d_lo)
    hi = np.where(fc0, d_hi, 0.0)
    out = np.where(fc0, d_hi, -np.inf)
    fail_end = _fails(w, v, mask, np.where(fc0, hi, lo))
    todo = np.flatnonzero(np.where(fc0, fail_end, ~fail_end))
    a, b = lo[todo], hi[todo]  # closure at a, none at b
    while len(todo) and np.max(b - a) > tol:
        mid = 0.5 * (a + b)
        f = _fails(w[todo], v[todo], mask[todo], mid)
        b = np.where(f, mid, b)
        a = np.where(f, a, mid)
    out[todo] = b
    return out


def escape_level_bisection(free: NDArray[np.bool_], energy: NDArray[np.float64], start: tuple[int, int, int],
                           border: NDArray[np.bool_], periodic: bool = False) -> float:
    """The same minimax level as :func:`escape_level`, by brute force: bisection over the sorted
    energies of the free cells, connectivity by scipy.ndimage.label (26-connected). The reference."""
    energy = np.broadcast_to(energy, free.shape)

    def connected(level: float) -> bool:
        lab, ids = _component(free & (energy <= level), start, periodic)
        return bool(np.isin(lab[border], ids).any())

    levels = np.unique(energy[free])
    levels = levels[levels >= energy[start]]
    if not connected(levels[-1]):
        return math.inf
    lo, hi = -1, len(levels) - 1  # not connected at levels[lo] (or below all), connected at levels[hi]
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if connected(levels[mid]):
            hi = mid
        else:
            lo = mid
    return float(levels[hi])
