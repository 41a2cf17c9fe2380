"""The manipulation plane of a thin object: its contacts G and B, effective friction, world frame.

Data flow: object outline and friction -> planar antipodal pair (G, B) ->
the vertical plane through G and B, in which the planar planner runs with the
effective friction mu'_G, mu'_B and length l = |GB| (paper sec. 5.1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from ..mechanics.antipodal import antipodal_pairs, effective_friction, pair_angles
from .outline import ContactCandidates, Outline


@dataclass(frozen=True)
class ContactPoint:
    """G or B on the outline (object frame, metres): where, the nearest inward normal, the contact kind."""

    point: NDArray[np.float64]
    normal: NDArray[np.float64]
    kind: str  # corner, edge or smooth
    radius: float  # of curvature, metres: 0 at a corner (cusp), inf on a straight side
    beta: float  # angle between GB and the inward normal, rad
    touch: tuple[float, float] = (0.0, 0.0)
    """Where the table (at G) or the thumb's face (at B) first touches the outline, from the contact
    (m): how much further out along GB, and how far across it (docs/model.md 11.7). The faces
    contain the plane's normal, so they touch where the outline reaches furthest along GB: (0, 0)
    where the contact does (its normal range holds GB); a smooth contact with beta > 0 is passed
    by R sin(beta) across GB, where the thumb's force has a moment about GB the plan does not count."""
    span: tuple[float, float] = (0.0, 0.0)
    """How far the outline lies on the face touching it (the table at G, the thumb's at B) across GB,
    each way from the contact (m; right, then left of the direction the face presses in): a straight
    side's two ends, (0, 0) at a point contact. The face supports the object only within it, so an
    object pressed across GB from outside the supports tips about the line to a support's end."""

    def to_dict(self) -> dict:
        """The contact as plan.json and the stability report give it (metres)."""
        return {"kind": self.kind, "radius_m": None if math.isinf(self.radius) else self.radius,
                "edge_contact": self.edge_contact, "point": self.point.tolist(),
                "touched_from_m": {"along": self.touch[0], "across": self.touch[1]},
                "span_m": list(self.span)}

    @property
    def edge_contact(self) -> bool:
        """Inside a straight side square to GB (span > 0 both ways): the table (or the thumb's face)
        touches the whole side, a segment contact that holds x-moments either way. A side at an
        angle to the face is touched at one point only, and one ending at the contact holds one way."""
        return min(self.span) > 0.0


@dataclass(frozen=True)
class ManipulationPlane:
    """The chosen plane: contacts, friction margin (rad), effective friction, and its frame in the world.

    frame: 4x4 homogeneous transform from the plane frame (origin at G on the table,
    x toward B, z up) to the world, with the object at its target pose.
    """

    g: ContactPoint
    b: ContactPoint
    margin: float
    mu_g: float
    mu_b: float
    frame: NDArray[np.float64]
    fixed: bool

    @property
    def length(self) -> float:
        return float(np.linalg.norm(self.b.point - self.g.point))

    def to_dict(self) -> dict:
        return {
            "G": self.g.point.tolist(), "B": self.b.point.tolist(),
            "length_m": self.length, "margin_rad": self.margin,
            "mu_eff": {"G": self.mu_g, "B": self.mu_b},
            "beta_rad": {"G": self.g.beta, "B": self.b.beta},
            "contacts": {"G": self.g.to_dict(), "B": self.b.to_dict()},
            "frame": self.frame.tolist(), "fixed_by_user": self.fixed,
        }


#: How far from the outline (m) a contact fixed by the scene may lie: it is taken at the outline's
#: nearest contact candidate within this, else at the nearest point of the outline's curve or side.
FIXED_TOLERANCE = 1e-4


def _with_candidate(cand: ContactCandidates, point: NDArray, normal: NDArray, kind: str, radius: float) -> ContactCandidates:
    """The candidates with one more (a single inward normal)."""
    return cand.joined(ContactCandidates(point[None], normal[None], normal[None], np.array([kind]), np.array([radius])))


