"""Curved sections (mechanics.section): the top's geometry against independent oracles (scipy's
elliptic integral, circles, finite differences), the finger rolling on it without slip, the
force analysis with the top's true normals against the LP oracle, the solid the collision check
uses, the scene fields that give a section (bad ones refused naming the field), and the reference
planner's example 6 (scenes/reference_semi_ellipse.yaml)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import yaml

from conftest import SCENES
from oracle import lp_force_closure
from ungrasp_ompl.errors import InputError, UnknownFieldError
from ungrasp_ompl.mechanics import DigitGeometry, contact_wrenches, force_closure, force_closure_margin
from ungrasp_ompl.mechanics import kinematics as kin
from ungrasp_ompl.mechanics.force_closure import Friction, SectionContact, SlidingModel
from ungrasp_ompl.mechanics.section import Section, SectionError, finger_contact
from ungrasp_ompl.scene import Scene

SEMI = Section.semi_ellipse(0.25)
CURVED = {"semi_ellipse": SEMI, "lens": Section.lens(0.12, 0.04), "plano_lens": Section.lens(0.2, 0.0),
          "rounded_rim": Section.rounded_rim(0.1, 0.03),
          "profile": Section.profile(np.column_stack([np.linspace(0, 1, 41),
                                                      0.1 * np.sqrt(np.clip(1 - (2 * np.linspace(0, 1, 41) - 1) ** 2,
                                                                            0, None)) ** 0.5 + 0.02]))}


def _rot(v, a):
    c, s = np.cos(a), np.sin(a)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


# -- the section's top --------------------------------------------------------------------------------
def test_semi_ellipse_arc_length_is_the_elliptic_integral():
    """The top's arc length from B's end to the point at parametric angle t of the ellipse
    (x = 1/2 + cos t / 2, z = b sin t) is b E(t | 1 - 1/(4 b^2))... written for scipy as the
    incomplete integral of the second kind along the ellipse's other axis."""
    from scipy.special import ellipeinc

    for b in (0.25, 0.1, 0.5):
        sec = Section.semi_ellipse(b)
        a = 0.5
        t = np.linspace(0.0, math.pi, 13)
        # x = a cos t, z = b sin t: ds = sqrt(a^2 sin^2 t + b^2 cos^2 t) dt = a sqrt(1 - m cos^2 t) dt,
        # m = 1 - b^2/a^2; with t = pi/2 - v, cos t = sin v: s(t) = a (E(pi/2 | m) - E(pi/2 - t | m))
        m = 1.0 - (b / a) ** 2
        expected = a * (ellipeinc(math.pi / 2, m) - ellipeinc(math.pi / 2 - t, m))
        s = np.array([sec.angle_at(np.arctan2(b * np.cos(x), a * np.sin(x)) * -1.0) for x in t[1:-1]])
        assert sec.top_length == pytest.approx(2 * a * ellipeinc(math.pi / 2, m), abs=1e-13)
        points = sec.at(expected).point
        np.testing.assert_allclose(points, np.column_stack([0.5 + a * np.cos(t), b * np.sin(t)]), atol=1e-12)
        np.testing.assert_allclose(s, expected[1:-1], atol=1e-11)


def test_lens_arcs_are_circles():
    """A lens's top is a circular arc through G and B rising thickness - bottom above GB: every point
    is the radius from the centre, the curvature is 1/radius, and the arc length is radius times the
    angle it spans; its bottom rises from GB at G and B by the bottom arc's end angle."""
    sec = Section.lens(0.12, 0.04)
    h = 0.08
    rad = (0.25 + h * h) / (2 * h)
    centre = np.array([0.5, h - rad])
    tp = sec.at(np.linspace(0, sec.top_length, 31))
    np.testing.assert_allclose(np.linalg.norm(tp.point - centre, axis=-1), rad, atol=1e-12)
    np.testing.assert_allclose(tp.kappa, 1 / rad, rtol=1e-10)
    span = 2 * math.asin(0.5 / rad)
    assert sec.top_length == pytest.approx(rad * span, rel=1e-12)
    assert sec.height == pytest.approx(h, abs=1e-12)
    rb = (0.25 + 0.04 ** 2) / (2 * 0.04)
    assert sec.rim_angles[0] == pytest.approx(math.asin(0.5 / rb), rel=1e-12)
    poly = sec.polygon(32)
    assert poly[:, 1].min() == pytest.approx(-0.04, abs=1e-3) and poly[:, 1].max() == pytest.approx(h, abs=1e-3)


