"""Prism roll simulation of the x-moment (roll) stability (paper sec. 4.3).

The object is a polygonal prism: its outline as the bottom face, the top face
at its thickness. Object frame: G at the origin, x toward B, y in the
object's plane, z along its normal (the top face at z = thickness); A on the
top face above the GB line. The table is a plane through the support line at
G, inclined by theta below the object's plane; the thumb face a plane through
the support line at B, inclined by psi. Both stay put while the prism rolls.

The prism rolls about the axis through its current contacts with the table
and the thumb face (first G and B); when another vertex reaches either plane
the axis moves to it, and the rolling goes on. The finger does not turn with
the perturbation, so A's friction cone keeps its initial direction (along
-z, like gravity in the paper's conservative argument) while the point A
moves with the prism. At each tilt the cone is discretised into rays and the
grasp restores itself there when one of them has a moment about the axis
against the roll. A point A on the axis (a thin object before the axis
moves) gives no moment at all: not restoring. A tall prism on small radii
carries A past its rolling axis, where no ray restores (paper fig. 5d).
"""

from __future__ import annotations

import copy
import functools
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray


#: The two ways the prism is rolled about G->B (RollDirection.sign) in words: +1 lifts the side of
#: the object left of G->B as seen from the finger (from the top face, where A presses), -1 the
#: side right of it (a right-handed turn about G->B, and the opposite one).
ROLL_WAYS = {1: "left side up", -1: "right side up"}
#: How to read ROLL_WAYS, said once beside them.
ROLL_WAYS_NOTE = "sides of G->B seen from the finger"


def describe_restoring(ranges_deg: dict[int, tuple[float, float] | None]) -> str:
    """The tilts (deg) over which the grasp restores itself, each way named:
    "left side up 0.25..30.00 deg, right side up none (sides of G->B seen from the finger)".
    ranges_deg: by RollDirection.sign, a (first, last) tilt in deg or None (never restores)."""
    parts = [f"{ROLL_WAYS[sign]} " + ("none" if r is None else f"{r[0]:.2f}..{r[1]:.2f} deg")
             for sign, r in ranges_deg.items()]
    return f"{', '.join(parts)} ({ROLL_WAYS_NOTE})"


@dataclass
class RollDirection:
    """Outcome of rolling one way: the sampled tilts (rad), whether each restores, the axis changes."""

    sign: int
    tilts: NDArray[np.float64]
    restoring: NDArray[np.bool_]
    events: list[float] = field(default_factory=list)

    def restoring_range(self) -> tuple[float, float] | None:
        """The tilt interval (rad) over which the grasp restores itself, from the first restoring
        sample to the last before it stops restoring; None if it never does."""
        idx = np.flatnonzero(self.restoring)
        if not len(idx):
            return None
        start = idx[0]
        stop = start
        while stop + 1 < len(self.restoring) and self.restoring[stop + 1]:
            stop += 1
        return float(self.tilts[start]), float(self.tilts[stop])


@dataclass
class RollResult:
    directions: list[RollDirection]
    max_tilt: float
    onset: float

    @property
    def self_restoring(self) -> bool:
        """Restoring in both directions from the onset tilt up to max_tilt."""
        for d in self.directions:
            r = d.restoring_range()
            if r is None or r[0] > self.onset + 1e-12 or r[1] < self.max_tilt - 1e-9:
                return False
        return True


def _cross(a: NDArray, b: NDArray) -> NDArray:
    """a x b for 3-vectors (..., 3) that broadcast (np.cross without its per-call cost, which
    dominates here: the roll turns a handful of points at a time, hundreds of times)."""
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1], a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def _rotate(points: NDArray, origin: NDArray, axis: NDArray, angles: NDArray) -> NDArray:
    """Rotate points (V, 3) about the line (origin, unit axis) by each angle: (K, V, 3) (Rodrigues)."""
    p = points - origin
    c, s = np.cos(angles)[:, None, None], np.sin(angles)[:, None, None]
    k = axis[None, None, :]
    dot = (p @ axis)[None, :, None]
    return origin + p[None] * c + _cross(k, p[None]) * s + k * dot * (1 - c)


