"""The ``simulate`` command's workflow: plan (or read) a scene's plan, execute it on the arm, and
run perturbed trials of it in MuJoCo; or, for a layout, tile it and run whole attempts.

:func:`simulate_scene` returns a :class:`SceneSimulation` and :func:`simulate_layout` a
:class:`LayoutSimulation`; each has ``summary()`` (what the command prints) and ``write(dir)``
(what it writes). Lengths in metres, angles in radians, times in seconds.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..errors import InputError
from ..io import write_text_atomic
from ..layout.model import Layout
from ..parallel.options import RunOptions
from ..scene.perturbation import Perturbation, preset, trial_params
from .. import planning
from ..planning.deviate import PlanProblem, check_psi_offset, deviated_plan, plan_problems
from ..planning.margins import Objective
from ..planning.result import Plan
from ..planning.setup import LATTICE, PlannerOptions
from ..provenance import environment
from ..plots.trials import draw_trials
from ..robot.export import export_all
from ..robot.touch_off import touch_off
from ..robot.pipeline import Execution
from ..scene import Scene
from ..scene.options import Landing
from ..sim.campaign import ENGINES, SimulationReport, engine_name, simulate
from ..sim.poses import record_trial, trial_start_time, write_trial_poses
from ..sim.plan_trials import placement
from ..sim.setup import Variant, object_outline
from ..sim.tiling import ShortAim, TilingAttempt, simulate_tiling, tile_aimed
from ..sim.trial import TrialSetup, trial_mjcf
from ..sim.world import World
from ..layout.tiler import Tiling, TilingOptions
from ..view.record import write_view_record
from .plan_files import read_plan_for
from .tile import first_touch_off, layout_summary


@dataclass(frozen=True)
class SimulateOptions:
    """What ``simulate`` runs and how."""

    trials: int = 10
    """Trials of the placement (attempts of a layout), >= 1."""
    perturb: str = "paper"
    """The errors' preset (perturbation.PRESETS): paper, none, grasp, friction, mass, thickness."""
    run: RunOptions = RunOptions()
    """How the trials run: run.seed seeds their errors; run.jobs worker processes (>= 1; None: all
    cores), or the Ray cluster at run.cluster (None: this machine)."""
    plan: str | os.PathLike[str] | None = None
    """plan.json (or a directory holding one) to execute; None: plan the scene."""
    planner: PlannerOptions = PlannerOptions(seed=1)
    """How the planner runs when planning here (planning.setup.PlannerOptions): an OMPL planner by
    name, or lattice; its time (s), seed, iterations and objective (docs/model.md, section 6; a
    layout plans with the cost); a layout's piece k is planned with seed + k."""
    finger_tip: str | None = None
    """rounded or flat instead of the scene's finger tip; None: the scene's."""
    start_psi_offset: float | None = None
    """Start the plan with psi larger by this (rad; the caging experiment); None: as planned."""
    world: World = World()
    """How the world the trials run in differs from the scene's (sim.world): neither the plan nor
    the hand's aim sees it."""
    thickness: float | None = None
    """The simulated object's thickness (m) instead of the scene's, the motion unchanged."""
    equal_digits: bool = False
    """Simulate a thumb as long as the finger (alpha 0), the motion unchanged (a control)."""
    force: bool = False
    """Execute a plan made for another scene (plan.json names its scene); False: refuse it (InputError)."""
    engine: str = "mujoco"
    """The physics engine the trials run in (sim.campaign.ENGINES): mujoco, or drake (the optional
    extra [drake]; docs/model.md 11.19); ToolError (exit 1) when Drake is not installed."""

    def perturbation(self) -> Perturbation:
        """The errors' preset; InputError naming `perturb` for an unknown one."""
        return preset(self.perturb)

    def validated(self, scene: Scene | None = None) -> "SimulateOptions":
        """These options checked (against the scene, or for a layout when scene is None);
        InputError naming the field otherwise."""
        if self.trials < 1:
            raise InputError("trials", "must be at least 1")
        self.run.validated()
        self.perturbation()
        if self.force and self.plan is None:
            raise InputError("force", "applies only with plan (a plan.json to execute)")
        self._check_engine(scene)
        if scene is None:
            for name in ("plan", "start_psi_offset", "thickness", "finger_tip"):
                if getattr(self, name) is not None:
                    raise InputError(name, "applies to a single scene, not to a layout")
            if self.equal_digits or self.planner.objective not in (None, Objective.COST):
                raise InputError("equal_digits" if self.equal_digits else "objective",
                                 "applies to a single scene, not to a layout")
            return self
        if self.thickness is not None and not 0.0 < self.thickness < 0.05:
            raise InputError("thickness", f"must be a thickness in metres in (0, 0.05), got {self.thickness:g}")
        if self.thickness is None and scene.object_thickness <= 0.0:
            raise InputError("object.thickness", "the simulator needs an object with a thickness (m)", scene.source)
        if self.start_psi_offset is not None:
            check_psi_offset(self.start_psi_offset)
        if self.plan is None and self.planner.planner != LATTICE:
            self.planner.validated()
        return self

    def _check_engine(self, scene: Scene | None) -> None:
        """The engine known, and Drake installed and asked for what its world builds (a scene's or
        a layout's: a parallel gripper, a world that changes no contact setting of MuJoCo's own)."""
        if self.engine not in ENGINES:
            raise InputError("engine", f"must be one of {', '.join(ENGINES)}, got {self.engine!r}")
        if self.engine != "drake":
            return
        if self.world.cone != World().cone or self.world.stiffness != 1.0:
            raise InputError("world", "cone and stiffness are MuJoCo's contact settings; Drake's contacts are its own "
                             "(docs/model.md 11.19)")
        from ..robot.pipeline import gripper_links

        if scene is not None and gripper_links(scene) is not None:
            raise InputError("engine", "drake builds the parallel gripper; a pincer runs in MuJoCo")
        from ..sim.drake_world import require_drake

        require_drake()


