"""The tolerance of a plan (docs/model.md, section 4.6) against a brute-force oracle that moves
the plan's states by randomly drawn errors with its own rigid-body arithmetic (the calibration as
a 3D transform about the palm, the digits' corners across their width), identities, and bad input."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from ungrasp_ompl import Scene
from ungrasp_ompl.scene.options import Release
from ungrasp_ompl.errors import InputError
from ungrasp_ompl.mechanics import across_support, force_closure, kinematic_checks, s_b
from ungrasp_ompl.mechanics.antipodal import effective_friction
from ungrasp_ompl.mechanics.kinematics import contact_d, digit_axis, digit_polygons, pressed_state, thumb_normal
from ungrasp_ompl.planning import plan
from ungrasp_ompl.mechanics.path import plan_samples
from ungrasp_ompl.planning.deviate import steeper_start
from ungrasp_ompl.scene.perturbation import PRESETS
from ungrasp_ompl.planning.plan_tolerance import tolerance
from ungrasp_ompl.scene.tolerance import LADDER_STEP, ToleranceOptions, ToleranceReason, ladder, state_tolerances


@pytest.fixture(scope="module")
def pick():
    scene = Scene.from_file("guitar_pick")
    return scene, plan(scene, planner="lattice")


def _draw(rng: np.random.Generator, m: int, corners: bool) -> dict[str, np.ndarray]:
    """m errors in units of the box (each component in [-1, 1], friction loss in [0, 1]); with
    corners, each component lies on its bound half the time."""
    def u(*shape):
        x = rng.uniform(-1.0, 1.0, size=(m, *shape))
        if corners:
            x = np.where(rng.random(x.shape) < 0.5, np.sign(x), x)
        return x
    return {"along": u(), "across": u(), "yaw": u(), "loss": np.abs(u(3)), "thick": u(), "palm": u(3),
            "turn": u(3), "table": u()}


def _rotation(rx: float, ry: float, rz: float) -> np.ndarray:
    cx, sx, cy, sy, cz, sz = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry), math.cos(rz), math.sin(rz)
    return np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]) @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]]) \
        @ np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])


def oracle_insecure(scene: Scene, result, scale: float, errors: dict[str, np.ndarray],
                    rows: np.ndarray | None = None) -> np.ndarray:
    """For each plan sample (rows) and error (scale times the paper box): whether the moved state
    is insecure. The calibration moves the digits' corners, across their width, by one rigid 3D
    transform about the palm's origin at the start, as the simulator moves the hand; with a start
    press the hand runs that much lower still, and B and A are looked at where the object then
    lies (mechanics.pressed_state), as well as where the moved state has them."""
    box, l, dg = PRESETS["paper"], scene.object_length, scene.digits
    smp = plan_samples(result, scene.options.resolution, both_modes=True)
    rows = np.arange(len(smp.states)) if rows is None else rows
    q = smp.states[rows]
    m = len(errors["along"])
    th, d, ps = (np.repeat(q[:, i], m) for i in range(3))
    e = {k: np.tile(v, (len(q),) + (1,) * (v.ndim - 1)) * scale for k, v in errors.items()}
    a = e["along"] * box.shift_mm / 1000
    turn = np.radians(e["turn"] * box.palm_turn_deg)
    shift = e["palm"] * box.palm_shift_mm / 1000
    height = e["table"] * box.table_mm / 1000
    t = dg.object_thickness * (1 + e["thick"] * box.thickness)
    # the planar state: the grasp shift moves A on the object, the palm's turn about y tilts it
    th1, d1 = th - turn[:, 1], d + a / l
    sa, sb = np.repeat(smp.a_sign[rows], m), np.repeat(smp.b_sign[rows], m)
    bad = np.zeros(len(th), dtype=bool)
    press = dg.press * l
    depth = np.zeros(len(th))
    beta = (scene.plane.g.beta, scene.plane.b.beta)
    yaw = np.abs(np.radians(e["yaw"] * box.yaw_deg))
    for j in range(m):  # friction per error: each has its own coefficients
        mu = [c * (1 - loss * box.friction) for c, loss in zip(scene.mu_contacts, errors["loss"][j] * scale)]
        mu[0], mu[2] = (float(np.nan_to_num(effective_friction(mu[k], beta[i] + yaw[j]), nan=0.0))
                        for i, k in ((0, 0), (1, 2)))
        at = np.arange(j, len(th), m)
        bad[at] = ~force_closure(th1[at], d1[at], ps[at], sa[at], sb[at], scene.friction.with_mu(tuple(mu)))
    for i in np.unique(t):
        k = t == i
        checks = kinematic_checks(th1[k], d1[k], ps[k], replace(dg, object_thickness=i, thumb_tip_margin=0.0))
        ok = checks["d"] & checks["s_B >= 0"] & checks["s_B <= thumb_length"] & checks["aperture"]
        # the digits where the hand is: the planned state with A moved on the object, G moved by the
        # shift, then the calibration's rigid motion about the palm's origin at the start
        digits = replace(dg, object_thickness=i)
        thumb, finger = digit_polygons(th[k], d1[k], ps[k], digits)
        pts = np.concatenate([thumb, finger], axis=1) * l + (a[k, None] * np.stack([np.cos(th[k]), np.sin(th[k])], -1))[:, None]
        half = dg.width * l / 2
        p3 = np.concatenate([np.stack([pts[..., 0], np.full(pts.shape[:2], y), pts[..., 1]], -1) for y in (-half, half)], 1)
        th0, d0, ps0 = result.states[0]
        e0, n0 = digit_axis(th0, ps0), thumb_normal(th0, ps0)
        axes = np.array([[n0[0], 0, n0[1]], [0, 1, 0], [e0[0], 0, e0[1]]]).T  # palm x, y, z as columns
        start_thumb, start_finger = digit_polygons(th0, d0, ps0, dg)
        w0 = np.dot(start_finger[0] - start_thumb[0], n0)  # the opening at the start
        p0 = (start_thumb[0] - dg.thumb_length * e0 + w0 / 2 * n0) * l
        p0 = np.array([p0[0], 0.0, p0[1]])
        rot = np.stack([axes @ _rotation(*tr) @ axes.T for tr in turn[k]])
        moved = np.einsum("nij,npj->npi", rot, p3 - p0) + p0 + (shift[k] @ axes.T)[:, None]
        # with the start press the hand runs press below all that, and the table holds G: the
        # point the plan has at G, carried by the same motion, rises by g_rise over the table,
        # and the object lies at the state pressed by the press less that
        g_at = np.stack([a[k] * np.cos(th[k]), np.zeros(k.sum()), a[k] * np.sin(th[k])], -1)
        g_rise = (np.einsum("nij,nj->ni", rot, g_at - p0) + p0 + shift[k] @ axes.T)[:, 2] - height[k]
        depth[k] = (press - g_rise) / l
        _, dp, pp, found = pressed_state(th1[k], d1[k], ps[k], depth[k], digits)
        ok &= found & (s_b(dp, pp, dg.alpha, i, dg.finger_tip_radius) >= 0.0)
        low = moved[..., 2].min(axis=1) - press
        bad[k] |= ~ok | (low < height[k])
        if not scene.sim.handed_over:  # a hand that lifts G at the start by more than the press: it hangs
            g_start = np.stack([a[k] * math.cos(th0), np.zeros(k.sum()), a[k] * math.sin(th0)], -1)
            start_rise = (np.einsum("nij,nj->ni", rot, g_start - p0) + p0 + shift[k] @ axes.T)[:, 2] - height[k]
            bad[k] |= start_rise > press
    last = len(smp.states) - 1
    at_end = np.repeat(rows == last, m)
    if at_end.any():
        from ungrasp_ompl.geometry.collision import CollisionChecker

        r = scene.robot
        checker = CollisionChecker(scene.collision_model())
        bad[at_end] |= checker.termination_collides(np.column_stack([th1, d1, ps])[at_end], r.termination,
                                                    r.termination_opening)
    # A beside GB by the grasp's shift across: inside the supports' ends (G's and B's straight sides
    # on the table and the thumb, seen along the face's normal) on that side, as planned and pressed
    across = np.abs(e["across"]) * box.shift_mm / 1000
    g_end, b_end = (min(scene.plane.g.span), min(min(scene.plane.b.span), dg.width * l / 2))
    for dd, pp in ((d1, ps), pressed_state(th1, d1, ps, depth, dg)[1:3]):
        from_g = (1.0 - contact_d(dd, pp, dg.finger_tip_radius)) * l  # A's place along GB, from G
        # the side of the line from G's end (0, g_end) to B's (l, b_end) that A, at (from_g, across), lies on
        outside = l * (across - g_end) - from_g * (b_end - g_end) > 0.0
        bad |= outside
    return bad.reshape(len(q), m)


@pytest.mark.parametrize("name, binds", [("guitar_pick", ToleranceReason.NO_TERMINATION),
                                         ("puzzle_piece", ToleranceReason.G_LIFTED)])
@pytest.mark.slow
def test_oracle_finds_nothing_within_the_tolerance_and_something_just_beyond(pick, name, binds):
    """The pick's lattice plan is bound by its release; the puzzle piece's from d 0.8 (its start
    before decision 0121, its plan ending anywhere in the goal region as it then did) by a hand so
    high at the start that the press no longer brings G down to the table."""
    if name == "guitar_pick":
        scene, result = pick
    else:
        scene = Scene.from_file(name).with_start_d(0.8).with_options(release=Release.OBJECTIVE)
        result = plan(scene, planner="lattice")
    tol = tolerance(scene, result)
    assert 0 < tol.scale < 1 and tol.reason is binds
    rng = np.random.default_rng(7)
    inside = oracle_insecure(scene, result, tol.scale, _draw(rng, 300, corners=True))
    assert not inside.any()
    smp = plan_samples(result, scene.options.resolution, both_modes=True)
    k = np.flatnonzero(np.all(np.isclose(smp.states, tol.state), axis=1))  # in each contact mode it is sampled in
    # the search found the state insecure at the ladder's next step (the true bound lies below it)
    beyond = oracle_insecure(scene, result, LADDER_STEP * tol.scale, _draw(rng, 3000, corners=True), rows=k)
    assert beyond.any()


def test_a_start_outside_force_closure_has_no_tolerance(pick):
    """A start steeper than the scene's friction holds (its nominal coefficients: the tolerance's friction
    loss is the true friction's deviation from them, docs/model.md 4.7) tolerates nothing."""
    scene, result = pick
    nominal = replace(scene, friction_uncertainty=0.0)
    offset = next(math.radians(x) for x in range(1, 60)
                  if not nominal.force_closure([result.states[0][0] + math.radians(x)] + result.states[0][1:])[0])
    tol = tolerance(scene, steeper_start(result, offset))
    assert tol.scale == 0.0
    assert tol.reason is ToleranceReason.NOT_FORCE_CLOSED
    assert tol.primitive == 0 and tol.physical["shift_mm"] == 0.0


