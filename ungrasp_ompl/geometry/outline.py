"""Outlines of thin objects in their own plane, and their contact candidates.

An outline is a closed polygon (metres, counter-clockwise) whose vertices are
either sharp corners of the object or samples of a smooth curve (circle and
ellipse arcs, rounded corners). Its contact candidates are the vertices and
points inside its straight sides, each with an inward normal (a normal cone
at a sharp corner) and a radius of curvature: 0 at a sharp corner (a cusp),
infinite inside a straight side (an edge contact), the circle through the
neighbouring samples on a smooth curve.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray


class OutlineError(ValueError):
    """A degenerate outline; the message says why."""


@dataclass(frozen=True)
class ContactCandidates:
    """Points where G or B may sit, with what the contact looks like there.

    normal_lo, normal_hi: the inward normal cone (equal except at sharp
    corners), unit vectors, counter-clockwise from lo to hi. kind: 'corner',
    'edge' or 'smooth'. radius: of curvature, metres (0 corner, inf edge).
    """

    points: NDArray[np.float64]
    normal_lo: NDArray[np.float64]
    normal_hi: NDArray[np.float64]
    kind: NDArray[np.str_]
    radius: NDArray[np.float64]

    def joined(self, other: "ContactCandidates") -> "ContactCandidates":
        """These candidates, then other's."""
        return ContactCandidates(*(np.concatenate([getattr(self, f), getattr(other, f)])
                                   for f in ("points", "normal_lo", "normal_hi", "kind", "radius")))


