"""Friction known within a range (docs/model.md 4.7): the range check against the LP oracle at the
range's ends, plans of a shipped object scene secure at both ends, uncertainty 0 as before, bad input."""

from __future__ import annotations

import copy
import itertools
import math

import numpy as np
import pytest
import yaml

from conftest import pick_before_0107, run_cli
from oracle import friction_margin_bisection, lp_force_closure
from ungrasp_ompl import Scene
from ungrasp_ompl.cli.exits import EXIT_BAD_INPUT
from ungrasp_ompl.errors import InputError
from ungrasp_ompl.mechanics import Friction, contact_wrenches, force_closure, force_closure_margin
from ungrasp_ompl.mechanics.margin import friction_margin
from ungrasp_ompl.mechanics.path import plan_samples
from ungrasp_ompl.planning.atlas import SecurityAtlas
from ungrasp_ompl.planning.setup import plan
from ungrasp_ompl.shipped import resolve

MU = (0.25, 0.35, 0.35)  # the guitar pick's contacts
U = 0.3
MODES = list(itertools.product((-1, 0, 1), repeat=2))  # (A, B): stick, or sliding with the sign of dd / ds_B
TIMING = ("time_to_first_solution_s", "planning_time_s", "setup_time_s")


def random_states(n: int, seed: int):
    rng = np.random.default_rng(seed)
    return rng.uniform(0, math.pi / 2, n), rng.uniform(0, 1, n), rng.uniform(0, math.radians(120), n)


def end_frictions(low, high, mode, model):
    """The two exactly known frictions of the range for a contact mode, built here from the rule:
    every contact at the low end; the sliding contacts at the high end, the sticking ones low."""
    sa, sb = mode
    mixed = (low[0], high[1] if sa else low[1], high[2] if sb else low[2])
    return Friction(low, model), Friction(mixed, model)


def lp_at(th, d, ps, mode, friction):
    return lp_force_closure(*contact_wrenches(th, d, ps, mode[0], mode[1], friction))


def clear(th, d, ps, mode, frictions):
    """States whose closed-form margin at every given friction is 0 or above 1e-7: the LP's
    answer is not too close to call (as in test_force_closure)."""
    out = np.ones(len(th), dtype=bool)
    for f in frictions:
        m = force_closure_margin(th, d, ps, mode[0], mode[1], f)
        out &= (m > 1e-7) | (m <= 0.0)
    return out


def shipped(name: str) -> dict:
    return yaml.safe_load(resolve(name, "scene").read_text())


def plane_coefficients(scene: Scene, factor: float) -> tuple[float, float, float]:
    """The plane's coefficients with the contacts' times factor, by docs/model.md 5.2's reduction
    cos(phi') = cos(phi) / cos(beta), written out here."""
    g, a, b = (m * factor for m in scene.mu_contacts)

    def reduced(m, beta):
        return math.tan(math.acos(math.cos(math.atan(m)) / math.cos(beta)))

    return reduced(g, scene.plane.g.beta), a, reduced(b, scene.plane.b.beta)


# --- the range check against the LP oracle ------------------------------------------------------

@pytest.mark.parametrize("model", ["relaxed", "strict"])
@pytest.mark.parametrize("mode", MODES, ids=lambda m: f"A{m[0]:+d}B{m[1]:+d}")
def test_range_check_is_lp_force_closure_at_both_ends(model, mode):
    """On 3,000 random states per contact mode and sliding model, force closure over the range
    +-30 % is exactly LP force closure with every contact at the low end and with the sliding
    contacts at the high end (the sticking ones low); it rejects states the nominal friction holds."""
    th, d, ps = random_states(3000, seed=hash((model, mode)) % 2**32)
    friction = Friction(MU, model, U)
    low, high = tuple(m * (1 - U) for m in MU), tuple(m * (1 + U) for m in MU)
    ends = end_frictions(low, high, mode, model)
    at_low, at_high = (lp_at(th, d, ps, mode, f) for f in ends)
    got = force_closure(th, d, ps, *mode, friction)
    sure = clear(th, d, ps, mode, ends)
    assert sure.mean() > 0.99
    assert np.array_equal(got[sure], (at_low & at_high)[sure])
    assert 0.0 < got.mean() < 1.0
    nominal = force_closure(th, d, ps, *mode, Friction(MU, model))
    assert np.any(nominal & ~got)  # the range is a stricter test than the nominal friction
    if model == "relaxed":  # the low end decides alone: its wrench cone lies inside the high end's
        assert not np.any((at_low & ~at_high)[sure])
    elif mode != (0, 0):  # a strict sliding edge turns with mu: the high end rejects more
        assert np.any((at_low & ~at_high)[sure])