def test_the_box_doubled_halves_the_scale_and_any_larger_box_lowers_it(pick):
    scene, result = pick
    paper = PRESETS["paper"]
    base = tolerance(scene, result)
    double = replace(paper, **{k: 2 * getattr(paper, k) for k in ("shift_mm", "yaw_deg", "friction", "thickness",
                                                                  "palm_shift_mm", "palm_turn_deg", "table_mm")})
    halved = tolerance(scene, result, ToleranceOptions(box=double))
    assert halved.scale == pytest.approx(base.scale / 2, rel=5e-3)
    assert halved.physical["shift_mm"] == pytest.approx(base.physical["shift_mm"], rel=5e-3)
    for key in ("shift_mm", "table_mm", "palm_shift_mm"):
        grown = tolerance(scene, result, ToleranceOptions(box=replace(paper, **{key: 3 * getattr(paper, key)})))
        assert grown.scale <= base.scale * (1 + 2e-3)


def test_each_component_alone_is_tolerated_at_least_as_much_as_all_together(pick):
    scene, result = pick
    tol = tolerance(scene, result)
    # the shift across alone moves A beside GB: it tips the object where A leaves the supports,
    # as the binding state lies or pressed, whichever is nearer G
    th, d, ps = tol.state
    dg = scene.digits
    held = min(across_support(d, ps, dg), across_support(*pressed_state(th, d, ps, dg.press, dg)[1:3], dg))
    assert tol.component_scales["shift_across"] == pytest.approx(held * scene.object_length * 1000
                                                                 / PRESETS["paper"].shift_mm, rel=1e-2)
    assert min(tol.component_scales.values()) >= tol.scale * (1 - 1e-2)
    assert tol.component == min(tol.component_scales, key=tol.component_scales.get)
    assert type(tol).from_dict(tol.to_dict()) == tol


