"""The friction margin (rad) and the kinematic margins (m): signs against force closure and the
kinematic checks, exact thresholds against the LP oracle, and its shift property."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from oracle import friction_margin_bisection, lp_force_closure
from ungrasp_ompl.geometry.collision import CollisionChecker
from ungrasp_ompl.mechanics import Friction, contact_wrenches, force_closure, kinematic_checks, thumb_clearance
from ungrasp_ompl.mechanics.force_closure import REFERENCE_MU
from ungrasp_ompl.mechanics.margin import MAX_CONE_HALF_ANGLE, friction_margin, shrinking_wrenches
from ungrasp_ompl.scene import Scene

SCENES = Path(__file__).resolve().parents[1] / "scenes"
MODES = [(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1)]


def _grid(n_theta: int = 13, n_d: int = 11, n_psi: int = 17) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    th, d, ps = np.meshgrid(np.linspace(0.0, math.pi / 2, n_theta), np.linspace(0.02, 1.0, n_d),
                            np.linspace(0.0, math.radians(150), n_psi), indexing="ij")
    return th.ravel(), d.ravel(), ps.ravel()


def _shrunk(mu: tuple[float, float, float], delta: float) -> tuple[float, float, float]:
    """Friction whose cones are narrower by delta (rad; wider when negative)."""
    return tuple(math.tan(math.atan(m) - delta) for m in mu)


@pytest.mark.parametrize("model", ["relaxed", "strict"])
@pytest.mark.parametrize("mode", MODES)
def test_sign_agrees_with_force_closure_on_a_grid(model, mode):
    th, d, ps = _grid()
    m = friction_margin(th, d, ps, *mode, Friction(REFERENCE_MU, model))
    fc = force_closure(th, d, ps, *mode, Friction(REFERENCE_MU, model))
    assert np.array_equal(m > 0, fc)
    assert fc.any() and (~fc).any()
    assert np.all(m <= min(math.atan(x) for x in REFERENCE_MU) + 1e-15)


def test_shrinking_wrenches_are_the_shrunk_cones_wrenches():
    """cos(delta) W + sin(delta) V has the direction of contact_wrenches with cones shrunk by delta."""
    th, d, ps = _grid(5, 4, 6)
    for mode in MODES:
        for model in ("relaxed", "strict"):
            w, v, mask = shrinking_wrenches(th, d, ps, *mode, Friction(REFERENCE_MU, model))
            for delta in (-0.4, 0.1, 0.18):
                ref, ref_mask = contact_wrenches(th, d, ps, *mode, Friction(_shrunk(REFERENCE_MU, delta), model))
                got = math.cos(delta) * w + math.sin(delta) * v
                got /= np.linalg.norm(got, axis=-1, keepdims=True)
                ref = ref / np.linalg.norm(ref, axis=-1, keepdims=True)
                assert np.array_equal(mask, ref_mask)
                assert np.allclose(got[mask], ref[mask], atol=1e-12)


@pytest.mark.parametrize("model", ["relaxed", "strict"])
def test_threshold_flips_the_lp_oracle(model):
    """Cones shrunk by the margin minus 1e-6 rad are force-closed for the LP oracle, and by the margin
    plus 1e-6 rad they are not: the margin is where force closure changes, on both sides of 0."""
    rng = np.random.default_rng(7)
    n = 120
    th, d, ps = rng.uniform(0, math.pi / 2, n), rng.uniform(0.05, 1, n), rng.uniform(0, math.radians(140), n)
    eps = 1e-6
    checked = {True: 0, False: 0}
    cases, wrenches, masks = [], [], []
    for mode in MODES:
        m = friction_margin(th, d, ps, *mode, Friction(REFERENCE_MU, model))
        cap = min(math.atan(x) for x in REFERENCE_MU)
        lo = max(math.atan(x) for x in REFERENCE_MU) - MAX_CONE_HALF_ANGLE
        use = np.isfinite(m) & (m < cap - 1e-9) & (m > lo + 1e-6)
        for i in np.flatnonzero(use):
            for delta, closed in ((m[i] - eps, True), (m[i] + eps, False)):
                w, mask = contact_wrenches(th[i], d[i], ps[i], *mode, Friction(_shrunk(REFERENCE_MU, delta), model))
                cases.append((mode, th[i], d[i], ps[i], m[i], delta, closed))
                wrenches.append(w[0])
                masks.append(mask[0])
            checked[bool(m[i] > 0)] += 1
    lp = lp_force_closure(np.array(wrenches), np.array(masks))  # each state its own block of one LP
    assert [case for case, closed in zip(cases, lp) if closed != case[-1]] == []
    assert checked[True] > 50 and checked[False] > 50  # thresholds inside and outside force closure


def test_states_near_the_boundary_against_the_lp_oracle():
    """States a hair's breadth from losing force closure (along theta) have margins of about zero
    and the oracle's sign. Every state is bisected at once, 60 halvings of its first flip."""
    rng = np.random.default_rng(3)
    d, ps = rng.uniform(0.3, 1, 300), rng.uniform(0, math.radians(60), 300)
    th = np.linspace(0, math.pi / 2, 2001)
    fc = force_closure(th[None, :], d[:, None], ps[:, None], 0, -1)
    flips = fc[:, 1:] != fc[:, :-1]
    has = flips.any(axis=1)
    first = np.argmax(flips, axis=1)[has]
    d, ps = d[has], ps[has]
    a, b = th[first], th[first + 1]  # bisect theta to the boundary
    fa = fc[has, first]
    for _ in range(60):
        mid = 0.5 * (a + b)
        same = force_closure(mid, d, ps, 0, -1) == fa
        a, b = np.where(same, mid, a), np.where(same, b, mid)
    for t in (a, b):
        m = friction_margin(t, d, ps, 0, -1)
        assert np.all(np.abs(m) < 1e-5)
        w, mask = contact_wrenches(t, d, ps, 0, -1)
        for k in np.flatnonzero(np.abs(m) > 1e-7):  # clear of the LP's own tolerance
            assert lp_force_closure(w[k:k + 1], mask[k:k + 1])[0] == (m[k] > 0)
    assert len(d) > 100