@pytest.mark.parametrize("model", ["relaxed", "strict"])
def test_range_check_with_a_mode_per_state_equals_one_mode_at_a_time(model):
    """States in mixed contact modes, checked in one call, get the answer of their own mode; the
    margins are the smaller of the two ends' (relaxed: the low end's as the bisection oracle finds
    it, which the high end's is never below where the low end holds; strict, where the bisection
    does not apply, closure coming and going along the shrink angle: the margins of the two exactly
    known frictions, which tests/test_margin.py holds to the LP)."""
    th, d, ps = random_states(600, seed=11)
    rng = np.random.default_rng(12)
    sa, sb = rng.integers(-1, 2, 600), rng.integers(-1, 2, 600)
    friction = Friction(MU, model, U)
    together = force_closure(th, d, ps, sa, sb, friction)
    margins = friction_margin(th, d, ps, sa, sb, friction)
    low, high = tuple(m * (1 - U) for m in MU), tuple(m * (1 + U) for m in MU)
    for mode in MODES:
        k = (sa == mode[0]) & (sb == mode[1])
        assert np.array_equal(together[k], force_closure(th[k], d[k], ps[k], *mode, friction))
        ends = end_frictions(low, high, mode, model)
        if model == "relaxed":
            at_low, at_high = (friction_margin_bisection(th[k], d[k], ps[k], *mode, f) for f in ends)
            held = at_low > 0
            assert np.all(at_high[held] >= at_low[held] - 1e-9)
            oracle = at_low
        else:
            oracle = np.minimum(*(friction_margin(th[k], d[k], ps[k], *mode, f) for f in ends))
        finite = np.isfinite(oracle)
        np.testing.assert_allclose(margins[k][finite], oracle[finite], atol=1e-8)
        assert np.array_equal(margins[k][~finite], oracle[~finite])
        assert np.array_equal(margins[k] > 0, together[k])


def test_a_lattice_over_the_range_agrees_with_state_by_state_and_the_oracle():
    """The secure lattice (what the OMPL validators and the exact search read) of the guitar pick
    under strict sliding and +-30 % friction equals force closure over the range state by state in
    every mode a leg makes, and the LP oracle at both ends on a sample of its states."""
    scene = Scene.from_file("guitar_pick").with_options(sliding_model="strict")
    box = np.array([[math.radians(10), 0.6, 0.0], [math.radians(30), 0.77, math.radians(40)]])
    atlas = SecurityAtlas(scene, box, resolution=(math.radians(1), 0.01, math.radians(1)))
    th, d, ps = (g.ravel() for g in np.meshgrid(*atlas.axes, indexing="ij"))
    friction = scene.friction
    rng = np.random.default_rng(3)
    for mode in [(0, 0), (0, -1), (0, 1), (1, 1)]:  # strict: P_dpsi forward (-1, -1) holds nowhere here
        lattice = atlas.mode_ok(*mode).ravel()
        assert lattice.any()
        held = atlas.holdable.ravel()
        assert np.array_equal(lattice[held], force_closure(th[held], d[held], ps[held], *mode, friction))
        k = rng.choice(np.flatnonzero(held), 400, replace=False)
        ends = end_frictions(friction.low, friction.high, mode, "strict")
        k = k[clear(th[k], d[k], ps[k], mode, ends)]
        assert len(k) > 390
        assert np.array_equal(lattice[k], lp_at(th[k], d[k], ps[k], mode, ends[0]) & lp_at(th[k], d[k], ps[k], mode, ends[1]))


