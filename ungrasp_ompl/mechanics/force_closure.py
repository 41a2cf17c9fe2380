"""Planar force closure of the three contacts G, A, B (docs/model.md, section 4).

A unit contact force f at point p gives the wrench (p_x f_z - p_z f_x, f_x, f_z),
moments about G, lengths over l. A sticking contact contributes its two
friction-cone edges; a sliding contact pushes along the one edge that opposes
the sliding (``strict``), or anywhere between that edge and the normal
(``relaxed``, the reference planner's model).

Force closure means the wrenches positively span R^3. With at most six
wrenches there is a closed form: the span fails exactly when some plane
through the origin spanned by two of the wrenches has all the others on one
closed side (such a plane carries a facet of the wrench cone). So for every
pair (w_i, w_j) with n = w_i x w_j != 0 the other wrenches must reach both
open sides of n. Everything is vectorised over states.

A friction known only within a range (:attr:`Friction.uncertainty`, docs/model.md 4.7) is checked
over the whole range: force_closure and force_closure_margin hold for it where they hold with every
contact at the range's low end and, under the strict model, also with the sliding contacts at its
high end (the sticking ones still low).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from itertools import combinations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .section import Section, finger_contact


class SlidingModel(StrEnum):
    """Which friction a sliding contact may exert (docs/model.md, section 4.3). A member is its
    name as a string, so files and comparisons with the name keep working."""

    #: A sliding contact may apply anything between its friction cone's edge and its normal (the default).
    RELAXED = "relaxed"
    #: A sliding contact applies one wrench, on its friction cone's edge.
    STRICT = "strict"

    def describe(self) -> str:
        """The model in words for a person (files keep the name)."""
        return ("a sliding contact may push anywhere between its friction cone's edge and its normal"
                if self is SlidingModel.RELAXED else "a sliding contact pushes along its friction cone's edge only")


SLIDING_MODELS = tuple(m.value for m in SlidingModel)

@dataclass(frozen=True)
class SectionContact:
    """Where the finger touches a curved section, for the force analysis: the section (over l)
    and the finger tip's radius r (over l; 0 a sharp corner or a flat tip). A then lies on the
    section's top where the finger rolls on it (mechanics.section.finger_contact) and pushes
    along the top's inward normal there, its friction along the top's tangent."""

    section: Section
    tip_radius: float = 0.0

    def geometry(self, theta: ArrayLike, d: ArrayLike, psi: ArrayLike) -> tuple[NDArray, ...]:
        """A's point (p_x, p_z), its normal acting on the object (n_x, n_z) and its tangent toward
        B's end (t_x, t_z) in the plane, each at the broadcast shape of theta, d and psi."""
        theta = np.asarray(theta, dtype=float)
        c = finger_contact(self.section, d, psi, self.tip_radius)
        ct, st = np.cos(theta), np.sin(theta)
        (px, pz), (nx, nz) = np.moveaxis(c.top.point, -1, 0), np.moveaxis(c.top.normal, -1, 0)
        wx, wz = ct * nx - st * nz, st * nx + ct * nz  # the outward normal in the plane
        return ct * px - st * pz, st * px + ct * pz, -wx, -wz, wz, -wx


#: The reference planner's friction (angles 11, 17, 17 deg at G, A, B), the default mu.
REFERENCE_MU = (float(np.tan(np.radians(11))), float(np.tan(np.radians(17))), float(np.tan(np.radians(17))))