@pytest.mark.parametrize("name", sorted(CURVED))
def test_the_top_is_parametrised_by_arc_length_with_unit_outward_normals(name):
    """By central differences in s: |dP/ds| = 1, the normal is unit and orthogonal to dP/ds and
    points out of the section (to the right of the top run from B to G), and dphi/ds = kappa >= 0."""
    sec = CURVED[name]
    s = np.linspace(0.02, sec.top_length - 0.02, 57)
    h = 1e-6
    tp, lo, hi = sec.at(s), sec.at(s - h), sec.at(s + h)
    tangent = (hi.point - lo.point) / (2 * h)
    np.testing.assert_allclose(np.linalg.norm(tangent, axis=-1), 1.0, atol=1e-7)
    np.testing.assert_allclose(np.linalg.norm(tp.normal, axis=-1), 1.0, atol=1e-14)
    np.testing.assert_allclose(np.sum(tangent * tp.normal, axis=-1), 0.0, atol=1e-7)
    np.testing.assert_allclose(tangent[:, 0] * tp.normal[:, 1] - tangent[:, 1] * tp.normal[:, 0], -1.0, atol=1e-7)
    np.testing.assert_allclose((hi.phi - lo.phi) / (2 * h), tp.kappa, rtol=1e-5, atol=1e-5)
    assert np.all(tp.kappa >= 0)
    np.testing.assert_allclose(tp.normal, np.column_stack([-np.sin(tp.phi), np.cos(tp.phi)]), atol=1e-14)
    np.testing.assert_allclose(sec.at(sec.angle_at(tp.phi)).phi, tp.phi, atol=1e-9)  # angle_at inverts phi
    turning = tp.kappa > 1e-3  # where phi turns, only at s
    np.testing.assert_allclose(sec.angle_at(tp.phi[turning]), s[turning], atol=1e-9)


def test_a_sampled_profile_follows_its_curve():
    """A profile sampled from a semi-ellipse, smoothed by the spline, gives back the semi-ellipse's
    arc length and its points to the samples' resolution."""
    t = np.linspace(math.pi, 0.0, 201)  # from G's end to B's end
    pts = np.column_stack([0.5 + 0.5 * np.cos(t), 0.25 * np.sin(t)])
    prof = Section.profile(pts)
    assert prof.top_length == pytest.approx(SEMI.top_length, rel=2e-4)
    assert prof.thickness == pytest.approx(0.25, abs=1e-4)
    s = np.linspace(0.05, SEMI.top_length - 0.05, 9)
    np.testing.assert_allclose(prof.at(s * prof.top_length / SEMI.top_length).point, SEMI.at(s).point, atol=2e-3)


def test_bad_sections_are_refused():
    with pytest.raises(SectionError, match="convex"):
        Section.profile([[0, 0.1], [0.3, 0.05], [0.6, 0.12], [1.0, 0.1]])
    with pytest.raises(SectionError, match="from G's end"):
        Section.profile([[0.1, 0.1], [0.3, 0.15], [0.6, 0.15], [1.0, 0.1]])
    with pytest.raises(SectionError, match="thickness"):
        Section.semi_ellipse(0.0)
    with pytest.raises(SectionError, match="bottom"):
        Section.lens(0.1, 0.1)
    with pytest.raises(SectionError, match="kind"):
        Section("cylinder", 0.1)


