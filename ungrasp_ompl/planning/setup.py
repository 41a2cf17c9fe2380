"""Planner setup: the OMPL problem for a scene, solved by any geometric planner by name.

Mirrors og.SimpleSetup: :class:`UngraspSetup` owns the space information
(state space, validity checker, motion validator), the problem definition
(start, sampleable goal region, objective) and the planner; :func:`plan` is
the one-call entry point.

Reproducibility (docs/model.md, section 9): OMPL's seed generator is seeded
afresh before every seeded run (seed_ompl), and a seeded run stops after a
fixed count of planner iterations (not on wall time), so the same seed gives
the same plan, in a fresh process or after other plans. A cost-optimising
planner also stops once its path reaches the exact lattice optimum (checked
at its iterations, so the stop is as reproducible as the budget).
"""

from __future__ import annotations

import math
from time import perf_counter
from dataclasses import asdict, dataclass, replace
from functools import cached_property
from collections.abc import Callable
from typing import Any, cast
from enum import Enum

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from ..errors import InputError, ToolError
from ..mechanics.margin import friction_margin
from ..mechanics.release import ReleaseModelError
from ..parallel.options import check_seed
from ..parallel.runner import TaskStatus, run_in_child
from ..scene import Scene, StateClass
from ..scene.stability import analyse
from ..scene.options import Release
from .atlas import Leg, SecurityAtlas, goal_behind_start, goal_cut_by_start, planning_box
from .goal import LatticeGoalRegion
from .lattice import lattice_search, optimum_cost
from .margins import OBJECTIVES, LatticeMargins, Objective
from .names import LATTICE, PLANNERS
from .objective import PrimitiveCostObjective, make_objective, reduce_vertices
from .path_margin import path_friction_margin
from .plan_tolerance import tolerance
from .predicted_landing import farthest_landing, predict_landing, release_goals
from .result import (AtGAB, Diagnostics, GoalEmpty, HoldableMap, ObjectRecord, PathSource, Plan, PlanOutcome,
                     PlaneRecord, Report3D, Solution, StabilityRecord, StartNotHeld, StoppedBy, friction_record,
                     merge_legs, sequence_cost)
from .space import make_state_space, path_states, set_state
from .turns import ROADMAP_PLANNERS, RoadmapCostObjective, RoadmapMotionValidator, TakeTurns
from .validity import LatticeValidityChecker, PrimitiveMotionValidator
from .verify import PathCheck, PathProblem, first_failing_leg


#: Planners that may spin in C++ without checking their termination condition, and what was seen.
#: AORRTC's loop (its connect step re-adding one state, checking the same motion each time) is
#: ended by PrimitiveMotionValidator.REPEAT_LIMIT; the watchdog stays for loops without callbacks.
UNRULY_PLANNERS = {
    "AORRTC": "in the ompl 2.0.1 wheel its connect loop can re-add one state forever without "
              "checking the time limit (seen in 5 of 10 and 2 of 8 runs on reference_asymmetric before "
              "the motion validator refused repeated motions; in none of 70 runs since)",
}
#: Seconds a run may take beyond its time cap before it counts as hung.
HANG_GRACE_S = 60.0

#: Planners of the ompl wheel that cannot run with Python callbacks, and why. None now: PRM and
#: PRMstar, whose two solver threads deadlock on the GIL, run with their threads taking turns
#: (planning/turns.py).
UNUSABLE_PLANNERS: dict[str, str] = {}


class Limitation(Enum):
    """Why a planner of the ompl wheel cannot solve ungrasping problems (directed, sparse secure
    motions): measured, and read in its source. ``bench`` prints the code next to a 0% success
    rate and the reason under its table."""

    LAZY_ROADMAP = ("FMT* checks only the cheapest connection to each sample and never retries it from a "
                    "node it has closed; secure motions here are sparse and one-way, so its open set empties "
                    "after a few dozen edges and it reports that no path exists (0 of 20 bench runs of 1 s on "
                    "reference_asymmetric and guitar_pick; none either with 3000 samples, 3x its radius or "
                    "extended FMT* for 20 s)")
    BACKWARD_GOAL_TREE = ("BFMT* grows its goal tree by checking each edge from the goal side, against the "
                          "direction the path travels it; primitives run one way, so that tree never grows and "
                          "what is left is FMT*'s lazy search (0 of 20 bench runs of 1 s on reference_asymmetric "
                          "and guitar_pick, 0 of 3 runs of 5 s)")

    @property
    def code(self) -> str:
        """A short name for tables: lazy-roadmap, backward-goal-tree."""
        return self.name.lower().replace("_", "-")


#: Planners that cannot solve these problems, and why (see Limitation).
KNOWN_LIMITATIONS: dict[str, Limitation] = {"FMT": Limitation.LAZY_ROADMAP, "BFMT": Limitation.BACKWARD_GOAL_TREE}

#: The planner's longest motion by objective (state units): the same for all, so that the robust
#: objectives' planner is the cost's, its objective aside. The maximin objectives had 0.05, a
#: stand-in for their earlier additive objective, which ranked paths narrower than the bottleneck by
#: a sum rather than by their smallest margin; it grows the tree six times slower, and their replans
#: without P_dpsi (planning.max_landing_spread) found no path within the budget on puzzle_piece and
#: fabric_chalk (seeds 1-3 and 5 with margin, 1-3 of fabric_chalk with tolerance; with 0.3, seed 3
#: of fabric_chalk alone, with either objective or the cost).
DEFAULT_RANGE = {"cost": 0.3, "balanced": 0.3, "margin": 0.3, "tolerance": 0.3}