@dataclass(frozen=True)
class Outline:
    """A closed outline: vertices (n, 2) in metres, counter-clockwise; which vertices are
    smooth-curve samples; which sides (vertex i to i + 1) are straight sides of the object
    rather than chords of a sampled curve."""

    vertices: NDArray[np.float64]
    smooth: NDArray[np.bool_]
    straight: NDArray[np.bool_]

    @classmethod
    def make(cls, vertices: ArrayLike, smooth: ArrayLike | bool = False,
             straight: ArrayLike | None = None) -> "Outline":
        """Validate and orient an outline; raises OutlineError when it is degenerate.

        straight defaults to: a side is straight unless both its ends are smooth samples.
        """
        v = np.asarray(vertices, dtype=float)
        if v.ndim != 2 or v.shape[1] != 2:
            raise OutlineError(f"vertices must be a list of [x, y] points, got shape {v.shape}")
        if np.allclose(v[0], v[-1]) and len(v) > 1:
            v = v[:-1]
        if len(v) < 3:
            raise OutlineError(f"needs at least 3 points, got {len(v)}")
        sm = np.broadcast_to(np.asarray(smooth, dtype=bool), (len(v),)).copy()
        st = ~(sm & np.roll(sm, -1)) if straight is None else np.asarray(straight, dtype=bool).copy()
        if not np.all(np.isfinite(v)):
            raise OutlineError("has a non-finite coordinate")
        seg = np.linalg.norm(np.roll(v, -1, axis=0) - v, axis=1)
        if np.any(seg < 1e-12):
            raise OutlineError("has repeated consecutive points")
        if _self_intersects(v):
            raise OutlineError("is self-intersecting")
        area = _signed_area(v)
        scale = max(np.ptp(v[:, 0]), np.ptp(v[:, 1])) ** 2
        if abs(area) <= 1e-9 * scale:
            raise OutlineError("has zero area")
        if area < 0:  # reverse to counter-clockwise; side i then joins reversed vertices i and i + 1
            v, sm, st = v[::-1].copy(), sm[::-1].copy(), np.roll(st[::-1], -1).copy()
        return cls(v, sm, st)

    @property
    def area(self) -> float:
        return _signed_area(self.vertices)

    def refined(self, max_sagitta: float) -> NDArray[np.float64]:
        """The vertices (m) with the sampled curves filled in: each side that is a chord of a
        smooth curve is divided along the circle through its ends and the next sample on the same
        curve (exact for circular arcs) until no chord strays more than max_sagitta (m) from its
        arc. The original vertices are kept, so contact points chosen among them stay vertices."""
        v = self.vertices
        n = len(v)
        out = []
        for i in range(n):
            out.append(v[i])
            centre = self._arc_centre(i)
            if centre is None:
                continue
            a, b = v[i], v[(i + 1) % n]
            r = float(np.linalg.norm(a - centre))
            a0 = math.atan2(*(a - centre)[::-1])
            turn = (math.atan2(*(b - centre)[::-1]) - a0 + math.pi) % (2 * math.pi) - math.pi
            step = 2 * math.acos(max(-1.0, 1 - max_sagitta / r)) if max_sagitta < r else math.pi
            k = math.ceil(abs(turn) / step)
            for j in range(1, k):
                ang = a0 + turn * j / k
                out.append(centre + r * np.array([math.cos(ang), math.sin(ang)]))
        return np.array(out)

    def _arc_centre(self, i: int) -> NDArray[np.float64] | None:
        """Centre of the circle that side i (a chord of a sampled curve) follows: through its ends
        and the next sample on the same curve; None for a straight side (or collinear samples)."""
        v, n = self.vertices, len(self.vertices)
        if self.straight[i]:
            return None
        third = v[(i + 2) % n] if not self.straight[(i + 1) % n] else v[i - 1] if not self.straight[i - 1] else None
        return None if third is None else _circumcentre(v[i], v[(i + 1) % n], third)

    def support(self, direction: ArrayLike) -> NDArray[np.float64]:
        """The point of the outline (m) furthest along a direction, its sampled curves taken as the
        circles refined draws: where a plane normal to the direction first touches it."""
        u = np.asarray(direction, dtype=float)
        u = u / np.linalg.norm(u)
        v, n = self.vertices, len(self.vertices)
        points = [v[int(np.argmax(v @ u))]]
        for i in range(n):
            centre = self._arc_centre(i)
            if centre is None:
                continue
            a, b = v[i] - centre, v[(i + 1) % n] - centre
            p = np.linalg.norm(a) * u  # the circle's furthest point, if it lies on this side's arc
            turn = a[0] * b[1] - a[1] * b[0]
            if turn * (a[0] * p[1] - a[1] * p[0]) >= 0 and turn * (p[0] * b[1] - p[1] * b[0]) >= 0 and p @ (a + b) > 0:
                points.append(centre + p)
        return max(points, key=lambda q: float(q @ u))

    def contact_at(self, point: ArrayLike, tol: float) -> tuple[NDArray[np.float64], NDArray[np.float64], str, float] | None:
        """The contact at the outline's point nearest to point (m), where it lies within tol (m) of
        the outline, else None: that point of the curve (on a sampled curve, on the circle its
        chord follows, as refined draws it), its inward normal, its kind ('smooth' on a curve,
        'edge' on a straight side) and radius of curvature (m). Where the nearest point is a
        vertex, None: candidates() describes the vertices."""
        p = np.asarray(point, dtype=float)
        v = self.vertices
        edge = np.roll(v, -1, axis=0) - v
        t = np.clip(np.einsum("ij,ij->i", p - v, edge) / np.einsum("ij,ij->i", edge, edge), 0.0, 1.0)
        i = int(np.argmin(np.linalg.norm(v + t[:, None] * edge - p, axis=1)))
        length = float(np.linalg.norm(edge[i]))
        if not 1e-9 < t[i] * length < length - 1e-9:
            return None
        inward = np.array([-edge[i, 1], edge[i, 0]]) / length  # left of a counter-clockwise side
        centre = self._arc_centre(i)
        if centre is None:  # a straight side
            on, normal, kind, radius = v[i] + t[i] * edge[i], inward, "edge", math.inf
        else:
            radius = float(np.linalg.norm(v[i] - centre))
            radial = (p - centre) / np.linalg.norm(p - centre)
            on, kind = centre + radius * radial, "smooth"
            normal = -radial if -radial @ inward > 0 else radial  # toward the centre where the curve is convex
        return (on, normal, kind, radius) if np.linalg.norm(on - p) <= tol else None

    def candidates(self, edge_samples: int = 9) -> ContactCandidates:
        """Contact candidates: every vertex, plus edge_samples points inside each straight side."""
        v = self.vertices
        n = len(v)
        nxt, prv = np.roll(v, -1, axis=0), np.roll(v, 1, axis=0)
        edge = nxt - v
        length = np.linalg.norm(edge, axis=1)
        inward = np.stack([-edge[:, 1], edge[:, 0]], axis=1) / length[:, None]  # left of a CCW edge
        before = np.roll(inward, 1, axis=0)  # inward normal of the side ending at each vertex
        pts, lo, hi, kind, radius = [], [], [], [], []
        for i in range(n):
            if self.smooth[i]:
                nrm = before[i] + inward[i]
                nrm /= np.linalg.norm(nrm)
                pts.append(v[i]), lo.append(nrm), hi.append(nrm), kind.append("smooth")
                radius.append(_circumradius(prv[i], v[i], nxt[i]))
            else:
                pts.append(v[i]), lo.append(before[i]), hi.append(inward[i]), kind.append("corner")
                radius.append(0.0)
        for i in range(n):
            if not self.straight[i]:
                continue
            for s in (np.arange(edge_samples) + 1) / (edge_samples + 1):
                pts.append(v[i] + s * edge[i]), lo.append(inward[i]), hi.append(inward[i])
                kind.append("edge"), radius.append(math.inf)
        return ContactCandidates(np.array(pts), np.array(lo), np.array(hi), np.array(kind), np.array(radius))

    def double_normals(self) -> ContactCandidates:
        """The outline's double normals with its straight sides, as contact candidates: for each
        straight side, the point of the outline furthest along the side's inward normal (support,
        on the circles of its sampled curves) and that point's foot on the side, where the foot lies
        inside the side. A pair of them has GB along both contacts' normals (beta 0 at each end), so
        the table's or the thumb's face lies flush with the side and touches the far point exactly
        where the plan puts it. The far point's normal is the side's, reversed; a far point at a
        vertex is left to candidates() (its kind and normal cone are the vertex's)."""
        v = self.vertices
        n = len(v)
        pts, nrm, kind, radius = [], [], [], []
        for i in range(n):
            if not self.straight[i]:
                continue
            edge = v[(i + 1) % n] - v[i]
            length = float(np.linalg.norm(edge))
            inward = np.array([-edge[1], edge[0]]) / length
            far = self.support(inward)
            along = float((far - v[i]) @ edge) / length ** 2
            if not 1e-9 < along < 1.0 - 1e-9:
                continue  # the foot falls on a corner or off the side
            pts.append(v[i] + along * edge), nrm.append(inward), kind.append("edge"), radius.append(math.inf)
            at = None if np.min(np.linalg.norm(v - far, axis=1)) < 1e-12 else self.contact_at(far, 1e-9)
            if at is not None:
                pts.append(far), nrm.append(-inward), kind.append(at[2]), radius.append(at[3])
        pts, nrm = np.reshape(pts, (-1, 2)), np.reshape(nrm, (-1, 2))
        return ContactCandidates(pts, nrm, nrm.copy(), np.array(kind, dtype=str), np.array(radius, dtype=float))


