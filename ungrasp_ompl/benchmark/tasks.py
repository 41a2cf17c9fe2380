"""Benchmark runs: one planner on one scene, each a task of a :class:`~ungrasp_ompl.parallel.runner.Runner`.

A run seeds OMPL's random numbers afresh with ``seed + run`` (planning.setup.seed_ompl, so a
worker runs task after task and each gives what it would in a fresh process), builds the scene's
:class:`~ungrasp_ompl.planning.UngraspSetup` with the planner by name and solves on wall
time, like OMPL's ``tools::Benchmark`` does (or, given iterations, for that many
iterations, reproducibly). The planner ``lattice`` is the exact search over the primitive
lattice at the scene's own resolution. A run's status is read from the plan's typed
outcome (:class:`~ungrasp_ompl.planning.result.PlanOutcome`), never from its text.
"""

from __future__ import annotations

import enum
import time
from collections.abc import Callable, Sequence
from contextlib import closing
from dataclasses import dataclass, replace

from ..errors import InputError, ToolError, UngraspError
from ..parallel.runner import Runner, TaskStatus
from ..parallel.stream import RowStream
from ..planning.margins import Objective
from ..planning.plan_tolerance import tolerance
from ..planning.result import Plan, PlanOutcome
from ..planning.setup import (HANG_GRACE_S, LATTICE, PlannerOptions, UngraspSetup, hang_deadline, lattice_plan,
                              seed_ompl)
from ..scene import Scene


class RunStatus(enum.Enum):
    """How one benchmark run ended (the order is the benchmark log's enum)."""

    EXACT = "exact"  #: a path that passed re-validation
    TIMEOUT = "timeout"  #: none found within the time, though the lattice holds one
    INVALID = "invalid"  #: the path returned failed re-validation
    UNSOLVABLE_START_OR_GOAL = "unsolvable_start_or_goal"  #: the start cannot be held or the goal region is empty
    INFEASIBLE = "infeasible"  #: the exact lattice search reaches no goal state
    HUNG = "hung"  #: killed HANG_GRACE_S s after its time cap, or its process ended without an answer


#: The run statuses by name, in the benchmark log's enum order.
STATUSES = tuple(s.value for s in RunStatus)

#: A run's status from its plan's outcome.
_STATUS_OF = {
    PlanOutcome.SOLVED: RunStatus.EXACT,
    PlanOutcome.START_NOT_HELD: RunStatus.UNSOLVABLE_START_OR_GOAL,
    PlanOutcome.GOAL_EMPTY: RunStatus.UNSOLVABLE_START_OR_GOAL,
    PlanOutcome.INVALID_PATH: RunStatus.INVALID,
    PlanOutcome.NO_SECURE_PATH: RunStatus.INFEASIBLE,
    PlanOutcome.NOT_FOUND: RunStatus.TIMEOUT,
    PlanOutcome.HUNG: RunStatus.HUNG,
}

#: Called with (runs done, runs in all) before the first run and after each run.
Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class Task:
    """One run: a planner on a scene, in its own child process. It carries all it needs
    (scene, planner options with the run's seed), so its result does not depend on where it runs."""

    group: str
    """The scene's key (benchmark) or the alpha's index (sweep)."""
    scene: Scene
    """The scene to plan."""
    planner: PlannerOptions
    """How the run plans, whole: planner.planner an OMPL planner by name, or ``lattice``;
    planner.seed OMPL's RNG seed of this run (an integer, required); planner.time the planning
    time (s: wall time, or with planner.iterations the cap of 5 times it); planner.iterations the
    planner iterations (count, making the run reproducible; None: stop on wall time, OMPL still
    drawing from the seed); planner.objective what it optimises (None: the cost); its range,
    goal bias and simplification as for ``plan``. The lattice run reads the objective only."""
    run: int
    """The run's index (count); -1: a lattice yardstick run, not reported as a planner run."""

    def __post_init__(self) -> None:
        if isinstance(self.planner.seed, bool) or not isinstance(self.planner.seed, int):
            raise InputError("seed", f"a benchmark run needs an integer seed, got {self.planner.seed!r}")

    @property
    def objective(self) -> Objective:
        """What the run optimises (docs/model.md, section 6): planner.objective, None as the cost
        (a campaign compares its runs on one objective, never each scene's own)."""
        return Objective(self.planner.objective or Objective.COST)

    @property
    def deadline(self) -> float:
        """Seconds after which the run's process is killed and the run counted as hung."""
        p = self.planner
        return hang_deadline(p.time, bool(p.iterations))