def test_relaxed_margin_matches_bisection():
    """Force closure is monotone in the shrink angle with relaxed sliding: plain bisection (which
    stops where force_closure's 1e-9 tolerance bites, slightly early) agrees to 1e-6 rad."""
    rng = np.random.default_rng(11)
    n = 3000
    th, d, ps = rng.uniform(0, math.pi / 2, n), rng.uniform(0, 1, n), rng.uniform(0, math.radians(150), n)
    for mode in MODES:
        m = friction_margin(th, d, ps, *mode)
        ref = friction_margin_bisection(th, d, ps, *mode)
        assert np.array_equal(np.isfinite(m), np.isfinite(ref))
        fin = np.isfinite(m)
        assert np.max(np.abs(m[fin] - ref[fin])) < 1e-6
        assert np.all(ref[fin] <= m[fin] + 1e-12)


@settings(max_examples=60, deadline=None)
@given(theta=st.floats(0.0, math.pi / 2), d=st.floats(0.05, 1.0), psi=st.floats(0.0, 2.4),
       a=st.sampled_from((-1, 0, 1)), b=st.sampled_from((-1, 0, 1)), model=st.sampled_from(("relaxed", "strict")),
       delta=st.floats(-0.1, 0.1))
def test_margin_shifts_with_the_cones(theta, d, psi, a, b, model, delta):
    """Cones narrower by delta leave a margin smaller by delta (while neither window's end bites),
    where force closure is the same all the way from the new cones to the old margin's threshold:
    always with relaxed sliding (monotone in the cones); with strict sliding, whose closure can come
    and go along delta, where force_closure itself says so along that stretch."""
    m = friction_margin(theta, d, psi, a, b, Friction(REFERENCE_MU, model))[0]
    m2 = friction_margin(theta, d, psi, a, b, Friction(_shrunk(REFERENCE_MU, delta), model))[0]
    cap = min(math.atan(x) for x in REFERENCE_MU)
    lo = max(math.atan(x) for x in REFERENCE_MU) - MAX_CONE_HALF_ANGLE
    if not (np.isfinite(m) and lo + 0.2 < m < cap - 0.2):
        return
    stretch = delta + (m - delta) * np.linspace(0.0, 1.0, 101)[:-1]  # from the new cones up to m, m left out
    closed = [bool(force_closure(theta, d, psi, a, b, Friction(_shrunk(REFERENCE_MU, t), model))[0]) for t in stretch]
    if model == "relaxed":
        assert all(c == (m > delta) for c in closed)
    if all(c == (m > delta) for c in closed):
        assert m2 == pytest.approx(m - delta, abs=1e-7)


