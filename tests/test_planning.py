"""Planning: directed motions, the lattice against brute force, golden plans, the Python API."""

from __future__ import annotations

import heapq
import json
import math

import numpy as np
import pytest

from conftest import ROOT, peg_scene_file, run_cli
from ungrasp_ompl import Scene
from ungrasp_ompl.errors import InputError
from ungrasp_ompl.mechanics import Friction, kinematic_checks
from ungrasp_ompl.planning.atlas import FORWARD, SecurityAtlas, planning_box, reference_cost
from ungrasp_ompl.planning.lattice import lattice_search, optimum_cost
from ungrasp_ompl.planning.result import merge_legs, sequence_cost
from ungrasp_ompl.planning.setup import PlannerOptions, UngraspSetup
from ungrasp_ompl.planning.verify import LegCheck, PathCheck, verify_leg

BRUTE_FORCE = (math.radians(1.5), 0.015, math.radians(1.5))  # the brute-force search's lattice
GOLDEN = ROOT / "tests" / "golden"


@pytest.fixture(scope="module")
def setup(scenes):
    return UngraspSetup(scenes["reference_asymmetric"], PlannerOptions())


def state(space, q):
    s = space.allocState()
    s[0], s[1], s[2] = (float(x) for x in q)
    return s


def test_motion_validator_is_directed(setup):
    """A pivot down from the start is secure; the same motion back up is not a forward primitive."""
    a = setup.scene.start
    b = a + np.array([-math.radians(5), 0, 0])
    mv, sp = setup.motion_validator, setup.space
    assert mv.checkMotion(state(sp, a), state(sp, b))
    assert not mv.checkMotion(state(sp, b), state(sp, a))
    obj = setup.objective
    assert math.isfinite(obj.motionCost(state(sp, a), state(sp, b)).value())
    assert not math.isfinite(obj.motionCost(state(sp, b), state(sp, a)).value())
    assert not obj.isSymmetric()


def test_a_path_that_is_not_secure_says_why_in_values(setup):
    """path_legs names, as values, why a path cannot be executed: a state outside the planning box,
    an edge against the primitives' directions, a leg that fails the exact re-check."""
    a = setup.scene.start
    legs, problem = setup.path_legs(np.array([a, a + [0, 0, 10.0]]))
    assert not legs and problem.check is PathCheck.OUTSIDE_BOX
    down = a + np.array([-math.radians(5), 0, 0])  # back up from here is no forward primitive
    legs, problem = setup.path_legs(np.array([down, a]))
    assert not legs and (problem.check, problem.index) == (PathCheck.NO_SECURE_LEGS, 0)
    assert json.loads(json.dumps(problem.evidence()))["path_check"] == "no_secure_legs"
    # past the thumb's tip: the re-check's first failure is kinematic, at the first sample beyond
    far = a + np.array([0, -0.9, 0])
    failure = verify_leg(setup.scene, "P_d", a, far, setup.atlas.res)
    assert failure.check is LegCheck.KINEMATICS
    assert not all(v.all() for v in kinematic_checks(*np.array([failure.state]).T, setup.scene.digits).values())


@pytest.mark.slow
def test_reverse_primitives_allow_the_way_back(scenes):
    """With reverse primitives a tree planner's motion validator passes a motion both ways (RRT's:
    RRT*'s is the same validator, and would search the lattice optimum first, to no use here)."""
    from ungrasp_ompl.planning.validity import PrimitiveMotionValidator

    scene = scenes["reference_asymmetric"].with_options(reverse_primitives=True)
    s = UngraspSetup(scene, PlannerOptions(planner="RRT"))
    assert not s.stop_at_optimum and type(s.motion_validator) is PrimitiveMotionValidator
    a = scene.start
    b = a + np.array([-math.radians(5), 0, math.radians(3)])
    assert s.motion_validator.checkMotion(state(s.space, a), state(s.space, b))
    assert s.motion_validator.checkMotion(state(s.space, b), state(s.space, a))


