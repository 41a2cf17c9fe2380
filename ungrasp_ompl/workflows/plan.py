"""The ``plan`` command's workflow: plan a scene (or certify candidate plans in simulation), with
the plan's tolerance and optionally its weakest cage, and export it for the arm.

:func:`plan_scene` returns a :class:`ScenePlan`: ``summary()`` is what the command prints,
``write(dir)`` writes plan.json and cspace.png, ``export(dir)`` executes the plan on the arm and
writes the trajectory, plan.json and the view's record. Lengths in metres, angles in radians.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import InputError
from ..io import write_text_atomic
from ..mechanics.release import ReleaseModelError
from ..parallel import RunOptions
from ..planning.plan_tolerance import tolerance
from ..planning.predicted_landing import predict_landing
from ..planning.result import Plan
from ..planning.setup import LATTICE, PlannerOptions
from ..planning.setup import plan as plan_planar
from ..robot.export import export_all
from ..robot.pipeline import Execution, execute
from ..robot.touch_off import touch_off
from ..scene import Scene
from ..scene.options import Landing

if TYPE_CHECKING:  # pragma: no cover
    from ..planning.cage_profile import CageMinimum
    from ..sim.certify import CertifyOptions, CertifyProgress, CertifyResult


@dataclass(frozen=True)
class PlanOptions:
    """What ``plan`` plans with and what it adds to the plan."""

    planner: PlannerOptions = PlannerOptions(seed=1)
    """How the planner runs (planning.setup.PlannerOptions): an OMPL geometric planner by name, or
    lattice (the exact search); its time (s), seed, iterations and objective."""
    cage: bool = False
    """Also find the plan's weakest cage (the object needs a thickness)."""
    certify: CertifyOptions | None = None
    """Choose among candidate plans by simulated success (sim.certify); None: plan once."""

    def validated(self, scene: Scene) -> "PlanOptions":
        """These options checked against the scene; InputError naming the field otherwise."""
        if self.planner.planner != LATTICE:  # the OMPL planner's options, before a seed is drawn for them
            self.planner.validated()
        if self.cage and scene.object_thickness <= 0.0:
            raise InputError("cage", "the cage's potential energy needs an object with a thickness (object.thickness)")
        if self.certify is not None:
            self.certify.validated(scene)
        return self


#: certify.csv's columns (ScenePlan.write_certification): a candidate's fields of plan.json's
#: certification.candidates, and whether it was kept. Costs in reference units, times in seconds.
CERTIFY_COLUMNS = ("index", "kept", "source", "planner", "objective", "seed", "status", "cost", "successes", "trials",
                   "wilson_low", "wilson_high", "same_as", "causes", "why", "planning_time_s")


@dataclass
class ScenePlan:
    """A scene's plan and what was found about it (see the module)."""

    scene: Scene
    """The scene planned."""
    plan: Plan
    """The plan (the kept candidate when certified, the first when none could be kept); unsolved when none was found."""
    options: PlanOptions
    """What planning used."""
    certification: CertifyResult | None = None
    """Every candidate, its trials and which was kept (plan --certify)."""
    cage: CageMinimum | None = None
    """The plan's weakest cage (options.cage)."""

    @property
    def solved(self) -> bool:
        """A plan was found (and, when certifying, a candidate could be simulated)."""
        return self.plan.solved and (self.certification is None or self.certification.certified)

    def summary(self) -> str:
        """The candidates' table (when certifying), the plan's summary, the kept candidate and the cage."""
        lines = [] if self.certification is None else [certification_table(self.scene, self.certification)]
        if self.certification is not None and not self.certification.certified:
            return "\n".join(lines)
        lines.append(self.plan.summary())
        if self.certification is not None:
            lines.append(kept_line(self.certification))
        if self.cage is not None:
            lines.append(self.cage.describe())
        return "\n".join(lines)

    def document(self) -> dict:
        """plan.json: the plan, and its cage and certification when found."""
        extra = {"cage": self.cage.to_dict()} if self.cage is not None else {}
        if self.certification is not None:
            extra["certification"] = self.certification.to_dict()
        return {**self.plan.to_dict(), **extra}

    def write(self, out: str | os.PathLike[str]) -> dict[str, Path]:
        """Write plan.json and cspace.png (the C-space map with the path) into out, atomically, and
        certify.csv when certified (write_certification); returns their paths by kind."""
        out = Path(out)
        files = {"plan": out / "plan.json", "cspace": out / "cspace.png"}
        write_text_atomic(files["plan"], json.dumps(self.document(), indent=2) + "\n")
        from ..plots.cspace import draw_plan  # matplotlib: loaded when a picture is drawn

        draw_plan(self.scene, self.plan, files["cspace"])
        if self.certification is not None:
            files["certify"] = self.write_certification(out)
        return files

    def write_certification(self, out: str | os.PathLike[str]) -> Path:
        """Write certify.csv into out, atomically: a row per candidate (CERTIFY_COLUMNS, as
        plan.json's certification.candidates holds them; kept 1 or 0; causes as "cause: count; ...";
        an empty cell for none), whether one was kept or not. Returns its path."""
        if self.certification is None:
            raise ValueError("the plan was not certified (PlanOptions.certify)")
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(CERTIFY_COLUMNS)
        for c in self.certification.candidates:
            row = c.to_dict()
            row["kept"] = int(c.index == self.certification.kept)
            row["causes"] = "; ".join(f"{cause}: {n}" for cause, n in (row["causes"] or {}).items())
            writer.writerow(["" if row[k] is None else row[k] for k in CERTIFY_COLUMNS])
        path = Path(out) / "certify.csv"
        write_text_atomic(path, buf.getvalue())
        return path

    def execute(self, jobs: int = 1) -> Execution:
        """The plan on the arm: inverse kinematics, timing and the gripper's openings (with
        robot.landing simulated or expected, aimed by where the simulated release lands the object:
        sim.landing, the expected landing's releases jobs at a time; modelled, by where the model of
        the fall lands it: robot.pipeline.modelled_aim)."""
        if not self.plan.solved:
            raise ValueError("the scene has no plan to execute")
        if self.scene.robot.landing is not Landing.PLANNED:  # placement aims it as robot.landing says
            # the simulator (MuJoCo and the trials' modules): loaded when a landing is simulated
            from ..sim.plan_trials import placement

            return placement(self.scene, self.plan, run=RunOptions(jobs=jobs))[0]
        return execute(self.scene, self.plan)

    def export(self, out: str | os.PathLike[str], execution: Execution | None = None) -> dict[str, Path]:
        """Write the executed trajectory (every format robot.export writes, with the touch-off's
        program when the scene's robot makes one), the view's record and plan.json into out,
        atomically; returns their paths by kind."""
        # the view's record reads the simulator's modules (sim.poses; scipy.special): loaded to export
        from ..view.record import write_view_record

        out = Path(out)
        execution = execution or self.execute()
        files = export_all(execution.trajectory, out, touch_off(self.scene, self.plan, execution.trajectory))
        files["view"] = write_view_record(out, [(self.scene, self.plan)], execution)
        files["plan"] = out / "plan.json"
        write_text_atomic(files["plan"], json.dumps(self.document(), indent=2) + "\n")
        return files