@dataclass(frozen=True)
class Friction:
    """The friction of the plane's three contacts and how a sliding contact may use it: the one
    value every force-closure and margin function takes. With an uncertainty u > 0 the coefficients
    are known only within a range, from ``low`` to ``high`` (the contacts' coefficients times 1 - u
    and 1 + u, reduced to the plane as mu is), and force closure must hold over all of it
    (docs/model.md 4.7)."""

    mu: tuple[float, float, float] = REFERENCE_MU
    """Coefficients at G, A, B (dimensionless; the manipulation plane's, docs/model.md 5.2)."""
    model: SlidingModel = SlidingModel.RELAXED
    """Which friction a sliding contact may apply (docs/model.md, section 4.3)."""
    uncertainty: float = 0.0
    """How far the true coefficients may lie from the contacts' nominal ones, as a fraction of them either way (0 <= u < 1; 0: known exactly)."""
    low: tuple[float, float, float] | None = None
    """Coefficients at G, A, B at the range's low end (the plane's, from the contacts' times 1 - u); None: mu times 1 - u."""
    high: tuple[float, float, float] | None = None
    """Coefficients at G, A, B at the range's high end (the plane's, from the contacts' times 1 + u); None: mu times 1 + u."""
    contact_a: SectionContact | None = None
    """Where the finger touches a curved section (its point and normal there); None: on the segment, (1 - d) u from G, its normal square to GB."""

    def __post_init__(self) -> None:
        if self.model not in SLIDING_MODELS:
            raise ValueError(f"sliding model must be one of {SLIDING_MODELS}, not {self.model!r}")
        object.__setattr__(self, "model", SlidingModel(self.model))
        object.__setattr__(self, "mu", tuple(float(m) for m in self.mu))
        u = self.uncertainty
        if isinstance(u, bool) or not isinstance(u, (int, float)) or not 0.0 <= u < 1.0:
            raise ValueError(f"friction uncertainty must be a fraction in [0, 1), not {u!r}")
        object.__setattr__(self, "uncertainty", float(u))
        for name, factor in (("low", 1.0 - u), ("high", 1.0 + u)):
            given = getattr(self, name)
            end = tuple(m * factor for m in self.mu) if given is None or u == 0.0 else tuple(float(m) for m in given)
            object.__setattr__(self, name, end)
        if u > 0.0 and not all(lo <= m <= hi for lo, m, hi in zip(self.low, self.mu, self.high)):
            raise ValueError(f"friction range must hold mu: low {self.low}, mu {self.mu}, high {self.high}")

    @property
    def secure_over(self) -> tuple[float, float]:
        """The range as factors of the contacts' nominal coefficients: (1 - u, 1 + u)."""
        return 1.0 - self.uncertainty, 1.0 + self.uncertainty

    def with_mu(self, mu: tuple[float, float, float]) -> "Friction":
        """The same sliding model (and contact geometry at A) with other coefficients at G, A, B, known exactly."""
        return Friction(mu, self.model, contact_a=self.contact_a)

    def ends(self, a_slides: bool, b_slides: bool) -> tuple["Friction", ...]:
        """The exactly known frictions at which force closure decides the range for a contact mode
        in which A and B slide or stick as given: every contact at the low end; under the strict
        model with a sliding contact, also the sliding contacts at the high end and the sticking
        ones at the low end. (A relaxed sliding contact offers the arc from its normal to its edge,
        which only grows with mu, so the low end's wrench cone lies inside the high end's and the
        low end decides alone; a strict one offers the edge alone, which turns with mu.)"""
        out = (Friction(self.low, self.model, contact_a=self.contact_a),)
        if self.model is SlidingModel.STRICT and (a_slides or b_slides):
            out += (Friction((self.low[0], self.high[1] if a_slides else self.low[1],
                              self.high[2] if b_slides else self.low[2]), self.model, contact_a=self.contact_a),)
        return out


#: The reference planner's friction with relaxed sliding: the default of every function below.
REFERENCE_FRICTION = Friction()

#: Force closure requires a margin above this (dimensionless, see below).
FC_TOLERANCE = 1e-9

_PAIRS = list(combinations(range(6), 2))
_CHUNK = 8192
#: Up to this many states, force_closure takes every triple product at once (_spans_stacked);
#: above it, per product at the shapes of what it depends on (_spans).
STACKED_STATES = 256


def cone_edges(normal: ArrayLike, tangent: ArrayLike, mu: float) -> tuple[NDArray, NDArray]:
    """The two edges of a planar friction cone, unit vectors (..., 2).

    The normal rotated toward +tangent and toward -tangent by atan(mu).
    """
    n = np.asarray(normal, dtype=float)
    t = np.asarray(tangent, dtype=float)
    c = 1.0 / np.sqrt(1.0 + mu * mu)
    s = mu * c
    return n * c + t * s, n * c - t * s