def _signed_area(v: NDArray) -> float:
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _circumradius(a: NDArray, b: NDArray, c: NDArray) -> float:
    ab, bc, ca = np.linalg.norm(b - a), np.linalg.norm(c - b), np.linalg.norm(a - c)
    cross = abs((b - a)[0] * (c - a)[1] - (b - a)[1] * (c - a)[0])
    return math.inf if cross < 1e-18 else ab * bc * ca / (2 * cross)


def _circumcentre(a: NDArray, b: NDArray, c: NDArray) -> NDArray[np.float64] | None:
    """Centre of the circle through three points; None when they are collinear."""
    p, q = a - c, b - c
    d = 2 * (p[0] * q[1] - q[0] * p[1])
    if abs(d) < 1e-18:
        return None
    pp, qq = p @ p, q @ q
    return c + np.array([q[1] * pp - p[1] * qq, p[0] * qq - q[0] * pp]) / d


def _self_intersects(v: NDArray) -> bool:
    """Whether two non-adjacent sides cross (vectorised over side pairs)."""
    n = len(v)
    a, b = v, np.roll(v, -1, axis=0)
    i, j = np.triu_indices(n, k=2)
    keep = ~((i == 0) & (j == n - 1))
    i, j = i[keep], j[keep]

    def orient(p, q, r):
        return np.sign((q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0]))

    o1, o2 = orient(a[i], b[i], a[j]), orient(a[i], b[i], b[j])
    o3, o4 = orient(a[j], b[j], a[i]), orient(a[j], b[j], b[i])
    return bool(np.any((o1 * o2 < 0) & (o3 * o4 < 0)))