def plan_scene(scene: Scene, options: PlanOptions,
               progress: Callable[[CertifyProgress], None] | None = None) -> ScenePlan:
    """Plan the scene (or certify options.certify's candidates, progress reporting each step),
    measure the plan's tolerance, predict where its release lands the object (an object with a
    thickness and an opening termination: planning.predicted_landing) and, with options.cage, its weakest cage."""
    options.validated(scene)
    certification = None
    if options.certify is None:
        result = plan_planar(scene, **dataclasses.asdict(options.planner))
    else:
        from ..sim.certify import certify  # the simulator (MuJoCo and the trials' modules): loaded to certify

        certification = certify(scene, options.certify, progress)
        if not certification.certified:
            return ScenePlan(scene, certification.candidates[0].plan, options, certification)
        result = certification.plan
    if result.solved and result.tolerance is None:
        result = dataclasses.replace(result, tolerance=tolerance(scene, result).to_dict())
    if result.solved and result.predicted_landing is None and scene.object_thickness > 0.0:
        try:
            result = dataclasses.replace(result, predicted_landing=predict_landing(scene, result).to_dict())
        except ReleaseModelError:  # a termination the model of the fall does not cover (rotate)
            pass
    cage = None
    if options.cage and result.solved:
        # scipy.ndimage and scipy.sparse: a second to import, loaded when a cage is asked for
        from ..planning.cage_profile import cage_profile

        cage = cage_profile(scene, result).weakest(result)
    return ScenePlan(scene, result, options, certification, cage)


def certification_table(scene: Scene, result: CertifyResult) -> str:
    """The candidates of plan --certify, one line each: source, cost, success and interval."""
    o = result.options
    lines = [f"{len(result.candidates)} candidate plans of {scene.name}, {o.trials} trials each (perturbation "
             f"'{o.perturb}', seed {o.run.seed}: trial k meets the same errors in every candidate), {o.run.jobs} jobs:",
             f"  {'#':>2}  {'source':<26} {'cost':>8}  {'success':>8}  Wilson 95 %"]
    for c in result.candidates:
        cost = "" if c.plan.cost is None else f"{c.plan.cost:.2f}"
        if c.simulated:
            low, high = c.interval
            what = f"{c.successes:>3}/{len(c.results):<4}  {100 * low:3.0f}-{100 * high:.0f} %"
            if c.same_as is not None:
                what += f" (the path of #{c.same_as})"
            elif c.causes:
                cause, n = next(iter(c.causes.items()))
                what += f"; {n} x {cause}" + (" ..." if len(c.causes) > 1 else "")
        else:
            what = f"{c.status.value.replace('_', ' ')}: {c.why}"
        lines.append(f"  {c.index:>2}  {c.source.label():<26} {cost:>8}  {what}")
    n = len(result.candidates)
    lines.append(f"  {result.wall_time_s:.1f} s in all, {result.wall_time_s / n:.1f} s per candidate")
    if not result.certified:
        lines.append(f"no candidate of {scene.name} could be simulated (none solved and executable)")
    return "\n".join(lines)


def kept_line(result: CertifyResult) -> str:
    """Which candidate plan --certify kept, with its counts."""
    kept = result.candidates[result.kept]
    low, high = kept.interval
    return (f"kept candidate #{kept.index} ({kept.source.label()}): success {kept.successes}/{len(kept.results)}, "
            f"Wilson 95 % interval {100 * low:.1f}-{100 * high:.1f} % (the highest lower bound of the "
            f"{sum(c.simulated for c in result.candidates)} simulated)")