def test_atlas_agrees_with_exact_mechanics(setup):
    """A motion is secure on the atlas iff one of its leg sequences passes the exact check
    (mechanics and FCL, no atlas tables) at the lattice resolution."""
    atlas = setup.atlas
    rng = np.random.default_rng(4)
    secure = 0
    for _ in range(300):
        a = tuple(int(x) for x in rng.integers(0, atlas.shape))
        b = tuple(int(np.clip(a[k] + FORWARD[k] * rng.integers(0, 8), 0, atlas.shape[k] - 1)) for k in range(3))
        fast = atlas.motion_secure(a, b)
        if a == b:
            continue
        exact = any(all(verify_leg(atlas.scene, leg.primitive, atlas.state(leg.start), atlas.state(leg.end), atlas.res) is None
                        for leg in legs) for legs in atlas.realisations(a, b))
        assert fast == exact, (a, b)
        secure += fast
    assert 10 < secure < 290


def brute_force_optimum(atlas, goal_box):
    """Textbook Dijkstra over (lattice state, primitive under way) with one-step legs: T and P legs
    secure as the atlas checks them; D, X and Y (psi alone within a P_dpsi, which must slide d
    before another primitive or the goal) steps secure at both ends in some mode of a P_dpsi: A
    sliding toward B, B toward the palm (ds_B = cos(psi) dd - d sin(psi) dpsi < 0 for dd < 0,
    dpsi >= 0 below psi = 90 deg), also sticking at 90 deg, and either way beyond."""
    opts = atlas.scene.options
    steps = {"T": (-1, 0, 0), "P": (0, 0, 1), "D": (0, -1, 0), "X": (0, -1, 1), "Y": (0, 0, 1)}
    prim = {"T": "P_theta", "P": "P_psi", "D": "P_dpsi", "X": "P_dpsi"}

    def dpsi_mode(idx):
        c = math.cos(atlas.axes[2][idx[2]])
        modes = [-1] if c > 1e-9 else [-1, 0] if c >= -1e-9 else [-1, 0, 1]
        return any(atlas.mode_ok(-1, b)[idx] for b in modes)
    start = atlas.index(atlas.scene.start)
    heap = [(0.0, start, "")]
    done = set()
    while heap:
        cost, idx, last = heapq.heappop(heap)
        if (idx, last) in done:
            continue
        done.add((idx, last))
        q = atlas.state(idx)
        if np.all(q >= goal_box[0] - 1e-9) and np.all(q <= goal_box[1] + 1e-9) and atlas.holdable[idx] \
                and last != "P_dpsi before d":
            return cost
        for kind, st in steps.items():
            nxt = tuple(idx[k] + st[k] for k in range(3))
            if any(not 0 <= nxt[k] < atlas.shape[k] for k in range(3)):
                continue
            if kind in "DXY" and not (dpsi_mode(idx) and dpsi_mode(nxt)):
                continue
            if kind in "TP" and not (atlas.leg_secure(kind, idx, nxt) and last != "P_dpsi before d"):
                continue
            new = "P_dpsi before d" if kind == "Y" and last != "P_dpsi" else prim.get(kind, "P_dpsi")
            c = reference_cost(np.asarray(st) * atlas.res, opts.d_weight)
            c += opts.mode_change_penalty if last and last[:6] != new[:6] else 0.0
            heapq.heappush(heap, (cost + c, nxt, new))
    return None


@pytest.mark.parametrize("name, reachable", [("reference_asymmetric", True), ("reference_equal_digits", False),
                                             ("reference_upper_obstacle", True)])
