"""Contact modes: a sliding contact's friction opposes the object's velocity relative to the digit.

The relative velocities come from finite differences of the kinematics of
three rigid bodies (object pivoting about G, finger, thumb), not from the
sign rules of the code under test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ungrasp_ompl.mechanics import (
    DigitGeometry,
    Friction,
    contact_wrenches,
    finger_tip,
    primitive_of,
    primitive_sliding_signs,
    thumb_tip,
)
from ungrasp_ompl.mechanics.kinematics import thumb_normal

DIGITS = DigitGeometry(alpha=0.47)
MU = (0.19, 0.31, 0.31)
H = 1e-7


def cross_z(omega, r):
    """omega (z-axis rate) x r for planar vectors r (..., 2)."""
    return omega[..., None] * np.stack([-r[..., 1], r[..., 0]], -1)


def relative_velocities(q, dq):
    """Object velocity relative to the finger at A and to the thumb at B, each (N, 2)."""
    th, d, ps = q.T
    q1 = q + H * dq
    a0, a1 = finger_tip(th, d), finger_tip(q1[:, 0], q1[:, 1])
    t0 = thumb_tip(th, d, ps, DIGITS.alpha)
    t1 = thumb_tip(q1[:, 0], q1[:, 1], q1[:, 2], DIGITS.alpha)
    b = np.stack([np.cos(th), np.sin(th)], -1)
    w_obj = dq[:, 0]
    w_dig = dq[:, 0] + dq[:, 2]
    v_obj_a = cross_z(w_obj, a0)  # object material point at A (object pivots about G)
    v_fin_a = (a1 - a0) / H  # the finger tip is a point of the finger
    v_obj_b = cross_z(w_obj, b)
    v_thumb_b = (t1 - t0) / H + cross_z(w_dig, b - t0)  # thumb material point at B
    return v_obj_a - v_fin_a, v_obj_b - v_thumb_b


PRIMITIVE_STEPS = {
    "P_psi": [(0, 0, 1), (0, 0, -1)],
    "P_dpsi": [(0, -1, 0), (0, 1, 0), (0, -0.01, math.radians(1)), (0, 0.01, -math.radians(2))],
    "P_theta": [(-1, 0, 0), (1, 0, 0)],
}


@pytest.mark.parametrize("primitive", PRIMITIVE_STEPS)
def test_sliding_edge_opposes_relative_velocity(primitive):
    rng = np.random.default_rng(11)
    n = 2000
    q = np.column_stack([rng.uniform(0.05, 1.4, n), rng.uniform(0.1, 1, n), rng.uniform(0.02, math.radians(115), n)])
    for step in PRIMITIVE_STEPS[primitive]:
        dq = np.tile(np.asarray(step, dtype=float), (n, 1))
        assert primitive_of(step)[0] == primitive
        v_a, v_b = relative_velocities(q, dq)
        sa, sb = primitive_sliding_signs(primitive, q[:, 1], q[:, 2], dq[:, 1], dq[:, 2])
        w, _ = contact_wrenches(q[:, 0], q[:, 1], q[:, 2], sa, sb, Friction(MU, "strict"))
        n_a = np.stack([np.sin(q[:, 0]), -np.cos(q[:, 0])], -1)
        n_b = thumb_normal(q[:, 0], q[:, 2])
        for v, normal, sign, slot in ((v_a, n_a, sa, 2), (v_b, n_b, sb, 4)):
            # contacts persist: no relative velocity along the normal
            np.testing.assert_allclose(np.sum(v * normal, -1), 0.0, atol=1e-5)
            speed = np.linalg.norm(v, axis=-1)
            sliding = sign != 0
            np.testing.assert_array_equal(sliding, speed > 1e-5)  # slides iff it moves relative to the digit
            f = w[:, slot, 1:]
            tangential = f - np.sum(f * normal, -1, keepdims=True) * normal
            assert np.all(np.sum(tangential[sliding] * v[sliding], -1) < 0)


def test_primitive_of_classifies_directions():
    assert primitive_of((-0.1, 0, 0)) == ("P_theta", 1)
    assert primitive_of((0.1, 0, 0)) == ("P_theta", -1)
    assert primitive_of((0, 0, 0.2)) == ("P_psi", 1)
    assert primitive_of((0, -0.1, 0.2)) == ("P_dpsi", 1)
    assert primitive_of((0, 0.1, -0.2)) == ("P_dpsi", -1)
    assert primitive_of((0, -0.1, 0)) == ("P_dpsi", 1)
    assert primitive_of((0, -0.1, -0.2)) is None  # d and psi both down: no single primitive
    assert primitive_of((-0.1, 0, 0.2)) is None
    assert primitive_of((0, 0, 0)) is None