#: Iterations per second of --time that a seeded run is given (measured: RRT* runs
#: 8,000-11,000 iterations per second on the reference scenes and 4,000-5,000 on the
#: shipped 3D scenes on 2 cores, so a seeded run takes about --time seconds).
ITERATIONS_PER_SECOND = 6000
#: The same for planners far from that rate: PRM and PRM* make about 2 calls per milestone and
#: share the time with their search rounds (measured: 1,000 calls take 0.45-0.85 s, 5,000 take
#: 3.5-7.6 s on reference_asymmetric and guitar_pick on 2 cores).
PLANNER_ITERATIONS_PER_SECOND = {"PRM": 1000, "PRMstar": 1000}
#: A seeded run's hard cap on its time, as a multiple of its --time: a guard against a runaway, not a
#: limit a slower or busier machine meets (the budget above takes 0.7-1.5 of --time on the reference
#: machine), since a run the cap stops is not the plan its seed gives elsewhere.
SEEDED_TIME_CAP = 30.0


def hang_deadline(time: float, budgeted: bool) -> float:
    """Seconds after which a planning process is killed and counted as hung: its run's hard cap
    (SEEDED_TIME_CAP times time for a run that stops on an iteration budget, else time) and
    HANG_GRACE_S."""
    return (SEEDED_TIME_CAP * time if budgeted else time) + HANG_GRACE_S


@dataclass(frozen=True)
class PlannerOptions:
    """How to run the planner."""

    planner: str = "RRTstar"
    """An OMPL geometric planner by name (PLANNERS)."""
    time: float = 1.0
    """Planning time (s); a seeded run: the size of its iteration budget, SEEDED_TIME_CAP times it its hard cap."""
    seed: int | None = None
    """Seed of OMPL's random numbers: the same seed gives the same plan. None: not reproducible."""
    iterations: int | None = None
    """Planner iterations (termination-condition calls); None: ITERATIONS_PER_SECOND (PRM, PRM*:
    PLANNER_ITERATIONS_PER_SECOND) times time when seeded, unbounded otherwise."""
    range: float | None = None
    """The planner's longest motion, in state units (theta and psi in rad, d over l); None: the
    scene's planning.range, else the objective's DEFAULT_RANGE (for_scene)."""
    goal_bias: float = 0.1
    """How often a tree-based planner steers to a goal sample (0-1)."""
    simplify: bool = True
    """Shorten the path with OMPL's PathSimplifier (shortcuts in travel direction)."""
    objective: Objective | None = None
    """What to optimise (docs/model.md, section 6): cost, margin (the smallest friction margin along
    the path), balanced (cost plus planning.margin_weight times a penalty growing as it shrinks) or
    tolerance (the smallest tolerance of the `paper` errors along the path, section 4.6); None: the
    scene's planning.objective (scene_objective)."""

    def validated(self) -> "PlannerOptions":
        if self.planner in UNUSABLE_PLANNERS:
            raise InputError("planner", f"{self.planner} is not usable here: {UNUSABLE_PLANNERS[self.planner]}")
        if self.planner not in PLANNERS:
            raise InputError("planner", f"unknown planner {self.planner!r} (known: {', '.join(PLANNERS + (LATTICE,))})")
        if not (isinstance(self.time, (int, float)) and math.isfinite(self.time) and self.time > 0):
            raise InputError("time", f"must be a positive number of seconds, got {self.time!r}")
        if self.seed is not None:
            check_seed(self.seed)
        if self.iterations is not None and (not isinstance(self.iterations, int) or self.iterations < 1):
            raise InputError("iterations", f"must be a positive integer, got {self.iterations!r}")
        if self.range is not None and not self.range > 0:
            raise InputError("range", f"must be positive, got {self.range!r}")
        if not 0 <= self.goal_bias <= 1:
            raise InputError("goal_bias", f"must lie in [0, 1], got {self.goal_bias!r}")
        return self if self.objective is None else replace(self, objective=check_objective(self.objective, self.planner))

    def for_scene(self, scene: Scene) -> "PlannerOptions":
        """These options resolved for scene: the objective their own, else the scene's
        (scene_objective); the range their own, else the scene's planning.range, else the
        objective's DEFAULT_RANGE."""
        opts = replace(self, objective=scene_objective(self.objective, scene, self.planner))
        if opts.range is not None:
            return opts
        return replace(opts, range=scene.options.range or DEFAULT_RANGE.get(opts.objective, DEFAULT_RANGE["cost"]))


def scene_objective(objective: Objective | str | None, scene: Scene, planner: str) -> Objective:
    """The objective a plan of scene optimises: the one named; None, the scene's planning.objective,
    except for the roadmap planners (which optimise the cost only), which optimise the cost.
    InputError naming `objective` for one the planner cannot optimise (check_objective)."""
    if objective is None:
        objective = Objective.COST if planner in ROADMAP_PLANNERS else scene.options.objective
    return check_objective(objective, planner)


