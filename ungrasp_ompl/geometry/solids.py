"""Convex solids fixed in the world: the walls of a frame and the pieces already placed (python-fcl).

World frame: x, y on the table, z up, metres; the table's top is z = 0. A
solid is kept as its vertices; collision checkers build the FCL shape from
their convex hull in whatever frame they work in. Non-convex outlines are
represented by their convex hull (conservative).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import fcl
import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclass(frozen=True)
class Solid:
    """A named convex body: its vertices (N, 3) in the world (m)."""

    name: str
    vertices: NDArray[np.float64]

    def transformed(self, pose: NDArray) -> NDArray[np.float64]:
        """The vertices expressed in another frame: pose (4x4) maps that frame to the world."""
        return (self.vertices - pose[:3, 3]) @ pose[:3, :3]

    def shape(self) -> fcl.Convex:
        """The FCL shape of its convex hull in world coordinates (built once per solid)."""
        key = (self.name, self.vertices.tobytes())
        if key not in _SHAPES:
            if len(_SHAPES) > 4096:
                _SHAPES.clear()
            foot = self.upright_foot()
            _SHAPES[key] = prism_shape(foot[0], foot[1], foot[2]) if foot else convex_shape(self.vertices)
        return _SHAPES[key]

    def upright_foot(self) -> tuple[NDArray[np.float64], float, float] | None:
        """When the solid is an upright prism (two heights, the same (x, y) at both): its foot's
        convex hull (K, 2) of world (x, y) counter-clockwise, and its bottom and top z (m); else None."""
        key = (self.name, self.vertices.tobytes())
        if key not in _FEET:
            if len(_FEET) > 4096:
                _FEET.clear()
            v = self.vertices
            z = np.unique(v[:, 2])
            feet = [{tuple(p) for p in v[v[:, 2] == h, :2].round(12)} for h in z]
            upright = len(z) == 2 and feet[0] == feet[1]
            _FEET[key] = (convex_hull_2d(v[:, :2]), float(z[0]), float(z[1])) if upright else None
        return _FEET[key]

    def grown(self, margin: float) -> "Solid":
        """The solid grown by margin (m) on every side, under an upright prism's foot excepted (it
        stands on the table): the Minkowski sum with a regular octagon whose inscribed circle has
        radius margin and, up and down, with margin. It holds every point within margin of the
        solid and reaches at most 8 % further across (1.47 times margin at its edges, where both
        add). margin <= 0 returns the solid itself."""
        if margin <= 0.0:
            return self
        turn = np.arange(8) * (math.pi / 4) + math.pi / 8
        ring = (margin / math.cos(math.pi / 8)) * np.column_stack([np.cos(turn), np.sin(turn)])
        foot = self.upright_foot()
        if foot is not None:
            hull, bottom, top = foot
            return prism(self.name, convex_hull_2d((hull[:, None, :] + ring).reshape(-1, 2)), bottom, top + margin)
        steps = np.vstack([np.column_stack([ring, np.full(8, z)]) for z in (-margin, margin)])
        points = (self.vertices[:, None, :] + steps).reshape(-1, 3)
        return Solid(self.name, points[_convex_hull(points).vertices])

    def in_frame(self, pose: NDArray) -> fcl.CollisionObject:
        """A collision object of the solid in another frame, pose (4x4) mapping that frame to the world."""
        rot = pose[:3, :3].T
        return fcl.CollisionObject(self.shape(), fcl.Transform(rot, -rot @ pose[:3, 3]))


_SHAPES: dict[tuple, fcl.Convex] = {}
_FEET: dict[tuple, tuple[NDArray, float, float] | None] = {}


def prism(name: str, polygon: ArrayLike, bottom: float, top: float) -> Solid:
    """A vertical prism over a planar polygon (N, 2) of world (x, y) points, from z = bottom to top (m)."""
    p = np.asarray(polygon, dtype=float)
    lo = np.column_stack([p, np.full(len(p), bottom)])
    hi = np.column_stack([p, np.full(len(p), top)])
    return Solid(name, np.vstack([lo, hi]))


def box(name: str, centre: ArrayLike, size: ArrayLike, yaw: float = 0.0) -> Solid:
    """A box standing on its base: centre (x, y, z) and size (sx, sy, sz) in metres, turned by yaw (rad) about z."""
    c = np.asarray(centre, dtype=float)
    sx, sy, sz = (float(v) / 2 for v in size)
    corners = np.array([[-sx, -sy], [sx, -sy], [sx, sy], [-sx, sy]])
    rot = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    return prism(name, corners @ rot.T + c[:2], c[2] - sz, c[2] + sz)


def _convex_hull(points: NDArray):
    """scipy's ConvexHull, imported on first use: scipy.spatial alone takes 0.3 s to import."""
    from scipy.spatial import ConvexHull

    return ConvexHull(points)


