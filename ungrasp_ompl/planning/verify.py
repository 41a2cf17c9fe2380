"""Independent re-validation of planned legs with the exact mechanics (no atlas).

Every leg is sampled in its travel direction at a resolution no coarser than
the lattice's (default: half a lattice step, SAMPLES_PER_STEP), and each sample is
checked for kinematic validity, collision (python-fcl) and force closure in the contact
mode the leg's velocity makes there; force closure is also checked everywhere between
two samples in the same contact mode (first_loss_along), so that a band thinner than
the sampling where the grip is lost is not stepped over.

Force closure in a contact mode changes only where three contact wrenches become coplanar,
where one of the 20 triple products det(w_i, w_j, w_k) of the six wrench slots changes sign
(mechanics/force_closure.py: the test is a function of those signs). The products are smooth
along a motion but where the finger's contact on a curved section passes from its face to its
rounded tip, where the contact's speed over the section changes at once: there a product can
dip through 0 and back within a fraction of a lattice step, a thin band where the grip is lost
between two states that hold. first_loss_along halves a segment's pieces where a product may
change sign (its sign differs at the piece's ends, or the tangents at its ends meet below 0, as
they do around such a dip) and checks force closure where it halves them, to 2^-30 of the
segment (DEPTH). A product convex or concave along a piece is caught; one with an inflection
that dips through 0 and back between two tangents that do not meet below 0 is not.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..geometry.collision import CollisionChecker
from ..mechanics import (Friction, SlidingModel, contact_wrenches, force_closure, kinematic_checks,
                         primitive_sliding_signs)
from ..scene import Scene

#: Samples per lattice step that the re-validation takes along a leg (verify_legs: at half a
#: lattice step), and the pieces each lattice step of the secure lattice is checked in (atlas.py):
#: the same points, so that a leg the lattice finds secure re-validates.
SAMPLES_PER_STEP = 2
#: How often first_loss_along halves a piece of a segment where force closure may change (to
#: 2^-30 of the segment: a band where it is lost narrower than that is not looked for).
DEPTH = 30
#: The step (a fraction of the segment) of the finite differences that give a product's slope.
_SLOPE_STEP = 1e-7
#: The wrench slots' triples (i, j, k), i < j < k, whose triple products decide force closure.
_TRIPLES = np.array(list(itertools.combinations(range(6), 3)), dtype=np.intp)


class LegCheck(Enum):
    """The check a leg fails first (verify_leg runs them in this order)."""

    #: A kinematic condition (LegFailure.detail names it: "d", "s_B >= 0", "thumb clearance", ...).
    KINEMATICS = "kinematics"
    #: Not force-closed in the contact mode the leg's velocity makes there.
    FORCE_CLOSURE = "force_closure"
    #: The digits or the object meet the table or an obstacle (LegFailure.detail names the pairs).
    COLLISION = "collision"


@dataclass(frozen=True)
class LegFailure:
    """Why a leg is not secure: the check that fails and the first state where it does."""

    check: LegCheck
    """The first check that fails."""
    state: tuple[float, float, float]
    """The first failing sample: theta (rad), d (over l), psi (rad)."""
    detail: str = ""
    """The kinematic condition, or the colliding pairs ("thumb-table, ..."); empty for force closure."""

    def describe(self) -> str:
        """One phrase for a person, e.g. "s_B >= 0 fails at (theta 30.00 deg, d 0.8000, psi 0.00 deg)"."""
        where = _fmt(self.state)
        if self.check is LegCheck.KINEMATICS:
            return f"{self.detail} fails at {where}"
        if self.check is LegCheck.FORCE_CLOSURE:
            return f"not force-closed in its contact mode at {where}"
        return f"collision {self.detail} at {where}"

    __str__ = describe



class PathCheck(Enum):
    """Why a planner's path cannot be executed as primitive legs (UngraspSetup.path_legs)."""

    #: A state of the path lies outside the planning box.
    OUTSIDE_BOX = "outside_box"
    #: An edge of the path has no secure primitive legs in its travel direction (PathProblem.index).
    NO_SECURE_LEGS = "no_secure_legs"
    #: A leg fails re-validation with the exact mechanics (PathProblem.index, .primitive, .failure).
    LEG_FAILS = "leg_fails"