# -- the finger rolling on it -------------------------------------------------------------------------
def _states(rng, n, sec, r):
    """Random (theta, d, psi) with the finger inside the top (on the dome or the corner, or on the face)."""
    theta = rng.uniform(0.05, 1.4, n)
    psi = rng.uniform(0.0, 1.3, n)
    d = rng.uniform(0.05, sec.top_length + 0.3, n)
    c = finger_contact(sec, d, psi, r)
    ok = (c.top.s > 0.02) & (c.top.s < sec.top_length - 0.02) & (c.beta < math.pi / 2 - 0.02)
    return theta[ok], d[ok], psi[ok]


@pytest.mark.parametrize("r", [0.0, 0.03])
@pytest.mark.parametrize("name", ["semi_ellipse", "lens", "rounded_rim", "profile"])
def test_the_finger_touches_the_top_where_their_normals_meet(name, r):
    """At the contact the finger's own profile point (its face, or its dome r from the dome's
    centre at the finger's arc sigma_f) is the top's point, and the finger's outward normal there is
    the top's inward one; every point of the section lies on the inner side of the tangent line
    there, and every point of the finger's outline (digit_polygons) on the outer side."""
    sec = CURVED[name]
    rng = np.random.default_rng(5)
    dg = DigitGeometry(alpha=0.47, finger_tip_radius=r, finger_tip_thickness=max(0.05, 2 * r), section=sec)
    theta, d, psi = _states(rng, 300, sec, r)
    pinch = kin.section_pinch(d, psi, r, sec)
    c = pinch["contact"]
    e, n = pinch["e"], pinch["n"]
    for i in range(len(d)):
        sf = c.sigma_f[i]
        face_end = pinch["corner"][i] - r * e[i]  # where the dome meets the face; the body lies along +n_B
        if sf <= 0.0 or r == 0.0:
            point, normal_f = face_end + min(sf, 0.0) * e[i], -n[i]
        else:
            b = sf / r  # round the dome from its face end: its outward normal turns from -n_B toward e
            normal_f = -n[i] * math.cos(b) + e[i] * math.sin(b)
            point = face_end + r * n[i] + r * normal_f
        np.testing.assert_allclose(point, c.top.point[i], atol=1e-9)
        if sf < 0.0 or (r > 0.0 and sf > 0.0):  # a sharp corner's normal is the top's, whatever it is
            np.testing.assert_allclose(normal_f, -c.top.normal[i], atol=1e-9)
    poly = sec.polygon(200)
    side = np.sum((poly[None] - c.top.point[:, None]) * c.top.normal[:, None], axis=-1)
    assert side.max() <= 1e-9
    _, finger = kin.digit_polygons(theta, d, psi, dg)
    normal_w = _rot(c.top.normal, theta)
    a_w = kin.contact_point(theta, d, psi, 0.0, r, sec)
    finger[:, [0, 3]] -= r * kin.digit_axis(theta, psi)[:, None]  # a rounded finger is ball-nosed: its dome
    dome = kin.dome_centre(theta, d, psi, 0.0, r, sec)
    assert np.sum((finger - a_w[:, None]) * normal_w[:, None], axis=-1).min() >= -1e-9
    np.testing.assert_allclose(np.sum((dome - a_w) * normal_w, axis=-1), r, atol=1e-9) if r else None
    assert np.sum((dome - a_w) * normal_w, axis=-1).min() >= r - 1e-9


