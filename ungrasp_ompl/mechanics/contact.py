"""Contact modes and motion primitives (docs/model.md, section 3).

G never slides. A slides iff d changes; B slides iff s_B changes, with
ds_B = cos(psi) dd - d sin(psi) dpsi. A sliding contact pushes the object
along the friction-cone edge that opposes the object's velocity relative to
the digit:

- at A the finger tip is a point of the finger while the contact runs along
  the object, so v_object - v_finger = dd * u (u from G to B), and friction
  on the object points along -sign(dd) * u (toward B while d decreases);
- at B the object's end is a point of the object while the contact runs along
  the thumb face, so v_object - v_thumb = -ds_B * e (e from palm to tips), and
  friction on the object points along +sign(ds_B) * e (toward the palm while
  s_B decreases).

On a curved section (mechanics.section) d is the slide coordinate, so A still slides iff dd != 0,
the object slipping past the finger along the top's tangent toward B; B's sign is taken from the
segment's ds_B all the same, which tests/test_section.py checks against finite differences of the
section's s_B (ds_B/dpsi < 0, ds_B/dd > 0 wherever the gripper is open and psi < 90 deg).
"""

from __future__ import annotations

from enum import StrEnum
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .kinematics import digit_axis, object_axis

class Primitive(StrEnum):
    """The paper's motion primitives (docs/model.md 3.3). A member is its name as a string
    ("P_theta", ...), so files, plan.json and comparisons with the name keep working."""

    #: Pivot about G; every contact sticks.
    THETA = "P_theta"
    #: The thumb turns; G and A stick, B slides.
    PSI = "P_psi"
    #: The finger slides toward B while psi grows (or holds).
    DPSI = "P_dpsi"

    def describe(self) -> str:
        """What the primitive does, in words for a person (files keep the name)."""
        return {Primitive.THETA: "the pinch pivots about G, every contact sticking",
                Primitive.PSI: "the thumb turns about B, the object's end sliding on it",
                Primitive.DPSI: "the finger slides along the object toward B as the thumb turns"}[self]


#: The paper's primitives: which coordinates each one moves, and the sign of
#: its forward (paper) direction in (theta, d, psi).
PRIMITIVES: dict[Primitive, tuple[int, int, int]] = {
    Primitive.THETA: (-1, 0, 0),
    Primitive.PSI: (0, 0, 1),
    Primitive.DPSI: (0, -1, 1),
}

#: Velocities below this (per unit of the largest component) count as zero.
_ZERO = 1e-12


class ContactMode(NamedTuple):
    """Sliding at A and B: 0 sticks, otherwise the sign of dd (A) or ds_B (B)."""

    a: int
    b: int

    @property
    def sliding(self) -> tuple[str, ...]:
        return tuple(name for name, s in (("A", self.a), ("B", self.b)) if s)


def sliding_signs(
    d: ArrayLike, psi: ArrayLike, dd: ArrayLike, dpsi: ArrayLike
) -> tuple[NDArray[np.int8], NDArray[np.int8]]:
    """Signs of dd (sliding at A) and of ds_B (sliding at B), each in {-1, 0, 1}."""
    d, psi, dd, dpsi = (np.asarray(x, dtype=float) for x in (d, psi, dd, dpsi))
    dsb = np.cos(psi) * dd - d * np.sin(psi) * dpsi
    scale = np.maximum(np.abs(dd), np.abs(dpsi)) + 1e-300
    sa = np.where(np.abs(dd) > _ZERO * scale, np.sign(dd), 0).astype(np.int8)
    sb = np.where(np.abs(dsb) > 1e-9 * scale, np.sign(dsb), 0).astype(np.int8)
    return sa, sb


def contact_mode(q: ArrayLike, dq: ArrayLike) -> ContactMode:
    """Contact mode of a single velocity dq = (dtheta, dd, dpsi) at state q."""
    _, d, psi = np.asarray(q, dtype=float)
    sa, sb = sliding_signs(d, psi, dq[1], dq[2])
    return ContactMode(int(sa), int(sb))


def friction_directions(
    theta: ArrayLike, psi: ArrayLike, a_sign: ArrayLike, b_sign: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit tangential friction on the object at A and at B, shape (..., 2) each.

    Zero where the contact sticks.
    """
    a = np.asarray(a_sign, dtype=float)[..., None]
    b = np.asarray(b_sign, dtype=float)[..., None]
    return -a * object_axis(theta), b * digit_axis(theta, psi)


def primitive_of(dq: ArrayLike, tol: float = 1e-12) -> tuple[str, int] | None:
    """The primitive whose legs move along dq, and its direction (+1 paper, -1 reverse).

    P_theta moves theta alone, P_psi psi alone, P_dpsi moves d (with psi
    moving the other way or not at all) at fixed theta. None when no single
    primitive realises dq (or dq is zero).
    """
    dth, dd, dps = (float(x) for x in dq)
    moving = [abs(x) > tol for x in (dth, dd, dps)]
    if moving == [True, False, False]:
        return "P_theta", 1 if dth < 0 else -1
    if moving == [False, False, True]:
        return "P_psi", 1 if dps > 0 else -1
    if moving[1] and not moving[0] and (not moving[2] or dd * dps < 0):
        return "P_dpsi", 1 if dd < 0 else -1
    return None


def primitive_sliding_signs(
    primitive: str, d: ArrayLike, psi: ArrayLike, dd: ArrayLike, dpsi: ArrayLike
) -> tuple[NDArray[np.int8], NDArray[np.int8]]:
    """Sliding signs at A and B during a primitive leg moving with (dd, dpsi).

    The contact mode is the primitive's own: P_theta sticks everywhere;
    P_psi slides B against dpsi (ds_B = -d sin(psi) dpsi), taken in its limit
    psi -> 0+ so that the leg's first state is checked in the leg's mode;
    P_dpsi slides A with dd and B with the sign of ds_B (B sticks where
    ds_B vanishes, e.g. a pure finger slide at psi = 90 deg).
    """
    d, psi, dd, dpsi = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (d, psi, dd, dpsi)))
    zero = np.zeros(d.shape, dtype=np.int8)
    if primitive == Primitive.THETA:
        return zero, zero.copy()
    if primitive == Primitive.PSI:
        return zero, (-np.sign(dpsi)).astype(np.int8)
    if primitive == Primitive.DPSI:
        return sliding_signs(d, psi, dd, dpsi)
    raise ValueError(f"unknown primitive {primitive!r}; expected one of {', '.join(PRIMITIVES)}")