def test_bad_input_names_the_field(pick):
    scene, result = pick
    unsolved = replace(result, solution=replace(result.solution, primitives=[]))
    with pytest.raises(InputError, match="plan"):
        tolerance(scene, unsolved)
    with pytest.raises(InputError, match="perturbation"):
        tolerance(scene, result, ToleranceOptions(perturbation="earthquake"))
    with pytest.raises(InputError, match="max_scale"):
        tolerance(scene, result, ToleranceOptions(max_scale=-1.0))
    with pytest.raises(InputError, match="resolution"):
        tolerance(scene, result, ToleranceOptions(resolution=(0.1, 0.0, 0.1)))
    with pytest.raises(InputError, match="box.table_mm"):
        tolerance(scene, result, ToleranceOptions(box=replace(PRESETS["paper"], table_mm=math.nan)))


# -- a state's own tolerance, and the tolerance objective ---------------------------------------------

def test_a_plan_tolerates_the_least_of_its_states_tolerances_to_a_ladder_step(pick):
    """state_tolerances over a plan's samples (the last one terminal): the least of them is the
    ladder's last scale at or below the plan's tolerance, and the split into force closure and the
    other checks loses nothing (a state's tolerance is the smaller of its two parts')."""
    scene, result = pick
    smp = plan_samples(result, scene.options.resolution, both_modes=True)
    terminal = np.zeros(len(smp.states), dtype=bool)
    terminal[-1] = True
    args = (scene, smp.states, smp.a_sign, smp.b_sign, terminal, np.asarray(result.states[0]))
    each = state_tolerances(*args)
    levels = ladder(ToleranceOptions().max_scale)
    s = tolerance(scene, result).scale
    below = levels[levels <= s * (1 + 2e-3)]  # the plan's scale is bisected to 1e-3 of itself
    assert each.min() == below[-1]
    kinematic = state_tolerances(*args, closure=False)
    assert np.array_equal(each, np.minimum(kinematic, state_tolerances(*args, kinematic=False)))
    # the closure part searched no higher than the other part, as the tolerance objective asks it:
    # the same least of the two; and where upto is below the ladder, nothing is checked
    assert np.array_equal(each, np.minimum(kinematic, state_tolerances(*args, kinematic=False, upto=kinematic)))
    between = np.where(np.arange(len(each)) % 3 == 0, -np.inf, 0.5 * (kinematic + levels[-1]))  # off the ladder
    capped = state_tolerances(*args, kinematic=False, upto=between)
    assert np.all(np.isneginf(capped[::3]))
    on_ladder = levels[np.searchsorted(levels, between[1::3], side="right") - 1]  # upto taken down to the ladder
    assert np.array_equal(capped[1::3], np.minimum(state_tolerances(*args, kinematic=False)[1::3], on_ladder))


