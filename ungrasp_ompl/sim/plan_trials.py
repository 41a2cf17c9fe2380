"""The one plan -> robot -> simulation pipeline: ``placement`` executes a plan on the robot and
sets up its trials (``simulate``, ``map``, ``design`` and certification all go through it), and
``plan_trials`` runs a plan's trials one after another in this process (a cell of ``map`` or
``design``).

The plan is executed on the robot (robot.pipeline.execute: placement, IK, timing); when the robot
cannot execute it (out of reach, an arm collision, beyond the joint limits) there are no trials and
the robot's reason says why. Otherwise trial k meets the preset's errors drawn from (seed, k), as
every campaign draws them.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import UngraspError
from ..parallel import RunOptions
from ..planning.result import Plan
from ..planning.setup import with_3d_report
from ..robot.pipeline import Execution, execute, modelled_aim
from ..scene import Scene
from ..scene.options import Landing
from ..scene.perturbation import preset, trial_params
from .landing import robot_landing
from .outcome import TrialResult
from .setup import TrialSetup, Variant, trial_setup
from .trial import run_trial


@dataclass(frozen=True)
class PlanTrials:
    """The simulated trials of one plan."""

    results: tuple[TrialResult, ...]
    """Each trial's result, in order (empty when the robot cannot execute the plan)."""
    unexecutable: UngraspError | None = None
    """The robot's error when it cannot execute the plan (robot.ik.ReachabilityError,
    robot.pipeline.CollisionError, robot.timing.TimingError, each with its evidence); None otherwise."""

    @property
    def executable(self) -> bool:
        """The robot could execute the plan, so it was simulated."""
        return self.unexecutable is None

    @property
    def successes(self) -> int:
        """Trials placed within the scene's sim.max_error (count)."""
        return sum(r.success for r in self.results)


def placement(scene: Scene, plan: Plan, variant: Variant = Variant(),
              run: RunOptions = RunOptions(jobs=1)) -> tuple["Execution", TrialSetup]:
    """A solved plan executed on the robot (placement, IK, timing) and what its trials share, with
    the variant's changes to the simulated world. With robot.landing simulated or expected, the
    hand is aimed by where the release, simulated in the scene's own world (no variant) with no
    error or on average over drawn ones, lands the object (sim.landing; left as planned when the
    release with no error does not put it down; the drawn ones on run's workers or cluster; with
    robot.landing modelled, by where the model of the fall lands
    it, robot.pipeline.modelled_aim, no release simulated). Raises the
    robot's UngraspError when it cannot execute the plan (out of reach, an arm collision, beyond
    the joint limits)."""
    if scene.plane is not None and plan.object is None:
        plan = with_3d_report(scene, plan)  # the object and its plane, which the placement needs
    if scene.robot.landing is Landing.MODELLED:  # the model's aim: no release simulated
        execution = execute(scene, plan, modelled_aim(scene, plan))
    else:
        execution = execute(scene, plan)
        landing = robot_landing(trial_setup(scene, plan, execution.trajectory, execution.robot), scene.robot, run)
        if landing is not None and any(landing.aim):
            execution = execute(scene, plan, landing.aim)
    aim = execution.aims[0]
    return execution, trial_setup(scene, plan, execution.trajectory, execution.robot, variant, aim=aim)


def plan_trials(scene: Scene, plan: Plan, trials: int, perturbation: str = "paper", seed: int = 1) -> PlanTrials:
    """Execute a solved plan on the robot and simulate trials of it with the named preset's
    errors; PlanTrials (without results, and with the robot's error, when it cannot be executed)."""
    try:
        _, setup = placement(scene, plan)
    except UngraspError as exc:
        return PlanTrials((), exc)
    params = trial_params(preset(perturbation), seed, trials)
    return PlanTrials(tuple(run_trial(setup, p, k, seed) for k, p in enumerate(params)))