def _slots(theta, d, psi, a_sign, b_sign, friction: Friction):
    """Wrenches of unit forces in the six slots and the masks of the slots that exist: lists of
    (m, f_x, f_z) and of bools, each array at its own broadcast shape (G's are scalars, A's follow
    theta and d, B's theta and psi, unless the signs vary more), so that a lattice given as three
    orthogonal axes costs its axes here, not its states."""
    mu, relaxed = friction.mu, friction.model is SlidingModel.RELAXED
    theta, d, psi, a_sign, b_sign = (np.asarray(x, dtype=float) for x in (theta, d, psi, a_sign, b_sign))
    ct, st = np.cos(theta), np.sin(theta)
    cb, sb = np.cos(theta + psi), np.sin(theta + psi)
    slots, masks = [], []
    # G: fixed at the origin, never slides; normal (0, 1), tangent (1, 0).
    c, s = 1.0 / np.sqrt(1.0 + mu[0] ** 2), mu[0] / np.sqrt(1.0 + mu[0] ** 2)
    for sign in (1.0, -1.0):
        slots.append((np.float64(0.0), np.float64(sign * s), np.float64(c)))
        masks.append(np.True_)
    # A at (1 - d) u: normal (sin t, -cos t), tangent u; friction along -sign(dd) u. On a curved
    # section (friction.contact_a), where the finger touches its top: the top's inward normal and
    # its tangent toward B's end; friction along -sign(dd) times that tangent.
    # B at u: normal n_B = (-sin b, cos b), tangent e = -(cos b, sin b); friction along sign(ds_B) e.
    a_geometry = ((1.0 - d) * ct, (1.0 - d) * st, st, -ct, ct, st) if friction.contact_a is None else \
        friction.contact_a.geometry(theta, d, psi)
    contacts = (
        (*a_geometry, -a_sign, a_sign, mu[1]),
        (ct, st, -sb, cb, -cb, -sb, b_sign, b_sign, mu[2]),
    )
    for px, pz, nx, nz, tx, tz, fric, sliding_sign, m in contacts:
        c, s = 1.0 / np.sqrt(1.0 + m * m), m / np.sqrt(1.0 + m * m)
        stick = sliding_sign == 0
        # first slot: the + edge when sticking, else the edge along the friction direction
        tau = np.where(stick, 1.0, fric)
        f1 = (nx * c + tau * tx * s, nz * c + tau * tz * s)
        # second slot: the - edge when sticking, else the normal (relaxed) or nothing (strict)
        cn = np.where(stick, c, 1.0)
        ctn = np.where(stick, -s, 0.0)
        f2 = (nx * cn + ctn * tx, nz * cn + ctn * tz)
        for fx, fz in (f1, f2):
            slots.append((px * fz - pz * fx, fx, fz))
        masks.append(np.True_)
        masks.append(stick | relaxed)
    return slots, masks


def _unit(slots: list, masks: list) -> list[tuple[NDArray, NDArray, NDArray]]:
    """The slots' wrenches scaled to unit length (zero where a slot does not exist), each at its
    own shape."""
    out = []
    for (m, fx, fz), mask in zip(slots, masks):
        inv = np.where(mask, 1.0 / np.sqrt(m * m + fx * fx + fz * fz), 0.0)
        out.append((m * inv, fx * inv, fz * inv))
    return out