@dataclass(frozen=True)
class RunResult:
    """What one run measured. Times in seconds, cost in reference units (None: no path).

    time_s is the benchmark log's ``time``: an OMPL planner's planning time
    (solve() only), or the lattice planner's wall time to build the lattice
    and search it. wall_time_s: the whole task in its process, setup included.
    """

    group: str
    planner: str
    run: int
    seed: int
    status: RunStatus
    cost: float | None
    mode_switches: int | None
    time_to_first_solution_s: float | None
    planning_time_s: float
    setup_time_s: float
    iterations: int | None
    wall_time_s: float
    min_margin_deg: float | None = None
    """The path's smallest friction margin (deg), each leg in its contact mode; None: no path."""
    tolerance: float | None = None
    """The path's tolerance of the `paper` errors (a scale of their box), measured under the
    tolerance objective; None: another objective, or no path."""

    @property
    def solved(self) -> bool:
        """A path was found and passed re-validation."""
        return self.status is RunStatus.EXACT

    @property
    def time_s(self) -> float:
        return self.planning_time_s


def run_status(plan: Plan) -> RunStatus:
    """The status of a run from its plan's outcome."""
    return _STATUS_OF[plan.outcome]


def _ompl_run(task: Task) -> dict:
    """Solve with an OMPL planner, OMPL seeded with the task's seed: on wall time, or for the
    task's iterations (its goal samples seeded too, so the run is reproducible)."""
    options = replace(task.planner, objective=task.objective)
    if options.iterations is None:  # on wall time the run is not reproducible, but OMPL still draws from the seed
        seed_ompl(options.seed)
        options = replace(options, seed=None)  # a seeded setup would stop on an iteration budget instead
    plan = UngraspSetup(task.scene, options).solve()
    return dict(status=run_status(plan), cost=plan.cost, mode_switches=plan.mode_switches,
                time_to_first_solution_s=plan.time_to_first_solution_s, planning_time_s=plan.planning_time_s,
                setup_time_s=plan.setup_time_s, iterations=plan.iterations, min_margin_deg=plan.min_margin_deg,
                tolerance=_tolerance(task.scene, plan, task.objective))


def _tolerance(scene: Scene, plan: Plan, objective: Objective) -> float | None:
    """The plan's tolerance under the tolerance objective (what it optimised), else None."""
    return tolerance(scene, plan).scale if objective == Objective.TOLERANCE and plan.solved else None


def _lattice_run(scene: Scene, objective: Objective = Objective.COST) -> dict:
    """The exact optimum on the scene's lattice for an objective; its time is building the lattice
    plus the search. Its cost is the optimum even when the optimum's legs fail re-validation
    (status invalid)."""
    plan = lattice_plan(scene, objective=objective)
    elapsed = plan.setup_time_s + plan.planning_time_s
    return dict(status=run_status(plan), cost=plan.lattice_optimum, mode_switches=plan.mode_switches,
                time_to_first_solution_s=elapsed if plan.solved else None, planning_time_s=elapsed,
                setup_time_s=0.0, iterations=None, min_margin_deg=plan.min_margin_deg,
                tolerance=_tolerance(scene, plan, objective))


def run_task(task: Task) -> RunResult:
    """Run one task (OMPL's random numbers seeded here for it)."""
    t0 = time.perf_counter()
    measured = _lattice_run(task.scene, task.objective) if task.planner.planner == LATTICE else _ompl_run(task)
    return RunResult(group=task.group, planner=task.planner.planner, run=task.run, seed=task.planner.seed,
                     wall_time_s=time.perf_counter() - t0, **measured)


