"""How far a state is from losing its grip: the friction margin and the kinematic margins.

Friction margin (radians; printed in degrees). Every friction cone has the half-angle
phi_X = atan(mu_X) at X in {G, A, B}. Shrink every cone by the same angle delta (phi_X - delta;
a negative delta grows them) and keep the contact mode: a sticking contact keeps both edges of
its shrunk cone, a sliding one the edge opposing its sliding (and, relaxed, the normal), exactly
as :mod:`~ungrasp_ompl.mechanics.force_closure` builds its wrenches. The *friction margin* is
the largest angle delta* by which every cone can shrink with force closure still holding all the
way (force closure holds for every delta in [0, delta*)); where force closure fails now, it is
minus the least growth that gives force closure (delta* < 0: closure just below delta*, none in
(delta*, 0]). It is positive exactly where
:func:`~ungrasp_ompl.mechanics.force_closure.force_closure` holds, 0 on the boundary, negative
outside. It is capped at min(phi_X) (a cone cannot shrink past its axis) and is -inf where even
cones grown until the widest has the half-angle MAX_CONE_HALF_ANGLE = 89 deg
(delta = max(phi_X) - 89 deg) give no force closure. With sticking contacts and relaxed sliding
the force sets only grow with the cones, so force closure holds below delta* and fails above it;
a strict sliding contact's single edge moves instead, and force closure can come and go along
delta (the margin is then the first change, going out from delta = 0).

Closed form of the events. Along delta a cone edge turns toward its normal at unit rate, so each
contact wrench is w(delta) = cos(delta) W + sin(delta) V with W, V fixed (a relaxed sliding
contact's normal wrench is scaled by cos(delta) > 0, which changes no sign). Force closure can
only change where three wrenches become coplanar (a facet of the wrench cone appears, see
force_closure.py), i.e. at a root of det(w_i, w_j, w_k) = cos^3(delta) P(tan delta) with P a
cubic whose coefficients are triple products of the W and V. The roots of the 20 cubics in the
window (0, delta_max] or [delta_min, 0), and their critical points (which catch tangencies), are
the candidate thresholds, each polished to machine precision by safeguarded Newton steps on its
monotone piece. delta* is the first candidate at which force_closure.py's own test changes:
found by bisection over the sorted candidates where force closure is monotone (about 7
vectorised force-closure evaluations), by a scan outward from 0 otherwise. delta* is thus exact
up to rounding, a root of the force-closure margin itself rather than the point where it falls
below force_closure.py's tolerance 1e-9 (which plain bisection on delta finds, about 1e-9 rad
earlier: the tests' bisection oracle, the reference).

Relation to :func:`~ungrasp_ompl.mechanics.force_closure.force_closure_margin`: that margin is
dimensionless (the sine of how far the wrenches reach past the nearest facet plane of their
cone) and is what force closure is tested with; this one has a unit and a physical reading
(how much friction the grasp can lose), and it is a root of that margin along delta: the
wrenches here come from :func:`~ungrasp_ompl.mechanics.force_closure.contact_wrenches` and force
closure is decided by its own test, so the two never disagree on the sign.

Kinematic margins (metres, or over l with length 1): how far B sits from the thumb's tip (beyond
``thumb_tip_margin``) and from its base, the digits' and housing's lowest point above the table
(beyond ``table_clearance``), and their distance from the scene's obstacles: each is 0 where the
corresponding check of kinematics.py or the collision check flips, positive inside.

Frame: the manipulation plane, G at the origin, x along the table toward B, z up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import combinations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .convex import signed_distance
from .force_closure import (FC_TOLERANCE, REFERENCE_FRICTION, Friction, SlidingModel, _pair_margin, contact_wrenches,
                            force_closure, over_range)
from .kinematics import DigitGeometry, digit_bodies, s_b, thumb_clearance

_TRIPLES = list(combinations(range(6), 3))
_CHUNK = 4096
_NEWTON_STEPS = 60
#: The widest a friction cone may grow in the margin's search (rad): 89 deg, short of a half-plane.
MAX_CONE_HALF_ANGLE = math.radians(89.0)


# -- the contact wrenches as functions of the shrink angle ---------------------------------------
def shrinking_wrenches(
    theta: ArrayLike,
    d: ArrayLike,
    psi: ArrayLike,
    a_sign: ArrayLike = 0,
    b_sign: ArrayLike = 0,
    friction: Friction = REFERENCE_FRICTION,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """W, V (N, 6, 3) and the slot mask (N, 6): with every cone shrunk by the angle delta (rad)
    the six slots' wrenches are cos(delta) W + sin(delta) V (up to a positive factor).

    Both come from :func:`~ungrasp_ompl.mechanics.force_closure.contact_wrenches`, the one place
    that fixes the slots, points, normals and friction signs: W is its wrenches for the friction
    mu (unit forces; moment about G, f_x, f_z), and since a cone edge at the half-angle
    phi - delta is cos(delta) times the edge at phi plus sin(delta) times that edge turned by 90
    deg toward the normal, V = sqrt(2) W(pi/4) - W, with W(pi/4) its wrenches for the cones
    shrunk by 45 deg (friction tan(atan(mu) - pi/4), which is negative for cones narrower than
    45 deg and still gives the right edges). A relaxed sliding contact's normal slot does not
    turn: its V is zero.
    """
    w, mask = contact_wrenches(theta, d, psi, a_sign, b_sign, friction)
    quarter = tuple(math.tan(math.atan(m) - math.pi / 4) for m in friction.mu)
    w45, _ = contact_wrenches(theta, d, psi, a_sign, b_sign, friction.with_mu(quarter))
    v = math.sqrt(2.0) * w45 - w
    _, _, _, sa, sb = np.broadcast_arrays(
        *(np.ravel(np.atleast_1d(np.asarray(x, dtype=float))) for x in (theta, d, psi, a_sign, b_sign))
    )
    v[:, 3] = np.where((sa != 0)[:, None], 0.0, v[:, 3])  # A's normal slot while A slides
    v[:, 5] = np.where((sb != 0)[:, None], 0.0, v[:, 5])  # B's normal slot while B slides
    return w, v, mask


def _fails(w: NDArray, v: NDArray, mask: NDArray, delta: NDArray) -> NDArray[np.bool_]:
    """True where force closure fails with every cone shrunk by delta (N,): force_closure.py's test
    (unit wrenches, margin above FC_TOLERANCE)."""
    c, s = np.cos(delta)[:, None, None], np.sin(delta)[:, None, None]
    wr = c * w + s * v
    norm = np.linalg.norm(wr, axis=-1)
    inv = np.where(mask & (norm > 0), 1.0 / np.where(norm > 0, norm, 1.0), 0.0)
    comp = (wr * inv[..., None]).transpose(1, 2, 0)  # (6, 3, N) as force_closure's helper takes them
    return ~(_pair_margin(np.ascontiguousarray(comp)) > FC_TOLERANCE)


def _limits(mu: tuple[float, float, float]) -> tuple[float, float]:
    """The range of the shrink angle: cones grown until the widest has the half-angle
    MAX_CONE_HALF_ANGLE (a half-plane's two edges are antiparallel and no longer generate it,
    and nearly antiparallel ones make the force-closure test degenerate), shrunk until the
    narrowest is a ray."""
    phi = [math.atan(m) for m in mu]
    return max(phi) - MAX_CONE_HALF_ANGLE, min(phi)


# -- the event candidates: roots of the triple-product cubics ------------------------------------
_I, _J, _K = (np.array(x) for x in zip(*_TRIPLES))


def _cross(a: NDArray, b: NDArray) -> NDArray:
    return np.stack([a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
                     a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
                     a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]], axis=-1)


def _cubic_coefficients(w: NDArray, v: NDArray) -> NDArray[np.float64]:
    """Coefficients (c0, c1, c2, c3) of P(t) = det(W_i + t V_i, W_j + t V_j, W_k + t V_k) for
    every slot triple (i, j, k), shape (4, N, 20)."""
    wi, wj, wk, vi, vj, vk = w[:, _I], w[:, _J], w[:, _K], v[:, _I], v[:, _J], v[:, _K]
    ww, wv, vw, vv = _cross(wi, wj), _cross(wi, vj), _cross(vi, wj), _cross(vi, vj)

    def dot(a, b):
        return np.einsum("nmj,nmj->nm", a, b)

    return np.stack([dot(ww, wk), dot(vw, wk) + dot(wv, wk) + dot(ww, vk),
                     dot(vv, wk) + dot(vw, vk) + dot(wv, vk), dot(vv, vk)])


def _polyval(c: NDArray, t: NDArray) -> NDArray:
    return ((c[3] * t + c[2]) * t + c[1]) * t + c[0]


def _cubic_events(c: NDArray, t_lo: NDArray, t_hi: NDArray) -> NDArray[np.float64]:
    """Real roots and critical points of the cubics c (4, M) within [t_lo, t_hi] (M,), NaN where
    there is none; shape (5, M). On each monotone piece between critical points a sign change
    brackets one root, found by safeguarded Newton steps to machine precision."""
    a, b, cc = 3.0 * c[3], 2.0 * c[2], c[1]  # P'(t) = a t^2 + b t + cc
    scale = np.maximum(np.abs(c).max(axis=0), 1e-300)
    quad = np.abs(a) > 1e-14 * scale
    lin = ~quad & (np.abs(b) > 1e-14 * scale)
    disc = b * b - 4.0 * a * cc
    sq = np.sqrt(np.maximum(disc, 0.0))
    q = -0.5 * (b + np.where(b >= 0, sq, -sq))
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = np.where(quad, q / np.where(quad, a, 1.0), np.where(lin, -cc / np.where(lin, b, 1.0), np.nan))
        r2 = np.where(quad & (q != 0), cc / np.where(q != 0, q, 1.0), np.nan)
    r1 = np.where(quad & (disc < 0), np.nan, r1)
    r2 = np.where(quad & (disc < 0), np.nan, r2)
    crit = np.stack([r1, r2])
    crit = np.where((crit > t_lo) & (crit < t_hi), crit, np.nan)
    # breakpoints of the monotone pieces, sorted (missing critical points collapse onto t_lo)
    brk = np.sort(np.stack([t_lo, np.where(np.isnan(crit[0]), t_lo, crit[0]),
                            np.where(np.isnan(crit[1]), t_lo, crit[1]), t_hi]), axis=0)
    left, right = brk[:-1], brk[1:]  # (3, M)
    f_left, f_right = _polyval(c[:, None], left), _polyval(c[:, None], right)
    has = (np.sign(f_left) * np.sign(f_right) <= 0) & (right > left)
    roots = np.full(left.shape, np.nan)
    piece, col = np.nonzero(has)
    lo, hi, flo, fhi = left[piece, col], right[piece, col], f_left[piece, col], f_right[piece, col]
    cf = c[:, col]
    x = np.where(flo == 0, lo, np.where(fhi == 0, hi, lo - flo * (hi - lo) / np.where(fhi != flo, fhi - flo, 1.0)))
    x = np.clip(x, lo, hi)
    where = np.arange(len(x))
    active = (flo != 0) & (fhi != 0)
    for _ in range(_NEWTON_STEPS):
        if not active.any():
            break
        k = np.flatnonzero(active)
        xk, ck, lk, hk, fl = x[k], cf[:, k], lo[k], hi[k], flo[k]
        fx = _polyval(ck, xk)
        dfx = (3.0 * ck[3] * xk + 2.0 * ck[2]) * xk + ck[1]
        same = np.sign(fx) == np.sign(fl)
        lk = np.where(same, xk, lk)
        hk = np.where(same, hk, xk)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = xk - fx / dfx
        ok = (step > lk) & (step < hk) & np.isfinite(step)
        new = np.where(ok, step, 0.5 * (lk + hk))
        done = (fx == 0) | (np.abs(new - xk) <= 1e-15 * (1.0 + np.abs(xk))) | (hk - lk <= 1e-15 * (1.0 + np.abs(xk)))
        x[k] = np.where(fx == 0, xk, new)
        lo[k], hi[k] = lk, hk
        active[k[done]] = False
    roots[piece, col] = x[where]
    return np.concatenate([roots, crit])


# -- the friction margin -------------------------------------------------------------------------
def friction_margin(
    theta: ArrayLike,
    d: ArrayLike,
    psi: ArrayLike,
    a_sign: ArrayLike = 0,
    b_sign: ArrayLike = 0,
    friction: Friction = REFERENCE_FRICTION,
) -> NDArray[np.float64]:
    """The friction margin of each state in the given contact mode, radians, shape (N,).

    The largest angle by which every friction cone can shrink with force closure still holding:
    positive exactly where :func:`force_closure` holds, 0 on its boundary, negative outside (the
    angle by which every cone must grow); at most min(atan(mu)); -inf where no growth of the cones
    gives force closure. Arguments as for force_closure (a_sign, b_sign in {-1, 0, 1}).

    For a friction known within a range (Friction.uncertainty > 0), the smallest of the margins
    at the frictions that decide the range (Friction.ends: the cones narrowed from the low end,
    and under the strict model also from the sliding contacts' high end). Under the relaxed model
    that is the low end's margin alone: where force closure holds there, every cone narrowed by
    delta from the high end holds the one narrowed from the low end, so the high end's margin is
    never smaller.
    """
    return over_range(_friction_margin_at, theta, d, psi, a_sign, b_sign, friction, np.minimum)


def _friction_margin_at(theta, d, psi, a_sign, b_sign, friction: Friction) -> NDArray[np.float64]:
    """friction_margin for friction's coefficients mu alone."""
    w, v, mask, fc0, monotone = _prepared(theta, d, psi, a_sign, b_sign, friction)
    out = np.full(len(w), _limits(friction.mu)[1])
    # where closure is monotone and still holds with the narrowest cone shrunk to a ray, the margin
    # is that cap (what the candidates' bisection ends with): no event is needed there
    capped = monotone & fc0
    capped[capped] = ~_fails(w[capped], v[capped], mask[capped], np.full(int(capped.sum()), out[0]))
    rest = np.flatnonzero(~capped)
    for lo in range(0, len(rest), _CHUNK):
        k = rest[lo:lo + _CHUNK]
        out[k] = _margin_chunk(w[k], v[k], mask[k], fc0[k], monotone[k], friction.mu)
    return out


def _prepared(theta, d, psi, a_sign, b_sign, friction: Friction):
    """Wrenches W, V and mask, force closure now, and where force closure is monotone in the
    shrink angle (every sliding contact relaxed: its arc from the normal to its edge shrinks;
    a strict sliding contact's single edge moves instead)."""
    w, v, mask = shrinking_wrenches(theta, d, psi, a_sign, b_sign, friction)
    theta, d, psi, a_sign, b_sign = np.broadcast_arrays(
        *(np.ravel(np.atleast_1d(np.asarray(x, dtype=float))) for x in (theta, d, psi, a_sign, b_sign))
    )
    fc0 = force_closure(theta, d, psi, np.sign(a_sign), np.sign(b_sign), friction)
    monotone = np.full(len(w), friction.model is SlidingModel.RELAXED) | ((a_sign == 0) & (b_sign == 0))
    return w, v, mask, fc0, monotone


def _margin_chunk(w: NDArray, v: NDArray, mask: NDArray, fc0: NDArray, monotone: NDArray, mu) -> NDArray:
    n = len(w)
    d_lo, d_hi = _limits(mu)
    # the window: (0, hi] where force closure holds now, [lo, 0] where it does not
    left = np.where(fc0, 0.0, d_lo)
    right = np.where(fc0, d_hi, 0.0)
    coeff = _cubic_coefficients(w, v).reshape(4, -1)
    t_lo = np.repeat(np.tan(left), len(_TRIPLES))
    t_hi = np.repeat(np.tan(right), len(_TRIPLES))
    events = np.arctan(_cubic_events(coeff, t_lo, t_hi)).reshape(5, n, len(_TRIPLES))
    live = mask[:, _I] & mask[:, _J] & mask[:, _K]
    events = np.where(live[None], events, np.nan).transpose(1, 0, 2).reshape(n, -1)
    inside = (events > left[:, None]) & (events < right[:, None])
    count = inside.sum(axis=1)
    cand = np.concatenate([left[:, None], np.sort(np.where(inside, events, np.inf), axis=1),
                           np.full((n, 1), np.inf)], axis=1)
    cand[np.arange(n), count + 1] = right  # ascending: the window's ends and the events inside
    out = np.where(fc0, d_hi, -np.inf)
    mono = np.flatnonzero(monotone)
    if len(mono):
        out[mono] = _bisect_candidates(w[mono], v[mono], mask[mono], fc0[mono], cand[mono], count[mono], out[mono])
    scan = np.flatnonzero(~monotone)
    if len(scan):
        out[scan] = _scan_candidates(w[scan], v[scan], mask[scan], fc0[scan], cand[scan], count[scan], out[scan])
    return out


def _bisect_candidates(w, v, mask, fc0, cand, count, out):
    """Monotone case: the first candidate at which force closure fails, by bisection over the
    sorted candidates (closure holds at cand[0] and fails at cand[count + 1] once the window's far
    end is checked)."""
    rows = np.arange(len(w))
    end = np.where(fc0, cand[rows, count + 1], cand[:, 0])
    fail_end = _fails(w, v, mask, end)
    todo = np.flatnonzero(np.where(fc0, fail_end, ~fail_end))
    lo_i = np.zeros(len(todo), dtype=int)
    hi_i = count[todo] + 1
    while True:
        open_ = np.flatnonzero(hi_i - lo_i > 1)
        if not len(open_):
            break
        mid = (lo_i[open_] + hi_i[open_]) // 2
        idx = todo[open_]
        f = _fails(w[idx], v[idx], mask[idx], cand[idx, mid])
        hi_i[open_] = np.where(f, mid, hi_i[open_])
        lo_i[open_] = np.where(f, lo_i[open_], mid)
    out = out.copy()
    out[todo] = cand[todo, hi_i]
    return out


def _scan_candidates(w, v, mask, fc0, cand, count, out):
    """Non-monotone case (a strict sliding contact): scanning outward from delta = 0, the first
    candidate above 0 at which force closure fails, or the first interval below 0 in which it
    holds (whose upper end is the margin); force closure only changes at the candidates."""
    out = out.copy()
    rows = np.arange(len(w))
    pos = np.where(fc0, 1, count + 1)  # the candidate (fc0) or the interval's upper end (not fc0)
    live = rows.copy()
    while len(live):
        p = pos[live]
        up = fc0[live]
        at = np.where(up, cand[live, p], 0.5 * (cand[live, p - 1] + cand[live, p]))
        f = _fails(w[live], v[live], mask[live], at)
        hit = np.where(up, f, ~f)
        out[live[hit]] = cand[live[hit], p[hit]]
        pos[live] += np.where(up, 1, -1)
        past = np.where(up, pos[live] > count[live] + 1, pos[live] < 1)
        live = live[~hit & ~past]
    return out


# -- kinematic margins ---------------------------------------------------------------------------
def kinematic_margins(
    theta: ArrayLike,
    d: ArrayLike,
    psi: ArrayLike,
    digits: DigitGeometry,
    length: float = 1.0,
    obstacles: tuple[NDArray, ...] = (),
) -> dict[str, NDArray[np.float64]]:
    """Kinematic margins of each state, in metres when length is the object length l (over l
    with length 1); each is 0 where its check flips and positive inside:

    - ``thumb_tip``: B's distance from the thumb's tip along its face beyond ``thumb_tip_margin``
      (s_B - margin);
    - ``thumb_base``: B's distance from the thumb's base (thumb_length - s_B);
    - ``table``: the lowest point of the thumb, the finger and the housing above the table,
      beyond ``table_clearance`` (their polygons as the collision check sees them; the thumb
      tip's corner is :func:`~ungrasp_ompl.mechanics.kinematics.thumb_clearance`);
    - ``obstacles``: the signed distance of the digits and the housing from the nearest obstacle
      polygon (each (k, 2), CCW, over l like the digits), +inf without obstacles.
    """
    theta, d, psi = (np.ravel(np.atleast_1d(np.asarray(x, dtype=float))) for x in (theta, d, psi))
    theta, d, psi = np.broadcast_arrays(theta, d, psi)
    sb = s_b(d, psi, digits.alpha, digits.object_thickness, digits.finger_tip_radius, digits.section)
    bodies = digit_bodies(theta, d, psi, digits)
    lowest = np.min([b[:, :, 1].min(axis=1) for b in bodies], axis=0)
    lowest = np.minimum(lowest, thumb_clearance(theta, d, psi, digits))
    near = np.full(theta.shape, np.inf)
    for poly in obstacles:
        for body in bodies:
            near = np.minimum(near, signed_distance(body, np.asarray(poly, dtype=float)))
    return {
        "thumb_tip": (sb - digits.thumb_tip_margin) * length,
        "thumb_base": (digits.thumb_length - sb) * length,
        "table": (lowest - digits.table_clearance) * length,
        "obstacles": near * length,
    }


# -- the result ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Margins:
    """Margins of N states (:meth:`~ungrasp_ompl.scene.Scene.margin`): the friction margin (rad,
    shape (N,)) in each state's contact mode, and the kinematic margins (m, each shape (N,); keys
    as in :func:`kinematic_margins`). Every margin is positive inside, 0 where its check flips."""

    friction: NDArray[np.float64]
    kinematic: dict[str, NDArray[np.float64]]

    @property
    def friction_deg(self) -> NDArray[np.float64]:
        """The friction margin in degrees (for printing)."""
        return np.degrees(self.friction)

    @property
    def kinematic_mm(self) -> dict[str, NDArray[np.float64]]:
        """The kinematic margins in millimetres (for printing)."""
        return {k: v * 1000.0 for k, v in self.kinematic.items()}

    def smallest_kinematic(self) -> NDArray[np.float64]:
        """The smallest kinematic margin of each state (m)."""
        return np.min(np.stack(list(self.kinematic.values())), axis=0)