# -- shapes ---------------------------------------------------------------------------
def polygon(vertices: ArrayLike) -> Outline:
    """A polygon with sharp corners (metres)."""
    return Outline.make(vertices, smooth=False)


def ellipse(a: float, b: float, samples: int = 180) -> Outline:
    """An ellipse with semi-axes a (x) and b (y), centred at the origin, sampled finely (a circle when a == b)."""
    t = np.linspace(0, 2 * np.pi, samples, endpoint=False)
    return Outline.make(np.column_stack([a * np.cos(t), b * np.sin(t)]), smooth=True)


def rounded_polygon(vertices: ArrayLike, radius: ArrayLike, arc_samples: int = 24) -> Outline:
    """A convex polygon whose corners are rounded with the given radii (one, or one per corner), metres."""
    v = Outline.make(vertices).vertices
    n = len(v)
    r = np.broadcast_to(np.asarray(radius, dtype=float), (n,))
    sides = np.roll(v, -1, axis=0) - v
    side_len = np.linalg.norm(sides, axis=1)
    turn = [math.acos(float(np.clip(np.dot(-sides[i - 1], sides[i]) / (side_len[i - 1] * side_len[i]), -1, 1)))
            for i in range(n)]  # interior angle at each corner
    if any(t >= math.pi - 1e-9 for t in turn) or _signed_area(v) <= 0:
        raise OutlineError("rounded polygons must be convex")
    reach = np.array([r[i] / math.tan(turn[i] / 2) for i in range(n)])  # corner to tangent point
    for i in range(n):
        if reach[i] + reach[(i + 1) % n] > side_len[i] + 1e-12:
            raise OutlineError(f"corner radii {r[i]:g} and {r[(i + 1) % n]:g} m do not fit on side {i}")
    pts, smooth, straight = [], [], []
    for i in range(n):
        p, a, c = v[i], v[i - 1], v[(i + 1) % n]
        u1, u2 = (a - p) / np.linalg.norm(a - p), (c - p) / np.linalg.norm(c - p)
        half = turn[i] / 2
        if r[i] <= 0:
            pts.append(p), smooth.append(False), straight.append(True)
            continue
        dist = reach[i]
        centre = p + (u1 + u2) / np.linalg.norm(u1 + u2) * r[i] / math.sin(half)
        t1, t2 = p + u1 * dist, p + u2 * dist
        a1 = math.atan2(*(t1 - centre)[::-1])
        a2 = math.atan2(*(t2 - centre)[::-1])
        if a2 < a1:
            a2 += 2 * math.pi
        for k, ang in enumerate(np.linspace(a1, a2, arc_samples)):
            pts.append(centre + r[i] * np.array([math.cos(ang), math.sin(ang)]))
            smooth.append(True)
            straight.append(k == arc_samples - 1)  # the side after the arc's last sample
    return Outline.make(np.array(pts), smooth=np.array(smooth), straight=np.array(straight))