@dataclass
class SceneSimulation:
    """A scene's plan, its execution and its simulated trials (see the module)."""

    scene: Scene
    """The scene simulated (with the finger tip asked for)."""
    plan: Plan
    """The plan executed (deviated when asked); unsolved when planning found none."""
    options: SimulateOptions
    """What the run used."""
    execution: Execution | None = None
    """The arm's trajectory and robot (None: no plan)."""
    setup: TrialSetup | None = None
    """What every trial starts from (None: no plan)."""
    report: SimulationReport | None = None
    """The trials, in order (None: no plan)."""

    @property
    def problems(self) -> list[PlanProblem]:
        """Why the scene's model rejects the plan (a plan read from a file, a deviated start); empty: it does not."""
        return self.report.plan_problems if self.report is not None else []

    def summary(self) -> str:
        """What the command prints: the success rate, its interval, the errors and the failures."""
        if self.report is None:
            return self.plan.summary()
        report, scene = self.report, self.scene
        lines = [f"warning: the model rejects this plan for {scene.name}: {p}" for p in self.problems]
        s = report.to_dict()
        errs, yaw, (low, high) = s["position_error_mm"], s["yaw_error_deg"], s["success_interval_95"]
        n = len(report.trials)
        lines.append(f"{scene.name}: {n} trials in {engine_name(report.engine)} of the plan's "
                     f"{len(self.plan.primitives)} primitives "
                     f"({self.setup.drive.times[-1]:.2f} s from the first primitive to the end of the retreat); "
                     f"{errors_words(report.perturbation)}; seed {report.seed}"
                     + ("" if report.world.nominal else
                        f"; the simulated world differs from the one the plan and its aim assume: "
                        f"{report.world.describe()}"))
        lines.append(f"success: {report.successes}/{n} trials placed the object flat within "
                     f"{1000 * scene.sim.max_error:g} mm of its target (95 % confidence interval of the success rate: "
                     f"{100 * low:.0f}-{100 * high:.0f} %)" + (
                         f"; in those it lay {errs['mean']:.2f} mm from its target on average ({errs['max']:.2f} mm at "
                         f"most) and turned {yaw['mean']:.2f} deg on average ({yaw['max']:.2f} deg at most)"
                         if report.successes else ""))
        reach = report.table_pyramid_reach()
        if reach is not None:
            lines.append(f"under pyramidal cones G's friction along GB reaches {reach:.2f} of the table's coefficient: "
                         f"MuJoCo lays its friction pyramids along directions fixed in the world, the table's along "
                         f"the x and y axes, and GB heads {math.degrees(report.gb_heading) % 360:.0f} deg from the x "
                         "axis; the digits' pyramids turn with GB too (docs/model.md 11.16)")
        if scene.robot.landing is Landing.MODELLED:
            lines.append(f"the hand was aimed {report.aim.describe()} from the plan's landing, to the middle of where the "
                         "model of the object's fall puts it over friction 0.7 to 1.3 times the scene's and either "
                         "friction-cone model" + (f", and {1000 * scene.robot.landing_offset:+.2f} mm along GB beyond it "
                                                  "(robot.landing_offset)" if scene.robot.landing_offset else ""))
        elif scene.robot.landing is not Landing.PLANNED:
            where = ("with no error put the object" if scene.robot.landing is Landing.SIMULATED else
                     f"put the object on average over {scene.robot.landing_pairs} pairs of draws of the paper's "
                     "errors, each in a world of its own")
            lines.append(f"the hand was aimed {report.aim.describe()} from the plan's landing, to where the release "
                         f"simulated {where}" if any(report.aim) else
                         "the hand was aimed as planned: the release simulated with no error did not place the object "
                         "by the strict verdict, so there was no landing to aim by")
        offset = s["placed_offset_mm"]
        if report.placed:
            lines.append(f"where the placed objects came to rest: {offset['along_mean']:+.2f} mm along GB (+ toward B) "
                         f"and {offset['across_mean']:+.2f} mm across it from the target on average, standard "
                         f"deviations {offset['along_sd']:.2f} and {offset['across_sd']:.2f} mm"
                         + (" (on a cell, the mean along GB is what robot.landing_offset is short of)"
                            if scene.robot.landing is Landing.MODELLED else ""))
        if report.placed != report.successes:
            placed = s["placed_position_error_mm"]
            lines.append(f"by the paper's criterion alone (flat, no digit touching, however far from the target) "
                         f"{report.placed}/{n} trials placed it, {placed['mean']:.2f} mm from the target on average "
                         f"({placed['max']:.2f} mm at most)")
        lines += [f"  {k} {'trial' if k == 1 else 'trials'}: {what}" for what, k in failure_words(report.trials)]
        wall = sum(t.wall_time_s for t in report.trials) / n
        lines.append(f"the simulation ran at {report.real_time_factor():.2g} times real time per worker process "
                     f"({wall:.2f} s of computing per trial); the object sank at most {s['max_penetration_mm']:.3f} mm "
                     "into a digit or the table (the simulated contacts are slightly soft)")
        tracking = [(t.palm_tracking_mm, t.palm_tracking_deg) for t in report.trials if hasattr(t, "palm_tracking_mm")]
        if tracking:
            lines.append(f"the palm's PD joints kept it within {max(m for m, _ in tracking) * 1000:.1f} um and "
                         f"{max(d for _, d in tracking):.4f} deg of its commanded pose at every control tick")
        return "\n".join(lines)

    def write(self, out: str | os.PathLike[str]) -> dict[str, Path]:
        """Write plan.json, the exported trajectory, trials.csv, summary.json, trials.png,
        view_scene.json, trial_poses.json (trial 0 recorded) and model.xml (trial 0's world with
        its keyframe 'start') into out, each atomically; returns their paths by name. Trials run in
        Drake write neither of the last two (both are MuJoCo's: its world, its trial 0 replayed)."""
        if self.report is None or self.execution is None or self.setup is None:
            raise ValueError("nothing was simulated: the scene has no plan")
        out = Path(out)
        files = {"plan": out / "plan.json", "trials": out / "trials.csv", "summary": out / "summary.json",
                 "picture": out / "trials.png", "model": out / "model.xml"}
        write_text_atomic(files["plan"], self.plan.to_json())
        trajectory = self.execution.trajectory
        files.update(export_all(trajectory, out, touch_off(self.scene, self.plan, trajectory)))
        first = trial_params(self.report.perturbation, self.report.seed, 1)[0]
        mujoco = self.report.engine == "mujoco"
        if mujoco:
            write_text_atomic(files["model"], trial_mjcf(self.setup, first))
        else:
            del files["model"]
        world = {f"world_{k}": v for k, v in self.report.world.to_dict().items()}
        rows = [{**t.to_row(), **world, "engine": self.report.engine} for t in self.report.trials]
        buf = io.StringIO()
        writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        write_text_atomic(files["trials"], buf.getvalue())
        write_text_atomic(files["summary"], json.dumps(self.report.to_dict(), indent=1) + "\n")
        draw_trials(self.report, object_outline(self.scene), self.setup.target_pose, files["picture"])
        files["view"] = write_view_record(out, [(self.scene, self.plan)], self.execution, kind="simulation")
        if mujoco:
            files["poses"] = write_trial_poses(out, record_trial(
                self.setup, first, trial_start_time(self.execution.trajectory), 0, self.report.seed,
                self.report.trials[0]))
        return files