@settings(max_examples=40, deadline=None)
@given(theta=st.floats(0.0, math.pi / 2), d=st.floats(0.05, 1.0), psi=st.floats(0.0, 2.4),
       a=st.sampled_from((-1, 0, 1)), b=st.sampled_from((-1, 0, 1)), u=st.floats(0.01, 0.99))
def test_relaxed_force_closure_holds_all_the_way_to_the_margin(theta, d, psi, a, b, u):
    """With relaxed sliding, cones shrunk by any fraction of a positive margin stay force-closed, and
    cones grown by a fraction of a negative margin's size are not yet."""
    m = friction_margin(theta, d, psi, a, b)[0]
    if not np.isfinite(m) or abs(m) < 1e-6:
        return
    delta = u * m
    fc = force_closure(theta, d, psi, a, b, Friction(_shrunk(REFERENCE_MU, delta)))[0]
    assert fc == (m > 0)


# -- the scene's margins -----------------------------------------------------------------------
def test_scene_margin_units_and_modes():
    scene = Scene.from_file(SCENES / "reference_asymmetric.yaml")
    q = np.array([scene.start, scene.start])
    dq = np.array([[0, 0, 0], [0, -1, 0.5]])
    m = scene.margin(q, dq)
    assert m.friction.shape == (2,)
    assert m.friction[0] == pytest.approx(friction_margin(*scene.start, 0, 0, scene.friction)[0])
    assert m.friction_deg[0] == pytest.approx(math.degrees(m.friction[0]))
    assert (m.friction[0] > 0) == bool(scene.force_closure(q[:1])[0])
    assert (m.friction[1] > 0) == bool(scene.force_closure(q[1:], dq[1:])[0])
    # B from the thumb tip: s_B = d cos psi - alpha (a segment, point finger), in metres
    assert m.kinematic["thumb_tip"][0] == pytest.approx((0.8 - 0.47) * scene.object_length)
    assert m.kinematic_mm["thumb_tip"][0] == pytest.approx((0.8 - 0.47) * scene.object_length * 1000)
    with pytest.raises(ValueError, match="dq"):
        scene.margin(q, dq[:1])


def test_kinematic_margins_change_sign_where_the_checks_flip():
    scene = Scene.from_file(SCENES / "reference_upper_obstacle.yaml")
    th, d, ps = _grid(25, 21, 31)
    q = np.column_stack([th, d, ps])
    m = scene.margin(q).kinematic
    checks = kinematic_checks(th, d, ps, scene.digits)
    assert np.array_equal(m["thumb_tip"] >= -1e-12, checks["s_B >= 0"])
    assert np.array_equal(m["thumb_base"] >= -1e-12, checks["s_B <= thumb_length"])
    assert np.all(m["table"] <= thumb_clearance(th, d, ps, scene.digits) * scene.object_length + 1e-15)
    # the digits against the obstacle: the same verdict as FCL's narrow phase (away from grazing)
    checker = CollisionChecker(scene.collision_model())
    clear = np.abs(m["obstacles"]) > 1e-6
    idx = np.flatnonzero(clear & (np.abs(m["table"]) > 1e-6))
    rng = np.random.default_rng(0)
    idx = rng.choice(idx, 400, replace=False)
    hits = np.array([any(c.split("/")[0] in ("thumb", "finger") and c.endswith("upper_corner")
                         for c in checker.contacts(q[i])) for i in idx])
    assert hits.any() and (~hits).any()
    assert np.array_equal(hits, m["obstacles"][idx] < 0)
    # digits into the table: the same verdict as the collision checker
    table_hits = np.array([any(c in ("thumb/table", "finger/table") for c in checker.contacts(q[i])) for i in idx])
    assert np.array_equal(table_hits, m["table"][idx] < 0)