@dataclass(frozen=True)
class PathProblem:
    """The first reason a path is not a secure sequence of legs."""

    check: PathCheck
    """What fails."""
    index: int | None = None
    """The path's edge (NO_SECURE_LEGS) or the realised leg (LEG_FAILS), from 0."""
    primitive: str | None = None
    """The failing leg's primitive (LEG_FAILS)."""
    failure: LegFailure | None = None
    """Why the leg fails (LEG_FAILS)."""

    def describe(self) -> str:
        """One phrase for a person."""
        if self.check is PathCheck.OUTSIDE_BOX:
            return "a state lies outside the planning box"
        if self.check is PathCheck.NO_SECURE_LEGS:
            return f"edge {self.index} has no secure primitive legs in its travel direction"
        return f"leg {self.index} ({self.primitive}) {self.failure}"

    __str__ = describe

    def evidence(self) -> dict:
        """Plan.evidence of an invalid path: the phrase and the values behind it (JSON types)."""
        out = {"problem": self.describe(), "path_check": self.check.value, "index": self.index}
        if self.failure is not None:
            out.update(primitive=self.primitive, leg_check=self.failure.check.value, state=list(self.failure.state),
                       detail=self.failure.detail)
        return out


def _leg_samples(q0: ArrayLike, q1: ArrayLike, resolution: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The samples (n + 1, 3) verify_leg checks along a leg from q0 to q1 (states (theta rad, d over
    l, psi rad)), its ends included, no farther apart than resolution per coordinate; and the leg's
    step q1 - q0."""
    q0, q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
    step = q1 - q0
    n = max(1, int(math.ceil(np.max(np.abs(step) / np.asarray(resolution)) - 1e-9)))
    return q0 + np.linspace(0.0, 1.0, n + 1)[:, None] * step, step


def verify_leg(
    scene: Scene,
    primitive: str,
    q0: ArrayLike,
    q1: ArrayLike,
    resolution: ArrayLike,
    checker: CollisionChecker | None = None,
) -> LegFailure | None:
    """Check one leg from q0 to q1 (states (theta, d, psi)); None if secure, else why not."""
    q, step = _leg_samples(q0, q1, resolution)
    th, d, ps = q.T
    for name, ok in kinematic_checks(th, d, ps, scene.digits).items():
        if not ok.all():
            return LegFailure(LegCheck.KINEMATICS, _state(q[np.argmin(ok)]), name)
    sa, sb = primitive_sliding_signs(primitive, d, ps, step[1], step[2])
    fc = force_closure(th, d, ps, sa, sb, scene.friction)
    if not fc.all():
        return LegFailure(LegCheck.FORCE_CLOSURE, _state(q[np.argmin(fc)]))
    same = np.flatnonzero((sa[:-1] == sa[1:]) & (sb[:-1] == sb[1:]))  # pieces in one contact mode
    lost = first_loss_along(q[same], q[same + 1], sa[same], sb[same], scene.friction)
    if not np.isnan(lost).all():
        k = int(np.argmax(~np.isnan(lost)))
        return LegFailure(LegCheck.FORCE_CLOSURE, _state(q[same[k]] + lost[k] * (q[same[k] + 1] - q[same[k]])))
    checker = checker or CollisionChecker(scene.collision_model())
    hit = checker.in_collision(q)
    if hit.any():
        bad = q[np.argmax(hit)]
        return LegFailure(LegCheck.COLLISION, _state(bad), ", ".join(checker.contacts(bad)))
    return None


def first_failing_leg(
    scene: Scene,
    legs: Sequence[tuple[str, ArrayLike, ArrayLike]],
    resolution: ArrayLike,
    checker: CollisionChecker | None = None,
) -> tuple[int, LegFailure] | None:
    """The first of legs ((primitive, q0, q1) each, in order) that verify_leg finds not secure, and
    why (verify_leg's answer for it); None when every leg is secure.

    verify_leg leg by leg, each of its checks run once over the samples of every leg still secure
    (a handful of array operations for a whole path instead of a handful per leg): every check
    decides each sample, or each piece between two samples, on its own, so a leg fails here
    exactly where it fails alone; the failing leg is then checked alone for its reason."""
    if not legs:
        return None
    parts = [_leg_samples(q0, q1, resolution) for _, q0, q1 in legs]
    q = np.concatenate([samples for samples, _ in parts])
    owner = np.repeat(np.arange(len(legs)), [len(samples) for samples, _ in parts])
    signs = [primitive_sliding_signs(primitive, samples[:, 1], samples[:, 2], step[1], step[2])
             for (primitive, _, _), (samples, step) in zip(legs, parts)]
    sa, sb = (np.concatenate(x) for x in zip(*signs))
    th, d, ps = q.T
    bad = np.zeros(len(legs), dtype=bool)
    held = np.logical_and.reduce(list(kinematic_checks(th, d, ps, scene.digits).values()))
    bad[owner[~held]] = True
    live = np.flatnonzero(~bad[owner])
    bad[owner[live[~force_closure(th[live], d[live], ps[live], sa[live], sb[live], scene.friction)]]] = True
    same = np.flatnonzero((owner[:-1] == owner[1:]) & (sa[:-1] == sa[1:]) & (sb[:-1] == sb[1:])
                          & ~bad[owner[:-1]])  # pieces of a leg still secure, in one contact mode
    lost = first_loss_along(q[same], q[same + 1], sa[same], sb[same], scene.friction)
    bad[owner[same[~np.isnan(lost)]]] = True
    checker = checker or CollisionChecker(scene.collision_model())
    live = np.flatnonzero(~bad[owner])
    if len(live):
        bad[owner[live[checker.in_collision(q[live])]]] = True
    for k in np.flatnonzero(bad):
        primitive, q0, q1 = legs[k]
        why = verify_leg(scene, primitive, q0, q1, resolution, checker)
        if why is not None:
            return int(k), why
    return None


def first_loss_along(q0: ArrayLike, q1: ArrayLike, a_sign: ArrayLike, b_sign: ArrayLike, friction: Friction,
                     depth: int = DEPTH) -> NDArray[np.float64]:
    """Where force closure is first lost along each straight segment from q0 to q1 ((N, 3) states
    (theta rad, d over l, psi rad)) in the contact mode (a_sign, b_sign) (each (N,) or a scalar):
    the fraction t in [0, 1] of the first point found not force-closed (0 or 1: an end), NaN where
    the segment is force-closed throughout (see the module docstring; friction's whole range, as
    force_closure checks it). Each segment is searched on its own; the segments whose contact
    modes have the same slots and the same deciding frictions (_mode_groups) are searched together."""
    q0, q1 = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q0, q1))
    n = len(q0)
    sa, sb = (np.broadcast_to(np.asarray(x, dtype=int), (n,)) for x in (a_sign, b_sign))
    out = np.full(n, np.nan)
    for sel, deciding in _mode_groups(sa, sb, friction):
        out[sel] = _first_loss(q0[sel], q1[sel], sa[sel], sb[sel], friction, deciding, depth)
    return out


def _mode_groups(sa: NDArray, sb: NDArray, friction: Friction) -> list[tuple[NDArray[np.intp], tuple[Friction, ...]]]:
    """The segments in contact modes (sa, sb) (each (N,)) in groups that _first_loss may search
    together, each with the frictions that decide its range (Friction.ends; friction itself when
    known exactly): under the relaxed model every mode has all six wrench slots and the range's
    low end decides alone, so all the segments form one group; under the strict model a sliding
    contact loses a slot and adds the range's high end, so the groups are by which contacts slide."""
    if friction.model is SlidingModel.RELAXED:
        keys = np.zeros(len(sa), dtype=int)
    else:
        keys = 2 * (sa != 0) + (sb != 0)
    out = []
    for key in np.unique(keys):
        a_slides, b_slides = bool(key // 2), bool(key % 2)
        deciding = friction.ends(a_slides, b_slides) if friction.uncertainty > 0.0 else (friction,)
        out.append((np.flatnonzero(keys == key), deciding))
    return out


def _triple_products(q: NDArray, a: NDArray, b: NDArray, deciding: tuple[Friction, ...]) -> NDArray[np.float64]:
    """The triple products of the contact wrenches' slots at states q (N, 3) in modes (a, b) (each
    (N,)), at every friction that decides the range (deciding, _mode_groups): shape (N, 20 times
    their count)."""
    out = []
    for f in deciding:
        w, exists = contact_wrenches(q[:, 0], q[:, 1], q[:, 2], a, b, f)
        w = w * exists[..., None]  # a slot the mode does not have spans nothing
        i, j, k = _TRIPLES.T
        out.append(np.einsum("ntc,ntc->nt", np.cross(w[:, i], w[:, j]), w[:, k]))
    return np.concatenate(out, axis=1)


def _first_loss(q0: NDArray, q1: NDArray, a: NDArray, b: NDArray, friction: Friction,
                deciding: tuple[Friction, ...], depth: int) -> NDArray[np.float64]:
    """first_loss_along for segments in contact modes (a, b) (each (N,)) of one of _mode_groups'
    groups, whose range deciding decides: the segments' pieces where some triple product may
    change sign (_may_change) halved, force closure checked where they are halved, depth times at
    most."""
    out = np.full(len(q0), np.nan)
    if not len(q0):
        return out
    step = q1 - q0
    for t, q in ((1.0, q1), (0.0, q0)):  # the ends (the first one last, so that it wins)
        fc = force_closure(q[:, 0], q[:, 1], q[:, 2], a, b, friction)
        out[~fc] = t
    seg = np.flatnonzero(np.isnan(out))
    lo, hi = np.zeros(len(seg)), np.ones(len(seg))
    for _ in range(depth):
        if not len(seg):
            break
        may = _may_change(q0[seg], step[seg], lo, hi, a[seg], b[seg], deciding)
        seg, lo, hi = seg[may], lo[may], hi[may]
        mid = (lo + hi) / 2.0
        q = q0[seg] + mid[:, None] * step[seg]
        lost = ~force_closure(q[:, 0], q[:, 1], q[:, 2], a[seg], b[seg], friction)
        np.fmin.at(out, seg[lost], mid[lost])
        keep = ~lost
        seg, lo, mid, hi = seg[keep], lo[keep], mid[keep], hi[keep]
        seg, lo, hi = np.concatenate([seg, seg]), np.concatenate([lo, mid]), np.concatenate([mid, hi])
    return out


def _may_change(q0: NDArray, step: NDArray, lo: NDArray, hi: NDArray, a: NDArray, b: NDArray,
                deciding: tuple[Friction, ...]) -> NDArray[np.bool_]:
    """Per piece [lo, hi] of a segment q0 + t step in contact mode (a, b) (each per piece): whether
    some triple product may change sign on it. It may where its sign differs at the two ends; else
    where the tangents at its ends (slopes by finite differences) meet at or beyond 0, i.e. where a
    product convex along the piece might dip through 0 and back (the tangents lie below a convex
    function; a concave one is least at an end)."""
    h = np.minimum(_SLOPE_STEP, (hi - lo) / 8.0)
    ts = np.concatenate([lo, lo + h, hi - h, hi])
    n = len(lo)
    q = np.tile(q0, (4, 1)) + ts[:, None] * np.tile(step, (4, 1))
    p = _triple_products(q, np.tile(a, 4), np.tile(b, 4), deciding).reshape(4, n, -1)
    width = (hi - lo)[:, None]
    f0, f1 = p[0], p[3]
    sign = np.sign(f0)
    changes = np.sign(f1) != sign
    g0 = (p[1] - p[0]) / h[:, None] * width * sign  # slopes along the piece (its length 1), the sign made positive
    g1 = (p[3] - p[2]) / h[:, None] * width * sign
    f0, f1 = f0 * sign, f1 * sign
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (f1 - g1 - f0) / (g0 - g1)  # where f0 + g0 t = f1 - g1 (1 - t)
        dips = (sign != 0) & (t > 0.0) & (t < 1.0) & (f0 + g0 * t <= 0.0)
    return np.any(changes | dips, axis=1)


def _state(q: ArrayLike) -> tuple[float, float, float]:
    th, d, ps = (float(x) for x in q)
    return th, d, ps


def _fmt(q: ArrayLike) -> str:
    th, d, ps = q
    return f"(theta {math.degrees(th):.2f} deg, d {d:.4f}, psi {math.degrees(ps):.2f} deg)"