def errors_words(p: Perturbation) -> str:
    """The errors each trial draws (a perturbation preset's bounds), in words for a person."""
    words = []
    if p.shift_mm or p.yaw_deg:
        words.append(f"the object up to {p.shift_mm:g} mm off in the grasp along and across it and turned up to "
                     f"{p.yaw_deg:g} deg")
    if p.friction:
        words.append(f"friction up to {100 * p.friction:g} % lower")
    if p.mass:
        words.append(f"mass {100 * p.mass:g} % either way")
    if p.thickness:
        words.append(f"thickness {100 * p.thickness:g} % either way")
    if p.palm_shift_mm or p.palm_turn_deg:
        words.append(f"the hand's calibration up to {p.palm_shift_mm:g} mm and {p.palm_turn_deg:g} deg off")
    if p.table_mm:
        words.append(f"the table's height {p.table_mm:g} mm either way")
    if p.probe_noise_n:
        words.append(f"the touch-off's force readings {p.probe_noise_n:g} N noisy")
    if not words:
        return "no errors drawn"
    name = "the paper's" if p.name == "paper" else f"the '{p.name}' preset's"
    return f"each trial draws random errors within {name} bounds (docs/model.md 11.3): " + ", ".join(words)


def failure_words(trials: list) -> list[tuple[str, int]]:
    """The failed trials in words, counted by what happened and where ('the grip was lost ... during
    primitive 5 (P_dpsi: ...)', 3), most first."""
    from collections import Counter

    from ..mechanics.contact import Primitive

    def where(t) -> str:
        if t.phase is None:
            return ""
        if t.phase in tuple(Primitive):
            return f" during primitive {t.phase_index + 1} ({t.phase}: {Primitive(t.phase).describe()})"
        return {"termination": " while the gripper let go", "retreat": " during the hand's retreat"}.get(
            t.phase, f" during the {t.phase}")

    counts = Counter(t.outcome.describe() + where(t) for t in trials if not t.success)
    return counts.most_common()