def check_objective(objective: Objective | str, planner: str) -> Objective:
    """The objective by its name; InputError unless it is one of OBJECTIVES and the planner can optimise it."""
    if objective not in OBJECTIVES:
        raise InputError("objective", f"must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    if objective != Objective.COST and planner in ROADMAP_PLANNERS:
        raise InputError("objective", f"{planner} optimises the cost only (its roadmap objective takes edges "
                         "either way while it grows); use RRTstar or lattice for the robust objectives")
    return Objective(objective)


class UngraspSetup:
    """The OMPL problem of one scene, ready to solve (like og.SimpleSetup). With options.seed it
    seeds OMPL's random numbers itself (seed_ompl), so the same options give the same plan."""

    def __init__(self, scene: Scene, options: PlannerOptions = PlannerOptions(), atlas: SecurityAtlas | None = None):
        """atlas: the scene's secure lattice over its planning box when built already (tiling's
        proof built it); otherwise it is built here."""
        self.scene = scene
        self.options = options.validated().for_scene(scene)
        if self.options.seed is not None:  # before OMPL builds anything that draws numbers
            seed_ompl(self.options.seed)
        t0 = perf_counter()
        if atlas is not None and (atlas.scene is not scene or not np.allclose(atlas.res, scene.options.resolution)):
            raise ValueError("the atlas given was built for another scene or resolution")
        self.atlas = atlas if atlas is not None else SecurityAtlas(scene, planning_box(scene))
        self.atlas.prepare()
        self.space = make_state_space(planning_box(scene))
        self.si = ob.SpaceInformation(self.space)
        self.validity_checker = LatticeValidityChecker(self.si, self.atlas)
        roadmap = self.options.planner in ROADMAP_PLANNERS
        self.motion_validator = (RoadmapMotionValidator if roadmap else PrimitiveMotionValidator)(self.si, self.atlas)
        self.si.setStateValidityChecker(self.validity_checker)
        self.si.setMotionValidator(self.motion_validator)
        self.si.setup()
        self.margins = LatticeMargins.of(self.atlas, self.options.objective) if self.options.objective != Objective.COST else None
        if self.margins is not None:
            self.margins.prepare()
            self.objective = make_objective(self.si, self.atlas, self.margins)
        else:
            self.objective = (RoadmapCostObjective if roadmap else PrimitiveCostObjective)(self.si, self.atlas)
        # the lattice optimum stops an optimising planner (the cost objective's yardstick); where it
        # does not exist no planner runs (solve)
        self.stop_at_optimum = self.options.objective == Objective.COST and self.options.planner in OPTIMISING_PLANNERS
        if self.stop_at_optimum and self.lattice_optimum is not None:
            # OMPL's own stop: a path of objective cost below this is the optimum, as every motion
            # pays at least one leg's penalty, so the objective exceeds the plan's cost by one or more
            self.objective.setCostThreshold(ob.Cost(self.lattice_optimum + self.objective.penalty + OPTIMUM_TOLERANCE))
        self.goal = LatticeGoalRegion(self.si, self.atlas, scene.goal, np.random.default_rng(options.seed))
        self.pdef = ob.ProblemDefinition(self.si)
        self._start = self.space.allocState()
        set_state(self._start, scene.start)
        self.pdef.addStartState(self._start)
        self.pdef.setGoal(self.goal)
        self.pdef.setOptimizationObjective(self.objective)
        self.planner = getattr(og, self.options.planner)(self.si)
        for setter, value in (("setRange", self.options.range), ("setGoalBias", self.options.goal_bias)):
            if hasattr(self.planner, setter):
                getattr(self.planner, setter)(value)
        self.planner.setProblemDefinition(self.pdef)
        self.planner.setup()
        self.setup_time = perf_counter() - t0

    @cached_property
    def lattice_optimum(self) -> float | None:
        """The cost of the exact optimum on the secure lattice (reference units; None: no secure
        path reaches the goal), searched once (planning.lattice.optimum_cost)."""
        return optimum_cost(self.atlas, self.scene.goal.box())

    # -- diagnosis -----------------------------------------------------------------
    def ends_problem(self) -> EndsProblem | None:
        """Why planning cannot start (the start cannot be held, or the goal region is empty), or None."""
        return ends_problem(self.scene, self.atlas, self.goal.maxSampleCount() > 0)

    # -- solving -------------------------------------------------------------------
    def solve(self) -> Plan:
        """Plan, re-validate the path leg by leg in its travel direction, and report."""
        opts, scene = self.options, self.scene
        plan = Plan(outcome=PlanOutcome.NOT_FOUND, scene=scene.name, planner=opts.planner, seed=opts.seed,
                    sliding_model=scene.options.sliding_model, friction=friction_record(scene.friction),
                    objective=opts.objective,
                    diagnostics=Diagnostics(setup_time_s=self.setup_time, resolution=[float(x) for x in self.atlas.res]),
                    holdable_map=HoldableMap.of(self.atlas))
        problem = self.ends_problem()
        if problem:
            return plan.with_diagnostics(stopped_by=StoppedBy.NOT_STARTED).fail(problem.outcome, **problem.evidence)
        if self.lattice_optimum is None:  # the exact search reaches no goal state: every path the planner
            # could find is one of secure lattice moves, so it would spend its whole budget for nothing
            return self._no_path(plan.with_diagnostics(stopped_by=StoppedBy.NOT_STARTED))
        budget = opts.iterations
        cap = opts.time
        if opts.seed is not None:
            rate = PLANNER_ITERATIONS_PER_SECOND.get(opts.planner, ITERATIONS_PER_SECOND)
            budget = budget or max(1, int(rate * opts.time))
            cap = SEEDED_TIME_CAP * opts.time
        best_cost = getattr(self.planner, "bestCost", None)
        state = {"n": 0, "first": None, "stop": "", "best": math.inf}
        optimum = self.lattice_optimum if self.stop_at_optimum and opts.planner in TREE_PLANNERS else None
        t0 = perf_counter()

        def done() -> bool:
            state["n"] += 1
            elapsed = perf_counter() - t0
            if state["first"] is None:
                found = math.isfinite(best_cost().value()) if best_cost else self.pdef.hasExactSolution()
                if found:
                    state["first"] = elapsed
            if optimum is not None and best_cost().value() < state["best"]:  # a better path: is it optimal?
                state["best"] = best_cost().value()
                if self._tree_path_cost() <= optimum + OPTIMUM_TOLERANCE:
                    state["stop"] = StoppedBy.OPTIMUM
                    return True
            if budget is not None and state["n"] >= budget:
                state["stop"] = StoppedBy.ITERATIONS
                return True
            if elapsed >= cap:
                state["stop"] = StoppedBy.TIME
                return True
            return False

        turns = None
        if opts.planner in ROADMAP_PLANNERS:
            turns = TakeTurns(self.planner, done, lambda: self.objective.heuristic_calls,
                              either_way=(self.motion_validator, self.objective))
        status = self.planner.solve(ob.PlannerTerminationCondition(turns or done))
        planning_time = perf_counter() - t0
        if turns is not None:
            if turns.interrupt is not None:
                raise turns.interrupt
            if state["first"] is None and self.objective.first_solution is not None:
                state["first"] = self.objective.first_solution - t0
        stopped_by = state["stop"] or StoppedBy.PLANNER
        if not state["stop"] and best_cost and self.objective.isSatisfied(best_cost()):
            stopped_by = StoppedBy.OPTIMUM  # OMPL stopped at the cost threshold
        plan = plan.with_diagnostics(planning_time_s=planning_time, iterations=state["n"], stopped_by=stopped_by)
        exact = self.pdef.hasExactSolution() and str(status) in ("Exact solution",)
        if not exact:
            return self._no_path(plan)
        path = self.pdef.getSolutionPath()
        if plan.stopped_by == StoppedBy.OPTIMUM:
            pass  # optimal as it is; OMPL's shortcuts count legs, not changes, and can add one
        elif opts.simplify and self.margins is not None:  # OMPL's reduceVertices ignores the objective
            path = reduce_vertices(self.si, self.objective, path)
        elif opts.simplify:
            simplifier = og.PathSimplifier(self.si, self.goal, self.objective)
            simplifier.reduceVertices(path)
        legs, problem = self.path_legs(path_states(path))
        if problem:
            return plan.fail(PlanOutcome.INVALID_PATH, **problem.evidence())
        plan = plan.with_diagnostics(time_to_first_solution_s=state["first"] if state["first"] is not None
                                     else planning_time)
        return solved_plan(plan, self.atlas, legs, self.margins)

    def _tree_path_cost(self) -> float:
        """The cost, counted as a plan's (merged primitives), of the planner's best path so far,
        read from its tree (getPlannerData marks the best goal state; every state has one parent);
        inf without one."""
        data = ob.PlannerData(self.si)
        self.planner.getPlannerData(data)
        if data.numGoalVertices() == 0:
            return math.inf
        k = data.getGoalIndex(0)
        states = []
        for _ in range(data.numVertices()):  # up the tree to its root
            s = data.getVertex(k).getState()
            states.append((s[0], s[1], s[2]))
            parents = data.getIncomingEdges(k)
            if not parents:
                break
            k = parents[0]
        legs, problem = self._realised(np.array(states[::-1]))
        return math.inf if problem else sequence_cost(self.atlas, merge_legs(self.atlas, legs))[0]

    def path_legs(self, states: np.ndarray) -> tuple[list[Leg], PathProblem | None]:
        """Primitive legs realising a path of states, each edge in its travel direction,
        choosing among the realisations of every edge (the best for a robust objective) those
        with fewest primitive changes overall; every leg re-validated with the exact mechanics."""
        legs, problem = self._realised(states)
        return (legs, problem) if problem else (legs, verify_legs(self.scene, self.atlas, legs))

    def _realised(self, states: np.ndarray) -> tuple[list[Leg], PathProblem | None]:
        """path_legs before the re-validation: the legs, or why the path has none."""
        atlas = self.atlas
        idx = []
        for q in states:
            i = atlas.index(q)
            if i is None:
                return [], PathProblem(PathCheck.OUTSIDE_BOX)
            if not idx or idx[-1] != i:
                idx.append(i)
        options = []
        for k, (a, b) in enumerate(zip(idx[:-1], idx[1:])):
            found = atlas.realise(a, b)
            if not found:
                return [], PathProblem(PathCheck.NO_SECURE_LEGS, k)
            if self.margins is not None:  # the realisations the objective ranks first
                found = self.margins.best(found)
            options.append(found)
        return _fewest_changes(options), None

    def _no_path(self, plan: Plan) -> Plan:
        """The plan failed with the exact lattice search's verdict: no secure path, or one the
        planner did not find (its cost recorded as lattice_optimum)."""
        optimum = self.lattice_optimum
        res = plan.resolution
        if optimum is None:
            return plan.fail(PlanOutcome.NO_SECURE_PATH, resolution=res)
        plan = plan.with_diagnostics(lattice_optimum=optimum)
        limit = f"{plan.iterations} iterations" if plan.stopped_by == StoppedBy.ITERATIONS else f"{plan.planning_time_s:.2f} s"
        return plan.fail(PlanOutcome.NOT_FOUND, resolution=res, stopped_by=plan.stopped_by, limit=limit,
                         lattice_optimum=optimum)


@dataclass(frozen=True)
class EndsProblem:
    """Why no path can start or end (ends_problem): the plan's outcome and its evidence."""

    outcome: PlanOutcome
    """START_NOT_HELD or GOAL_EMPTY."""
    evidence: StartNotHeld | GoalEmpty
    """Plan.evidence under that outcome."""


def ends_problem(scene: Scene, atlas: SecurityAtlas, goal_reachable: bool | None = None) -> EndsProblem | None:
    """Why no path can start or end: the start state cannot be held (Scene.diagnose's evidence)
    or no goal state can be held with room to let go; None if neither.
    goal_reachable: whether the goal region holds such a state, when the caller knows."""
    start = scene.diagnose(scene.start)
    if start.state_class is not StateClass.HELD:
        return EndsProblem(PlanOutcome.START_NOT_HELD, dict(state_class=start.state_class.name,
                           failed_checks=list(start.failed_checks), contacts=list(start.contacts)))
    behind = goal_behind_start(scene)
    if behind:
        return EndsProblem(PlanOutcome.GOAL_EMPTY, dict(outside_box=True, behind_start=behind))
    box = scene.goal.box()
    if goal_reachable is None:
        goal_reachable = atlas.can_let_go_in(box)
    if not goal_reachable:
        cut = goal_cut_by_start(scene)
        return EndsProblem(PlanOutcome.GOAL_EMPTY, dict(holdable=bool(atlas.holdable_in(box).any()),
                                                        termination=scene.robot.termination,
                                                        **({"cut_by_start": cut} if cut else {})))
    return None


def verify_legs(scene: Scene, atlas: SecurityAtlas, legs: list[Leg]) -> PathProblem | None:
    """Re-check every leg in its travel direction with the exact mechanics and FCL at half the
    lattice step (planning.verify.verify_leg, every leg at once: first_failing_leg); the first
    failure, or None."""
    found = first_failing_leg(scene, [(leg.primitive, atlas.state(leg.start), atlas.state(leg.end)) for leg in legs],
                              atlas.res / 2)
    if found is None:
        return None
    k, why = found
    return PathProblem(PathCheck.LEG_FAILS, k, legs[k].primitive, why)


#: Planners whose best path so far can be read from their tree while they run (solve's stop at the
#: lattice optimum); the others stop there when OMPL finds the objective's cost threshold met.
TREE_PLANNERS = ("RRTstar", "InformedRRTstar", "SORRTstar")
#: Planners that stop at the objective's cost threshold (PRM* is stopped by TakeTurns; the others
#: stop at their first path).
OPTIMISING_PLANNERS = TREE_PLANNERS + ("BITstar", "AORRTC")
#: A cost this close (reference units) to the lattice optimum is the optimum.
OPTIMUM_TOLERANCE = 1e-9


#: A path's smallest margin this close (deg) to the lattice's bottleneck is the bottleneck (the
#: plan's states are recomputed from its corners, a rounding away from the lattice's).
FORCED_TOLERANCE_DEG = 1e-9


def solved_plan(plan: Plan, atlas: SecurityAtlas, legs: list[Leg], margins: LatticeMargins | None = None) -> Plan:
    """The plan solved by verified legs: merged primitives, corner states, cost, and the friction
    margins (the smallest of each primitive and of the path, the start's; with the lattice's
    margins, its bottleneck and whether the path's smallest margin is forced by it)."""
    steps = merge_legs(atlas, legs)
    states = [[float(x) for x in atlas.scene.start]] + [q for s in steps for q in s.waypoints[1:]]
    cost, l1, switches = sequence_cost(atlas, steps)
    plan = replace(plan, outcome=PlanOutcome.SOLVED, evidence={},
                   solution=Solution(states, steps, cost, l1, switches))
    scene = atlas.scene
    margin: dict = {"start_margin_deg": math.degrees(float(friction_margin(*scene.start, 0, 0, scene.friction)[0]))}
    if steps:  # every state the legs pass at the lattice's resolution, in its leg's mode, the start included
        margin["margin_profile_deg"] = [math.degrees(m) for m in path_friction_margin(scene, plan).of_primitives()]
        margin["min_margin_deg"] = min(margin["margin_profile_deg"])
    bottleneck = margins.bottleneck if margins is not None and margins.objective != Objective.TOLERANCE else None
    if bottleneck is not None:
        margin["margin_bottleneck_deg"] = math.degrees(bottleneck)
        if "min_margin_deg" in margin:
            margin["margin_forced"] = margin["min_margin_deg"] >= margin["margin_bottleneck_deg"] - FORCED_TOLERANCE_DEG
    return plan.with_diagnostics(**margin, path_from=PathSource.PLANNER)


def lattice_plan(scene: Scene, seed: int | None = None, atlas: SecurityAtlas | None = None,
                 objective: Objective | str = Objective.COST) -> Plan:
    """The exact optimum on the scene's lattice as a plan (the 'lattice' planner): a Dijkstra search
    with the planners' cost (or a bottleneck search for the margin objective, lattice_search), its
    legs re-validated like any planner's path."""
    objective = check_objective(objective, LATTICE)
    t0 = perf_counter()
    atlas = atlas if atlas is not None else SecurityAtlas(scene, planning_box(scene))
    margins = LatticeMargins.of(atlas, objective) if objective != Objective.COST else None
    t1 = perf_counter()
    result = lattice_search(atlas, scene.goal.box(), objective, margins)
    t2 = perf_counter()
    plan = Plan(outcome=PlanOutcome.NOT_FOUND, scene=scene.name, planner=LATTICE, seed=seed,
                sliding_model=scene.options.sliding_model, friction=friction_record(scene.friction),
                objective=objective, holdable_map=HoldableMap.of(atlas),
                diagnostics=Diagnostics(setup_time_s=t1 - t0, planning_time_s=t2 - t1,
                                        resolution=[float(x) for x in atlas.res], stopped_by=StoppedBy.PLANNER,
                                        lattice_optimum=result.cost))
    if not result.reachable:
        problem = ends_problem(scene, atlas)
        return plan.fail(problem.outcome, **problem.evidence) if problem else plan.fail(PlanOutcome.NO_SECURE_PATH, resolution=plan.resolution)
    problem = verify_legs(scene, atlas, result.legs)
    if problem:
        return plan.fail(PlanOutcome.INVALID_PATH, **problem.evidence())
    return solved_plan(plan.with_diagnostics(time_to_first_solution_s=t2 - t1), atlas, result.legs, margins)


def _fewest_changes(options: list[list[list[Leg]]]) -> list[Leg]:
    """Pick one realisation per edge minimising the primitive changes along the path (Viterbi)."""

    def changes(legs: list[Leg]) -> int:
        return sum(a.primitive != b.primitive for a, b in zip(legs[:-1], legs[1:]))

    best = [(changes(r), [i]) for i, r in enumerate(options[0])]
    for k in range(1, len(options)):
        nxt = []
        for j, r in enumerate(options[k]):
            cands = []
            for i, (c, trail) in enumerate(best):
                prev = options[k - 1][i]
                joint = int(bool(prev) and bool(r) and prev[-1].primitive != r[0].primitive)
                cands.append((c + joint + changes(r), trail + [j]))
            nxt.append(min(cands, key=lambda x: x[0]))
        best = nxt
    _, trail = min(best, key=lambda x: x[0])
    return [leg for k, i in enumerate(trail) for leg in options[k][i]]


def plan(scene: Scene, planner: str | PlannerOptions = "RRTstar", time: float = 1.0, seed: int | None = None,
         iterations: int | None = None, atlas: SecurityAtlas | None = None, **options) -> Plan:
    """Plan an ungrasp for scene with an OMPL planner by name (or 'lattice'); see PlannerOptions,
    which may also be passed whole as planner (its fields then replace the arguments, which must be
    left at their defaults: InputError otherwise).

    With a seed the result is reproducible: the same seed gives the same plan
    (timing fields aside). A planner known to ignore its time limit runs in a
    child process that is stopped HANG_GRACE_S seconds after its cap. atlas: the
    scene's secure lattice when built already (used when planning in this process). With the
    scene's planning.min_tolerance above 0, the plan found carries its tolerance, and one below
    that floor fails (PlanOutcome.BELOW_MIN_TOLERANCE).

    With the margin objective the plan is never narrower than the cost objective's of the same
    scene, planner, seed and budget (docs/model.md, section 6.1): both are planned, each through
    every check above, and the cost objective's is kept only where it is solved and keeps more
    margin (with_cost_baseline); nor narrower than the lattice's widest secure path, where that
    passes the same checks (with_widest_path, docs/decisions/0104); and where the planner finds no
    path in its budget but the lattice holds one, the lattice's widest is the plan (0120).
    """
    if isinstance(planner, PlannerOptions):
        if (time, seed, iterations, options) != (1.0, None, None, {}):
            raise InputError("planner", "give the planner's options as a PlannerOptions or as arguments, not both")
        return plan(scene, atlas=atlas, **asdict(planner))
    if scene.options.release is Release.LEAST_MOVING:
        return _least_moving_plan(scene, lambda s: plan(s, planner, time, seed, iterations, None, **options))
    options["objective"] = scene_objective(options.get("objective"), scene, planner)
    if options["objective"] == Objective.MARGIN:
        t0 = perf_counter()
        if atlas is None and planner not in UNRULY_PLANNERS:  # one lattice for both searches
            atlas = SecurityAtlas(scene, planning_box(scene))
        built = perf_counter() - t0
        baseline = _plan_objective(scene, planner, time, seed, iterations, atlas,
                                   **{**options, "objective": Objective.COST})
        own = _plan_objective(scene, planner, time, seed, iterations, atlas, **options)
        result = with_cost_baseline(own, baseline, atlas)
        result = with_widest_path(result, lambda: _plan_objective(scene, LATTICE, time, seed, iterations, atlas,
                                                                  **options))
        return result.with_diagnostics(setup_time_s=result.setup_time_s + built)
    return _plan_objective(scene, planner, time, seed, iterations, atlas, **options)


#: How many of the least-moving goal states planning.release least_moving tries, in order (record 0128).
LEAST_MOVING_TRIES = 5


def _least_moving_plan(scene: Scene, plan_to: Callable[[Scene], Plan]) -> Plan:
    """planning.release least_moving (records 0128, 0130): the plan to the goal state whose release
    moves the object least (predicted_landing.release_goals), its goal region narrowed to that lattice
    state, the states the plan may visit still bounded by the whole region (GoalSpec.within);
    where no path reaches it, to the next, up to LEAST_MOVING_TRIES; the first one's failure
    where none is reached. Without such a goal state, the plan the whole goal region gives.

    A goal state is ranked by the fall from the state itself, which is where the release starts
    only if the plan reaches it without a P_dpsi: across a P_dpsi the pinch carries the object
    (carried_start), so that plan's own landing is another. Where the plan found passes through a
    P_dpsi it is weighed against the plan to the least-moving goal state the start reaches at its
    own d, each by its own predicted landing, and the one whose farthest landing is nearer is kept."""
    whole = scene.with_options(release=Release.OBJECTIVE)
    goals = release_goals(whole)
    first = None
    for state, _ in goals[:LEAST_MOVING_TRIES]:
        result = plan_to(whole.with_goal_cell(state))
        if result.solved:
            return _carried_or_level(whole, result, goals, plan_to).with_diagnostics(release=Release.LEAST_MOVING.value)
        first = first or result.with_diagnostics(release=Release.LEAST_MOVING.value)
    return first if first is not None else plan_to(whole).with_diagnostics(release=Release.LEAST_MOVING.value)


def _carried_or_level(whole: Scene, found: Plan, goals: list, plan_to: Callable[[Scene], Plan]) -> Plan:
    """found, or where it passes through a P_dpsi, the plan to the least-moving goal state at the
    start's d (goals: release_goals, ranked) when that plan's own predicted landing lies nearer at its
    farthest (_least_moving_plan)."""
    if not any(str(p.type) == "P_dpsi" for p in found.primitives):
        return found
    half_d = whole.options.resolution[1] / 2
    level = next((state for state, _ in goals if abs(state[1] - whole.start[1]) <= half_d), None)
    if level is None:
        return found
    other = plan_to(whole.with_goal_cell(level))
    if not other.solved:
        return found
    try:
        nearer = farthest_landing(predict_landing(whole, other)) < farthest_landing(predict_landing(whole, found))
    except ReleaseModelError:
        return found
    return other if nearer else found


def _plan_objective(scene: Scene, planner: str, time: float, seed: int | None, iterations: int | None,
                    atlas: SecurityAtlas | None, **options) -> Plan:
    """plan for one objective, without the margin objective's comparison with the cost's."""
    if planner == LATTICE:
        result = lattice_plan(scene, seed, atlas, options.get("objective", Objective.COST))
        result = with_3d_report(scene, result) if scene.plane is not None else result
    else:
        opts = PlannerOptions(planner=planner, time=time, seed=seed, iterations=iterations, **options).validated()
        if planner in UNRULY_PLANNERS:
            result = _plan_in_child(scene, opts, deadline=hang_deadline(time, seed is not None))
        else:
            result = _plan_here(scene, opts, atlas)
    result = with_tolerance_floor(scene, result)
    if result.solved and scene.options.max_landing_spread is not None:
        result = with_landing_spread(scene, result,
                                     lambda s, a: _plan_objective(s, planner, time, seed, iterations, a, **options),
                                     atlas)
    return result


def with_cost_baseline(own: Plan, baseline: Plan, atlas: SecurityAtlas | None = None) -> Plan:
    """The margin objective's plan held to the cost objective's of the same scene, planner, seed and
    budget (baseline), so that it is never narrower by construction: its own where it is solved
    and keeps at least the baseline's smallest margin (within FORCED_TOLERANCE_DEG), or where the
    baseline is not solved; else the baseline's path as the margin plan, its bottleneck the margin
    search's (from atlas's margins where that search recorded none). Its times count both searches
    (the baseline's first, as plan runs it); its iterations and stop are the kept search's.

    The objective ranks the smallest margin first (MaximinObjective), but RRT* is anytime (within
    its budget its tree may hold no path as wide as the cost plan's), and the checks after
    planning (planning.max_landing_spread, planning.min_tolerance) may refuse its path and pass
    the cost plan's."""
    keep_own = not baseline.solved or (own.solved and
                                       own.min_margin_deg >= baseline.min_margin_deg - FORCED_TOLERANCE_DEG)
    kept = own if keep_own else replace(baseline, objective=own.objective).with_diagnostics(
        path_from=PathSource.COST_BASELINE)
    bottleneck = own.margin_bottleneck_deg
    if not keep_own and bottleneck is None and atlas is not None:
        found = LatticeMargins.of(atlas, Objective.MARGIN).bottleneck
        bottleneck = None if found is None else math.degrees(found)
    first = baseline.time_to_first_solution_s if baseline.solved else None
    if first is None and own.time_to_first_solution_s is not None:
        first = baseline.planning_time_s + own.time_to_first_solution_s
    changes: dict[str, Any] = dict(setup_time_s=own.setup_time_s + baseline.setup_time_s,
                                   planning_time_s=own.planning_time_s + baseline.planning_time_s,
                                   time_to_first_solution_s=first)
    if not keep_own:
        changes["margin_bottleneck_deg"] = bottleneck
        changes["margin_forced"] = (None if bottleneck is None or kept.min_margin_deg is None
                                    else kept.min_margin_deg >= bottleneck - FORCED_TOLERANCE_DEG)
    return kept.with_diagnostics(**changes)


def with_widest_path(result: Plan, widest: Callable[[], Plan]) -> Plan:
    """A margin plan held to the lattice's bottleneck (docs/decisions/0104, 0120): kept where it
    keeps the widest margin any secure lattice path keeps (margin_forced), or where that is not
    known; else the plan widest() returns (the exact lattice search's widest path, through the
    checks any plan passes) in its place when that is solved and keeps more margin than the
    planner's path, or when the planner found no path in its budget (NOT_FOUND: it keeps none);
    its planner and seed the planner's, its times both searches', its path_from
    PathSource.LATTICE (LATTICE_FALLBACK where the planner found none)."""
    found_none = result.outcome is PlanOutcome.NOT_FOUND
    if result.planner == LATTICE or (not result.solved and not found_none) or \
            (result.solved and result.margin_forced is not False):
        return result
    other = widest()
    if not other.solved or other.min_margin_deg is None or \
            (result.solved and other.min_margin_deg <= result.min_margin_deg + FORCED_TOLERANCE_DEG):
        return result
    kept = replace(other, planner=result.planner, seed=result.seed)
    return kept.with_diagnostics(path_from=PathSource.LATTICE if result.solved else PathSource.LATTICE_FALLBACK,
                                 iterations=result.iterations, stopped_by=result.stopped_by,
                                 lattice_optimum=result.lattice_optimum,
                                 time_to_first_solution_s=result.time_to_first_solution_s,
                                 setup_time_s=result.setup_time_s + other.setup_time_s,
                                 planning_time_s=result.planning_time_s + other.planning_time_s)


def with_landing_spread(scene: Scene, result: Plan, replan: Callable[[Scene, SecurityAtlas | None], Plan],
                        atlas: SecurityAtlas | None = None) -> Plan:
    """A solved plan held to the scene's planning.max_landing_spread (docs/model.md 11.24): with its
    predicted landing (planning.predicted_landing), kept when the landing moves no more than the bound over
    the friction's range and both cones; else, when the plan has a P_dpsi (which carries the object
    and makes its landing depend on friction), the scene planned again by replan without P_dpsi
    (planning.forbid_partial) and that plan kept when it keeps the bound; else failed
    (PlanOutcome.LANDING_SPREAD, path kept). replan takes the scene without P_dpsi and its secure
    lattice when one is known: atlas's for it (SecurityAtlas.with_options: the scene's lattice, built
    already, serves it), where atlas, the scene's, is given; None otherwise."""
    bound = scene.options.max_landing_spread
    landing = predict_landing(scene, result)
    result = replace(result, predicted_landing=landing.to_dict())
    if landing.spread <= bound:
        return result
    without: float | str = "the plan has no P_dpsi"
    if not scene.options.forbid_partial and any(p.type == "P_dpsi" for p in result.primitives):
        options = replace(scene.options, forbid_partial=True, max_landing_spread=None)
        lattice = atlas.with_options(options) if atlas is not None and atlas.scene is scene else None
        strict = lattice.scene if lattice is not None else replace(scene, options=options)
        other = replan(strict, lattice)
        if other.solved:
            kept = predict_landing(strict, other)
            if kept.spread <= bound:
                return replace(other, predicted_landing=kept.to_dict())
            without = kept.spread
        else:
            without = f"none found ({other.reason})"
    return result.fail(PlanOutcome.LANDING_SPREAD, spread_m=landing.spread, max_landing_spread_m=bound,
                       without_p_dpsi=without)


def with_tolerance_floor(scene: Scene, result: Plan) -> Plan:
    """A solved plan held to the scene's planning.min_tolerance (docs/model.md 4.6): with its
    tolerance measured, and failed (BELOW_MIN_TOLERANCE, path kept) below the floor; unchanged
    without a floor or a solution."""
    floor = scene.options.min_tolerance
    if floor <= 0 or not result.solved:
        return result
    tol = tolerance(scene, result).to_dict()
    result = replace(result, tolerance=tol)
    return result if tol["scale"] >= floor else result.fail(PlanOutcome.BELOW_MIN_TOLERANCE, tolerance=tol,
                                                             min_tolerance=floor)


def _plan_here(scene: Scene, opts: PlannerOptions, atlas: SecurityAtlas | None = None) -> Plan:
    ou.setLogLevel(ou.LogLevel.LOG_ERROR)
    setup = UngraspSetup(scene, opts, atlas)
    result = setup.solve()
    if result.solved and result.lattice_optimum is None:
        # the yardstick of the plan's cost, whatever its objective: searched already when the planner
        # stops there, else a sweep over the lattice built for planning (under 0.1 s on the shipped scenes)
        result = result.with_diagnostics(lattice_optimum=setup.lattice_optimum)
    return with_3d_report(scene, result) if scene.plane is not None else result


def seed_ompl(seed: int) -> None:
    """Seed OMPL's random numbers for the planner built next. OMPL's seed generator is one per
    process; setting its seed again restarts it, so every planner, sampler and goal built after
    this call draws the same numbers as in a fresh process (OMPL logs an error that the seed changes
    after numbers were drawn, which is what is wanted here: it is silenced)."""
    ou.setLogLevel(ou.LogLevel.LOG_NONE)
    try:
        ou.RNG.setSeed(seed)
    finally:
        ou.setLogLevel(ou.LogLevel.LOG_ERROR)


def with_3d_report(scene: Scene, result: Plan) -> Plan:
    """The plan with its 3D report: the object, manipulation plane, effective friction and 3D
    stability of a scene with an outline; each primitive says how x-moments are held."""
    states = [("start", scene.start)]
    if result.solved:
        states.append(("end", np.array(result.states[-1])))
    report = analyse(scene, states)
    steps = [replace(p, x_moments=report.x_mechanism) for p in result.primitives]
    mu_g, mu_a, mu_b = scene.mu
    # the lower floors' to_dict give plan.json's mappings; their shapes are planning.result's TypedDicts
    return replace(result, solution=replace(result.solution, primitives=steps),
                   report=Report3D(cast(ObjectRecord, scene.object3d.to_dict()),
                                   cast(PlaneRecord, scene.plane.to_dict()), AtGAB(G=mu_g, A=mu_a, B=mu_b),
                                   cast(StabilityRecord, report.to_dict())))


def _plan_in_child(scene: Scene, opts: PlannerOptions, deadline: float | None = None) -> Plan:
    """Plan in a fresh process (its own OMPL RNG); stop it after deadline seconds if given.
    An exception raised there is raised here; a process that ends without an answer is a ToolError."""
    outcome = run_in_child(_plan_here, scene, opts, deadline=deadline)
    if outcome.status is TaskStatus.HUNG:
        return Plan(outcome=PlanOutcome.HUNG, scene=scene.name, planner=opts.planner, seed=opts.seed,
                    sliding_model=scene.options.sliding_model, friction=friction_record(scene.friction),
                    diagnostics=Diagnostics(stopped_by=StoppedBy.KILLED, planning_time_s=deadline or 0.0),
                    evidence=dict(deadline_s=deadline, known=UNRULY_PLANNERS.get(opts.planner, "")))
    if outcome.status is TaskStatus.DIED:
        raise ToolError(f"the process planning {scene.name} with {opts.planner} ended without an answer")
    return outcome.unwrap()
