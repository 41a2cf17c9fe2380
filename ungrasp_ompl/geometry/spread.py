"""Pieces spread in a rectangular frame: the translations of convex outlines that make the smallest
gap between two of them, or between one and a wall, as large as it can be.

A layout whose pieces are cut a little smaller than their places leaves slack: between neighbours
(twice the cut) and between the outer pieces and the walls (whatever the frame adds). A piece put
down open-loop lands a millimetre or so off its target, and it is the narrowest gap that a landing
closes first; moving the targets so that the slack is shared out evenly widens that gap.

Frame coordinates: the frame's inner corner at the origin, x along its inner width, y along its
depth, metres. The outlines keep their headings; only their positions move.

The gap between two convex outlines is measured along one axis per pair, the edge normal of either
hull along which they lie furthest apart at the start (the separating-axis test). Along a fixed
axis a translation changes the gap linearly, and the distance between the outlines is never less
than their gap along any axis, so the program (scipy's HiGHS) is linear and what it promises holds
for the true distance: the smallest distance after the spread is at least ``Spread.gap``. Among
the translations that reach that gap, the program then takes the one that moves the outlines
least (the sum of the shifts' absolute coordinates), so that a layout already spread evenly stays
where it is.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .solids import hull_normals

#: The walls' inward normals in frame coordinates, in the order west, south, east, north.
_WALL_NORMALS = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])


@dataclass(frozen=True)
class Spread:
    """The translations that spread outlines in a frame, and the smallest gaps before and after."""

    shifts: NDArray[np.float64]
    """Each outline's translation (N, 2) in frame coordinates (m)."""
    gap_before: float
    """The smallest gap between two outlines or an outline and a wall as given (m; negative: an overlap)."""
    gap: float
    """The smallest such gap after the translations (m), along the pairs' axes: a lower bound on the
    smallest distance."""


def separation(a: ArrayLike, b: ArrayLike) -> tuple[float, NDArray[np.float64]]:
    """The gap between convex outlines a and b (N, 2) along the edge normal of either hull along
    which they lie furthest apart, and that axis (unit, (2,), pointing from a toward b). A positive
    gap is a lower bound on their distance (equal to it when an edge is nearest); a negative one is
    their least overlap along those normals."""
    pa, pb = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    na, nb = hull_normals(pa), hull_normals(pb)
    axes = np.vstack([na, -na, nb, -nb])
    gaps = (pb @ axes.T).min(axis=0) - (pa @ axes.T).max(axis=0)
    k = int(np.argmax(gaps))
    return float(gaps[k]), axes[k]


def _wall_gaps(outline: NDArray[np.float64], inner: tuple[float, float]) -> NDArray[np.float64]:
    """The outline's distances (4,) to the west, south, east and north walls (m)."""
    return np.array([outline[:, 0].min(), outline[:, 1].min(),
                     inner[0] - outline[:, 0].max(), inner[1] - outline[:, 1].max()])


def smallest_gap(outlines: Sequence[ArrayLike], inner: tuple[float, float]) -> float:
    """The smallest gap between two of the outlines (each (N, 2), frame coordinates) along their
    separating axis (separation), or between an outline and a wall of a frame inner[0] wide and
    inner[1] deep (m)."""
    polys = [np.asarray(p, dtype=float) for p in outlines]
    gaps = [float(_wall_gaps(p, inner).min()) for p in polys]
    gaps += [separation(polys[j], polys[i])[0] for i in range(len(polys)) for j in range(i)]
    return min(gaps)


#: Rounds of the program at most, and the gain of the smallest gap (m) below which they stop.
ROUNDS, GAIN = 20, 1e-8


def spread(outlines: Sequence[ArrayLike], inner: tuple[float, float]) -> Spread:
    """The translations of the outlines (each (N, 2), frame coordinates, m) inside a frame inner[0]
    wide and inner[1] deep that make the smallest gap between two outlines or an outline and a wall
    as large as it can be (see the module), moving them as little as that allows. The program is
    solved again from where it moved them, with each pair's axis found again, while the gap grows
    (by GAIN, at most ROUNDS times): a pair's best axis can change as it moves. ValueError when no
    outline is given or the program finds no solution (outlines too large for the frame)."""
    polys = [np.asarray(p, dtype=float) for p in outlines]
    if not polys:
        raise ValueError("no outlines to spread")
    shifts = np.zeros((len(polys), 2))
    before = gap = smallest_gap(polys, inner)
    for _ in range(ROUNDS):
        step = _spread_once([p + s for p, s in zip(polys, shifts)], inner)
        moved = smallest_gap([p + s + d for p, s, d in zip(polys, shifts, step)], inner)
        if moved < gap + GAIN:
            break
        shifts, gap = shifts + step, moved
    return Spread(shifts, before, gap)


def _spread_once(polys: list[NDArray[np.float64]], inner: tuple[float, float]) -> NDArray[np.float64]:
    """One round of the program: the least shifts (N, 2) that widen the smallest gap the most along
    the pairs' present axes."""
    from scipy.optimize import linprog  # scipy.optimize: 0.5 s to import, loaded to spread pieces

    n = len(polys)
    # rows a . (shifts, g) <= b, each saying "gap0 + axis . (shift_i - shift_j) >= g"
    rows, rhs = [], []
    for i in range(n):
        for w, gap in enumerate(_wall_gaps(polys[i], inner)):
            row = np.zeros(2 * n + 1)
            row[2 * i:2 * i + 2] = -_WALL_NORMALS[w]
            row[-1] = 1.0
            rows.append(row)
            rhs.append(gap)
        for j in range(i):
            gap, axis = separation(polys[j], polys[i])
            row = np.zeros(2 * n + 1)
            row[2 * i:2 * i + 2], row[2 * j:2 * j + 2], row[-1] = -axis, axis, 1.0
            rows.append(row)
            rhs.append(gap)
    a, b = np.array(rows), np.array(rhs)
    free = [(None, None)] * (2 * n)
    widest = linprog(np.r_[np.zeros(2 * n), -1.0], A_ub=a, b_ub=b, bounds=free + [(None, None)], method="highs")
    if widest.status != 0:
        raise ValueError(f"the outlines cannot be spread in the frame: {widest.message}")
    g = float(widest.x[-1])
    # the same gaps with g fixed at its largest, and |shift| <= u: the least sum of u
    eye = np.eye(2 * n)
    a2 = np.vstack([np.hstack([a[:, :-1], np.zeros((len(a), 2 * n))]),
                    np.hstack([eye, -eye]), np.hstack([-eye, -eye])])
    b2 = np.r_[b - g + 1e-9, np.zeros(4 * n)]
    least = linprog(np.r_[np.zeros(2 * n), np.ones(2 * n)], A_ub=a2, b_ub=b2, bounds=free + [(0, None)] * (2 * n),
                    method="highs")
    return (least.x if least.status == 0 else widest.x)[:2 * n].reshape(n, 2)
