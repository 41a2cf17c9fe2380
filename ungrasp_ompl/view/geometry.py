"""Triangle meshes of what the 3D view draws: boxes, cylinders, prisms over an outline, convex hulls.

Every body of the view is one triangle mesh in its own frame (metres), so the meshcat page and the
matplotlib key-frame strip draw exactly the same geometry. Faces are wound counter-clockwise seen
from outside (outward normals).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Facets around a cylinder's axis.
CYLINDER_FACETS = 24


@dataclass(frozen=True)
class Mesh:
    """vertices (N, 3) in m, in the body's frame; faces (M, 3) vertex indices, outward winding."""

    vertices: NDArray[np.float64]
    faces: NDArray[np.int64]

    def transformed(self, pose: NDArray) -> NDArray[np.float64]:
        """The vertices (N, 3) in the world for the body at pose (4x4, body to world)."""
        return self.vertices @ pose[:3, :3].T + pose[:3, 3]

    def moved(self, pose: NDArray) -> "Mesh":
        """The same mesh with its vertices expressed through pose (4x4): a fixed offset in the body."""
        return Mesh(self.transformed(pose), self.faces)


def merge(meshes: list[Mesh]) -> Mesh:
    """One mesh holding all of meshes."""
    verts, faces, offset = [], [], 0
    for m in meshes:
        verts.append(m.vertices)
        faces.append(m.faces + offset)
        offset += len(m.vertices)
    return Mesh(np.vstack(verts), np.vstack(faces))


def box(size: ArrayLike, centre: ArrayLike = (0.0, 0.0, 0.0)) -> Mesh:
    """An axis-aligned box of size (x, y, z) in m about centre."""
    sx, sy, sz = np.asarray(size, dtype=float) / 2
    corners = np.array([[x, y, z] for z in (-sz, sz) for y in (-sy, sy) for x in (-sx, sx)]) + np.asarray(centre)
    # corner index = 4 * top + 2 * (y high) + (x high)
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return Mesh(corners, np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]))


def cylinder(radius: float, length: float, facets: int = CYLINDER_FACETS) -> Mesh:
    """A closed cylinder of radius and length (m) along z, centred on the origin."""
    ang = 2 * math.pi * np.arange(facets) / facets
    ring = np.column_stack([radius * np.cos(ang), radius * np.sin(ang)])
    return prism(ring, -length / 2, length / 2)


def prism(outline: ArrayLike, bottom: float, top: float) -> Mesh:
    """A vertical prism over a simple polygon (N, 2) (x, y in m, either way round, convex or not),
    from z = bottom to top; the caps are ear-clipped."""
    p = np.asarray(outline, dtype=float)
    if _signed_area(p) < 0:
        p = p[::-1]
    n = len(p)
    verts = np.vstack([np.column_stack([p, np.full(n, bottom)]), np.column_stack([p, np.full(n, top)])])
    faces = []
    for i in range(n):
        j = (i + 1) % n
        faces += [(i, j, n + j), (i, n + j, n + i)]  # side
    for a, b, c in ear_clip(p):
        faces += [(a, c, b), (n + a, n + b, n + c)]  # bottom (facing down), top (up)
    return Mesh(verts, np.array(faces))


def ear_clip(polygon: ArrayLike) -> list[tuple[int, int, int]]:
    """Triangles (index triples, counter-clockwise) covering a simple counter-clockwise polygon (N, 2)."""
    p = np.asarray(polygon, dtype=float)
    left = list(range(len(p)))
    out: list[tuple[int, int, int]] = []

    def cross(o: int, a: int, b: int) -> float:
        return float((p[a, 0] - p[o, 0]) * (p[b, 1] - p[o, 1]) - (p[a, 1] - p[o, 1]) * (p[b, 0] - p[o, 0]))

    while len(left) > 3:
        m = len(left)
        for k in range(m):
            a, b, c = left[k - 1], left[k], left[(k + 1) % m]
            if cross(a, b, c) <= 1e-18:
                continue  # reflex or flat corner: not an ear
            inside = any(cross(a, b, v) >= 0 and cross(b, c, v) >= 0 and cross(c, a, v) >= 0
                         for v in left if v not in (a, b, c))
            if not inside:
                out.append((a, b, c))
                del left[k]
                break
        else:  # numerically degenerate remainder: fan it
            out += [(left[0], left[i], left[i + 1]) for i in range(1, len(left) - 1)]
            return out
    out.append((left[0], left[1], left[2]))
    return out


def extrude_y(outline_xz: ArrayLike, width: float) -> Mesh:
    """A prism over a simple polygon (N, 2) of (x, z) points (m), extruded along y from -width/2 to
    width/2 (a digit's profile in its plane)."""
    m = prism(outline_xz, -width / 2, width / 2)  # (x, z, y): swap the last two axes back
    return Mesh(m.vertices[:, [0, 2, 1]], m.faces[:, ::-1].copy())  # the swap mirrors: turn faces back out


def digit(length: float, t_tip: float, t_base: float, width: float, side: float, tip_radius: float = 0.0) -> Mesh:
    """A tapered digit in its jaw frame (m): the contact face on x = 0 from the palm (z = 0) to the
    tip (z = length), the body behind it on the side of x given by side (+1 or -1), tip_radius > 0
    rounds the tip's edge (a cylinder across the width, as the planner's rounded finger)."""
    end = length - tip_radius
    t_end = t_base + (t_tip - t_base) * end / length
    body = extrude_y([[0.0, 0.0], [0.0, end], [side * t_end, end], [side * t_base, 0.0]], width)
    if tip_radius <= 0.0:
        return body
    turn = np.array([[1.0, 0.0, 0.0, side * tip_radius], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, end],
                     [0.0, 0.0, 0.0, 1.0]])  # the cylinder's z along y, at the dome's centre
    return merge([body, cylinder(tip_radius, width).moved(turn)])


def convex_hull(points: ArrayLike) -> Mesh:
    """The convex hull of points (N, 3) in m (a frame's wall, a piece put down), outward faces."""
    from scipy.spatial import ConvexHull  # scipy.spatial: 0.4 s to import, loaded for a hull

    pts = np.asarray(points, dtype=float)
    hull = ConvexHull(pts)
    faces = hull.simplices.copy()
    centre = pts[hull.vertices].mean(axis=0)
    for k, (a, b, c) in enumerate(faces):  # qhull's winding is arbitrary: turn each face outward
        if np.dot(np.cross(pts[b] - pts[a], pts[c] - pts[a]), pts[a] - centre) < 0:
            faces[k] = (a, c, b)
    used, index = np.unique(faces, return_inverse=True)
    return Mesh(pts[used], index.reshape(faces.shape))


def _signed_area(p: NDArray) -> float:
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