@pytest.mark.parametrize("r", [0.0, 0.03])
@pytest.mark.parametrize("name", ["semi_ellipse", "lens", "rounded_rim", "profile"])
def test_the_finger_rolls_without_slip_and_slides_by_dd(name, r):
    """By central differences of the placed finger (finger_corner, turned with theta + psi): in a
    P_psi (d held) the finger's material point at A moves with the object's (which stands still),
    the contact moving over the top by the arc the finger rolls over (ds = dsigma_f); in a P_theta
    the two turn together about G; moving d alone, the object slips past the finger at A by dd
    along the top's tangent toward B's end (docs/model.md 3.2)."""
    sec = CURVED[name]
    theta, d, psi = _states(np.random.default_rng(9), 200, sec, r)
    h = 1e-6

    def material(th, dd, ps, th1, dd1, ps1):
        """Where the finger's material point at A in (th, dd, ps) is in (th1, dd1, ps1)."""
        corner0 = kin.finger_corner(th, dd, ps, 0.0, r, sec)
        corner1 = kin.finger_corner(th1, dd1, ps1, 0.0, r, sec)
        a0 = kin.contact_point(th, dd, ps, 0.0, r, sec)
        return corner1 + _rot(a0 - corner0, (th1 + ps1) - (th + ps))

    a = kin.contact_point(theta, d, psi, 0.0, r, sec)
    moved = (material(theta, d, psi, theta, d, psi + h) - material(theta, d, psi, theta, d, psi - h)) / (2 * h)
    np.testing.assert_allclose(moved, 0.0, atol=2e-6)  # rolling: no velocity at the contact
    c0, c1 = finger_contact(sec, d, psi, r), finger_contact(sec, d, psi + 0.01, r)
    np.testing.assert_allclose(c1.top.s - c0.top.s, c1.sigma_f - c0.sigma_f, atol=1e-12)
    turned = (material(theta, d, psi, theta + h, d, psi) - material(theta, d, psi, theta - h, d, psi)) / (2 * h)
    np.testing.assert_allclose(turned, np.column_stack([-a[:, 1], a[:, 0]]), atol=2e-6)  # turning with the object
    slid = (material(theta, d, psi, theta, d + h, psi) - material(theta, d, psi, theta, d - h, psi)) / (2 * h)
    normal_w = _rot(finger_contact(sec, d, psi, r).top.normal, theta)
    toward_b = np.column_stack([normal_w[:, 1], -normal_w[:, 0]])
    np.testing.assert_allclose(-slid, toward_b, atol=2e-6)  # v_object - v_finger = dd * tangent toward B


def test_b_slides_the_way_the_segment_s_rule_says_on_a_semi_ellipse():
    """The sliding sign at B the contact code takes from the segment's ds_B (contact.sliding_signs)
    holds on a curved section where the state opens the gripper: by finite differences of s_B,
    ds_B/dpsi < 0 (a P_psi slides B toward the palm) and ds_B/dd > 0 (a P_dpsi, d down, too)."""
    theta, d, psi = _states(np.random.default_rng(3), 400, SEMI, 0.02)
    w = kin.aperture(d, psi, 0.0, 0.02, SEMI)
    keep = (w > 1e-3) & (psi < math.pi / 2 - 0.05)
    d, psi = d[keep], psi[keep]
    h = 1e-6

    def sb(dd, ps):
        return kin.s_b(dd, ps, 0.47, 0.0, 0.02, SEMI)

    assert np.all((sb(d, psi + h) - sb(d, psi - h)) / (2 * h) < 0)
    assert np.all((sb(d + h, psi) - sb(d - h, psi)) / (2 * h) > 0)


def test_a_slab_section_gives_today_s_numbers_exactly_and_the_rolling_law_agrees_with_them():
    """DigitGeometry.section = Section.slab(t) changes nothing, bit for bit; the curved code run on
    the slab's flat top (section_pinch) gives the closed forms of docs/model.md 2.4 and 2.6."""
    rng = np.random.default_rng(1)
    theta, d, psi = rng.uniform(0.05, 1.4, 500), rng.uniform(0.05, 0.9, 500), rng.uniform(0.01, 1.5, 500)
    t, r = 0.04, 0.02
    base = DigitGeometry(alpha=0.4, object_thickness=t, finger_tip_radius=r, palm_width=0.5, palm_length=0.3)
    slab = replace(base, section=Section.slab(t))
    for f in (kin.thumb_clearance, kin.digits_clearance):
        assert np.array_equal(f(theta, d, psi, base), f(theta, d, psi, slab))
    assert np.array_equal(kin.across_support(d, psi, base), kin.across_support(d, psi, slab))
    for a, b in zip(kin.digit_polygons(theta, d, psi, base), kin.digit_polygons(theta, d, psi, slab)):
        assert np.array_equal(a, b)
    for name, a in kin.kinematic_checks(theta, d, psi, base).items():
        assert np.array_equal(a, kin.kinematic_checks(theta, d, psi, slab)[name])
    pinch = kin.section_pinch(d, psi, r, Section.slab(t))
    corner = _rot(pinch["corner"], theta)
    np.testing.assert_allclose(corner, kin.finger_corner(theta, d, psi, t, r), atol=1e-12)
    rel = pinch["corner"] - [1.0, 0.0]
    np.testing.assert_allclose(np.sum(rel * pinch["n"], -1), kin.aperture(d, psi, t, r), atol=1e-12)
    np.testing.assert_allclose(np.sum(rel * pinch["e"], -1) - 0.4, kin.s_b(d, psi, 0.4, t, r), atol=1e-12)
    np.testing.assert_allclose(1 - pinch["a"][:, 0], kin.contact_d(d, psi, r), atol=1e-12)