# --- a shipped object scene at +-30 % -----------------------------------------------------------

@pytest.fixture(scope="module")
def pick():
    scene = Scene.from_file("guitar_pick")
    assert scene.friction.uncertainty == U
    return scene


@pytest.mark.parametrize("planner", ["lattice", "RRTstar"])
def test_a_shipped_object_plans_secure_at_both_ends(pick, planner):
    """The guitar pick (uncertainty 0.3) plans with the exact lattice and with RRT* (seed 1), and
    every state its legs pass, in its leg's contact mode, is LP force-closed with the plane's
    coefficients from the contacts' times 0.7 and, for its sliding contacts, times 1.3; the plan
    says so, and its margins are the worse end's."""
    result = plan(pick, planner, seed=1)
    assert result.solved, result.reason
    assert result.secure_over == pytest.approx((0.7, 1.3))
    record = result.to_dict()["friction"]
    assert record["uncertainty"] == U and record["secure_over"] == pytest.approx([0.7, 1.3])
    low, high = plane_coefficients(pick, 0.7), plane_coefficients(pick, 1.3)
    np.testing.assert_allclose(record["mu_low"], low, rtol=1e-12)
    np.testing.assert_allclose(record["mu_high"], high, rtol=1e-12)
    s = plan_samples(result, result.resolution, both_modes=True)
    th, d, ps = s.states.T
    worst = np.full(len(th), np.inf)
    for mode in set(zip(s.a_sign.tolist(), s.b_sign.tolist())):
        k = (s.a_sign == mode[0]) & (s.b_sign == mode[1])
        for f in end_frictions(low, high, mode, pick.options.sliding_model):
            assert lp_at(th[k], d[k], ps[k], mode, f).all(), (mode, f)
            worst[k] = np.minimum(worst[k], friction_margin_bisection(th[k], d[k], ps[k], *mode, f))
    assert result.min_margin_deg == pytest.approx(math.degrees(worst.min()), abs=1e-6)


def test_the_nominal_plan_of_the_pick_is_not_secure_over_the_range():
    """The plan the nominal friction gives the pick from its start before decision 0107
    (uncertainty 0; the cost objective, through a P_dpsi) has states that lose LP force closure at
    the range's low end: the range changes what is planned."""
    nominal = pick_before_0107()
    ranged = Scene.from_dict(nominal)
    assert ranged.friction.uncertainty == U
    nominal["friction"]["uncertainty"] = 0
    result = plan(Scene.from_dict(nominal), "lattice")
    assert result.solved and result.secure_over == (1.0, 1.0)
    s = plan_samples(result, result.resolution, both_modes=True)
    low = plane_coefficients(ranged, 0.7)
    lost = np.zeros(len(s.states), dtype=bool)
    for mode in set(zip(s.a_sign.tolist(), s.b_sign.tolist())):
        k = (s.a_sign == mode[0]) & (s.b_sign == mode[1])
        lost[k] = ~lp_at(*s.states[k].T, mode, Friction(low, "relaxed"))
    assert lost.any()


# --- uncertainty 0 is the friction known exactly ------------------------------------------------

def test_uncertainty_zero_plans_as_a_scene_without_it():
    """A seeded plan of a scene whose friction gives uncertainty 0 is the plan of the same scene
    without the key, field for field (timing aside), and its friction is the nominal one alone."""
    absent = copy.deepcopy(shipped("guitar_pick"))
    del absent["friction"]["uncertainty"]
    zero = copy.deepcopy(absent)
    zero["friction"]["uncertainty"] = 0
    scenes = [Scene.from_dict(doc) for doc in (absent, zero)]
    assert scenes[0].friction == scenes[1].friction == Friction(scenes[0].mu, scenes[0].options.sliding_model)
    for planner in ("RRTstar", "lattice"):
        a, b = (plan(sc, planner, seed=1).to_dict() for sc in scenes)
        for doc in (a, b):
            for key in TIMING:
                doc.pop(key)
        assert a["solved"] and a == b