def _cone_rays(axis: NDArray, half_angle: float, rays: int) -> NDArray:
    """The axis and `rays` unit directions on a circular cone around it."""
    a = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0, 0]) if abs(a[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(a, helper)
    u /= np.linalg.norm(u)
    v = np.cross(a, u)
    t = np.linspace(0, 2 * np.pi, rays, endpoint=False)
    ring = math.cos(half_angle) * a + math.sin(half_angle) * (np.cos(t)[:, None] * u + np.sin(t)[:, None] * v)
    return np.vstack([a, ring])


#: How many roll simulations are remembered by their inputs (every plan of a scene rolls its
#: start, and most of a planner's plans end at the same few goal states).
ROLL_CACHE = 256


def roll_simulation(
    outline: NDArray,
    thickness: float,
    g: NDArray,
    b: NDArray,
    normal_g: NDArray,
    normal_b: NDArray,
    a_from_g: float,
    theta: float,
    psi: float,
    phi_a: float,
    max_tilt: float = math.radians(30),
    step: float = math.radians(0.25),
    onset: float = math.radians(1.0),
    rays: int = 16,
) -> RollResult:
    """Roll the prism both ways about GB up to max_tilt (rad) and record where it restores itself.

    outline (V, 2), g, b and the inward normals at G and B are in the object's plane (metres);
    a_from_g: distance of A from G along GB; theta, psi: inclination of the table and of the
    thumb face to the object (clamped to at least 1 deg); phi_a: friction angle at A. The
    grasp counts as self-restoring when it restores at every tilt from onset to max_tilt.
    The same inputs give the same result, remembered for the last ROLL_CACHE of them (a copy is
    returned).
    

    Size: its arguments are ROLL_CACHE's key (floats and tuples of floats), so they are given one by one."""
    vectors = tuple(tuple(float(v) for v in np.ravel(a)) for a in (g, b, normal_g, normal_b))
    outline = np.ascontiguousarray(outline, dtype=float)
    key = (outline.tobytes(), outline.shape, float(thickness), vectors, float(a_from_g), float(theta), float(psi),
           float(phi_a), float(max_tilt), float(step), float(onset), int(rays))
    return copy.deepcopy(_remembered_roll(key))


@functools.lru_cache(maxsize=ROLL_CACHE)
def _remembered_roll(key: tuple) -> RollResult:
    """roll_simulation for its inputs packed as a key (see there)."""
    outline_bytes, shape, thickness, (g, b, normal_g, normal_b), a_from_g, theta, psi, phi_a, max_tilt, step, onset, \
        rays = key
    outline = np.frombuffer(outline_bytes).reshape(shape)
    g, b, normal_g, normal_b = (np.array(v) for v in (g, b, normal_g, normal_b))
    x = (b - g) / np.linalg.norm(b - g)
    y = np.array([-x[1], x[0]])
    local = np.column_stack([(outline - g) @ x, (outline - g) @ y])
    bottom = np.column_stack([local, np.zeros(len(local))])
    top = bottom + [0.0, 0.0, thickness]
    body = np.vstack([bottom, top])
    length = float(np.linalg.norm(b - g))
    z = np.array([0.0, 0.0, 1.0])
    planes = []
    for point, n_in, tilt in ((np.zeros(3), normal_g, theta), (np.array([length, 0.0, 0.0]), normal_b, psi)):
        n_local = np.array([n_in @ x, n_in @ y, 0.0])  # inward in-plane normal, object frame
        tilt = max(tilt, math.radians(1.0))
        up = z * math.cos(tilt) + n_local * math.sin(tilt)  # plane normal, toward the object
        planes.append((point, up))
    a0 = np.array([a_from_g, 0.0, thickness])
    forces = _cone_rays(-z, phi_a, rays)
    tilts = np.arange(step, max_tilt + step / 2, step)
    directions = []
    for sign in (1, -1):
        pts, a_pt = body.copy(), a0.copy()
        contacts = [planes[0][0].copy(), planes[1][0].copy()]
        done, restoring, events, stuck, wedged = 0.0, [], [], 0, False
        for target in tilts:
            while not wedged and done < target - 1e-12:
                axis = contacts[1] - contacts[0]
                axis /= np.linalg.norm(axis)
                ang = np.array([min(step, target - done)]) * sign
                moved = _rotate(pts, contacts[0], axis, ang)[0]
                heights = [(moved - p) @ up for p, up in planes]
                worst = [float(np.min(h)) for h in heights]
                side = int(np.argmin(worst))
                if worst[side] < -1e-12 * length:
                    # a vertex went through a plane: the axis moves to the deepest one
                    k = int(np.argmin(heights[side]))
                    part = np.array([ang[0] * _touch_fraction(pts, contacts[0], axis, ang[0], k, planes[side])])
                    pts = _rotate(pts, contacts[0], axis, part)[0]
                    a_pt = _rotate(a_pt[None], contacts[0], axis, part)[0, 0]
                    done += abs(part[0])
                    contacts[side] = pts[k].copy()
                    events.append(done)
                    # two axis changes without turning: a whole side rests on a plane, the roll is blocked
                    stuck = stuck + 1 if abs(part[0]) < 1e-9 else 0
                    wedged = stuck >= 2
                    continue
                pts = moved
                a_pt = _rotate(a_pt[None], contacts[0], axis, ang)[0, 0]
                done += abs(ang[0])
            if wedged:  # the supports themselves stop the roll
                restoring.append(True)
                continue
            axis = contacts[1] - contacts[0]
            axis /= np.linalg.norm(axis)
            moments = _cross(a_pt - contacts[0], forces) @ (sign * axis)
            restoring.append(bool(np.min(moments) < -1e-12 * length))
        directions.append(RollDirection(sign, tilts.copy(), np.array(restoring), events))
    return RollResult(directions, float(tilts[-1]), onset)


def _touch_fraction(pts, origin, axis, angle, k, plane) -> float:
    """Fraction of the rotation step at which vertex k reaches the plane (bisection)."""
    point, up = plane
    # the vertex's height above the plane after turning by a (Rodrigues, as _rotate):
    # h(a) = cos_part cos a + sin_part sin a + rest
    p = pts[k] - origin
    along = float(p @ axis)
    cos_part = float((p - axis * along) @ up)
    sin_part = float(_cross(axis, p) @ up)
    rest = float((origin + axis * along - point) @ up)
    lo, hi = 0.0, 1.0
    for _ in range(24):
        mid = (lo + hi) / 2
        if cos_part * math.cos(angle * mid) + sin_part * math.sin(angle * mid) + rest < 0:
            hi = mid
        else:
            lo = mid
    return lo