def test_a_rounded_rim_is_a_slab_with_quarter_circles():
    """Its top is the slab's between the rims and quarter circles of its radius over them; on the
    flat the finger rolls as on a slab (d_A = d + r psi)."""
    sec = Section.rounded_rim(0.1, 0.03)
    assert sec.top_length == pytest.approx(1 - 0.06 + math.pi * 0.03, abs=1e-12)
    assert sec.ends_on_gb == (False, False) and Section.rounded_rim(0.1, 0.1).ends_on_gb == (True, True)
    tp = sec.at(np.linspace(0.0, math.pi / 2 * 0.03, 9))  # B's rim
    np.testing.assert_allclose(np.linalg.norm(tp.point - [0.97, 0.07], axis=-1), 0.03, atol=1e-12)
    d, psi = np.linspace(0.2, 0.8, 7), np.linspace(0.1, 0.5, 7)
    np.testing.assert_allclose(kin.contact_d(d, psi, 0.02, sec), d - math.pi / 2 * 0.03 + 0.03 + 0.02 * psi,
                               atol=1e-12)  # the arc from B's end reaches the flat 0.03 in from B


def test_the_pressed_state_on_a_section_lowers_the_palm_by_the_press():
    """pressed_state on a curved section (Newton's method with the rolling's derivatives): the palm
    (the thumb's base, half the opening across) lies exactly the press lower, the digits turned the
    same; run on a slab's section it gives the closed form's states."""
    dg = DigitGeometry(alpha=0.47, finger_tip_radius=0.03, section=SEMI)
    theta, d, psi = _states(np.random.default_rng(4), 300, SEMI, 0.03)

    def palm(th, dd, ps, digits):
        tip = kin.thumb_tip(th, dd, ps, digits.alpha, 0.0, digits.finger_tip_radius, digits.section)
        w = kin.aperture(dd, ps, 0.0, digits.finger_tip_radius, digits.section)
        return tip - digits.thumb_length * kin.digit_axis(th, ps) + (w / 2)[:, None] * kin.thumb_normal(th, ps)

    th1, d1, ps1, found = kin.pressed_state(theta, d, psi, 0.02, dg)
    assert found.mean() > 0.8
    np.testing.assert_allclose(th1 + ps1, theta + psi, atol=1e-12)
    moved = (palm(th1, d1, ps1, dg) - palm(theta, d, psi, dg))[found]
    np.testing.assert_allclose(moved, np.broadcast_to([0.0, -0.02], moved.shape), atol=1e-10)
    t, r = 0.05, 0.02
    closed = DigitGeometry(alpha=0.4, object_thickness=t, finger_tip_radius=r)
    rng = np.random.default_rng(2)
    theta, d, psi = rng.uniform(0.2, 1.0, 200), rng.uniform(0.3, 0.9, 200), rng.uniform(0.05, 1.0, 200)
    a = kin.pressed_state(theta, d, psi, 0.02, closed)
    b = kin._pressed_on_section(theta, d, psi, 0.02, replace(closed, section=Section.slab(t)), 8)
    assert np.array_equal(a[3], b[3]) and a[3].mean() > 0.8
    for x, y in zip(a[:3], b[:3]):
        np.testing.assert_allclose(x[a[3]], y[a[3]], atol=1e-12)