def test_the_shift_s_ends_bound_every_check_but_force_closure(pick, monkeypatch):
    """Without force closure, obstacles and the termination every check is linear in the grasp
    shift or the least of linear functions of it, so the shift's two ends decide: the same
    tolerances as over the whole grid of shifts."""
    import ungrasp_ompl.scene.tolerance as module

    scene, result = pick
    smp = plan_samples(result, scene.options.resolution, both_modes=True)
    rng = np.random.default_rng(5)
    q = smp.states + rng.normal(0.0, [0.05, 0.05, 0.05], smp.states.shape)  # around the path, some insecure
    ends = state_tolerances(scene, q, 0, 0, closure=False)
    whole, asked = module.ErrorBox.face_axes, []

    def whole_grid(self, s, on, shift_ends=False):
        asked.append(shift_ends)
        return whole(self, s, on, False)

    monkeypatch.setattr(module.ErrorBox, "face_axes", whole_grid)
    assert np.array_equal(ends, state_tolerances(scene, q, 0, 0, closure=False))
    assert any(asked)  # the shift's ends alone were asked for, and the whole grid given instead
    assert np.isfinite(ends).any() and (ends > 0).any()


def test_the_tolerance_search_keeps_the_most_tolerant_path_of_a_small_lattice():
    """On a small lattice with every secure path enumerated: the tolerance objective's bottleneck is
    the largest least step tolerance any path keeps, each step's the smaller of its ends', each
    end's state_tolerances in the step's contact mode (the termination at the goal's states), and
    the search's path keeps it."""
    from test_objectives import all_paths, small_problem

    from ungrasp_ompl.mechanics import primitive_sliding_signs
    from ungrasp_ompl.planning.atlas import LEG_PRIMITIVE
    from ungrasp_ompl.planning.lattice import lattice_search
    from ungrasp_ompl.planning.margins import TOLERANCE_CAP, LatticeMargins

    # a start low over the table, where the digits' clearance makes the tolerances differ
    scene = replace(Scene.from_file("puzzle_piece"), start=np.array([math.radians(15.0), 0.78, math.radians(36.0)]))
    atlas, goal_box = small_problem(scene)
    margins = LatticeMargins(atlas, "tolerance", goal_box)
    result = lattice_search(atlas, goal_box, "tolerance", margins)
    paths = all_paths(atlas, goal_box)
    assert len(paths) > 10 and result.reachable
    goal = atlas.releasable_in(goal_box)

    def ends(kind, a, b):  # (lattice index, sliding sign at A, at B) of a step's two ends
        dq = atlas.state(b) - atlas.state(a)
        return [(i, *(int(x) for x in primitive_sliding_signs(LEG_PRIMITIVE[kind], atlas.state(i)[1],
                                                                atlas.state(i)[2], dq[1], dq[2]))) for i in (a, b)]

    keys = sorted({e for p in paths for leg in p for e in ends(*leg)})
    own = {}
    for mode in {k[1:] for k in keys}:  # every end's own tolerance, one call per contact mode
        group = [k for k in keys if k[1:] == mode]
        q = np.array([atlas.state(k[0]) for k in group])
        values = state_tolerances(scene, q, *mode, np.array([goal[k[0]] for k in group]),
                                  options=ToleranceOptions(max_scale=TOLERANCE_CAP))
        own.update(zip(group, np.maximum(values, 0.0)))  # every end is secure to the atlas: at least 0

    steps = {leg: min(own[e] for e in ends(*leg)) for leg in {leg for p in paths for leg in p}}

    def step(kind, a, b):
        return steps[(kind, a, b)]

    widest = max(min(step(*leg) for leg in p) for p in paths)
    assert margins.bottleneck == widest < TOLERANCE_CAP and result.min_margin == widest
    assert min(step(leg.kind, leg.start, leg.end) for leg in result.legs) == widest
    assert len({min(step(*leg) for leg in p) for p in paths}) > 1  # the paths differ in tolerance