def test_lattice_search_equals_brute_force(scenes, name, reachable):
    """On a lattice of 1.5 deg / 0.015 / 1.5 deg (coarser has no secure path at all, so the
    comparison would be empty), with and without a secure path."""
    scene = scenes[name]
    atlas = SecurityAtlas(scene, planning_box(scene), resolution=BRUTE_FORCE)
    alone = optimum_cost(atlas, scene.goal.box())  # first: lattice_search's result is not there to read
    result = lattice_search(atlas, scene.goal.box())
    expected = brute_force_optimum(atlas, scene.goal.box())
    assert (expected is not None) == reachable
    assert (result.cost is None) == (expected is None) and (alone is None) == (expected is None)
    if expected is not None:
        assert result.cost == pytest.approx(expected, abs=1e-9)
        assert alone == pytest.approx(expected, abs=1e-9)
        # its legs are planner legs, secure, and add up to the cost
        assert all(leg.kind in "TPDX" and atlas.leg_secure(leg.kind, leg.start, leg.end) for leg in result.legs)
        steps = merge_legs(atlas, result.legs)
        assert sequence_cost(atlas, steps)[0] == pytest.approx(result.legs_cost, abs=1e-9)
        assert result.legs_cost == pytest.approx(result.cost, abs=1e-9)


@pytest.mark.parametrize("name, options", [("guitar_pick", {}), ("fabric_chalk_designed", {}),
                                           ("reference_asymmetric", {"forbid_partial": True})])
def test_the_optimum_s_cost_alone_is_the_search_s(name, options):
    """optimum_cost's sweep over the lattice's levels finds lattice_search's optimum on the planning
    lattice of scenes with other objects and digits, and without P_dpsi."""
    scene = Scene.from_file(name).with_options(**options)
    atlas = SecurityAtlas(scene, planning_box(scene))
    alone = optimum_cost(atlas, scene.goal.box())
    assert not atlas.cost_optima  # searched, not read from lattice_search's results
    assert alone == pytest.approx(lattice_search(atlas, scene.goal.box()).cost, abs=1e-9)


def golden(name):
    return json.loads((GOLDEN / f"{name}.json").read_text())


@pytest.mark.parametrize("name", ["reference_asymmetric", "reference_upper_obstacle", "reference_equal_digits"])
def test_golden_plan_reproduces(tmp_path, name):
    """Regression: the seeded CLI run gives the stored plan (states within 1e-9, same primitives)."""
    want = golden(name)
    proc = run_cli("plan", str(ROOT / "scenes" / f"{name}.yaml"), "--seed", "1", "--time", "1", "--out", str(tmp_path))
    assert proc.returncode == (0 if want["solved"] else 3), proc.stdout + proc.stderr
    got = json.loads((tmp_path / "plan.json").read_text())
    assert got["solved"] == want["solved"]
    np.testing.assert_allclose(got["states"], want["states"], atol=1e-9)
    strip = [{k: p[k] for k in ("type", "direction", "sliding", "stability")} for p in want["primitives"]]
    assert [{k: p[k] for k in ("type", "direction", "sliding", "stability")} for p in got["primitives"]] == strip
    if want["solved"]:
        assert got["cost"] == pytest.approx(want["cost"], abs=1e-9)


@pytest.mark.parametrize("name", ["reference_asymmetric", "reference_upper_obstacle"])
def test_golden_legs_are_secure(scenes, name):
    """Every leg of the golden plan passes the exact mechanics at a quarter of the planning resolution,
    its primitive moves only its own coordinates, and its stability class matches its sliding contacts."""
    scene, plan = scenes[name], golden(name)
    res = np.array(plan["resolution"]) / 4
    moves = {"P_theta": (0,), "P_psi": (2,), "P_dpsi": (1, 2)}
    for p in plan["primitives"]:
        pts = np.array(p["waypoints"])
        assert np.allclose(pts[0], p["start"]) and np.allclose(pts[-1], p["end"])
        for a, b in zip(pts[:-1], pts[1:]):
            assert verify_leg(scene, p["type"], a, b, res) is None
            still = [k for k in range(3) if k not in moves[p["type"]]]
            assert np.allclose(a[still], b[still])
        assert p["stability"] == ("full" if len(p["sliding"]) <= 1 else "partial")
    # the path is continuous and ends in the goal
    states = np.array(plan["states"])
    assert np.allclose(states[0], scene.start)
    assert scene.goal.contains(states[-1])[0]