def test_semi_ellipse_rolls_the_reference_planner_s_way():
    """With a sharp finger tip (r = 0) and its face on the semi-ellipse, the contact lies where the
    top's tangent is the face's: d_A = 1/2 + a tan psi / sqrt(b^2/a^2 + tan^2 psi) from B (the
    reference planner's example 6), until it reaches the tip; from there it stays."""
    psi = np.radians(np.linspace(0, 60, 61))
    a, b = 0.5, 0.25
    closed = a + a * np.tan(psi) / np.sqrt(b * b / a / a + np.tan(psi) ** 2)
    d_a = kin.contact_d(2.0, psi, 0.0, SEMI)  # the tip far beyond: the face touches all along
    np.testing.assert_allclose(d_a, closed, atol=1e-12)
    stop = 0.75
    s_stop = SEMI.at(SEMI.angle_at(math.atan(b * (stop - a) / (a * a * math.sqrt(1 - ((stop - a) / a) ** 2)))))
    d_a = kin.contact_d(float(s_stop.s), psi, 0.0, SEMI)
    np.testing.assert_allclose(d_a, np.minimum(closed, stop), atol=1e-9)


# -- force closure ------------------------------------------------------------------------------------
@pytest.mark.parametrize("model", list(SlidingModel))
@pytest.mark.parametrize("r", [0.0, 0.03])
def test_force_closure_on_a_semi_ellipse_agrees_with_the_lp(model, r):
    """The closed form with A where the finger touches the top and pushing along its inward normal
    (Friction.contact_a) decides as the LP oracle on the same wrenches, in every contact mode, on
    random states of a semi-ellipse; and those wrenches are the kinematics' contact point and normal."""
    rng = np.random.default_rng(11)
    n = 2000
    theta, d, psi = rng.uniform(0, math.pi / 2, n), rng.uniform(0.0, 1.6, n), rng.uniform(0, 1.6, n)
    friction = Friction(model=model, contact_a=SectionContact(SEMI, r))
    for a_sign in (-1, 0, 1):
        for b_sign in (-1, 0, 1):
            w, mask = contact_wrenches(theta, d, psi, a_sign, b_sign, friction)
            fc = force_closure(theta, d, psi, a_sign, b_sign, friction)
            margin = force_closure_margin(theta, d, psi, a_sign, b_sign, friction)
            lp = lp_force_closure(w, mask)
            sure = np.abs(margin) > 1e-7
            assert np.array_equal(fc[sure], lp[sure]), (a_sign, b_sign)
            assert np.array_equal(fc, margin > 1e-9)
            assert 0.05 < fc.mean() < 0.95 or (a_sign, b_sign) != (0, 0)
    # A's wrench is the unit force along the top's inward normal at the contact point
    w, mask = contact_wrenches(theta, d, psi, 0, 0, Friction(mu=(0.2, 0.0, 0.3), contact_a=SectionContact(SEMI, r)))
    p = kin.contact_point(theta, d, psi, 0.0, r, SEMI)
    f = -_rot(finger_contact(SEMI, d, psi, r).top.normal, theta)
    np.testing.assert_allclose(w[:, 2, 1:], f, atol=1e-12)
    np.testing.assert_allclose(w[:, 2, 0], p[:, 0] * f[:, 1] - p[:, 1] * f[:, 0], atol=1e-12)


def test_force_closure_on_a_lattice_matches_state_by_state():
    """Given as three axes (a lattice), the curved contact's wrenches take every state's shape and
    decide as the same states one by one."""
    friction = Friction(contact_a=SectionContact(SEMI, 0.0))
    th, d, ps = np.radians(np.arange(0, 60, 7.5)), np.linspace(0.6, 1.0, 9), np.radians(np.arange(0, 60, 5))
    grid = force_closure(th[:, None, None], d[None, :, None], ps[None, None, :], 0, -1, friction)
    T, D, P = np.meshgrid(th, d, ps, indexing="ij")
    flat = force_closure(T.ravel(), D.ravel(), P.ravel(), 0, -1, friction)
    assert grid.shape == T.shape and np.array_equal(grid.ravel(), flat) and 0 < flat.mean() < 1


