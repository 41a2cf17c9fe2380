"""Independent oracles for the tests: force closure by linear programming (scipy HiGHS)."""

from __future__ import annotations

import numpy as np
from scipy.optimize import linprog
from scipy.sparse import block_diag, csr_matrix, hstack, identity


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
        blocks = [csr_matrix(np.where(m[None, :], wi.T, 0.0)) for wi, m in zip(ws, ms)]
        a_lambda = block_diag(blocks, format="csr")  # (3k, 6k)
        eye = identity(3 * k, format="csr")
        a_eq = hstack([a_lambda, eye, -eye], format="csr")
        c = np.concatenate([np.zeros(6 * k), np.ones(6 * k)])
        lam_bounds = [(1.0, None) if m else (0.0, 0.0) for m in ms.ravel()]
        bounds = lam_bounds + [(0.0, None)] * (6 * k)
        res = linprog(c, A_eq=a_eq, b_eq=np.zeros(3 * k), bounds=bounds, method="highs")
        assert res.status == 0, res.message
        slack = res.x[6 * k :].reshape(2, k, 3).sum(axis=(0, 2))
        out[lo : lo + k] = (slack <= 1e-9) & (ranks[lo : lo + k] == 3)
    return out
