"""Convex shapes of the manipulation plane: a convex polygon dilated by a disc (pure numpy).

A :class:`ConvexShape` is the convex hull of its vertices (one vertex: a point, two: a segment)
grown by ``radius``: a disc is one vertex with a radius (a rounded finger tip's dome).
Coordinates are plane coordinates (x along the table, z up) in whatever length unit the caller
uses (metres in :mod:`~ungrasp_ompl.mechanics.cage`); angles in radians, turning x toward z.

Signed distance between two shapes: positive = the gap between them, negative = minus the
penetration depth (the shortest translation that separates them). For convex polygons it is
exact: the separating-axis test over both polygons' edge normals gives the penetration depth,
the vertex-to-edge distances the gap, and radii subtract. The configuration obstacle of a moving
polygon against a fixed one (the displacements where they meet) is their Minkowski difference,
built for many placements at once by merging the two polygons' edges by direction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray


def convex_hull(points: ArrayLike, tol: float = 1e-15) -> NDArray[np.float64]:
    """Counter-clockwise convex hull of points (k, 2) without repeated or collinear vertices
    (Andrew's monotone chain). One point gives one vertex, collinear points the two ends."""
    pts = np.unique(np.asarray(points, dtype=float).reshape(-1, 2), axis=0)  # sorted by x, then z
    if len(pts) <= 2:
        return pts
    scale = max(float(np.abs(pts).max()), 1e-300)

    def cross(o, a, b) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list = []
    upper: list = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= tol * scale * scale:
            lower.pop()
        lower.append(p)
    for p in pts[::-1]:
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= tol * scale * scale:
            upper.pop()
        upper.append(p)
    hull = np.array(lower[:-1] + upper[:-1])
    return hull if len(hull) >= 2 else pts[[0, -1]]


@dataclass(frozen=True)
class ConvexShape:
    """The convex hull of ``vertices`` (k, 2) grown by ``radius`` (>= 0), in the caller's units."""

    vertices: NDArray[np.float64]
    radius: float = 0.0

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, dtype=float)
        if v.ndim != 2 or v.shape[1] != 2 or len(v) == 0 or not np.all(np.isfinite(v)):
            raise ValueError(f"vertices must be a finite (k, 2) array with k >= 1, got shape {v.shape}")
        if not (self.radius >= 0.0 and np.isfinite(self.radius)):
            raise ValueError(f"radius must be finite and non-negative, got {self.radius}")
        object.__setattr__(self, "vertices", convex_hull(v))

    @classmethod
    def disc(cls, centre: ArrayLike, radius: float) -> "ConvexShape":
        return cls(np.asarray(centre, dtype=float).reshape(1, 2), radius)


def minkowski_difference(obstacle: ArrayLike, moving: ArrayLike) -> NDArray[np.float64]:
    """Vertices (N, K, 2), counter-clockwise, of obstacle (+) (-moving[n]) for N placements of a
    moving polygon: the displacements at which the moving polygon meets the obstacle (its
    configuration obstacle). obstacle (m, 2) and each moving[n] (k, 2) are convex polygons in CCW
    order (one vertex: a point; two: a segment, whose two edges run both ways). The sum's edges are
    those of both polygons merged by direction, so K is their number of edges (K = 1 for two
    points); its lowest x and z are the sums of theirs, which places it."""
    obstacle = np.asarray(obstacle, dtype=float)
    neg = -np.asarray(moving, dtype=float)
    low = obstacle.min(axis=0) + neg.min(axis=1)  # (N, 2)
    parts = []
    if len(obstacle) > 1:
        parts.append(np.broadcast_to(np.roll(obstacle, -1, axis=0) - obstacle, (len(neg),) + obstacle.shape))
    if neg.shape[1] > 1:
        parts.append(np.roll(neg, -1, axis=1) - neg)
    if not parts:
        return low[:, None, :]
    step = np.concatenate(parts, axis=1)
    angle = np.mod(np.arctan2(step[..., 1], step[..., 0]), 2.0 * np.pi)
    step = np.take_along_axis(step, np.argsort(angle, axis=1)[..., None], axis=1)
    verts = np.cumsum(step, axis=1) - step
    return verts + (low - verts.min(axis=1))[:, None, :]


def signed_distance(p: ArrayLike, q: ArrayLike, p_radius: float = 0.0, q_radius: float = 0.0
                    ) -> NDArray[np.float64]:
    """Signed distance between convex polygons p (N, k, 2) and q (m, 2) or (N, m, 2), each given
    by its vertices in CCW order, grown by p_radius and q_radius: the gap, or minus the
    penetration depth. Vectorised over N."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    if q.ndim == 2:
        q = np.broadcast_to(q, (len(p),) + q.shape)
    sep = np.full(len(p), -np.inf)  # the separating-axis overlap: largest gap along an edge normal
    for a, b in ((p, q), (q, p)):
        for k in range(a.shape[1]):
            step = a[:, (k + 1) % a.shape[1]] - a[:, k]
            norm = np.hypot(step[:, 0], step[:, 1])
            ok = norm > 0
            n = np.column_stack([step[:, 1], -step[:, 0]]) / np.where(ok, norm, 1.0)[:, None]
            own = np.einsum("ij,ij->i", n, a[:, k])
            other = np.einsum("ij,ikj->ik", n, b).min(axis=1)
            sep = np.where(ok, np.maximum(sep, other - own), sep)
    gap = np.full(len(p), np.inf)  # vertex-to-edge distances: the gap of separated polygons
    for a, b in ((p, q), (q, p)):
        for k in range(b.shape[1]):
            s0, s1 = b[:, k], b[:, (k + 1) % b.shape[1]]
            ab = s1 - s0
            den = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
            rel = a - s0[:, None, :]
            s = np.clip(np.einsum("ikj,ij->ik", rel, ab) / den[:, None], 0.0, 1.0)
            d = np.linalg.norm(rel - s[..., None] * ab[:, None, :], axis=-1).min(axis=1)
            gap = np.minimum(gap, d)
    out = np.where(sep > 0, gap, np.maximum(sep, -np.inf))
    # polygons with no proper edge (points) have no separating-axis estimate: the gap is exact
    return np.where(np.isfinite(sep), out, gap) - p_radius - q_radius