def contact_wrenches(
    theta: ArrayLike,
    d: ArrayLike,
    psi: ArrayLike,
    a_sign: ArrayLike,
    b_sign: ArrayLike,
    friction: Friction = REFERENCE_FRICTION,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Contact wrenches of G, A, B, shape (N, 6, 3), and which of the 6 slots exist.

    Slots: G edge +, G edge -, A, A, B, B. A sticking contact fills its two
    slots with its cone edges; a sliding one fills the first with the edge
    opposing the sliding and the second with its normal (relaxed) or nothing
    (strict). Each wrench is (moment about G, f_x, f_z) of a unit force, for
    friction's coefficients mu (the nominal ones of a friction known within a range).
    a_sign, b_sign as in
    :func:`~ungrasp_ompl.mechanics.contact.sliding_signs`.
    """
    slots, masks = _flat(_slots(theta, d, psi, a_sign, b_sign, friction), theta, d, psi, a_sign, b_sign)
    w = np.stack([np.stack(sl, axis=-1) for sl in slots], axis=1)
    return w, np.stack(masks, axis=1)


def _flat(slots_masks: tuple[list, list], *inputs: ArrayLike) -> tuple[list, list]:
    """The slots and masks of _slots broadcast to the inputs' common shape (at least 1-d) and
    flattened to (N,)."""
    slots, masks = slots_masks
    shape = np.broadcast_shapes(*(np.shape(np.atleast_1d(x)) for x in inputs))

    def flat(x):
        return np.ravel(np.broadcast_to(x, shape))

    return [tuple(flat(c) for c in sl) for sl in slots], [flat(m) for m in masks]


def force_closure_margin(
    theta: ArrayLike,
    d: ArrayLike,
    psi: ArrayLike,
    a_sign: ArrayLike = 0,
    b_sign: ArrayLike = 0,
    friction: Friction = REFERENCE_FRICTION,
) -> NDArray[np.float64]:
    """Force-closure margin of each state in the given contact mode, shape (N,).

    For every pair of wrenches spanning a plane, the smaller of how far the
    other (unit) wrenches reach to either side of it (sine of an angle); the
    margin is the smallest of these over pairs. Positive iff the wrenches
    positively span R^3, shrinking to zero as the state nears the loss of
    force closure; exactly zero without force closure. States with fewer than
    two independent wrenches get -1. For a friction known within a range, the
    smallest over the frictions that decide it (Friction.ends).
    """
    return over_range(_force_closure_margin_at, theta, d, psi, a_sign, b_sign, friction, np.minimum)


def _force_closure_margin_at(theta, d, psi, a_sign, b_sign, friction: Friction) -> NDArray[np.float64]:
    """force_closure_margin for friction's coefficients mu alone."""
    unit = _unit(*_flat(_slots(theta, d, psi, a_sign, b_sign, friction), theta, d, psi, a_sign, b_sign))
    n_state = unit[0][0].shape[0]
    comp = np.empty((6, 3, n_state))
    for k, w in enumerate(unit):
        comp[k, 0], comp[k, 1], comp[k, 2] = w
    out = np.empty(n_state)
    for lo in range(0, n_state, _CHUNK):  # chunks that stay in cache
        out[lo : lo + _CHUNK] = _pair_margin(comp[:, :, lo : lo + _CHUNK])
    return out


def _pair_margin(comp: NDArray) -> NDArray:
    """The margin of force_closure_margin for unit wrench components (6, 3, n)."""
    n_state = comp.shape[-1]
    margin = np.full(n_state, np.inf)
    any_live = np.zeros(n_state, dtype=bool)
    hi, lo, dot = np.empty(n_state), np.empty(n_state), np.empty(n_state)
    for i, j in _PAIRS:
        a, b = comp[i], comp[j]
        n0 = a[1] * b[2] - a[2] * b[1]
        n1 = a[2] * b[0] - a[0] * b[2]
        n2 = a[0] * b[1] - a[1] * b[0]
        norm = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        live = norm > 1e-9
        hi.fill(0.0)
        lo.fill(0.0)
        for k in range(6):
            if k != i and k != j:
                c = comp[k]
                np.multiply(n0, c[0], out=dot)
                dot += n1 * c[1]
                dot += n2 * c[2]
                np.maximum(hi, dot, out=hi)
                np.minimum(lo, dot, out=lo)
        reach = np.minimum(hi, -lo) / np.where(live, norm, 1.0)
        margin = np.where(live, np.minimum(margin, reach), margin)
        any_live |= live
    return np.where(any_live, margin, -1.0)


def force_closure(
    theta: ArrayLike,
    d: ArrayLike,
    psi: ArrayLike,
    a_sign: ArrayLike = 0,
    b_sign: ArrayLike = 0,
    friction: Friction = REFERENCE_FRICTION,
) -> NDArray[np.bool_]:
    """True where the contacts are in force closure in the given contact mode: where
    force_closure_margin exceeds FC_TOLERANCE. The arguments broadcast together; the result has
    their common shape (at least 1-d).

    The same test without the margin's value. Every triple product det(w_i, w_j, w_k) of the unit
    wrenches is computed once, from the cross product of lower dimension, so that every array
    keeps the shape of what it depends on: a lattice given as three orthogonal axes (theta
    (n0, 1, 1), d (1, n1, 1), psi (1, 1, n2)) costs full-size work only where A's and B's wrenches
    meet. Where every triple product is farther than twice FC_TOLERANCE from 0, every pair spans a
    plane (|w_i x w_j| >= |det(w_i, w_j, w_k)|) and the margin's test for a pair (some wrench on
    each open side of its plane, beyond FC_TOLERANCE |w_i x w_j| <= FC_TOLERANCE) reads the
    products' signs; the few other states (contacts aligned to within about 1e-9) are decided
    by force_closure_margin itself.

    For a friction known within a range (Friction.uncertainty > 0), true where the test holds at
    every friction that decides the range (Friction.ends); with uncertainty 0, one test at mu.
    """
    return over_range(_force_closure_at, theta, d, psi, a_sign, b_sign, friction, np.logical_and)


def _force_closure_at(theta, d, psi, a_sign, b_sign, friction: Friction) -> NDArray[np.bool_]:
    """force_closure for friction's coefficients mu alone."""
    args = np.broadcast_arrays(*(np.atleast_1d(np.asarray(x, dtype=float)) for x in (theta, d, psi, a_sign, b_sign)))
    slots, masks = _slots(theta, d, psi, a_sign, b_sign, friction)
    unit = [w for w, m in zip(_unit(slots, masks), masks) if np.any(m)]  # an absent slot spans nothing
    shape = args[0].shape
    ok, unsure = (_spans_stacked if math.prod(shape) <= STACKED_STATES else _spans)(unit, shape)
    if unsure.any():
        ok[unsure] = _force_closure_margin_at(*(x[unsure] for x in args), friction) > FC_TOLERANCE
    return ok


def over_range(check: Callable[..., NDArray], theta: ArrayLike, d: ArrayLike, psi: ArrayLike, a_sign: ArrayLike,
               b_sign: ArrayLike, friction: Friction, worst: Callable[[NDArray, NDArray], NDArray]) -> NDArray:
    """A per-state test or margin over friction's range: check (a function of theta, d, psi,
    a_sign, b_sign and an exactly known Friction, whose result has the states' common shape or is
    that flattened) at mu when the friction is known exactly, else the worst (np.logical_and,
    np.minimum) of its values at the frictions that decide the range in each state's contact mode
    (Friction.ends). Where every state has the same sliding contacts (a lattice's mode), each
    friction is checked on the arguments as given, so their broadcast shapes are kept."""
    if friction.uncertainty == 0.0:
        return check(theta, d, psi, a_sign, b_sign, friction)
    low = check(theta, d, psi, a_sign, b_sign, friction.ends(False, False)[0])
    modes = [(a, b) for a, b in ((True, False), (False, True), (True, True)) if len(friction.ends(a, b)) > 1]
    if not modes:  # relaxed sliding: the low end decides alone
        return low
    args = [np.atleast_1d(np.asarray(x, dtype=float)) for x in (theta, d, psi, a_sign, b_sign)]
    shape = np.broadcast_shapes(*(x.shape for x in args))
    out = low.reshape(shape).copy()
    a_slides, b_slides = np.broadcast_arrays(args[3] != 0, args[4] != 0, np.empty(shape))[:2]
    for a, b in modes:
        sel = (a_slides == a) & (b_slides == b)
        if not sel.any():
            continue
        high = friction.ends(a, b)[1]
        if sel.all():
            out = worst(out, check(theta, d, psi, a_sign, b_sign, high).reshape(shape))
        else:
            out[sel] = worst(out[sel], check(*(np.broadcast_to(x, shape)[sel] for x in args), high))
    return out.reshape(low.shape)


def _spans(unit: list[tuple[NDArray, NDArray, NDArray]], shape: tuple[int, ...]
           ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """force_closure's test on the signs of the triple products of unit wrenches given as
    broadcastable components (m, f_x, f_z): the answer, and where a product is too near 0 for
    its sign to decide (within twice FC_TOLERANCE). Each product is taken through the cross
    product of the two wrenches that vary least."""
    n = len(unit)
    shapes = [np.broadcast_shapes(*(np.shape(c) for c in w)) for w in unit]
    size: dict[tuple[int, int], int] = {}
    cross: dict[tuple[int, int], tuple] = {}

    def pair_size(pair: tuple[int, int]) -> int:
        if pair not in size:
            size[pair] = math.prod(np.broadcast_shapes(shapes[pair[0]], shapes[pair[1]]))
        return size[pair]

    positive, negative = {}, {}
    decided = np.ones(shape, dtype=bool)  # every product farther than the band from 0
    band = 2.0 * FC_TOLERANCE
    for i, j, k in combinations(range(n), 3):  # det(w_i, w_j, w_k) = (w_i x w_j) . w_k = -(w_i x w_k) . w_j = ...
        options = (((i, j), k, False), ((i, k), j, True), ((j, k), i, False))
        (a, b), other, odd = min(options, key=lambda o: pair_size(o[0]))
        if (a, b) not in cross:
            u, v = unit[a], unit[b]
            cross[a, b] = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
        v = _dot(cross[a, b], unit[other])
        above, below = v > band, v < -band  # neither: too near 0 to decide
        positive[i, j, k], negative[i, j, k] = (below, above) if odd else (above, below)
        decided &= above | below
    ok = np.ones(shape, dtype=bool)
    for others in _pair_triples(n):
        pos = neg = False
        for key, odd in others:
            pos = pos | (negative[key] if odd else positive[key])
            neg = neg | (positive[key] if odd else negative[key])
        ok &= pos & neg
    return ok, ~decided


def _dot(c: tuple, w: tuple) -> NDArray[np.float64]:
    """c . w for vectors given as broadcastable components (x, y, z), at their common shape. Where
    one varies along the lattice's second axis and the other along its third (the products of
    A's and B's wrenches), the full-size result is one batched 3-term matrix product per theta
    instead of five full-size array operations."""
    sc, sw = (np.broadcast_shapes(*(np.shape(x) for x in v)) for v in (c, w))
    if len(sc) == len(sw) == 3 and sc[1] == sw[2] == 1 and sc[2] > 1 and sw[1] > 1:
        c, w, sc, sw = w, c, sw, sc
    if len(sc) == len(sw) == 3 and sc[2] == sw[1] == 1 and sc[1] > 1 and sw[2] > 1:
        left = np.stack(np.broadcast_arrays(*c), axis=-1)[:, :, 0, :]  # (n0 or 1, n1, 3)
        right = np.stack(np.broadcast_arrays(*w), axis=1)[:, :, 0, :]  # (n0 or 1, 3, n2)
        return np.matmul(left, right)
    return c[0] * w[0] + c[1] * w[1] + c[2] * w[2]


def _spans_stacked(unit: list[tuple[NDArray, NDArray, NDArray]], shape: tuple[int, ...]
                   ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """_spans for a few states: the wrenches stacked at the states' shape and every triple product
    taken at once, so that a call costs a dozen array operations instead of some three hundred
    (a leg's or a tolerance check's handful of states pays numpy's per-operation overhead, not its
    arithmetic)."""
    n = len(unit)
    w = np.empty((n, 3, *shape))
    for k, components in enumerate(unit):
        for c in range(3):
            w[k, c] = components[c]
    i, j, k, pairs, odd = _stacked_index(n)
    a, b, o = w[i], w[j], w[k]
    det = ((a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]) * o[:, 0] + (a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]) * o[:, 1]
           + (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]) * o[:, 2])  # (triples, *shape), sorted triples
    unsure = np.any(np.abs(det) <= 2.0 * FC_TOLERANCE, axis=0)
    flip = odd.reshape(odd.shape + (1,) * len(shape))
    above, below = det[pairs] > 0.0, det[pairs] < 0.0  # (pairs, others, *shape)
    pos, neg = np.where(flip, below, above), np.where(flip, above, below)
    return np.all(pos.any(axis=1) & neg.any(axis=1), axis=0), unsure


@functools.cache
def _stacked_index(n: int) -> tuple[NDArray[np.int_], ...]:
    """_spans_stacked's tables for n wrenches: the sorted triples (i, j, k) as three index arrays,
    and for each pair the indices of its triples and whether each is an odd permutation of the
    pair and its third wrench (as _pair_triples)."""
    triples = list(combinations(range(n), 3))
    where = {t: m for m, t in enumerate(triples)}
    table = _pair_triples(n)
    pairs = np.array([[where[key] for key, _ in others] for others in table], dtype=np.intp)
    odd = np.array([[flag for _, flag in others] for others in table], dtype=bool)
    i, j, k = (np.array(x, dtype=np.intp) for x in zip(*triples))
    return i, j, k, pairs, odd


@functools.cache
def _pair_triples(n: int) -> tuple[tuple[tuple[tuple[int, int, int], bool], ...], ...]:
    """For each pair (i, j) of n wrenches, every other wrench k as its sorted triple and whether
    (i, j, k) is an odd permutation of it (i < k < j): the triple products _spans reads per pair."""
    return tuple(tuple((tuple(sorted((i, j, k))), i < k < j) for k in range(n) if k != i and k != j)
                 for i, j in combinations(range(n), 2))
