"""Identities of the pinch geometry (docs/model.md, section 2)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from scipy.optimize import linprog

from ungrasp_ompl.mechanics import (DigitGeometry, across_support, aperture, digit_polygons, finger_tip, s_b,
                                    thumb_clearance, thumb_tip)
from ungrasp_ompl.mechanics.kinematics import (contact_d, digit_axis, finger_corner, kinematic_checks,
                                              kinematic_validity, pressed_state, release_travel, thumb_normal)

DIGITS = DigitGeometry(alpha=0.47)


@pytest.fixture
def states():
    rng = np.random.default_rng(7)
    n = 5000
    return rng.uniform(0, math.pi / 2, n), rng.uniform(0.01, 1, n), rng.uniform(0, math.radians(120), n)


def test_s_b_is_position_of_b_on_thumb_face(states):
    """B = thumb tip + s_B (palm direction): s_B measured from the tip toward the palm."""
    th, d, ps = states
    b = np.stack([np.cos(th), np.sin(th)], -1)
    tip = thumb_tip(th, d, ps, DIGITS.alpha)
    e = digit_axis(th, ps)
    offset = b - tip
    np.testing.assert_allclose(np.sum(offset * -e, -1), s_b(d, ps, DIGITS.alpha), atol=1e-12)
    np.testing.assert_allclose(np.sum(offset * thumb_normal(th, ps), -1), 0.0, atol=1e-12)  # B on the face
    np.testing.assert_allclose(s_b(d, ps, DIGITS.alpha), d * np.cos(ps) - DIGITS.alpha, atol=1e-12)


def test_finger_is_alpha_longer_and_aperture_is_d_sin_psi(states):
    """Along the digit axis the finger tip A lies alpha beyond the thumb tip; across it, w = d sin psi."""
    th, d, ps = states
    a = finger_tip(th, d)
    tip = thumb_tip(th, d, ps, DIGITS.alpha)
    np.testing.assert_allclose(np.sum((a - tip) * digit_axis(th, ps), -1), DIGITS.alpha, atol=1e-12)
    np.testing.assert_allclose(np.sum((a - tip) * thumb_normal(th, ps), -1), aperture(d, ps), atol=1e-12)
    # A on the object, (1 - d) from G
    np.testing.assert_allclose(np.linalg.norm(a, axis=-1), 1 - d, atol=1e-12)


def test_thumb_clearance_is_height_of_thumb_tip_back_corner(states):
    """The analytic clearance (docs/model.md, section 2.3) is the height of the thumb
    outline's tip back corner.
    That corner is the thumb's lowest point while the digit axis is steep enough for the
    thicker base to stay above it and does not lean past vertical; the collision check
    covers the other poses."""
    th, d, ps = states
    thumb, _ = digit_polygons(th, d, ps, DIGITS)
    clearance = thumb_clearance(th, d, ps, DIGITS)
    np.testing.assert_allclose(clearance, thumb[:, 3, 1], atol=1e-12)
    beta = th + ps
    taper = (DIGITS.thumb_base_thickness - DIGITS.thumb_tip_thickness) / DIGITS.thumb_length
    lean = (beta <= math.pi / 2) & (np.tan(beta) >= taper)
    np.testing.assert_allclose(clearance[lean], thumb[lean, :, 1].min(axis=1), atol=1e-12)


def test_digit_outlines_have_their_lengths_and_thicknesses(states):
    th, d, ps = states
    thumb, finger = digit_polygons(th, d, ps, DIGITS)
    for outline, length, t_tip, t_base in ((thumb, DIGITS.thumb_length, DIGITS.thumb_tip_thickness, DIGITS.thumb_base_thickness),
                                           (finger, DIGITS.finger_length, DIGITS.finger_tip_thickness, DIGITS.finger_base_thickness)):
        np.testing.assert_allclose(np.linalg.norm(outline[:, 1] - outline[:, 0], axis=-1), length, atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(outline[:, 3] - outline[:, 0], axis=-1), t_tip, atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(outline[:, 2] - outline[:, 1], axis=-1), t_base, atol=1e-12)
    # the two digits lie on either side of the gap between their faces
    n = thumb_normal(th, ps)
    assert np.all(np.sum((finger[:, 3] - finger[:, 0]) * n, -1) > 0)
    assert np.all(np.sum((thumb[:, 3] - thumb[:, 0]) * n, -1) < 0)


def test_kinematic_checks_name_each_failure():
    checks = kinematic_checks(math.radians(30), 0.4, 0.0, DIGITS)  # s_B = 0.4 - 0.47 < 0
    assert not checks["s_B >= 0"] and checks["d"] and checks["s_B <= thumb_length"]
    checks = kinematic_checks(0.0, 0.8, math.radians(20), DIGITS)  # flat object, thumb below the table
    assert not checks["thumb clearance"]


def test_a_thick_object_moves_the_finger_to_its_top_face(states):
    """With thickness t the finger presses the top face at A + t n_top: still alpha beyond the
    thumb tip along e, the faces w(t) = d sin psi + t cos psi apart, and B on the thumb face."""
    th, d, ps = states
    t = 0.1
    u = np.stack([np.cos(th), np.sin(th)], -1)
    a_top = finger_tip(th, d) + t * np.stack([-u[..., 1], u[..., 0]], -1)
    tip = thumb_tip(th, d, ps, DIGITS.alpha, t)
    np.testing.assert_allclose(np.sum((a_top - tip) * digit_axis(th, ps), -1), DIGITS.alpha, atol=1e-12)
    np.testing.assert_allclose(np.sum((a_top - tip) * thumb_normal(th, ps), -1), aperture(d, ps, t), atol=1e-12)
    np.testing.assert_allclose(np.sum((u - tip) * thumb_normal(th, ps), -1), 0.0, atol=1e-12)
    np.testing.assert_allclose(s_b(d, ps, DIGITS.alpha, t), s_b(d, ps, DIGITS.alpha) - t * np.sin(ps), atol=1e-12)


def _perp(v):
    """v turned by +90 deg: the velocity of the point v of a body turning at unit rate about the origin."""
    return np.stack([-v[..., 1], v[..., 0]], -1)


@pytest.mark.parametrize("velocity", [(-1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (-0.4, 0.0, 0.7), (0.0, -1.0, 0.0),
                                      (-0.2, -0.5, 0.4)])
def test_a_rounded_tip_rolls_on_the_object_without_slipping(states, velocity):
    """The finger as a rigid body, placed where finger_corner puts its tip corner, turned by
    theta + psi: its dome (centre r behind the face and r back from the corner) stays r above the
    object's top face. While d is fixed (theta and psi moving: P_theta, P_psi) the finger's
    material point at the contact moves with the object's (which turns about G at dtheta): the
    dome rolls without slipping, and the contact advances toward G over the object by r times
    the finger's turn against it (psi). When d moves, the object slides against the finger by
    dd u, the sliding of docs/model.md section 3.2. Finite differences, no formula of the code."""
    th, d, ps = states
    t, r, h = 0.04, 0.03, 1e-6

    def finger(q):
        th, d, ps = q
        corner = finger_corner(th, d, ps, t, r)
        return corner + r * (thumb_normal(th, ps) - digit_axis(th, ps)), th + ps

    u = np.stack([np.cos(th), np.sin(th)], -1)
    top = _perp(u)
    centre, _ = finger((th, d, ps))
    np.testing.assert_allclose(np.sum(centre * top, -1), t + r, atol=1e-12)  # r above the top face
    contact = centre - r * top
    # the contact on the object: (1 - d) from G when the digits lie along it, rolled r psi toward G
    np.testing.assert_allclose(np.sum(contact * u, -1), 1.0 - d - r * ps, atol=1e-12)
    v = np.asarray(velocity)
    (c1, b1), (c0, b0) = (finger(np.array([th, d, ps]) + s * h * v[:, None]) for s in (1.0, -1.0))
    v_finger = (c1 - c0) / (2 * h) + ((b1 - b0) / (2 * h))[:, None] * _perp(contact - centre)
    v_object = v[0] * _perp(contact)
    np.testing.assert_allclose(v_object - v_finger, v[1] * u, atol=1e-7)


def test_a_press_lowers_the_palm_straight_down_and_turns_it_not():
    """pressed_state(..., depth): the palm, midway between the digits' base corners on their faces
    (digit_polygons' vertex 1 of the thumb and of the finger), lies depth straight below the
    state's, the digits turned as before (theta + psi), G at the origin, the object turned down
    about G; a press of -depth brings the state back. A rounded tip on a thick object, states all
    over a plan's range, at once; a press deeper than the pinch stands finds no state."""
    digits = DigitGeometry(alpha=0.3, thumb_length=1.8, object_thickness=0.03, finger_tip_radius=0.03)
    rng = np.random.default_rng(11)
    n = 500
    q = np.column_stack([rng.uniform(0.15, 0.8, n), rng.uniform(0.3, 0.95, n), rng.uniform(0.0, 0.6, n)])
    depth = 0.03

    def palm(th, d, ps):
        thumb, finger = digit_polygons(th, d, ps, digits)
        return (thumb[:, 1] + finger[:, 1]) / 2

    th, d, ps, found = pressed_state(q[:, 0], q[:, 1], q[:, 2], depth, digits)
    assert found.all()
    np.testing.assert_allclose(palm(th, d, ps) - palm(*q.T), np.broadcast_to([0.0, -depth], (n, 2)), atol=1e-11)
    np.testing.assert_allclose(th + ps, q[:, 0] + q[:, 2], atol=1e-14)
    assert np.all(th < q[:, 0])
    back = pressed_state(th, d, ps, -depth, digits)
    np.testing.assert_allclose(np.column_stack(back[:3]), q, atol=1e-10)
    assert not pressed_state(0.3, 0.8, 0.0, 2.0, digits)[3]


def test_a_press_keeps_b_its_margin_where_the_object_lies_pressed():
    """With a press, a state is kinematically valid only if B also keeps thumb_tip_margin at the
    pressed state, s_B computed there; some states that keep it as planned lose it pressed (the
    object turns against the digits and B moves toward the thumb's tip)."""
    digits = DigitGeometry(alpha=0.47, thumb_length=1.8, object_thickness=0.03, finger_tip_radius=0.03,
                           thumb_tip_margin=0.03)
    pressed = dataclasses.replace(digits, press=0.03)
    rng = np.random.default_rng(5)
    n = 4000
    th, d, ps = rng.uniform(0.1, 0.6, n), rng.uniform(0.4, 1.0, n), rng.uniform(0.3, 1.0, n)
    plain = kinematic_validity(th, d, ps, digits)
    checks = kinematic_checks(th, d, ps, pressed)
    tp, dp, pp, found = pressed_state(th, d, ps, 0.03, pressed)
    margin_there = found & (s_b(dp, pp, 0.47, 0.03, 0.03) >= 0.03 - 1e-12)
    np.testing.assert_array_equal(checks["s_B >= 0 pressed"][plain], margin_there[plain])
    assert checks["s_B >= 0 pressed"][~plain].all()  # looked at only where the rest holds
    np.testing.assert_array_equal(kinematic_validity(th, d, ps, pressed), plain & margin_there)
    lost = plain & ~margin_there
    assert 0.01 < lost.mean() < 0.5


def test_across_support_is_where_the_supports_alone_can_balance_a_push_at_a():
    """Statics out of the plane, by linear programming: the table at G and the thumb's face at B push
    the object only along its face's normal, anywhere within their reach across the plane (the
    supports' ends, G at 0 and B at l along GB); a unit push on the face at A, d_A from B, delta
    across, is balanced (normal force and the two moments in the face's plane) by non-negative
    support forces iff |delta| <= across_support. Random supports, a rounded tip, both sides of
    the bound by 1e-6 l."""
    rng = np.random.default_rng(3)
    for _ in range(60):
        digits = DigitGeometry(alpha=0.47, finger_tip_radius=0.03, support=tuple(rng.uniform(0.0, 0.5, 2)))
        d, psi = rng.uniform(0.05, 0.95), rng.uniform(0.0, 1.0)
        x_a = 1.0 - float(contact_d(d, psi, digits.finger_tip_radius))  # A's distance from G along GB
        s_g, s_b_ = digits.support
        ends = np.array([[0.0, s_g], [0.0, -s_g], [1.0, s_b_], [1.0, -s_b_]])
        bound = float(across_support(d, psi, digits))
        for delta, balanced in ((bound - 1e-6, True), (bound + 1e-6, False), (-bound - 1e-6, False)):
            lp = linprog(np.zeros(4), A_eq=np.vstack([np.ones(4), ends.T]), b_eq=[1.0, x_a, delta],
                         bounds=[(0, None)] * 4, method="highs")
            assert (lp.status == 0) is balanced, (digits.support, d, psi, delta)


def test_the_across_margin_is_checked_where_the_object_lies_and_pressed():
    """across support holds where A lies across_margin inside the supports, as planned and (with a
    press) at the pressed state; a flat tip (an edge at A), no margin or no supports check nothing."""
    base = DigitGeometry(alpha=0.47, thumb_length=1.8, object_thickness=0.03, finger_tip_radius=0.03,
                         support=(0.0, 0.16), across_margin=0.03)
    rng = np.random.default_rng(9)
    n = 3000
    th, d, ps = rng.uniform(0.1, 0.6, n), rng.uniform(0.4, 1.0, n), rng.uniform(0.0, 1.0, n)
    checks = kinematic_checks(th, d, ps, base)
    np.testing.assert_array_equal(checks["across support"], across_support(d, ps, base) >= 0.03 - 1e-12)
    assert 0.05 < checks["across support"].mean() < 0.95
    pressed = dataclasses.replace(base, press=0.03)
    checks = kinematic_checks(th, d, ps, pressed)
    rest = np.all([v for k, v in checks.items() if "pressed" not in k], axis=0)
    _, dp, pp, found = pressed_state(th, d, ps, 0.03, pressed)
    there = found & (across_support(dp, pp, pressed) >= 0.03 - 1e-12)
    np.testing.assert_array_equal(checks["across support pressed"][rest], there[rest])
    assert (rest & ~there).any()  # some states keep it as planned and lose it pressed (A nearer G)
    for quiet in (dataclasses.replace(base, flat_finger_tip=True, finger_tip_radius=0.0),
                  dataclasses.replace(base, across_margin=0.0), dataclasses.replace(base, support=(0.0, 0.0))):
        assert not any(k.startswith("across") for k in kinematic_checks(th, d, ps, quiet))


@pytest.mark.parametrize("kind", ["open", "open_symmetric", "open_lift"])
def test_the_jaws_part_along_n_b_as_each_release_moves_them(states, kind):
    """Per unit of opening the finger moves one unit more along n_B than the thumb, and the palm
    half-way between them (a parallel gripper). open keeps the thumb on B, open_symmetric keeps
    the palm still; open_lift moves the finger along the top face's normal (away from it: nothing
    drags A along the face) and lowers the thumb by as much as open_symmetric does, half the
    opening times cos(theta + psi), while the palm does not go down (with the thumb's face turned
    down, theta + psi > pi/2, the finger still leaves the face and the thumb rises)."""
    th, _, ps = states
    go = release_travel(th, ps, kind)
    n = thumb_normal(th, ps)
    np.testing.assert_allclose(go["finger"] - go["thumb"], n, atol=1e-12)
    np.testing.assert_allclose(go["palm"], (go["finger"] + go["thumb"]) / 2, atol=1e-12)
    if kind == "open":
        np.testing.assert_allclose(go["thumb"], 0.0, atol=1e-12)
    elif kind == "open_symmetric":
        np.testing.assert_allclose(go["palm"], 0.0, atol=1e-12)
    else:
        up = np.column_stack([-np.sin(th), np.cos(th)])
        f = go["finger"]
        np.testing.assert_allclose(f[:, 0] * up[:, 1] - f[:, 1] * up[:, 0], 0.0, atol=1e-12)
        assert np.all(np.sum(f * up, axis=1) >= -1e-12)
        c = np.cos(th + ps)
        np.testing.assert_allclose(go["thumb"][:, 1], -c + np.abs(c) / 2, atol=1e-12)
        down = c > 0  # the thumb's face turned up, as at every goal
        np.testing.assert_allclose(go["thumb"][down, 1], release_travel(th, ps, "open_symmetric")["thumb"][down, 1],
                                   atol=1e-12)
        np.testing.assert_allclose(go["palm"][down, 1], 0.0, atol=1e-12)
