"""Force closure: the closed form against an LP oracle, and the model's anchors."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from oracle import lp_force_closure
from ungrasp_ompl.mechanics import Friction, cone_edges, contact_wrenches, force_closure, force_closure_margin

MU = tuple(math.tan(math.radians(a)) for a in (11, 17, 17))
MODES = list(itertools.product((-1, 0, 1), repeat=2))  # (A, B): stick, or sliding with the sign of dd / ds_B


def random_states(n: int, seed: int):
    rng = np.random.default_rng(seed)
    return rng.uniform(0, math.pi / 2, n), rng.uniform(0, 1, n), rng.uniform(0, math.radians(120), n)


@pytest.mark.parametrize("model", ["relaxed", "strict"])
@pytest.mark.parametrize("mode", MODES, ids=lambda m: f"A{m[0]:+d}B{m[1]:+d}")
def test_closed_form_equals_lp_oracle(model, mode):
    """On 10,000 random states per contact mode and sliding model the closed form agrees with the LP,
    asked for all the states at once and a hundred at a time (which force_closure computes another
    way: every triple product at once, STACKED_STATES)."""
    n = 10_000
    th, d, ps = random_states(n, seed=hash((model, mode)) % 2**32)
    friction = Friction(MU, model)
    w, mask = contact_wrenches(th, d, ps, mode[0], mode[1], friction)
    lp = lp_force_closure(w, mask)
    margin = force_closure_margin(th, d, ps, mode[0], mode[1], friction)
    closed = force_closure(th, d, ps, mode[0], mode[1], friction)
    few = np.concatenate([force_closure(th[k:k + 100], d[k:k + 100], ps[k:k + 100], mode[0], mode[1], friction)
                          for k in range(0, n, 100)])
    assert np.array_equal(few, closed)
    # the closed form's margin is exactly 0 off closure; only a margin in (0, 1e-7] is too close to call
    clear = (margin > 1e-7) | (margin <= 0.0)
    assert clear.mean() > 0.999
    assert np.array_equal(closed[clear], lp[clear])
    assert 0.0 < closed.mean() < 1.0  # both outcomes occur: the comparison is not vacuous


def test_wrenches_are_cone_edges_at_contact_points():
    """Sticking wrenches are the friction-cone edges of each contact, with moments about G."""
    th, d, ps = random_states(200, seed=3)
    w, mask = contact_wrenches(th, d, ps, 0, 0, Friction(MU, "relaxed"))
    assert mask.all()
    u = np.stack([np.cos(th), np.sin(th)], -1)
    contacts = [
        (np.zeros((200, 2)), np.tile([0.0, 1.0], (200, 1)), np.tile([1.0, 0.0], (200, 1)), MU[0]),
        ((1 - d)[:, None] * u, np.stack([np.sin(th), -np.cos(th)], -1), u, MU[1]),
        (u, np.stack([-np.sin(th + ps), np.cos(th + ps)], -1), -np.stack([np.cos(th + ps), np.sin(th + ps)], -1), MU[2]),
    ]
    for k, (p, n, t, mu) in enumerate(contacts):
        for j, f in enumerate(cone_edges(n, t, mu)):
            got = w[:, 2 * k + j]
            np.testing.assert_allclose(got[:, 1:], f, atol=1e-12)
            np.testing.assert_allclose(got[:, 0], p[:, 0] * f[:, 1] - p[:, 1] * f[:, 0], atol=1e-12)
            # the edge makes the friction angle with the normal
            np.testing.assert_allclose(np.arccos(np.sum(f * n, -1)), math.atan(mu), atol=1e-9)


@pytest.mark.parametrize("mode", [m for m in MODES if m != (0, 0)])
def test_sliding_models_nest(mode):
    """strict (one edge) force closure implies relaxed (edge + normal), which implies sticking."""
    th, d, ps = random_states(20_000, seed=5)
    strict = force_closure(th, d, ps, *mode, Friction(MU, "strict"))
    relaxed = force_closure(th, d, ps, *mode, Friction(MU, "relaxed"))
    stick = force_closure(th, d, ps, 0, 0, Friction(MU, "relaxed"))
    assert not np.any(strict & ~relaxed)
    assert not np.any(relaxed & ~stick)
    assert np.any(relaxed & ~strict)


def test_p_psi_near_reference_start_needs_relaxed_model():
    """docs/model.md, section 4.3: at theta 30 deg, d 0.8 and small psi, P_psi (B sliding toward
    the palm) is force-closed under the relaxed model and not under the strict one."""
    psi = np.radians(np.arange(0.0, 8.01, 0.5))
    relaxed = force_closure(math.radians(30), 0.8, psi, 0, -1, Friction(MU, "relaxed"))
    strict = force_closure(math.radians(30), 0.8, psi, 0, -1, Friction(MU, "strict"))
    assert relaxed.all()
    assert not strict.any()


def test_margin_shrinks_to_the_boundary():
    """The margin is positive exactly where force closure holds and is continuous across it."""
    psi = np.radians(np.linspace(0, 20, 4001))
    m = force_closure_margin(math.radians(30), 0.8, psi, 0, -1, Friction(MU, "strict"))
    fc = force_closure(math.radians(30), 0.8, psi, 0, -1, Friction(MU, "strict"))
    assert np.array_equal(fc, m > 1e-9)
    assert np.all(m[~fc] == 0.0)
    cross = np.flatnonzero(np.diff(fc.astype(int)) != 0)
    assert len(cross) >= 1
    assert np.all(np.maximum(m[cross], m[cross + 1]) < 1e-3)


def test_unknown_sliding_model_is_rejected():
    with pytest.raises(ValueError, match="sliding model"):
        Friction(MU, "sticky")
