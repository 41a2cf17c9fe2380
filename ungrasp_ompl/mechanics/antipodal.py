"""Planar antipodal pairs on an outline and the effective friction in the manipulation plane
(paper sec. 5.1, docs/model.md, section 5). Pure numpy; points in the object's own plane.

For contacts G and B with in-plane inward normal cones, beta_X is the angle
between the chord (from X toward the other contact) and the nearest inward
normal at X. The pair is antipodal when beta_G < phi_G and beta_B < phi_B
(each contact lies in the field of view of the other's friction cone); its
margin is min(phi_G - beta_G, phi_B - beta_B). It fits the task when the line
through each contact normal to that nearest normal supports the outline
(the object stays on one side of the table at G and of the thumb face at B).

The manipulation plane contains G, B and the object's normal; a friction
cone of half-angle phi whose axis makes angle gamma with it cuts it in a
planar cone of half-angle phi', cos phi' = cos phi / cos gamma (empty when
gamma >= phi: Assumption 2 fails). beta is a conservative gamma.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray


def _cross(a: NDArray, b: NDArray) -> NDArray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def cone_angle(direction: ArrayLike, lo: ArrayLike, hi: ArrayLike) -> tuple[NDArray, NDArray]:
    """Angle from unit directions (..., 2) to a normal cone [lo, hi] (counter-clockwise, < 180 deg),
    zero inside it, and the unit normal of the cone nearest to each direction."""
    c, lo, hi = (np.asarray(x, dtype=float) for x in (direction, lo, hi))
    inside = (_cross(lo, c) >= -1e-12) & (_cross(c, hi) >= -1e-12)
    to_lo = np.arccos(np.clip(np.sum(c * lo, -1), -1, 1))
    to_hi = np.arccos(np.clip(np.sum(c * hi, -1), -1, 1))
    angle = np.where(inside, 0.0, np.minimum(to_lo, to_hi))
    nearest = np.where(inside[..., None], c, np.where((to_lo <= to_hi)[..., None], lo, hi))
    return angle, nearest


def pair_angles(points: NDArray, lo: NDArray, hi: NDArray, i: ArrayLike, j: ArrayLike):
    """For ordered pairs (i as G, j as B): beta_G, beta_B and the nearest normals at G and B."""
    i, j = np.asarray(i), np.asarray(j)
    chord = points[j] - points[i]
    chord = chord / np.linalg.norm(chord, axis=-1, keepdims=True)
    beta_g, n_g = cone_angle(chord, lo[i], hi[i])
    beta_b, n_b = cone_angle(-chord, lo[j], hi[j])
    return beta_g, beta_b, n_g, n_b


def supports(vertices: NDArray, point: NDArray, normal: NDArray, tol: float = 1e-9) -> NDArray[np.bool_]:
    """Whether the line through each point normal to its inward normal has every vertex on its inner side."""
    scale = np.max(np.ptp(vertices, axis=0))
    reach = np.einsum("pk,vk->pv", normal, vertices) - np.sum(normal * point, -1)[:, None]
    return np.all(reach >= -tol * scale, axis=-1)


def antipodal_pairs(points: NDArray, lo: NDArray, hi: NDArray, vertices: NDArray,
                    phi_g: float, phi_b: float) -> tuple[NDArray, NDArray, NDArray]:
    """All ordered pairs (G index, B index) that are antipodal and fit the task, with their margins (rad).

    Vectorised over every pair of candidates.
    """
    n = len(points)
    i, j = np.nonzero(~np.eye(n, dtype=bool))
    far = np.linalg.norm(points[j] - points[i], axis=-1) > 1e-9
    i, j = i[far], j[far]
    beta_g, beta_b, n_g, n_b = pair_angles(points, lo, hi, i, j)
    ok = (beta_g < phi_g) & (beta_b < phi_b)
    i, j, beta_g, beta_b, n_g, n_b = i[ok], j[ok], beta_g[ok], beta_b[ok], n_g[ok], n_b[ok]
    fit = supports(vertices, points[i], n_g) & supports(vertices, points[j], n_b)
    margin = np.minimum(phi_g - beta_g, phi_b - beta_b)
    return i[fit], j[fit], margin[fit]


def effective_friction(mu: float, gamma: ArrayLike) -> NDArray[np.float64]:
    """mu' = tan(arccos(cos(atan mu) / cos gamma)); NaN where gamma >= atan(mu) (Assumption 2 fails)."""
    phi = math.atan(mu)
    gamma = np.asarray(gamma, dtype=float)
    c = math.cos(phi) / np.cos(gamma)
    with np.errstate(invalid="ignore"):
        return np.where(gamma < phi, np.tan(np.arccos(np.clip(c, -1, 1))), np.nan)
