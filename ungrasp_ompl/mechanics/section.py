"""The object's section in the manipulation plane, and where the finger touches it as it rolls.

Object frame: G at the origin, x along GB (B at (1, 0)), z up from GB toward the face the finger
presses; lengths over the object length l, angles in radians. G and B are the ends of the
section's bottom (its corners on the table and on the thumb's face); the finger touches its
*top*, the boundary from B's end back over the object to G's end. The top is parametrised by its
arc length s from B's end (0 <= s <= top_length); at s it has the point P(s), the outward unit
normal N(s) = (-sin phi, cos phi), phi(s) the normal's turn from GB's normal toward G, and the
curvature kappa(s) = dphi/ds (>= 0: the top is convex).

Kinds (Section.kind):

- ``slab``: today's object, a rectangle of thickness t (the top at height t, phi = 0);
- ``semi_ellipse``: a flat bottom GB and the upper half of the ellipse on it, half-axes 1/2
  and t (the reference planner's example 6, a Go stone);
- ``lens``: two circular arcs through G and B, the top one rising t - b above GB and the bottom
  one b below it (biconvex; b = t/2 unless given, b = 0 a plano-convex lens);
- ``rounded_rim``: a slab whose top meets its ends in quarter circles of radius rho (a coin's
  rim; rho = t: a semicircle over each end);
- ``profile``: sampled top points (x, z) from G's end to B's end, smoothed by a parametric cubic
  spline (scipy), above a flat bottom.

The finger's boundary near its tip is its straight face and, for a tip rounded with radius r,
the dome that joins the face to the tip's end (a quarter circle); r = 0 is a sharp corner. Both
are convex, so the finger touches the top where their normals are opposite, and it rolls on it
without slip (a sticking A) when the contact moves by the same arc length on both. Count the
finger's arc sigma_f from the dome's face end, positive over the dome toward the tip, negative
along the face toward the palm; then while A sticks the contact's s and sigma_f grow together,
and

  d = s - sigma_f

stays put: d is the *slide coordinate* of the state (theta, d, psi), which changes only when A
slides. On the dome, sigma_f = r (psi - phi(s)) (the dome's normal at the contact has turned
psi - phi from the face's), so s + r phi(s) = d + r psi; on the face, phi(s) = psi (the face is
tangent to the top there) and sigma_f = s - d <= 0. For a slab (phi = 0) this is
docs/model.md 2.6: the contact lies d_A = d + r psi from B. For a curved top with r = 0 (the
reference planner's digits) the face rolls over the top while the contact lies on it, the
contact moving toward G and along the face toward the tip as psi grows, until it reaches the tip
(s = d); from there the tip's corner stays on that point of the object.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: The section kinds, the default first.
SECTION_KINDS = ("slab", "semi_ellipse", "lens", "rounded_rim", "profile")
#: Intervals of the top's parameter in the tables the queries search (the answers are exact to
#: rounding within an interval: Gauss-Legendre arc lengths and Newton steps).
_INTERVALS = 2048
_GAUSS = np.polynomial.legendre.leggauss(4)
_NODES = (_GAUSS[0] + 1.0) / 2.0  # on [0, 1]
_WEIGHTS = _GAUSS[1] / 2.0


class SectionError(ValueError):
    """A section that cannot be built; the message says why."""


@dataclass(frozen=True)
class Section:
    """The object's section in the manipulation plane, over l (see the module docstring).

    kind: one of SECTION_KINDS. thickness: the greatest height of the top above GB plus, for a
    lens, the bottom's depth below it (over l). bottom: a lens's bottom arc's depth below GB at
    its middle (over l; 0 for the other kinds). points: a profile's top samples (x, z), from G's
    end (x = 0) to B's end (x = 1), over l. smoothing: a profile's spline smoothing (scipy
    splprep's s, over l squared; 0 interpolates the samples). radius: a rounded rim's radius (over
    l; 0 for the other kinds)."""

    kind: str = "slab"
    thickness: float = 0.0
    bottom: float = 0.0
    points: tuple[tuple[float, float], ...] = ()
    smoothing: float = 0.0
    radius: float = 0.0
    _table: dict = field(default=None, init=False, repr=False, compare=False, hash=False)

    def __post_init__(self) -> None:
        if self.kind not in SECTION_KINDS:
            raise SectionError(f"kind must be one of {', '.join(SECTION_KINDS)}, got {self.kind!r}")
        t = float(self.thickness)
        if not (math.isfinite(t) and 0.0 <= t < 1.0):
            raise SectionError(f"thickness must lie in [0, 1) (over the object length), got {t!r}")
        if self.kind in ("semi_ellipse", "lens") and t <= 0.0:
            raise SectionError(f"a {self.kind} needs a thickness > 0")
        if self.kind == "lens" and not 0.0 <= self.bottom < t:
            raise SectionError(f"a lens's bottom depth must lie in [0, thickness {t:g}), got {self.bottom!r}")
        if self.kind != "lens" and self.bottom != 0.0:
            raise SectionError("only a lens has a bottom depth")
        if self.kind == "rounded_rim" and not (0.0 < self.radius <= min(t, 0.5)):
            raise SectionError(f"a rounded rim's radius must lie in (0, thickness {t:g}], got {self.radius!r}")
        if self.kind != "rounded_rim" and self.radius != 0.0:
            raise SectionError("only a rounded rim has a radius")
        object.__setattr__(self, "thickness", t)
        object.__setattr__(self, "bottom", float(self.bottom))
        object.__setattr__(self, "radius", float(self.radius))
        object.__setattr__(self, "points", tuple((float(x), float(z)) for x, z in self.points))
        object.__setattr__(self, "_table", _build(self))

    # -- constructors ---------------------------------------------------------------------------
    @classmethod
    def slab(cls, thickness: float) -> "Section":
        """Today's object: a rectangle of thickness t over GB."""
        return cls("slab", thickness)

    @classmethod
    def semi_ellipse(cls, thickness: float) -> "Section":
        """A flat bottom GB under half an ellipse of half-axes 1/2 (along GB) and thickness."""
        return cls("semi_ellipse", thickness)

    @classmethod
    def lens(cls, thickness: float, bottom: float | None = None) -> "Section":
        """Two circular arcs through G and B, bottom below GB and thickness - bottom above it
        (bottom: thickness / 2 unless given)."""
        return cls("lens", thickness, thickness / 2 if bottom is None else bottom)

    @classmethod
    def rounded_rim(cls, thickness: float, radius: float | None = None) -> "Section":
        """A slab whose top meets its ends in quarter circles of radius (thickness / 2 unless given)."""
        return cls("rounded_rim", thickness, radius=thickness / 2 if radius is None else radius)

    @classmethod
    def profile(cls, points: ArrayLike, smoothing: float = 0.0) -> "Section":
        """A top through (or, with smoothing, near) the samples points (K, 2) of (x, z) from G's
        end (x = 0) to B's end (x = 1) over l, above a flat bottom; its thickness is the spline's
        greatest height."""
        p = np.asarray(points, dtype=float)
        if p.ndim != 2 or p.shape[1] != 2 or len(p) < 4:
            raise SectionError(f"a profile needs at least 4 points [x, z], got shape {p.shape}")
        if not np.all(np.isfinite(p)):
            raise SectionError("a profile point is not finite")
        return cls("profile", 0.0, 0.0, tuple(map(tuple, p)), float(smoothing))

    # -- queries --------------------------------------------------------------------------------
    @property
    def is_slab(self) -> bool:
        """Whether this is today's flat object (the kinematics' closed forms hold exactly)."""
        return self.kind == "slab"

    @property
    def top_length(self) -> float:
        """The top's arc length from B's end to G's end (over l)."""
        return float(self._table["s"][-1])

    @property
    def height(self) -> float:
        """The top's greatest height above GB (over l)."""
        return float(self._table["z_max"])

    @property
    def rim_angles(self) -> tuple[float, float]:
        """How far the bottom rises from GB at G and at B (rad): the object rests on its corner G
        only while theta is at least the first, and on its corner B against the thumb's face only
        while psi is at least the second (0 for a flat bottom)."""
        return self._table["rim"], self._table["rim"]

    @property
    def ends_on_gb(self) -> tuple[bool, bool]:
        """Whether the top starts on GB at G's end and at B's end (else a vertical end face joins
        them: a profile's or a rounded rim's ends above GB)."""
        z = self._table["z_ends"]
        return bool(z[1] <= 1e-12), bool(z[0] <= 1e-12)

    @property
    def end_angles(self) -> tuple[float, float]:
        """The top's normal turn phi at B's end and at G's end (rad)."""
        return float(self._table["phi"][0]), float(self._table["phi"][-1])

    def at(self, s: ArrayLike) -> "TopPoint":
        """The top at arc lengths s from B's end (clipped to [0, top_length]): TopPoint."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.top_length)
        return self._point(self._u_at(s, self._table["s"], lambda u: self._arc(u), self._speed))

    def angle_at(self, phi: ArrayLike) -> NDArray[np.float64]:
        """The arc length s at which the top's normal has turned by phi (the first such s where
        the top has a straight stretch; 0 or top_length beyond the ends' turns)."""
        tb = self._table
        u = self._u_at(np.asarray(phi, dtype=float), tb["phi"], self._phi, self._phi_rate)
        return self._arc(u)

    def polygon(self, samples: int = 64) -> NDArray[np.float64]:
        """The whole section as a counter-clockwise polygon (K, 2) over l: the bottom from G to B
        (a line, or the lens's bottom arc), then the top from B's end to G's end, sampled at
        samples points evenly in its parameter and as many evenly in its normal's turn."""
        lo, hi = self.end_angles
        turns = self._u_at(np.linspace(lo, hi, samples + 1), self._table["phi"], self._phi, self._phi_rate)
        u = np.unique(np.concatenate([np.linspace(0.0, 1.0, samples + 1), turns]))
        top = self._curve(u)[0]
        if self.kind == "lens" and self.bottom > 0.0:  # the bottom arc, from G to B below GB
            centre, rad, a0 = _arc_circle(self.bottom)
            a = np.linspace(a0 - math.pi, -a0, samples + 1)[1:-1]
            bottom = np.column_stack([0.5 + rad * np.cos(a), -centre + rad * np.sin(a)])
            pts = [np.array([[0.0, 0.0]]), bottom, np.array([[1.0, 0.0]]), top]
        else:
            pts = [np.array([[0.0, 0.0], [1.0, 0.0]]), top]
        poly = np.vstack(pts)
        keep = np.ones(len(poly), dtype=bool)  # drop repeated points (the top's ends on G and B)
        keep[1:] = np.linalg.norm(np.diff(poly, axis=0), axis=1) > 1e-12
        poly = poly[keep]
        if np.linalg.norm(poly[-1] - poly[0]) < 1e-12:
            poly = poly[:-1]
        return poly

    # -- the parametrised top -------------------------------------------------------------------
    def _curve(self, u: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """The top's point, first and second derivatives in its parameter u in [0, 1] (B's end to
        G's end), each (..., 2)."""
        return _curve(self, self._table, u)

    def _speed(self, u: NDArray) -> NDArray:
        c1 = self._curve(u)[1]
        return np.hypot(c1[..., 0], c1[..., 1])

    def _arc(self, u: NDArray) -> NDArray:
        """The arc length from B's end to parameter u: the table's to the interval's start plus
        Gauss-Legendre over the rest."""
        tb = self._table
        u = np.asarray(u, dtype=float)
        if tb["uniform"]:  # a parameter proportional to the arc length (lines and circles)
            return u * tb["s"][-1]
        k = np.clip(np.floor(u * _INTERVALS).astype(int), 0, _INTERVALS - 1)
        u0 = k / _INTERVALS
        h = u - u0
        nodes = u0[..., None] + h[..., None] * _NODES
        return tb["s"][k] + h * (self._speed(nodes) @ _WEIGHTS)

    def _phi(self, u: NDArray) -> NDArray:
        c1 = self._curve(u)[1]
        return np.arctan2(-c1[..., 1], -c1[..., 0])

    def _phi_rate(self, u: NDArray) -> NDArray:
        """dphi/du = kappa |c'|."""
        _, c1, c2 = self._curve(u)
        return (c1[..., 0] * c2[..., 1] - c1[..., 1] * c2[..., 0]) / (c1[..., 0] ** 2 + c1[..., 1] ** 2)

    def _u_at(self, value: NDArray, table: NDArray, f, rate) -> NDArray:
        """The parameter u where the increasing function f (tabulated as table at the intervals'
        ends, derivative rate) takes value: the table's interval, then Newton's steps within it
        (linear interpolation where f is flat)."""
        value = np.asarray(value, dtype=float)
        k = np.clip(np.searchsorted(table, value, side="left") - 1, 0, _INTERVALS - 1)
        lo, hi = table[k], table[k + 1]
        span = hi - lo
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = np.where(span > 0, (value - lo) / span, 0.0)
        u0 = k / _INTERVALS
        u = u0 + np.clip(frac, 0.0, 1.0) / _INTERVALS
        u = np.where(value > table[-1], 1.0, np.where(value < table[0], 0.0, u))
        flat = ~(span > 1e-15)
        for _ in range(2):  # from the interval's chord: quadratic convergence to rounding
            with np.errstate(divide="ignore", invalid="ignore"):
                step = (f(u) - value) / rate(u)
            step = np.where(np.isfinite(step) & ~flat, step, 0.0)
            u = np.clip(u - step, u0, u0 + 1.0 / _INTERVALS)
        inside = (value >= table[0]) & (value <= table[-1]) & ~flat
        off = inside & (np.abs(f(u) - value) > 1e-12 * (1.0 + np.abs(value)))
        if np.any(off):  # a kink in the interval (where a rounded rim's arc meets its flat): bisect there
            lo, hi, v = u0[off], u0[off] + 1.0 / _INTERVALS, value[off]
            for _ in range(45):
                mid = 0.5 * (lo + hi)
                below = f(mid) < v
                lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
            u = u.copy()
            u[off] = 0.5 * (lo + hi)
        return np.clip(u, 0.0, 1.0)

    def _point(self, u: NDArray) -> "TopPoint":
        c, c1, c2 = self._curve(u)
        speed = np.hypot(c1[..., 0], c1[..., 1])
        tangent = c1 / speed[..., None]  # toward G
        normal = np.stack([tangent[..., 1], -tangent[..., 0]], axis=-1)
        kappa = (c1[..., 0] * c2[..., 1] - c1[..., 1] * c2[..., 0]) / speed ** 3
        phi = np.arctan2(-tangent[..., 1], -tangent[..., 0])
        return TopPoint(u, self._arc(u), c, normal, phi, kappa)


class TopPoint(NamedTuple):
    """A point of the top: its parameter u, arc length s from B's end, point (..., 2) and outward
    unit normal (..., 2) in the object frame, the normal's turn phi (rad) and the curvature kappa
    (1/l)."""

    u: NDArray[np.float64]
    s: NDArray[np.float64]
    point: NDArray[np.float64]
    normal: NDArray[np.float64]
    phi: NDArray[np.float64]
    kappa: NDArray[np.float64]


def _arc_circle(sagitta: float) -> tuple[float, float, float]:
    """The circle of an arc over the chord [0, 1] rising sagitta above it: its centre's height
    (below the chord), its radius and the angle of the arc's ends from the horizontal seen from
    the centre."""
    rad = (0.25 + sagitta * sagitta) / (2.0 * sagitta)
    centre = sagitta - rad
    return centre, rad, math.atan2(-centre, 0.5)


def _curve(sec: Section, tb: dict, u: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    u = np.asarray(u, dtype=float)
    if sec.kind == "slab":
        one = np.ones_like(u)
        return (np.stack([1.0 - u, sec.thickness * one], axis=-1), np.stack([-one, 0 * one], axis=-1),
                np.stack([0 * one, 0 * one], axis=-1))
    if sec.kind == "semi_ellipse":
        a, b, w = 0.5, sec.thickness, math.pi
        c, s = np.cos(w * u), np.sin(w * u)
        return (np.stack([0.5 + a * c, b * s], axis=-1), np.stack([-a * w * s, b * w * c], axis=-1),
                np.stack([-a * w * w * c, -b * w * w * s], axis=-1))
    if sec.kind == "rounded_rim":  # by arc length: B's quarter circle, the flat, G's quarter circle
        rho, t = sec.radius, sec.thickness
        quarter, flat = math.pi / 2 * rho, 1.0 - 2.0 * rho
        total = 2 * quarter + flat
        s = u * total
        a = np.where(s < quarter, s / rho, np.where(s > quarter + flat, math.pi / 2 + (s - quarter - flat) / rho,
                                                    math.pi / 2))
        cx = np.where(s < quarter, 1.0 - rho, np.where(s > quarter + flat, rho, 1.0 - rho - (s - quarter)))
        on_arc = (s < quarter) | (s > quarter + flat)
        ca, sa = np.cos(a), np.sin(a)
        k = np.where(on_arc, 1.0, 0.0)
        point = np.stack([np.where(on_arc, cx + rho * ca, cx), t - rho + rho * sa], axis=-1)
        first = np.stack([-sa, ca], axis=-1) * total
        second = np.stack([-ca, -sa], axis=-1) * (k / rho * total * total)[..., None]
        return point, first, second
    if sec.kind == "lens":
        centre, rad, a0 = tb["circle"]
        w = math.pi - 2.0 * a0
        ang = a0 + w * u
        c, s = np.cos(ang), np.sin(ang)
        return (np.stack([0.5 + rad * c, centre + rad * s], axis=-1), np.stack([-rad * w * s, rad * w * c], axis=-1),
                np.stack([-rad * w * w * c, -rad * w * w * s], axis=-1))
    from scipy.interpolate import splev  # a profile: scipy, imported on first use

    tck = tb["tck"]
    flat = np.ravel(u) * tb["u_end"]
    out = []
    for der, scale in ((0, 1.0), (1, tb["u_end"]), (2, tb["u_end"] ** 2)):
        x, z = splev(flat, tck, der=der)
        out.append(np.stack([x, z], axis=-1).reshape(u.shape + (2,)) * scale)
    return tuple(out)


def _build(sec: Section) -> dict:
    """The tables the queries search: the arc length s and the normal's turn phi at the ends of
    _INTERVALS even intervals of the top's parameter, and the kind's own constants."""
    tb: dict = {"rim": 0.0}
    if sec.kind == "lens":
        top = sec.thickness - sec.bottom
        tb["circle"] = _arc_circle(top)
        if sec.bottom > 0.0:
            _, rad, a0 = _arc_circle(sec.bottom)
            tb["rim"] = math.pi / 2 - a0  # the bottom arc's tangent at G and B, from GB
    elif sec.kind == "profile":
        _profile_spline(sec, tb)
    u = np.linspace(0.0, 1.0, _INTERVALS + 1)
    nodes = u[:-1, None] + np.diff(u)[:, None] * _NODES
    c1 = _curve(sec, tb, nodes)[1]
    pieces = np.hypot(c1[..., 0], c1[..., 1]) @ _WEIGHTS / _INTERVALS
    tb["s"] = np.concatenate([[0.0], np.cumsum(pieces)])
    tb["uniform"] = sec.kind in ("slab", "lens", "rounded_rim")  # their parameter runs at a constant speed
    if tb["uniform"]:
        tb["s"] = u_grid_length(tb["s"][-1])
    c, c1, c2 = _curve(sec, tb, u)
    tb["phi"] = np.arctan2(-c1[..., 1], -c1[..., 0])
    if sec.kind == "slab":
        tb["phi"] = np.zeros_like(u)
    tb["z_max"] = float(c[:, 1].max())
    tb["z_ends"] = (float(c[0, 1]), float(c[-1, 1]))  # at B's end and at G's end
    if sec.kind == "profile":
        kappa = (c1[:, 0] * c2[:, 1] - c1[:, 1] * c2[:, 0]) / np.hypot(c1[:, 0], c1[:, 1]) ** 3
        if np.any(kappa < -1e-6):
            worst = int(np.argmin(kappa))
            raise SectionError(f"a profile's top must be convex (the finger rolls on it): its spline bends the "
                               f"other way near x = {c[worst, 0]:.3g} (curvature {kappa[worst]:.3g} over l)")
        if np.any(np.diff(tb["phi"]) < -1e-9):
            raise SectionError("a profile's top must turn one way from B's end to G's end")
        if c[:, 1].min() < -1e-9:
            raise SectionError("a profile's top must lie above GB (z >= 0)")
        object.__setattr__(sec, "thickness", tb["z_max"])
    return tb


def u_grid_length(total: float) -> NDArray[np.float64]:
    """The arc lengths at the tables' parameter grid for a top of that length run at constant speed."""
    return np.linspace(0.0, 1.0, _INTERVALS + 1) * total


def _profile_spline(sec: Section, tb: dict) -> None:
    """A profile's parametric cubic spline, from B's end to G's end (scipy splprep, chord-length
    parameter), into tb."""
    from scipy.interpolate import splprep

    p = np.asarray(sec.points, dtype=float)
    if abs(p[0, 0]) > 1e-9 or abs(p[-1, 0] - 1.0) > 1e-9:
        raise SectionError(f"a profile must run from G's end (x = 0) to B's end (x = the object length), got x "
                           f"from {p[0, 0]:.4g} to {p[-1, 0]:.4g} over l")
    if np.any(np.diff(p[:, 0]) <= 0.0):
        raise SectionError("a profile's x must grow from G's end to B's end")
    if np.any(p[:, 1] < 0.0):
        raise SectionError("a profile's z must be >= 0 (the top above GB)")
    p = p[::-1]  # from B's end to G's end
    step = np.linalg.norm(np.diff(p, axis=0), axis=1)
    uu = np.concatenate([[0.0], np.cumsum(step)])
    try:
        tck, _ = splprep([p[:, 0], p[:, 1]], u=uu / uu[-1], k=3, s=sec.smoothing * len(p), quiet=2)
    except Exception as exc:  # scipy's own message for a fit it cannot make
        raise SectionError(f"a profile's spline cannot be fitted: {exc}") from None
    tb["tck"], tb["u_end"] = tck, 1.0


class FingerContact(NamedTuple):
    """Where the finger touches the top in a state (object frame, over l): the top's point (see
    TopPoint) and the finger's own arc sigma_f from its dome's face end to the contact (positive
    over the dome, negative along the face), the dome's turn beta = psi - phi at the contact
    (0 on the face) and whether the contact lies on the face."""

    top: TopPoint
    sigma_f: NDArray[np.float64]
    beta: NDArray[np.float64]
    on_face: NDArray[np.bool_]


def finger_contact(section: Section, d: ArrayLike, psi: ArrayLike, tip_radius: float = 0.0) -> FingerContact:
    """Where a finger whose tip is rounded with radius r (over l; 0 a sharp corner) touches the
    section's top in the states of slide coordinate d and thumb angle psi (they broadcast): on
    the face where phi(s) = psi when d >= that s, else on the dome (or the corner) where
    s + r phi(s) = d + r psi (see the module docstring)."""
    d, psi = np.broadcast_arrays(np.asarray(d, dtype=float), np.asarray(psi, dtype=float))
    r = float(tip_radius)
    tb = section._table
    s_face = section.angle_at(psi)
    on_face = d >= s_face
    if r > 0.0:
        key = tb.get("h_r")
        if key is None or key[0] != r:
            tb["h_r"] = (r, tb["s"] + r * tb["phi"])
        h_tab = tb["h_r"][1]
        u = section._u_at(d + r * psi, h_tab, lambda x: section._arc(x) + r * section._phi(x),
                          lambda x: section._speed(x) + r * section._phi_rate(x))
    else:
        u = section._u_at(d, tb["s"], section._arc, section._speed)
    u_face = section._u_at(psi, tb["phi"], section._phi, section._phi_rate)
    top = section._point(np.where(on_face, u_face, u))
    beta = np.where(on_face, 0.0, psi - top.phi)
    sigma_f = np.where(on_face, top.s - d, r * beta)
    return FingerContact(top, sigma_f, beta, on_face)