@pytest.mark.slow
def test_the_tolerance_plan_tolerates_more_than_the_cost_plan_and_a_floor_rejects_the_cost_plan():
    """The lattice's tolerance plan tolerates at least what the cheapest plan does (to a ladder
    step); with planning.min_tolerance between the two, the cost plan fails with its tolerance as
    evidence and the tolerance plan is returned with its own. Both plans end anywhere in the goal
    region (planning.release objective), where each objective takes them."""
    from ungrasp_ompl.planning.margins import Objective
    from ungrasp_ompl.planning.result import PlanOutcome, describe_outcome
    from ungrasp_ompl.planning.setup import with_tolerance_floor

    # handed over: the start's lift does not cap both plans alike
    scene = Scene.from_file("puzzle_piece").with_options(release=Release.OBJECTIVE)
    scene = scene.with_sim(handed_over=True)  # and no bound on the landing's spread, which replans both alike
    scene = replace(scene, options=replace(scene.options, max_landing_spread=None))
    cheap = plan(scene, planner="lattice")
    robust = plan(scene, planner="lattice", objective="tolerance")
    assert robust.solved and robust.objective is Objective.TOLERANCE and robust.margin_bottleneck_deg is None
    low, high = tolerance(scene, cheap).scale, tolerance(scene, robust).scale
    assert high >= low / LADDER_STEP
    assert high > LADDER_STEP ** 2 * low  # two ladder steps apart: a floor between them tells them apart
    floored = replace(scene, options=replace(scene.options, min_tolerance=math.sqrt(low * high)))
    rejected = plan(floored, planner="lattice")
    assert rejected.outcome is PlanOutcome.BELOW_MIN_TOLERANCE and not rejected.solved
    assert rejected.evidence["tolerance"]["scale"] == pytest.approx(low)
    assert "below planning.min_tolerance" in describe_outcome(rejected.outcome, rejected.evidence)
    kept = with_tolerance_floor(floored, robust)  # what plan() does to the tolerance plan under the floor
    assert kept.solved and kept.tolerance["scale"] == pytest.approx(high)