# -- collision ------------------------------------------------------------------------------------
def test_the_collision_check_uses_the_curved_solid():
    """An obstacle just above the semi-ellipse's apex but below the slab's top of the same thickness
    is hit by neither... the semi-ellipse misses a box over its end that its bounding slab would
    hit, and hits one over its apex."""
    from ungrasp_ompl.geometry.collision import Box, CollisionChecker, CollisionModel

    l = 0.06
    dg = DigitGeometry(alpha=0.47, object_thickness=0.25, section=SEMI, width=0.3)
    # at theta = 0 the object lies along x from 0 to l, its top 0.25 l high at the middle
    corner = Box("corner", (0.002, 0.012), (0.006, 0.02))  # above the end: inside the slab, outside the ellipse
    apex = Box("apex", (0.029, 0.0145), (0.031, 0.02))  # touches the ellipse's apex region
    q = np.array([[1e-9, 0.9, 0.5]])
    hit = {}
    for box in (corner, apex):
        checker = CollisionChecker(CollisionModel(l, 0.25 * l, dg, (box,)))
        hit[box.name] = bool(checker._hits({"object": checker._object_pose(q[:, 0])})[0])
    assert hit == {"corner": False, "apex": True}


# -- scenes ---------------------------------------------------------------------------------------
def _doc(section, **object_fields):
    doc = yaml.safe_load((SCENES / "reference_semi_ellipse.yaml").read_text())
    doc["object"] = {"length": 0.06, "thickness": 0.015, "section": section, **object_fields}
    return doc


@pytest.mark.parametrize("section, field", [
    ("cylinder", "object.section"),
    ({"lens": {"bottom": 0.02}}, "object.section.lens.bottom"),
    ({"lens": {"bottom": -0.001}}, "object.section.lens.bottom"),
    ({"profile": {"points": [[0, 0.01], [0.02, 0.005], [0.04, 0.012], [0.06, 0.01]]}}, "object.section.profile"),
    ({"profile": {"points": [[0, 0.01], [0.02, 0.015], [0.04, 0.015], [0.05, 0.01]]}}, "object.section.profile.points"),
    ({"profile": {"points": [[0, 0.01], [0.06, 0.01]]}}, "object.section.profile.points"),
    ({"profile": {"points": "a"}}, "object.section.profile.points"),
    ({"semi_ellipse": {}, "lens": {}}, "object.section"),
    (3, "object.section"),
    ({"rounded_rim": {"radius": 0.02}}, "object.section.rounded_rim.radius"),
    ({"rounded_rim": {"radius": 0}}, "object.section.rounded_rim.radius"),
])
def test_bad_section_fields_are_refused_naming_the_field(section, field):
    with pytest.raises(InputError) as err:
        Scene.from_dict(_doc(section))
    assert err.value.field == field, err.value


def test_more_bad_section_scenes():
    with pytest.raises(UnknownFieldError) as err:
        Scene.from_dict(_doc({"lens": {"depth": 0.001}}))
    assert err.value.field == "object.section.lens.depth"
    with pytest.raises(InputError) as err:
        Scene.from_dict(_doc("semi_ellipse", thickness=0.0))
    assert err.value.field == "object.thickness"
    prof = {"profile": {"points": [[0, 0.0], [0.015, 0.004], [0.03, 0.005], [0.045, 0.004], [0.06, 0.0]]}}
    with pytest.raises(InputError) as err:  # the thickness must be the profile's height
        Scene.from_dict(_doc(prof, thickness=0.01))
    assert err.value.field == "object.thickness"
    doc = _doc("semi_ellipse")
    doc["bounds"] = {"d": [0.0, 1.3]}
    with pytest.raises(InputError) as err:
        Scene.from_dict(doc)
    assert err.value.field == "bounds.d" and "1.21106" in str(err.value)
    doc = yaml.safe_load((SCENES / "guitar_pick.yaml").read_text())
    doc["object"]["section"] = "semi_ellipse"
    with pytest.raises(InputError) as err:
        Scene.from_dict(doc)
    assert err.value.field == "object.section" and "circle" in str(err.value)


