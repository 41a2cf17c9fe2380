"""The out-of-plane margin (scene/stability3d.py, docs/model.md 11.18): an independent linear
programme agrees with it, it falls with friction and with the pyramid, and it reads the recorded
pick trial that the world with 0.7 times the friction turns out of the plane (the pick from its
start before decision 0107, which the trial was recorded from)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import linprog

from conftest import pick_before_0107
from ungrasp_ompl.scene.perturbation import preset, trial_params
from ungrasp_ompl.scene import Scene
from ungrasp_ompl.scene.stability3d import (ConeModel, OutOfPlaneLoads, object_mass_centre, out_of_plane_margin,
                                            plan_states)

PICK = "guitar_pick"


@pytest.fixture(scope="module")
def pick() -> Scene:
    return Scene.from_file(PICK)


@pytest.fixture(scope="module")
def recorded_pick() -> Scene:
    """The pick whose trial docs/model.md 11.18 reads (tools/world_failures.py): from its start
    before decision 0107 (d 0.77), planned under the cost objective."""
    return Scene.from_dict(pick_before_0107())


@pytest.fixture(scope="module")
def chalk() -> Scene:
    return Scene.from_file("fabric_chalk")


def oracle(scene: Scene, q, sa: int, sb: int, mu, cone: str, offset: float, sides: int = 32) -> float:
    """The largest push across the plane at the centre of mass held, written independently: the
    forces as components (normal, tangent, across) in each contact's frame, the cone as
    inequalities (the pyramid's |c_t| + |c_y| <= mu c_n; the inscribed polygon's facets), sliding
    contacts at their edge (relaxed: between the normal and it), nothing across; geometry from
    the state by plain trigonometry."""
    th, d, ps = q
    l, t, dg = scene.object_length, scene.object_thickness, scene.digits
    w, cx, cy = object_mass_centre(scene)
    u = np.array([math.cos(th), 0, math.sin(th)])
    top = np.array([-math.sin(th), 0, math.cos(th)])
    across = np.array([0.0, 1.0, 0.0])
    beta = th + ps
    n_b = np.array([-math.sin(beta), 0, math.cos(beta)])
    e = -np.array([math.cos(beta), 0, math.sin(beta)])
    a_along = (1 - d - dg.finger_tip_radius * ps) * l
    relaxed = scene.options.sliding_model == "relaxed"
    centre = cx * u + t / 2 * top + cy * across
    best = math.inf
    for side in (1.0, -1.0):
        contacts = []  # (point, normal, tangent, mu, friction sign along tangent or 0, jaw weight)
        for s in ([0.0] if dg.support[0] == 0 else [-dg.support[0] * l, dg.support[0] * l]):
            contacts.append((s * across, np.array([0, 0, 1.0]), np.array([1.0, 0, 0]), mu[0], 0, 0.0))
        contacts.append((a_along * u + t * top + side * offset * across, -top, u, mu[1], -sa, -1.0))
        for s in ([0.0] if dg.support[1] == 0 else [-dg.support[1] * l, dg.support[1] * l]):
            contacts.append((l * u + s * across, n_b, e, mu[2], sb, 1.0))
        for push in (1.0, -1.0):
            nv = 3 * len(contacts) + 1
            a_eq, a_ub, b_ub, bounds = [], [], [], []
            rows = np.zeros((7, nv))
            for k, (p, n, tg, m, slip, jaw) in enumerate(contacts):
                for j, axis in enumerate((n, tg, across)):
                    rows[:3, 3 * k + j] = axis
                    rows[3:6, 3 * k + j] = np.cross(p, axis)
                    rows[6, 3 * k + j] = jaw * axis @ n_b
                bounds += [(0, None), (None, None), (None, None)]
                if slip == 0:
                    if cone == "pyramidal":
                        for a, b in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
                            r = np.zeros(nv)
                            r[3 * k:3 * k + 3] = (-m, a, b)
                            a_ub.append(r)
                            b_ub.append(0.0)
                    else:
                        for i in range(sides):
                            ang = 2 * math.pi * (i + 0.5) / sides
                            r = np.zeros(nv)
                            r[3 * k:3 * k + 3] = (-m * math.cos(math.pi / sides), math.cos(ang), math.sin(ang))
                            a_ub.append(r)
                            b_ub.append(0.0)
                else:
                    # nothing across, and the friction along the slip: c_t = slip mu c_n (strict), or
                    # 0 <= slip c_t <= mu c_n (relaxed: between the normal and the edge)
                    across_row = np.zeros(nv)
                    across_row[3 * k + 2] = 1.0
                    a_eq.append(across_row)
                    edge = np.zeros(nv)
                    edge[3 * k:3 * k + 2] = (-m, slip)
                    if relaxed:
                        backward = np.zeros(nv)
                        backward[3 * k + 1] = -slip
                        a_ub += [edge, backward]
                        b_ub += [0.0, 0.0]
                    else:
                        a_eq.append(edge)
            rows[:3, -1] = push * across
            rows[3:6, -1] = push * np.cross(centre, across)
            gravity = np.concatenate([[0, 0, -w], np.cross(centre, [0, 0, -w])])
            rhs = np.concatenate([-gravity, [2 * scene.sim.grip_force]])
            eq = np.vstack([rows] + a_eq)
            beq = np.concatenate([rhs, np.zeros(len(a_eq))])
            cost = np.zeros(nv)
            cost[-1] = -1
            bounds += [(None, None)]
            res = linprog(cost, A_ub=np.array(a_ub) if a_ub else None, b_ub=np.array(b_ub) if b_ub else None,
                          A_eq=eq, b_eq=beq, bounds=bounds, method="highs")
            best = min(best, res.x[-1] if res.status == 0 else -math.inf)
    return best


def _random_states(scene: Scene, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([np.radians(rng.uniform(5, 40, n)), rng.uniform(0.55, 0.8, n),
                            np.radians(rng.uniform(0, 45, n))])


@pytest.mark.parametrize("cone", ["pyramidal", "elliptic"])
def test_the_margin_agrees_with_an_independent_linear_programme(pick, chalk, cone):
    for scene, seed in ((pick, 3), (chalk, 4), (pick.with_options(sliding_model="strict"), 5)):
        q = _random_states(scene, 6, seed)
        rng = np.random.default_rng(seed + 10)
        sa, sb = rng.integers(-1, 2, len(q)), rng.integers(-1, 2, len(q))
        mu = scene.plane_friction(rng.uniform(0.6, 1.2))
        got = out_of_plane_margin(scene, q, sa, sb, mu, cone).push
        want = [oracle(scene, qi, int(a), int(b), mu, cone, 1e-3) for qi, a, b in zip(q, sa, sb)]
        for g, w in zip(got, want):
            if math.isinf(w):
                assert g == w
            else:
                assert g == pytest.approx(w, abs=1e-6, rel=1e-6)


def test_the_margin_falls_with_friction_and_with_the_pyramid(pick, chalk):
    for scene in (pick, chalk):
        q = _random_states(scene, 8, 7)
        u = scene.friction_uncertainty
        nominal = out_of_plane_margin(scene, q, 0, 0, scene.plane_friction(1.0), "elliptic").push
        low = out_of_plane_margin(scene, q, 0, 0, scene.plane_friction(1.0 - u), "elliptic").push
        pyramid = out_of_plane_margin(scene, q, 0, 0, scene.plane_friction(1.0), "pyramidal").push
        finite = np.isfinite(nominal)
        assert finite.sum() >= 6
        assert np.all(low[finite] < nominal[finite])
        assert np.all(pyramid[finite] < nominal[finite])
        # the pyramid is inscribed in the cone: it never holds more, wherever it holds at all
        assert np.all(pyramid <= nominal + 1e-9)


def test_two_sliding_contacts_hold_a_twist_only_by_slipping_sideways(chalk):
    # P_dpsi: A and B slide. With B a point (the chalk's thumb side cut to nothing across) and the
    # grasp on GB, section 5.3's partial stability is a margin of exactly 0: the push's moment about
    # the vertical through G finds nothing to hold it. Slipping sideways within a 10 deg turn over
    # the leg helps under Coulomb's cone; under the pyramid it helps nothing while the slip stays
    # below 45 deg (a 20 mm slide here), and pushes with the pyramid's lateral edges beyond it (a
    # 1 mm slide at A's 8 mm lever: A, on the top face, holds the push's moment about GB). B's
    # straight side across the thumb's width twists back with its in-plane forces alone, and holds a
    # push even with the grasp 1 mm off.
    q = np.array([[math.radians(15), 0.7, math.radians(35)]])
    mu = chalk.plane_friction(1.0)
    on = OutOfPlaneLoads(offset=0.0)
    point = replace(chalk, digits=replace(chalk.digits, support=(0.0, 0.0)))
    for cone in ("elliptic", "pyramidal"):
        assert out_of_plane_margin(point, q, -1, -1, mu, cone, on).push[0] == pytest.approx(0.0, abs=1e-9)
    long, short = np.array([[0.02, 0.02]]), np.array([[0.001, 0.001]])
    assert out_of_plane_margin(point, q, -1, -1, mu, "elliptic", on, slide=long).push[0] > 0.01
    pyramid_long = out_of_plane_margin(point, q, -1, -1, mu, "pyramidal", on, slide=long).push[0]
    assert pyramid_long == pytest.approx(0.0, abs=1e-9)
    assert out_of_plane_margin(point, q, -1, -1, mu, "pyramidal", on, slide=short).push[0] > 0.01
    assert out_of_plane_margin(chalk, q, -1, -1, mu, "elliptic").push[0] > 0.0


def _press(scene: Scene, plan_like):
    states = plan_states(scene, plan_like)
    press = states.primitive < 0
    return states, press


class _Leg:
    def __init__(self, kind, a, b):
        self.type, self.waypoints = kind, [a, b]


class _Plan:
    """A plan's first leg from the scene's start (for the pick from before decision 0107: 30 deg,
    d 0.77, psi 0): 2.5 deg of P_theta."""

    solved = True

    def __init__(self, scene: Scene):
        start = [float(x) for x in scene.start]
        self.primitives = [_Leg("P_theta", start, [start[0] - math.radians(2.5), start[1], start[2]])]


def _trial_friction(scene: Scene, world: float, draw) -> tuple[float, float, float]:
    per = [scene.plane_friction(world * f) for f in draw.friction_scale]
    return per[0][0], per[1][1], per[2][2]


def test_the_recorded_pick_trial_turns_where_the_margin_is_negative(recorded_pick):
    # docs/model.md 11.18: trial 0 of `paper` seed 1 at the world's friction x0.7 times its drawn
    # factors (0.62-0.68 of the scene's) is squeezed out of the pinch during the start press and
    # leaves the plane (tools/world_failures.py); the same draw in the nominal world places. The
    # press, with the trial's friction and its shift across GB:
    scene = recorded_pick
    draw = trial_params(preset("paper"), 1, 1)[0]
    states, press = _press(scene, _Plan(scene))
    assert press.sum() >= 2
    loads = OutOfPlaneLoads(offset=abs(draw.shift_across_mm) / 1000)
    q, sa, sb, slide = states.states[press], states.a_sign[press], states.b_sign[press], states.slide[press]
    assert np.all(sa == 1) and np.all(sb == 1)  # the press slides A toward G and B along the thumb
    cold = out_of_plane_margin(scene, q, sa, sb, _trial_friction(scene, 0.7, draw), ConeModel.ELLIPTIC, loads, slide)
    warm = out_of_plane_margin(scene, q, sa, sb, _trial_friction(scene, 1.0, draw), ConeModel.ELLIPTIC, loads, slide)
    assert cold.push[0] < 0.0  # where the press begins, with the thumb's face along the object (psi 0)
    assert cold.push.min() == -math.inf  # no in-plane hold: the pinch slides out
    assert warm.push.min() > 0.0


def test_the_recorded_pick_trial_loses_its_pinch_where_the_margin_has_no_hold_and_places_in_the_nominal_world(
        recorded_pick):
    """The trial of docs/model.md 11.18 whose press has no in-plane hold at x0.7 (the margin -inf,
    above) fails before the termination there (at 0.1 ms, where that section's studies ran, out of
    the plane at the first tick; at the simulator's step, its grip lost in the first P_psi) and
    places in the nominal world."""
    from ungrasp_ompl import planning
    from ungrasp_ompl.scene.options import Landing
    from ungrasp_ompl.sim.outcome import Outcome
    from ungrasp_ompl.sim.plan_trials import placement
    from ungrasp_ompl.sim.trial import run_trial
    from ungrasp_ompl.sim.world import World

    scene = replace(recorded_pick, robot=replace(recorded_pick.robot, landing=Landing.PLANNED))
    plan = planning.plan(scene, planner="lattice", seed=1)
    _, setup = placement(scene, plan)
    draw = trial_params(preset("paper"), 1, 1)[0]
    # the draw's friction factors on top of the world's (the trial as recorded: friction_draw_in_world)
    cold = run_trial(replace(setup, world=World(friction=0.7), friction_draw_in_world=True), draw, 0, 1)
    assert cold.outcome in (Outcome.LEFT_PLANE, Outcome.GRIP_LOST) and cold.phase in ("P_theta", "P_psi")
    assert run_trial(setup, draw, 0, 1).outcome in (Outcome.SUCCESS, Outcome.OFF_TARGET)