def solid_mass_properties(vertices: ArrayLike) -> tuple[float, NDArray[np.float64]]:
    """The volume (m^3) and centroid (3,) (m, the points' frame) of the convex hull of points
    (N, 3): the hull split into tetrahedra from an inner point, each weighted by its volume."""
    v = np.asarray(vertices, dtype=float)
    hull = _convex_hull(v)
    inner = v[hull.vertices].mean(axis=0)
    tri = v[hull.simplices]  # (F, 3, 3)
    vols = np.abs(np.einsum("fi,fi->f", tri[:, 0] - inner, np.cross(tri[:, 1] - inner, tri[:, 2] - inner))) / 6.0
    centres = (tri.sum(axis=1) + inner) / 4.0
    volume = float(vols.sum())
    return volume, (vols[:, None] * centres).sum(axis=0) / volume


def convex_shape(vertices: ArrayLike) -> fcl.Convex:
    """An FCL convex shape on the convex hull of points (N, 3), faces wound outward."""
    v = np.asarray(vertices, dtype=float)
    hull = _convex_hull(v)
    pts = v[hull.vertices]
    remap = {int(old): new for new, old in enumerate(hull.vertices)}
    faces = []
    for simplex, eq in zip(hull.simplices, hull.equations):
        a, b, c = (remap[int(i)] for i in simplex)
        if np.dot(np.cross(pts[b] - pts[a], pts[c] - pts[a]), eq[:3]) < 0:
            b, c = c, b
        faces.extend([3, a, b, c])
    return fcl.Convex(pts, len(hull.simplices), np.array(faces, dtype=np.int64))


def convex_hull_2d(points: ArrayLike) -> NDArray[np.float64]:
    """The convex hull of planar points (N, 2): its vertices counter-clockwise, collinear points
    dropped (Andrew's monotone chain; the planar case needs no scipy, whose import costs 0.3 s)."""
    p = np.unique(np.asarray(points, dtype=float), axis=0)  # sorted by x, then y
    if len(p) < 3:
        return p

    def chain(pts: NDArray) -> list[NDArray]:
        out: list[NDArray] = []
        for q in pts:
            while len(out) >= 2:
                (ax, ay), (bx, by) = out[-1] - out[-2], q - out[-2]
                if ax * by - ay * bx > 0:  # a left turn: keep
                    break
                out.pop()
            out.append(q)
        return out

    lower, upper = chain(p), chain(p[::-1])
    return np.array(lower[:-1] + upper[:-1])


def prism_shape(polygon: ArrayLike, bottom: float, top: float) -> fcl.Convex:
    """An FCL convex shape: the convex hull of a planar polygon (N, 2) extruded along the third
    axis from bottom to top (m), faces wound outward."""
    hull = convex_hull_2d(polygon)
    n = len(hull)
    verts = np.vstack([np.column_stack([hull, np.full(n, bottom)]), np.column_stack([hull, np.full(n, top)])])
    faces = [list(range(n - 1, -1, -1)), list(range(n, 2 * n))]
    faces += [[i, (i + 1) % n, n + (i + 1) % n, n + i] for i in range(n)]
    flat = np.concatenate([[len(f), *f] for f in faces]).astype(np.int64)
    return fcl.Convex(verts, len(faces), flat)


def hull_normals(points: ArrayLike) -> NDArray[np.float64]:
    """The outward unit normals (K, 2) of the edges of the convex hull of planar points (N, 2):
    the separating-axis candidates of a convex polygon."""
    hull = convex_hull_2d(points)
    edges = np.roll(hull, -1, axis=0) - hull
    return np.column_stack([edges[:, 1], -edges[:, 0]]) / np.linalg.norm(edges, axis=1)[:, None]


def polygons_overlap(a: ArrayLike, b: ArrayLike, tol: float = 1e-6) -> bool:
    """Whether the convex hulls of two planar polygons (N, 2) overlap by more than tol (m) along
    every separating-axis candidate (touching along an edge is not an overlap)."""
    polys = [np.asarray(p, dtype=float) for p in (a, b)]
    for p in polys:
        for ax in hull_normals(p):
            pa, pb = polys[0] @ ax, polys[1] @ ax
            if min(pa.max(), pb.max()) - max(pa.min(), pb.min()) <= tol:
                return False
    return True