def test_a_section_scene_loads_with_its_section_over_l():
    doc = _doc({"lens": {"bottom": 0.005}})
    scene = Scene.from_dict(doc)
    sec = scene.digits.section
    assert sec.kind == "lens" and sec.thickness == pytest.approx(0.25) and sec.bottom == pytest.approx(0.005 / 0.06)
    assert scene.friction.contact_a == SectionContact(sec, scene.digits.finger_tip_radius)
    prof = {"profile": {"points": [[0, 0.0], [0.015, 0.004], [0.03, 0.005], [0.045, 0.004], [0.06, 0.0]]}}
    scene = Scene.from_dict(_doc(prof, thickness=0.005))
    assert scene.object_thickness == pytest.approx(0.005, rel=1e-3)
    assert Scene.from_dict(_doc("slab")).digits.section is None


@pytest.mark.parametrize("name", ["go_stone", "coin"])
def test_the_round_objects_load_with_their_sections_and_revolved_solids(name):
    """The Go stone (a semi-ellipse) and the coin (a rounded rim) on circle outlines: the section
    over l, the object's solid the section turned about the axis, their starts held."""
    from ungrasp_ompl.geometry.collision import object_solid

    scene = Scene.from_file(name)
    sec = scene.digits.section
    assert sec.kind == {"go_stone": "semi_ellipse", "coin": "rounded_rim"}[name]
    assert scene.object_thickness == pytest.approx(sec.thickness * scene.object_length)
    assert scene.is_valid(scene.start)[0] and scene.planar_only is None
    solid = object_solid(sec, scene.object_length, 0.02, True)
    radius = np.hypot(solid[:, 0] - scene.object_length / 2, solid[:, 1])
    assert radius.max() == pytest.approx(scene.object_length / 2, rel=1e-9)
    assert solid[:, 2].max() == pytest.approx(scene.object_thickness, rel=1e-3)


def test_example_6_is_solved_by_p_psi_then_p_theta_with_d_a_rising_as_the_face_rolls():
    """scenes/reference_semi_ellipse.yaml (the reference planner's example 6, its goal brought to where
    B stays on the thumb): the exact lattice plan is the reference's sequence, one P_psi (the
    finger's face rolling over the stone, then its tip held on one point) and one P_theta; along the
    P_psi the contact runs from the apex (d_A = 1/2) toward G, nonlinearly in psi, d held; the same
    seed gives RRT* the same plan."""
    from ungrasp_ompl.planning import plan

    scene = Scene.from_file(SCENES / "reference_semi_ellipse.yaml")
    result = plan(scene, planner="lattice")
    assert result.solved
    assert [p.type.value for p in result.solution.primitives] == ["P_psi", "P_theta"]
    leg = result.solution.primitives[0]
    (th, d, ps0), (_, d1, ps1) = leg.start, leg.end
    assert d == d1 and th == pytest.approx(math.radians(30))
    psi = np.linspace(ps0, ps1, 41)
    d_a = kin.contact_d(d, psi, scene.digits.finger_tip_radius, scene.digits.section)
    assert d_a[0] == pytest.approx(0.5, abs=1e-9) and np.all(np.diff(d_a) >= -1e-12) and d_a[-1] > 0.55
    rolling = d_a < d_a[-1] - 1e-9
    closed = 0.5 + 0.5 * np.tan(psi) / np.sqrt(0.25 + np.tan(psi) ** 2)  # the reference's rolling law
    assert 5 < rolling.sum() < 40 and np.allclose(d_a[rolling], closed[rolling], atol=1e-12)
    assert np.ptp(np.diff(d_a[rolling])) > 1e-4  # nonlinear in psi
    again = [plan(scene, planner="RRTstar", seed=4, iterations=3000).solution.states for _ in range(2)]
    assert again[0] == again[1] and again[0]