def test_a_scene_s_tolerance_floor_is_checked_by_its_field(tmp_path):
    from ungrasp_ompl.shipped import resolve

    base = resolve("guitar_pick").read_text()
    assert "planning:\n" in base and "min_tolerance" not in base
    text = tmp_path / "s.yaml"
    text.write_text(base.replace("planning:\n", "planning:\n  min_tolerance: 0.25\n"))
    assert Scene.from_file(text).options.min_tolerance == 0.25
    for bad in ("-0.1", "6", "much"):
        text.write_text(base.replace("planning:\n", f"planning:\n  min_tolerance: {bad}\n"))
        with pytest.raises(InputError) as err:
            Scene.from_file(text)
        assert err.value.field == "planning.min_tolerance"


@pytest.mark.parametrize("name", ["guitar_pick", "puzzle_piece_designed", "fabric_chalk"])
def test_the_lowest_point_is_the_lowest_vertex_of_the_digits_and_the_housing(name):
    """The tolerance's table check takes the heights alone: they agree with the lowest vertex of
    digit_polygons and of the housing's outline (housing_centre + housing_offsets), with and
    without the housing, over random states including ones no plan reaches."""
    from ungrasp_ompl.mechanics.kinematics import housing_centre, housing_offsets
    from ungrasp_ompl.scene.tolerance import _lowest

    rng = np.random.default_rng(7)
    theta, d, psi = rng.uniform(-0.5, 2.0, 5000), rng.uniform(-0.2, 1.2, 5000), rng.uniform(-0.5, 3.2, 5000)
    digits = Scene.from_file(name).digits
    thumb, finger = digit_polygons(theta, d, psi, digits)
    digits_low = np.minimum(thumb[..., 1].min(axis=-1), finger[..., 1].min(axis=-1))
    housing = (housing_centre(theta, d, psi, digits)[:, None, 1] + housing_offsets(theta, psi, digits)[..., 1]).min(axis=-1)
    assert np.allclose(_lowest(theta, d, psi, digits), np.minimum(digits_low, housing), rtol=0, atol=1e-12)
    assert np.allclose(_lowest(theta, d, psi, replace(digits, palm_width=0.0)), digits_low, rtol=0, atol=1e-12)


def test_without_a_start_press_a_hand_too_high_leaves_the_object_hanging_unless_handed_over():
    """With no start press any hand higher than planned lifts G off the table at the start, so the
    plan tolerates no error (G_LIFTED, the palm's shift alone enough to lift it); handed over, the
    object slides down in the pinch onto the table instead, and the same plan tolerates errors."""
    import yaml

    from ungrasp_ompl.shipped import resolve

    doc = yaml.safe_load(resolve("puzzle_piece").read_text())
    doc["robot"].pop("end_press", None)
    doc["robot"]["start_press"] = 0.0
    bare = Scene.from_dict(doc, source="puzzle_piece, no press")
    result = plan(bare, planner="lattice")
    hanging = tolerance(bare, result)
    assert hanging.reason is ToleranceReason.G_LIFTED and hanging.scale < 1e-3
    assert math.isfinite(hanging.component_scales["palm_shift"]) and hanging.component_scales["palm_shift"] < 1e-3
    handed = bare.with_sim(handed_over=True)
    assert tolerance(handed, result).scale > 0.05