def run_tasks(tasks: Sequence[Task], runner: Runner, progress: Progress | None = None,
              stream: RowStream | None = None) -> list[RunResult]:
    """Run tasks on a runner (child processes here or Ray workers); results in task order.

    With a stream (RUN_COLUMNS), a task whose row it holds already (an earlier, interrupted
    campaign) is not run again, and each new result is appended to it as it arrives. A run
    still going at its deadline (a planner that stops checking its termination condition, see
    planning.setup.UNRULY_PLANNERS) is killed and counted as hung, as is one whose process
    ends without an answer. A run that raises ends the campaign: its UngraspError as itself,
    anything else as a ToolError naming the run.
    """
    total = len(tasks)
    out: list[RunResult | None] = [None] * total
    todo = []
    for k, task in enumerate(tasks):
        row = stream.rows.get(task_key(task)) if stream else None
        if row is None:
            todo.append(k)
        else:
            out[k] = result_from_row(row)
    done = total - len(todo)
    if progress:
        progress(done, total)
    deadline = max((tasks[k].deadline for k in todo), default=HANG_GRACE_S)
    with closing(runner.run(run_task, [tasks[k] for k in todo], deadline)) as outcomes:
        for outcome in outcomes:
            task = tasks[todo[outcome.index]]
            if outcome.status is TaskStatus.FAILED:
                if isinstance(outcome.error, UngraspError):
                    raise outcome.error
                raise ToolError(f"{task.planner.planner} run {task.run} on {task.group} failed: "
                                f"{type(outcome.error).__name__}: {outcome.error}") from outcome.error
            result = outcome.value if outcome.status is TaskStatus.DONE else hung_result(task, outcome.wall_time_s)
            out[todo[outcome.index]] = result
            if stream:
                stream.append(run_row(task, result))
            done += 1
            if progress:
                progress(done, total)
    return out  # type: ignore[return-value]


#: runs.csv's columns: a task's key (the first RUN_KEY_COLUMNS), then what it measured.
RUN_COLUMNS = ("group", "planner", "run", "seed", "time_limit_s", "iteration_budget", "objective", "status", "cost",
               "mode_switches", "time_to_first_solution_s", "planning_time_s", "setup_time_s", "iterations",
               "wall_time_s", "min_margin_deg", "tolerance")
#: How many leading RUN_COLUMNS identify a task.
RUN_KEY_COLUMNS = 7


def task_key(task: Task) -> tuple[str, ...]:
    """A task's key in runs.csv: what decides its result, but for the planner's range, goal bias
    and simplification, which runs.csv does not hold (a campaign gives every task the same; one
    resumed with others keeps the rows made with the earlier)."""
    p = task.planner
    return (task.group, p.planner, str(task.run), str(p.seed), repr(float(p.time)),
            "" if p.iterations is None else str(p.iterations), task.objective)


def run_row(task: Task, r: RunResult) -> list[object]:
    """A run's row of runs.csv (RUN_COLUMNS)."""
    return [*task_key(task), r.status.value, r.cost, r.mode_switches, r.time_to_first_solution_s, r.planning_time_s,
            r.setup_time_s, r.iterations, r.wall_time_s, r.min_margin_deg, r.tolerance]


def result_from_row(row: Sequence[str]) -> RunResult:
    """A RunResult from its row of runs.csv."""
    named = dict(zip(RUN_COLUMNS, row))

    def number(key: str, kind: type = float):
        return kind(named[key]) if named.get(key) else None

    return RunResult(group=named["group"], planner=named["planner"], run=int(named["run"]), seed=int(named["seed"]),
                     status=RunStatus(named["status"]), cost=number("cost"), mode_switches=number("mode_switches", int),
                     time_to_first_solution_s=number("time_to_first_solution_s"),
                     planning_time_s=float(named["planning_time_s"]), setup_time_s=float(named["setup_time_s"]),
                     iterations=number("iterations", int), wall_time_s=float(named["wall_time_s"]),
                     min_margin_deg=number("min_margin_deg"), tolerance=number("tolerance"))


def hung_result(task: Task, wall: float) -> RunResult:
    """The result of a run killed at its deadline or whose process ended without an answer."""
    p = task.planner
    return RunResult(group=task.group, planner=p.planner, run=task.run, seed=p.seed, status=RunStatus.HUNG,
                     cost=None, mode_switches=None, time_to_first_solution_s=None, planning_time_s=p.time,
                     setup_time_s=0.0, iterations=None, wall_time_s=wall)


def lattice_yardstick(results: Sequence[RunResult], group: str) -> RunResult:
    """The first lattice run of a group (all are the same search)."""
    return next(r for r in results if r.group == group and r.planner == LATTICE)