def simulate_scene(scene: Scene, options: SimulateOptions,
                   progress: Callable[[object], None] | None = None) -> SceneSimulation:
    """Plan the scene (or read options.plan), execute the plan, and run options.trials perturbed
    trials of it; progress is called with each trial's result as it arrives. An unsolved plan
    comes back without trials. InputError naming the field for bad options."""
    options.validated(scene)
    perturbation = options.perturbation()
    if options.finger_tip is not None:
        scene = scene.with_digits(finger_tip=options.finger_tip)
    variant = Variant(thickness=options.thickness, equal_digits=options.equal_digits)
    if options.plan is not None:
        result = read_plan_for(scene, options.plan, options.force)
    else:
        result = planning.plan(scene, options.planner)
        if not result.solved:
            return SceneSimulation(scene, result, options)
    if options.start_psi_offset is not None:
        result = deviated_plan(result, options.start_psi_offset)
    problems = plan_problems(scene, result) if options.plan is not None or options.start_psi_offset else []
    execution, setup = placement(scene, result, variant, options.run)
    report = simulate(setup, perturbation, options.trials, options.run, progress=progress, scene=scene.name,
                      variant=variant, world=options.world, engine=options.engine)
    report.plan_problems = problems
    return SceneSimulation(scene, result, options, execution, replace(setup, world=options.world), report)


