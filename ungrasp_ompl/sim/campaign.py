"""Many trials of one placement: seeded perturbations, all cores, a summary.

``simulate`` runs trials of an executed plan and returns a ``SimulationReport``;
``deviated_plan`` and ``plan_problems`` serve the experiments that run a plan the model
would reject (a start outside force closure, a plan for another object).
"""

from __future__ import annotations

import collections
import math
from collections.abc import Callable, Iterator
from contextlib import closing, contextmanager
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import InputError
from ..planning.deviate import PlanProblem
from ..parallel.options import RunOptions
from ..parallel.runner import InlineRunner, LocalRunner, Runner, open_runner
from ..provenance import environment
from .outcome import TrialResult
from ..scene.perturbation import Perturbation, TrialParams, trial_params
from ..mechanics.release import pyramid_reach
from ..robot.pipeline import Aim
from .setup import Variant
from .trial import TrialSetup, run_trial
from .world import Cone, World


@dataclass
class SimulationReport:
    """The trials of one placement, in trial order, and what they were run with."""

    scene: str
    perturbation: Perturbation
    variant: Variant
    seed: int
    trials: list[TrialResult] = field(default_factory=list)
    plan_problems: list["PlanProblem"] = field(default_factory=list)  #: why the model would reject the plan (empty: secure)
    trajectory_duration_s: float = 0.0
    aim: Aim = Aim()  #: how the hand's motion was moved from the plan's frame (robot.landing)
    world: World = World()  #: how the world the trials ran in differs from the scene's
    engine: str = "mujoco"  #: the physics engine the trials ran in (ENGINES)
    gb_heading: float = 0.0  #: GB's direction on the table at the target, from the world's x axis (rad)

    @property
    def successes(self) -> int:
        """Trials placed within the scene's sim.max_error of the target."""
        return sum(t.success for t in self.trials)

    @property
    def placed(self) -> int:
        """Trials placed by the paper's criterion, however far from the target."""
        return sum(t.placed for t in self.trials)

    def causes(self) -> dict[str, int]:
        """Failures counted by outcome and phase ('grip lost in P_dpsi': 3)."""
        return failure_causes(self.trials)

    def errors_mm(self, placed: bool = False) -> np.ndarray:
        """Placement errors (mm) of the successful trials (of every placed trial, with placed)."""
        return np.array([t.position_error_mm for t in self.trials if (t.placed if placed else t.success)])

    def placed_offsets_mm(self) -> np.ndarray:
        """The placement offsets (mm, shape (N, 2): along GB, + toward B, and across it) of the trials
        placed by the paper's criterion: where the release puts the object against its target."""
        return np.array([(t.offset_along_mm, t.offset_across_mm) for t in self.trials if t.placed]).reshape(-1, 2)

    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second, over all trials (per worker)."""
        wall = sum(t.wall_time_s for t in self.trials)
        return sum(t.sim_time_s for t in self.trials) / wall if wall else math.nan

    def table_pyramid_reach(self) -> float | None:
        """Under MuJoCo's pyramidal cones, the share of the table's coefficient that G's friction
        reaches along GB (the pyramid's edges lie along the world's axes: mechanics.release.pyramid_reach
        at GB's heading); None in any other world or engine."""
        if self.world.cone is not Cone.PYRAMIDAL or self.engine != "mujoco":
            return None
        return pyramid_reach(math.cos(self.gb_heading), math.sin(self.gb_heading))

    def to_dict(self) -> dict:
        errs, placed = self.errors_mm(), self.errors_mm(placed=True)
        yaw = np.array([t.yaw_error_deg for t in self.trials if t.success])
        sink = np.array([t.max_penetration_mm for t in self.trials])
        off_dome = np.array([t.a_off_dome_share for t in self.trials if t.a_off_dome_share is not None])
        along, across = self.placed_offsets_mm().T
        return {
            "scene": self.scene, "trials": len(self.trials), "successes": self.successes,
            "success_rate": self.successes / len(self.trials) if self.trials else None,
            "success_interval_95": list(wilson_interval(self.successes, len(self.trials))),
            "placed_paper_criterion": self.placed,
            "position_error_mm": {"mean": _stat(errs, np.mean), "max": _stat(errs, np.max)},
            "placed_position_error_mm": {"mean": _stat(placed, np.mean), "max": _stat(placed, np.max)},
            "placed_offset_mm": {"along_mean": _stat(along, np.mean), "along_sd": _stat(along, _sd),
                                 "across_mean": _stat(across, np.mean), "across_sd": _stat(across, _sd)},
            "max_penetration_mm": _stat(sink, np.max),
            "a_off_dome_share_max": _stat(off_dome, np.max),
            "yaw_error_deg": {"mean": _stat(yaw, np.mean), "max": _stat(yaw, np.max)},
            "causes": self.causes(), "perturbation": self.perturbation.__dict__, "variant": self.variant.__dict__,
            "world": self.world.to_dict(), "engine": self.engine, "gb_heading_rad": self.gb_heading,
            "table_pyramid_reach_along_gb": self.table_pyramid_reach(),
            "seed": self.seed, "plan_problems": [str(p) for p in self.plan_problems],
            "trajectory_duration_s": self.trajectory_duration_s, "real_time_factor": self.real_time_factor(),
            "aim_m": [self.aim.x, self.aim.y], "aim_turn_rad": self.aim.turn,
            "environment": environment(),
        }


def failure_causes(trials: list[TrialResult]) -> dict[str, int]:
    """The failed trials counted by outcome and phase ('grip lost in P_dpsi': 3), most first."""
    counter = collections.Counter(t.outcome.value if t.phase is None else f"{t.outcome.value} in {t.phase}"
                                  for t in trials if not t.success)
    return dict(counter.most_common())


def wilson_interval(successes: int, trials: int) -> tuple[float, float]:
    """Wilson's 95 % score interval of a success rate: (low, high) in [0, 1] (scipy's)."""
    from scipy.stats import binomtest

    ci = binomtest(successes, trials).proportion_ci(confidence_level=0.95, method="wilson")
    return float(ci.low), float(ci.high)


def _stat(values: np.ndarray, f: Callable) -> float | None:
    return float(f(values)) if len(values) else None


def _sd(values: np.ndarray) -> float:
    """The sample standard deviation (0 for one value)."""
    return float(np.std(values, ddof=1)) if len(values) > 1 else 0.0


#: The physics engines a trial runs in: MuJoCo (sim.trial, the default) and Drake (sim.drake_trial,
#: the optional extra [drake]; docs/model.md 11.19).
ENGINES = ("mujoco", "drake")


def engine_name(engine: str) -> str:
    """The engine as a person names it."""
    return {"mujoco": "MuJoCo", "drake": "Drake"}.get(engine, engine)


def run_engine_trial(setup: TrialSetup, params: TrialParams, k: int = 0, seed: int | None = None,
                     engine: str = "mujoco") -> TrialResult:
    """One trial in the engine named (ENGINES): sim.trial.run_trial or sim.drake_trial.run_drake_trial."""
    if engine == "mujoco":
        return run_trial(setup, params, k, seed)
    if engine == "drake":
        from .drake_trial import run_drake_trial

        return run_drake_trial(setup, params, k, seed)
    raise InputError("engine", f"must be one of {', '.join(ENGINES)}, got {engine!r}")


def _one(args: tuple) -> TrialResult:
    """(setup, params, trial index, seed[, engine]) simulated (MuJoCo without an engine)."""
    return run_engine_trial(*args)


def simulate(setup: TrialSetup, perturbation: Perturbation, trials: int, run: RunOptions, *,
             progress: Callable[[TrialResult], None] | None = None, scene: str = "", variant: Variant = Variant(),
             world: World = World(), engine: str = "mujoco") -> SimulationReport:
    """Run trials 0 .. trials-1 of a placement in world (sim.world: the world the setup, its plan
    and its aim were made without), each with its own perturbation seeded by run.seed (the same
    seed gives the same trials wherever they run), run.workers at a time in worker processes
    (ungrasp_ompl.parallel.runner), or on the Ray cluster at run.cluster. A trial that raises, or
    whose worker dies, ends the campaign with that error (TaskLost for a worker that died).
    progress is called with each result as it arrives; scene and variant name what the report
    holds. engine: the physics engine (ENGINES).

    Size: the campaign's parts, as the workflows and tools hold them: the setup, the errors, the
    count, the run (seed, workers, cluster), the progress, the report's scene and variant, the world
    and the engine."""
    if trials < 1:
        raise InputError("trials", f"must be at least 1, got {trials}")
    run = run.validated()
    results = run_trials([replace(setup, world=world)], perturbation, trials, run, progress=progress,
                         engine=engine)[0]
    return SimulationReport(scene, perturbation, variant, run.seed, results,
                            trajectory_duration_s=float(setup.drive.times[-1]), aim=setup.aim, world=world,
                            engine=engine, gb_heading=math.atan2(setup.target_pose[1, 0], setup.target_pose[0, 0]))


def run_trials(setups: list[TrialSetup], perturbation: Perturbation, trials: int, run: RunOptions, *,
               progress: Callable[[TrialResult], None] | None = None,
               engine: str = "mujoco") -> list[list[TrialResult]]:
    """Trials 0 .. trials-1 of each setup, in trial order per setup, in the engine named (ENGINES).
    Trial k of every setup meets the same perturbation seeded by run.seed (so that placements are
    compared on the same errors); all the trials share one pool of run.workers worker processes
    (or the Ray cluster at run.cluster).
    A trial that raises, or whose worker dies, raises here (TaskLost for a worker that died);
    progress is called with each result as it arrives."""
    seed = run.seed
    params = trial_params(perturbation, seed, trials)
    work = [(setup, p, k, seed) if engine == "mujoco" else (setup, p, k, seed, engine)
            for setup in setups for k, p in enumerate(params)]
    results = run_each(work, run.workers, progress, run.cluster)
    return [results[i * trials:(i + 1) * trials] for i in range(len(setups))]


def run_each(work: list[tuple], jobs: int = 1,
             progress: Callable[[TrialResult], None] | None = None,
             cluster: str | None = None) -> list[TrialResult]:
    """Each (setup, errors, trial index, seed[, engine]) of work simulated (run_engine_trial), jobs at a
    time (trial_runner), in work's order. A trial that raises, or whose worker dies, raises here
    (TaskLost for a worker that died); progress is called with each result as it arrives."""
    # spawned workers import only numpy, mujoco and this package's sim modules
    results: list[TrialResult | None] = [None] * len(work)
    with trial_runner(jobs, len(work), cluster) as runner, closing(runner.run(_one, work)) as outcomes:
        for outcome in outcomes:
            results[outcome.index] = outcome.unwrap()
            if progress:
                progress(results[outcome.index])
    return results  # type: ignore[return-value]


@contextmanager
def trial_runner(jobs: int, trials: int, cluster: str | None = None) -> Iterator[Runner]:
    """Where trials run: a Ray cluster's pooled workers (at the address), else this process for
    one job, else ``jobs`` worker processes here, each running trial after trial."""
    if cluster is not None:
        with open_runner(jobs, cluster, fresh=False) as runner:
            yield runner
    elif jobs == 1 or trials == 1:
        yield InlineRunner()
    else:
        yield LocalRunner(min(jobs, trials), fresh=False)