@pytest.mark.parametrize("name", ["reference_asymmetric", "reference_upper_obstacle"])
def test_planner_cost_is_never_below_lattice_optimum(scenes, name):
    """On the same lattice and cost, no planner can beat the exact optimum."""
    scene, plan = scenes[name], golden(name)
    atlas = SecurityAtlas(scene, planning_box(scene))
    optimum = lattice_search(atlas, scene.goal.box()).cost
    assert plan["cost"] >= optimum - 1e-9
    assert plan["cost"] <= 1.05 * optimum  # and it is close to it


def test_python_api_queries(scenes):
    scene = scenes["reference_asymmetric"]
    rng = np.random.default_rng(0)
    q = np.column_stack([rng.uniform(0, 1.5, 500), rng.uniform(0.5, 1, 500), rng.uniform(0, 1.5, 500)])
    dq = np.tile([0.0, 0.0, 0.1], (500, 1))  # P_psi: B slides toward the palm
    from ungrasp_ompl.mechanics import force_closure
    expected = force_closure(q[:, 0], q[:, 1], q[:, 2], 0, -1, Friction(scene.mu))
    assert np.array_equal(scene.force_closure(q, dq), expected)
    stick = scene.force_closure(q)
    assert not np.any(expected & ~stick)
    valid = scene.is_valid(q)
    assert valid.shape == (500,) and not np.any(valid & ~stick)
    assert scene.is_valid(scene.start)[0]
    with pytest.raises(ValueError, match="shape"):
        scene.force_closure(np.zeros((3, 2)))
    for bad in ([[0.5, np.nan, 0.2]], [[0.1, 0.8, 0.0], [0.2, 0.8, np.inf]], "theta"):
        for query in (scene.force_closure, scene.margin, scene.is_valid):
            with pytest.raises(InputError) as err:
                query(bad)
            assert err.value.field == "q"
    with pytest.raises(InputError) as err:
        scene.margin(q[:1], [[0.0, np.nan, 0.1]])
    assert err.value.field == "dq"


def test_plan_api_is_reproducible_in_process(scenes):
    """plan() with a seed gives the same result called twice in one process (OMPL's seed
    generator restarted for each, planning.setup.seed_ompl)."""
    from ungrasp_ompl import plan

    scene = scenes["reference_upper_obstacle"]
    a = json.loads(plan(scene, seed=3, time=0.3).to_json())
    b = json.loads(plan(scene, seed=3, time=0.3).to_json())
    for d in (a, b):
        for key in ("time_to_first_solution_s", "planning_time_s", "setup_time_s"):
            d.pop(key)
    assert a == b and a["solved"]


def test_plan_takes_its_options_whole(scenes):
    """plan(scene, PlannerOptions(...)) plans as the same fields given as arguments do (the same
    path, seeded); options given both ways at once are refused, naming the planner."""
    from ungrasp_ompl import plan

    scene = scenes["reference_upper_obstacle"]
    options = PlannerOptions(planner="RRTstar", time=0.3, seed=5, iterations=600)
    whole, fields = plan(scene, options), plan(scene, planner="RRTstar", time=0.3, seed=5, iterations=600)
    assert whole.solved and whole.states == fields.states and whole.cost == fields.cost
    with pytest.raises(InputError) as err:
        plan(scene, options, seed=6)
    assert err.value.field == "planner"


def test_a_setup_seeds_ompl_itself(scenes):
    """UngraspSetup with a seed seeds OMPL's random numbers itself: built twice with the same
    options, with another seed's run in between, it solves to the same path and iteration."""
    scene = scenes["reference_upper_obstacle"]
    runs = [UngraspSetup(scene, PlannerOptions(planner="RRTstar", time=0.3, seed=seed, iterations=800)).solve()
            for seed in (7, 8, 7)]
    assert all(r.solved for r in runs)
    assert runs[0].states == runs[2].states and runs[0].iterations == runs[2].iterations
    assert runs[0].states != runs[1].states  # the seed matters, so the equality above is the seed's doing