# --- the manipulation plane's effective friction at the range's ends ----------------------------

def tilted_puzzle_piece(uncertainty: float) -> dict:
    """The puzzle piece with B fixed on its hypotenuse so that GB makes 20 deg with the side's
    normal there (G at the right angle, whose normals take in GB)."""
    doc = copy.deepcopy(shipped("puzzle_piece"))
    s = 0.025 * math.tan(math.radians(20))
    doc["contacts"] = {"G": [0.0, 0.0], "B": [0.025 + s, 0.025 - s]}
    doc["friction"]["uncertainty"] = uncertainty
    return doc


def test_the_planes_friction_at_each_end_is_reduced_from_the_contacts():
    """With GB 20 deg off the normal at B, the plane's mu'_B at each end is the reduction of the
    contact's coefficient times 0.9 and 1.1, which is not 0.9 and 1.1 times the nominal mu'_B."""
    scene = Scene.from_dict(tilted_puzzle_piece(0.1))
    assert scene.plane.b.beta == pytest.approx(math.radians(20), abs=1e-9)
    f = scene.friction
    np.testing.assert_allclose(f.low, plane_coefficients(scene, 0.9), rtol=1e-12)
    np.testing.assert_allclose(f.high, plane_coefficients(scene, 1.1), rtol=1e-12)
    assert f.low[2] < 0.9 * f.mu[2] - 0.01 and f.high[2] > 1.1 * f.mu[2] + 0.01


def test_a_range_whose_low_end_misses_a_cone_is_refused():
    """At +-30 % the thumb's cone at B (atan 0.315 = 17.5 deg) no longer reaches GB, 20 deg off
    the normal there (Assumption 2 at the low end): the loader names friction.uncertainty."""
    with pytest.raises(InputError) as err:
        Scene.from_dict(tilted_puzzle_piece(U))
    assert err.value.field == "friction.uncertainty"


# --- bad input ----------------------------------------------------------------------------------

@pytest.mark.parametrize("value", [-0.1, 1, 1.5, "x", None, True, math.nan, [0.3]])
def test_a_bad_uncertainty_is_refused_naming_the_field(tmp_path, value):
    """A negative, >= 1 or non-number uncertainty is an InputError naming friction.uncertainty
    (friction_angle_deg.uncertainty under angles), and `plan` answers it with one line and exit 2,
    writing nothing."""
    doc = shipped("guitar_pick")
    doc["friction"]["uncertainty"] = value
    with pytest.raises(InputError) as err:
        Scene.from_dict(doc)
    assert err.value.field == "friction.uncertainty"
    angles = shipped("reference_asymmetric")
    angles["friction_angle_deg"]["uncertainty"] = value
    with pytest.raises(InputError) as err:
        Scene.from_dict(angles)
    assert err.value.field == "friction_angle_deg.uncertainty"
    path, out = tmp_path / "scene.yaml", tmp_path / "out"
    path.write_text(yaml.safe_dump(doc))
    proc = run_cli("plan", str(path), "--seed", "1", "--time", "0.2", "--out", str(out))
    assert proc.returncode == EXIT_BAD_INPUT
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("ungrasp-ompl: error: ") and "friction.uncertainty" in lines[0]
    assert not out.exists() or not any(out.iterdir())


def test_friction_rejects_an_uncertainty_outside_zero_to_one():
    """The Friction value itself holds 0 <= u < 1 (library code gets ValueError, as for the model)."""
    for u in (-0.01, 1.0, math.nan):
        with pytest.raises(ValueError):
            Friction(MU, "relaxed", u)
    assert Friction(MU, "relaxed", 0.0).low == Friction(MU, "relaxed", 0.0).high == MU
