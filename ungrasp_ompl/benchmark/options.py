"""What a benchmark and a sweep run with, and the checks that name the option at fault.

Every check raises :class:`~ungrasp_ompl.errors.InputError` naming the options field at fault
(``planners``, ``runs``, ...; the CLI names the flag a person typed for it), so the command
answers with one line and exit 2 before anything runs or is written.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path

from ..errors import InputError
from ..parallel.options import RunOptions
from ..scene.options import Objective
from ..planning.setup import LATTICE, PLANNERS, UNUSABLE_PLANNERS, PlannerOptions, check_objective


@dataclass(frozen=True)
class BenchmarkOptions:
    """How ``bench`` runs the planners on its scenes."""

    planners: tuple[str, ...] = ("RRTstar", "RRTConnect", LATTICE)
    """Planner names (OMPL geometric planners, or ``lattice`` for the exact search), in table order."""
    runs: int = 10
    """Runs per scene and planner (count); run k is seeded with run.seed + k."""
    planner: PlannerOptions = PlannerOptions()
    """How every planner runs (planning.setup.PlannerOptions), passed whole to each run: its time per
    run (s: wall time, or with iterations the hard cap is 5 times it); its iterations per run (count:
    runs become reproducible like ``plan --seed``; None: a run stops on wall time, like OMPL's
    Benchmark); its objective, what every planner optimises, the lattice yardstick included
    (docs/model.md, section 6); its range, goal bias and simplification. Its planner name and seed
    are replaced per run: planners names them, run.seed seeds them."""
    run: RunOptions = RunOptions()
    """How the runs run: run.seed seeds OMPL's RNG for run 0 (run k gets seed + k), seeded afresh per
    run; run.jobs runs at a time on this machine (child processes; None: all cores; unused on a
    cluster); run.cluster a Ray cluster's address ("local" starts one here; None: this machine)."""
    out: str | os.PathLike[str] = "benchmark"
    """Output directory for the logs, the database, summary.csv and the plots."""
    resume: bool = False
    """Keep the runs already in out/runs.csv (an interrupted benchmark) and run only the others."""

    def validated(self) -> "BenchmarkOptions":
        """These options with the planner names checked and duplicates dropped, run.jobs None as all
        cores; InputError otherwise."""
        p, run = self.planner, self.run
        check_runs(self.runs, p.time, run.workers, run.seed, self.out)
        check_iterations(p.iterations)
        planners = tuple(validate_planners(self.planners))
        objective = check_objective(p.objective or Objective.COST, LATTICE)  # None: the cost, on every scene
        for planner in planners:
            check_objective(objective, planner)
        check_passed_whole(p)
        return replace(self, planners=planners, planner=replace(p, objective=objective),
                       run=replace(run.validated(), jobs=run.workers))


@dataclass(frozen=True)
class SweepOptions:
    """How ``sweep`` runs one planner over a range of digit asymmetry."""

    alphas: tuple[float, ...] = ()
    """Digit asymmetry values (finger minus thumb length, over the object length)."""
    planner: PlannerOptions = PlannerOptions()
    """How the planner runs (planning.setup.PlannerOptions), passed whole to each run: an OMPL
    geometric planner by name, or ``lattice``; its time per run (s, wall time, or the cap of 5 times
    it with iterations); its iterations per run (count, making runs reproducible; None: stop on wall
    time); its objective; its range, goal bias and simplification. Its seed is replaced per run:
    run.seed seeds the runs."""
    runs: int = 5
    """Runs per alpha (count); run k is seeded with run.seed + k."""
    run: RunOptions = RunOptions()
    """How the runs run: run.seed seeds OMPL's RNG for run 0 (run k gets seed + k); run.jobs runs at a
    time on this machine (child processes; None: all cores; unused on a cluster); run.cluster a Ray
    cluster's address ("local" starts one here; None: this machine)."""
    out: str | os.PathLike[str] = "sweep"
    """Output directory for sweep.csv and sweep.png."""
    resume: bool = False
    """Keep the runs already in out/runs.csv and run only the others."""

    def validated(self) -> "SweepOptions":
        """These options checked, run.jobs None as all cores; InputError naming the option otherwise."""
        p, run = self.planner, self.run
        (planner,) = validate_planners([p.planner], "planner")
        check_runs(self.runs, p.time, run.workers, run.seed, self.out)
        check_iterations(p.iterations)
        objective = check_objective(p.objective or Objective.COST, planner)  # None: the cost
        check_passed_whole(p)
        alphas = tuple(float(a) for a in self.alphas)
        if not alphas:
            raise InputError("alpha", "gives no value")
        return replace(self, planner=replace(p, planner=planner, objective=objective), alphas=alphas,
                       run=replace(run.validated(), jobs=run.workers))


def validate_planners(planners: Iterable[str], option: str = "planners") -> list[str]:
    """The planner names, duplicates dropped; InputError(option) for an unknown or refused one."""
    names = list(dict.fromkeys(planners))
    if not names:
        raise InputError(option, "names no planner")
    for name in names:
        if name == LATTICE:
            continue
        if name not in PLANNERS and name not in UNUSABLE_PLANNERS:
            raise InputError(option, f"unknown planner {name!r} (known: {', '.join(PLANNERS + (LATTICE,))})")
        try:
            PlannerOptions(planner=name).validated()
        except InputError as exc:  # a planner refused with the reason
            raise InputError(option, exc.reason) from None
    return names


def check_passed_whole(p: PlannerOptions) -> None:
    """Check what a campaign passes to every run besides the fields it checks itself: the range and
    the goal bias (PlannerOptions.validated's checks; InputError naming `range` or `goal_bias`)."""
    PlannerOptions(range=p.range, goal_bias=p.goal_bias).validated()


def check_runs(runs: int, time_limit: float, jobs: int, seed: int, out_dir: str | os.PathLike[str]) -> Path:
    """Check the options every campaign shares; returns out_dir as a Path."""
    if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
        raise InputError("runs", f"must be a positive integer, got {runs!r}")
    check_time(time_limit)
    check_jobs(jobs)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0 or seed + runs > 2**32:
        raise InputError("seed", f"must be an integer with seed + runs <= 2^32, got {seed!r}")
    return check_out(out_dir)


def check_time(time_limit: float) -> None:
    if isinstance(time_limit, bool) or not isinstance(time_limit, (int, float)) or not (
            math.isfinite(time_limit) and time_limit > 0):
        raise InputError("time", f"must be a positive number of seconds, got {time_limit!r}")


def check_jobs(jobs: int) -> None:
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise InputError("jobs", f"must be a positive integer, got {jobs!r}")


def check_iterations(iterations: int | None) -> None:
    if iterations is not None and (isinstance(iterations, bool) or not isinstance(iterations, int) or iterations < 1):
        raise InputError("iterations", f"must be a positive integer, got {iterations!r}")


def check_out(out_dir: str | os.PathLike[str]) -> Path:
    """out_dir as a Path; InputError("out") when it exists and is not a directory."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError("out", f"{out} exists and is not a directory")
    return out