def test_strict_model_changes_the_plan(scenes):
    """Under the strict model a sliding contact pushes along one cone edge only: P_psi is not
    force-closed at psi 2-8 deg near the reference start (B sticks at psi = 0 itself), and at 1 deg / 0.01 no secure path is left where the
    relaxed model's optimum costs 85 (both found by the exact lattice search)."""
    scene = scenes["reference_asymmetric"]
    fine = (math.radians(1), 0.01, math.radians(1))
    relaxed = lattice_search(SecurityAtlas(scene, planning_box(scene), fine), scene.goal.box()).cost
    strict_scene = scene.with_options(sliding_model="strict")
    strict = lattice_search(SecurityAtlas(strict_scene, planning_box(strict_scene), fine), scene.goal.box()).cost
    assert relaxed == pytest.approx(85.0)
    assert strict is None
    q = np.array([[math.radians(30), 0.8, math.radians(psi)] for psi in (2, 5, 8)])
    psi_up = np.tile([0.0, 0.0, 0.1], (3, 1))
    assert scene.force_closure(q, psi_up).all() and not strict_scene.force_closure(q, psi_up).any()



@pytest.mark.parametrize("seed", [True, -1, 2**32, 1.0, "1"])
def test_planner_options_refuse_a_seed_that_is_not_an_integer_in_range(seed):
    """PlannerOptions holds its seed to the one rule every seed obeys (parallel.options.check_seed):
    an integer in [0, 2^32), a bool not counting as one; the error names the field."""
    from ungrasp_ompl.planning.setup import PlannerOptions

    with pytest.raises(InputError) as err:
        PlannerOptions(seed=seed).validated()
    assert err.value.field == "seed"
    assert PlannerOptions(seed=2**32 - 1).validated().seed == 2**32 - 1


def test_a_goal_that_the_start_cuts_says_along_which_coordinate():
    """The puzzle piece with a flat finger tip: from d 0.62 the part of the goal region at or below
    the start's d (the forward primitives only lower d) holds no state that can be let go, and the
    outcome says that d cut it; from d 0.8 the same goal region is reached, at a d above 0.62."""
    from ungrasp_ompl.planning import plan
    from ungrasp_ompl.planning.result import PlanOutcome, describe_outcome

    flat = Scene.from_file(ROOT / "scenes" / "puzzle_piece.yaml").with_digits(finger_tip="flat")
    low = flat.with_start_d(0.62)
    cut = plan(low, planner="lattice")
    assert cut.outcome is PlanOutcome.GOAL_EMPTY and cut.evidence["cut_by_start"] == ["d"]
    assert describe_outcome(cut.outcome, cut.evidence) != describe_outcome(
        cut.outcome, {k: v for k, v in cut.evidence.items() if k != "cut_by_start"})
    whole = plan(flat.with_start_d(0.8), planner="lattice")
    assert whole.solved and whole.states[-1][1] > 0.62
    assert flat.goal.box()[0][1] <= 0.62 < flat.goal.box()[1][1]  # the goal's d range holds the low start


@pytest.mark.parametrize("planner", ["RRTstar", "RRTConnect"])
def test_no_planner_runs_where_the_exact_search_reaches_no_goal(tmp_path, planner):
    """Where a peg cuts the start off from the goal (conftest.peg_scene_file), plan answers
    NO_SECURE_PATH without running the planner (no iteration), and the planner run on the same
    problem anyway finds no path in its time (every path it can find is made of secure lattice
    moves, which the exact search has all tried)."""
    from ompl import base as ob

    from ungrasp_ompl.planning import plan
    from ungrasp_ompl.planning.result import PlanOutcome, StoppedBy

    scene = Scene.from_file(peg_scene_file(tmp_path))
    result = plan(scene, planner=planner, seed=1, time=0.5)
    assert (result.outcome, result.stopped_by, result.iterations) == (PlanOutcome.NO_SECURE_PATH, StoppedBy.NOT_STARTED, 0)
    run = UngraspSetup(scene, PlannerOptions(planner=planner, seed=1, time=0.5))
    assert run.lattice_optimum is None
    run.planner.solve(ob.timedPlannerTerminationCondition(0.5))
    assert not run.pdef.hasExactSolution()