@dataclass
class LayoutSimulation:
    """A layout's tiling and its simulated attempts (see the module)."""

    layout: Layout
    """The layout simulated."""
    tiling: Tiling
    """Its tiling (unsolved: no attempts)."""
    options: SimulateOptions
    """What the run used."""
    execution: Execution | None = None
    """The one trajectory putting every piece down (None: no tiling)."""
    attempts: list[TilingAttempt] = field(default_factory=list)
    """The attempts, in order."""
    short: tuple[ShortAim, ...] = ()
    """Pieces aimed short of their landing (sim.tiling.AimedTiling.short)."""

    @property
    def successes(self) -> int:
        """Attempts that put every piece flat inside the frame."""
        return sum(a.success for a in self.attempts)

    @property
    def placed(self) -> int:
        """Attempts placed by the paper's criterion: every piece placed by it (any error), all flat
        inside the frame."""
        return sum(a.placed for a in self.attempts)

    def summary(self) -> str:
        """The tiling's summary, then the attempts' success and each failed attempt's cause."""
        lines = layout_summary(self.layout, self.tiling, self.execution, self.short)
        if self.attempts:
            pieces = len(self.attempts[0].names)
            if not self.options.world.nominal:
                lines.append(f"in a world the tiling and its aims never saw: {self.options.world.describe()}")
            engine = "" if self.options.engine == "mujoco" else f" in {engine_name(self.options.engine)}"
            lines.append(f"success {self.successes}/{len(self.attempts)}{engine} (all {pieces} pieces flat inside the frame)")
            if self.placed != self.successes:
                lines.append(f"placed by the paper's criterion (any error) {self.placed}/{len(self.attempts)}")
            lines += [f"  attempt {a.attempt}: {a.cause()}" for a in self.attempts if not a.success]
        return "\n".join(lines)

    def write(self, out: str | os.PathLike[str]) -> dict[str, Path]:
        """Write summary.json and the exported trajectory (with the touch-off before the first piece,
        as tile exports it) into out, atomically."""
        if self.execution is None:
            raise ValueError("nothing was simulated: the layout has no tiling")
        out = Path(out)
        files = export_all(self.execution.trajectory, out, first_touch_off(self.tiling, self.execution))
        doc = {"layout": self.layout.name, "world": self.options.world.to_dict(), "engine": self.options.engine,
               "attempts": len(self.attempts), "successes": self.successes,
               "placed_paper_criterion": self.placed,
               "results": [{"attempt": a.attempt, "success": a.success, "placed": a.placed, "cause": a.cause(),
                            "pieces": [dict(name=n, **t.to_row()) for n, t in zip(a.names, a.pieces)]}
                           for a in self.attempts], "environment": environment()}
        files["summary"] = out / "summary.json"
        write_text_atomic(files["summary"], json.dumps(doc, indent=1) + "\n")
        return files


def simulate_layout(layout: Layout, options: SimulateOptions,
                    progress: Callable[[object], None] | None = None) -> LayoutSimulation:
    """Tile the layout (with options.planner) and run options.trials attempts of the whole tiling,
    every piece in turn (their errors seeded by options.run.seed); an unsolved tiling comes back
    without attempts."""
    options.validated(None)
    tiling, aimed = tile_aimed(layout, TilingOptions(planner=options.planner))
    if aimed is None:
        return LayoutSimulation(layout, tiling, options)
    setups = [(name, replace(setup, world=options.world)) for name, setup in aimed.setups]
    attempts = simulate_tiling(layout, setups, options.perturbation(), options.trials, options.run, progress,
                               options.engine)
    return LayoutSimulation(layout, tiling, options, aimed.execution, attempts, aimed.short)