def _touch(outline: Outline, point: NDArray, out: NDArray) -> tuple[float, float]:
    """ContactPoint.touch of a contact at point whose face presses from direction out (unit, in the
    object's plane): (along, across) from the contact to where the face first touches, (0, 0) where
    the contact reaches as far as any point of the outline (to 1 nm)."""
    reach = outline.support(out) - point
    along = float(reach @ out)
    if along <= 1e-9:
        return 0.0, 0.0
    return along, float(reach @ np.array([-out[1], out[0]]))


def _span(outline: Outline, point: NDArray, out: NDArray) -> tuple[float, float]:
    """ContactPoint.span of an edge contact at point whose face presses from direction out (unit):
    how far the outline's vertices on the face's line (within 1 nm) reach across GB each way."""
    across = np.array([-out[1], out[0]])
    rel = outline.vertices - point
    on = rel[np.abs(rel @ out) <= 1e-9] @ across
    return (max(0.0, -float(on.min())), max(0.0, float(on.max()))) if len(on) else (0.0, 0.0)


def flush(vertices: NDArray, g: NDArray, b: NDArray) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Per pair k, whether G (g[k]) and B (b[k]) lie inside a straight side square to GB, which
    then supports the object across the plane both ways (ContactPoint.span both > 0): the faces
    touching them, the table's and the thumb's, contain the plane's normal, so they touch a side
    along its length only when it is square to GB, and a side ending at the contact holds one way
    only. True where vertices lie on the line through the contact square to GB (within 1 nm) on
    both sides of it. g, b: (K, 2); vertices: (V, 2), metres."""
    u = b - g
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    across = np.stack([-u[:, 1], u[:, 0]], axis=1)

    def inside_side(p: NDArray) -> NDArray[np.bool_]:
        rel = vertices[None] - p[:, None]  # (K, V, 2)
        on = np.abs(np.einsum("kvi,ki->kv", rel, u)) <= 1e-9
        side = np.einsum("kvi,ki->kv", rel, across)
        return (on & (side > 1e-9)).any(axis=1) & (on & (side < -1e-9)).any(axis=1)
    return inside_side(g), inside_side(b)


def curved(radius: NDArray) -> NDArray[np.bool_]:
    """Whether contacts of these radii of curvature (m) roll on a curve, on which A's push beside
    GB restores the object: neither a corner (0) nor a straight side (inf; one square to GB holds
    x-moments by itself, see flush, and one at an angle to the face is not where the face touches)."""
    return (radius > 0) & np.isfinite(radius)


def plane_frame(g: NDArray, b: NDArray, position: ArrayLike, yaw: float) -> NDArray[np.float64]:
    """World frame of the manipulation plane for the object lying at (position, yaw) on the table."""
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s], [s, c]])
    gw = np.asarray(position, dtype=float) + rot @ g
    bw = np.asarray(position, dtype=float) + rot @ b
    x = np.append((bw - gw) / np.linalg.norm(bw - gw), 0.0)
    z = np.array([0.0, 0.0, 1.0])
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2] = x, np.cross(z, x), z
    frame[:3, 3] = [gw[0], gw[1], 0.0]
    return frame


def choose_plane(
    outline: Outline,
    mu_g: float,
    mu_b: float,
    position: ArrayLike = (0.0, 0.0),
    yaw: float = 0.0,
    fixed: tuple[ArrayLike, ArrayLike] | None = None,
    source: str | None = None,
) -> ManipulationPlane:
    """The antipodal pair with the largest friction margin that fits the task, or the user's fixed pair.

    The candidates are the outline's (Outline.candidates) and its double normals with its
    straight sides (Outline.double_normals). Among the pairs that fit, those whose contacts can
    hold x-moments (G or B inside a straight side square to GB, or curved contacts at both: flush,
    curved) come first, then the largest
    margin, then an edge contact at B (the thumb's face flush with a straight side, rather than
    on a point of small curvature that turns with the thumb instead of sliding on it; docs/model.md
    11.7), then the longest.

    Raises InputError when no pair is antipodal (friction too low) or a fixed
    pair breaks Assumption 2 or does not lie on the outline.
    """
    cand = outline.candidates() if fixed is not None else outline.candidates().joined(outline.double_normals())
    phi_g, phi_b = math.atan(mu_g), math.atan(mu_b)
    if fixed is not None:
        idx = []
        for name, p in zip("GB", fixed):
            dist = np.linalg.norm(cand.points - np.asarray(p, dtype=float), axis=1)
            k = int(np.argmin(dist))
            if dist[k] > FIXED_TOLERANCE:  # not at a candidate: the point of the outline's curve or side there
                at = outline.contact_at(p, FIXED_TOLERANCE)
                if at is None:
                    raise InputError(f"contacts.{name}", f"is {dist[k] * 1000:.2f} mm from the outline's nearest "
                                     f"contact candidate and more than {FIXED_TOLERANCE * 1000:.1f} mm from the outline",
                                     source)
                cand = _with_candidate(cand, *at)
                k = len(cand.points) - 1
            idx.append(k)
        i, j = idx
        beta_g, beta_b, n_g, n_b = pair_angles(cand.points, cand.normal_lo, cand.normal_hi, i, j)
        for name, beta, phi in (("G", beta_g, phi_g), ("B", beta_b, phi_b)):
            if beta >= phi:
                raise InputError(f"contacts.{name}", f"Assumption 2 fails: GB makes {math.degrees(beta):.1f} deg with "
                                 f"the boundary normal at {name}, not less than its friction angle "
                                 f"{math.degrees(phi):.1f} deg, so the manipulation plane misses the friction cone", source)
        margin = float(min(phi_g - beta_g, phi_b - beta_b))
    else:
        gi, bi, margins = antipodal_pairs(cand.points, cand.normal_lo, cand.normal_hi, outline.vertices, phi_g, phi_b)
        if not len(gi):
            raise InputError("friction", f"no antipodal pair (G, B) on the outline with friction angles "
                             f"{math.degrees(phi_g):.1f} deg at G and {math.degrees(phi_b):.1f} deg at B: "
                             "friction too low to hold the object between table and thumb", source)
        lengths = np.linalg.norm(cand.points[bi] - cand.points[gi], axis=1)
        edge_g, edge_b = flush(outline.vertices, cand.points[gi], cand.points[bi])
        x_stable = edge_g | edge_b | (curved(cand.radius[gi]) & curved(cand.radius[bi]))  # an edge contact or A's restoring effect
        # rank: x-moment support first, then the friction margin, an edge on the thumb, length
        best = np.lexsort((-lengths, ~edge_b, -np.round(margins, 9), ~x_stable))[0]
        i, j, margin = int(gi[best]), int(bi[best]), float(margins[best])
        beta_g, beta_b, n_g, n_b = pair_angles(cand.points, cand.normal_lo, cand.normal_hi, i, j)
    u = (cand.points[j] - cand.points[i]) / np.linalg.norm(cand.points[j] - cand.points[i])
    contacts = []
    for k, beta, normal, out in ((i, beta_g, n_g, -u), (j, beta_b, n_b, u)):
        kind = str(cand.kind[k])
        contacts.append(ContactPoint(cand.points[k], normal, kind, float(cand.radius[k]), float(beta),
                                     _touch(outline, cand.points[k], out),
                                     _span(outline, cand.points[k], out) if kind == "edge" else (0.0, 0.0)))
    g, b = contacts
    return ManipulationPlane(g, b, margin, float(effective_friction(mu_g, beta_g)), float(effective_friction(mu_b, beta_b)),
                             plane_frame(g.point, b.point, position, yaw), fixed is not None)
