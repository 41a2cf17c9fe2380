"""The ``cage`` command's workflow: the energy-bounded cage and the friction margin along a plan.

:func:`cage_report` takes a scene and :class:`CageOptions`, plans the scene (or reads a plan),
optionally starts it deviated, computes the cage of every state the plan passes
(planning.cage_profile) and each state's friction margin, and returns a :class:`CageReport`
whose ``summary()`` is what the command prints and whose ``write(dir)`` writes cage.json and
cage.png. Energies in joules (mJ where named), angles in radians (degrees where named), forces
in newtons.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..io import write_text_atomic
from ..mechanics.cage import Cage, CageGrid
from ..mechanics.path import plan_samples
from ..parallel.options import RunOptions
from ..parallel.runner import InlineRunner, LocalRunner
from ..planning.cage_profile import CageMinimum, CageProfile
from ..planning.deviate import PlanProblem, check_psi_offset, deviated_plan, plan_problems
from ..planning.path_margin import path_friction_margin, plan_friction_margins
from ..planning.result import Plan
from ..planning.setup import LATTICE, PlannerOptions
from .. import planning
from ..scene import Scene
from .plan_files import read_plan_for


@dataclass(frozen=True)
class CageOptions:
    """What ``cage`` examines and how finely."""

    plan: str | os.PathLike[str] | None = None
    """plan.json to examine, or a directory holding one; None: plan the scene."""
    planner: PlannerOptions = PlannerOptions(seed=1)
    """How the planner runs when planning here (planning.setup.PlannerOptions): an OMPL planner by
    name, or lattice; its time (s), seed, iterations and objective."""
    squeeze: float = 0.0
    """A constant force (N) pressing the object where the finger does; 0: gravity only."""
    refine: float = 1.0
    """Factor dividing the pose grid's steps and its penetration tolerance (dimensionless, > 0)."""
    finger_tip: str | None = None
    """rounded or flat instead of the scene's finger tip; None: the scene's."""
    start_psi_offset: float | None = None
    """Start the plan with psi larger by this (rad; the paper's deviated start); None: as planned."""
    force: bool = False
    """Examine a plan made for another scene (plan.json names its scene); False: refuse it (InputError)."""
    run: RunOptions = RunOptions()
    """Where the states' cages are computed: run.jobs worker processes on this machine (count;
    None: all cores); no cluster (run.cluster must be None), no random draws (run.seed unused)."""

    def validated(self, scene: Scene) -> "CageOptions":
        """These options checked against the scene; InputError naming the field otherwise."""
        if scene.object_thickness <= 0.0:
            raise InputError("object.thickness", "the cage's potential energy needs an object with a thickness (m)",
                             scene.source)
        if not (math.isfinite(self.refine) and self.refine > 0.0):
            raise InputError("refine", f"must be a positive factor, got {self.refine!r}")
        if not (math.isfinite(self.squeeze) and self.squeeze >= 0.0):
            raise InputError("squeeze", f"must be a force in newtons >= 0, got {self.squeeze!r}")
        if self.start_psi_offset is not None:
            check_psi_offset(self.start_psi_offset)
        if self.force and self.plan is None:
            raise InputError("force", "applies only with plan (a plan.json to examine)")
        self.run.validated()
        if self.run.cluster is not None:
            raise InputError("cluster", "the cage's states are computed on this machine")
        if self.plan is None and self.planner.planner != LATTICE:
            self.planner.validated()
        return self


@dataclass
class CageReport:
    """A plan's cage profile and friction margins, and what came before them (see the module)."""

    scene: Scene
    """The scene examined (with the finger tip asked for)."""
    plan: Plan
    """The plan examined (deviated when asked); unsolved when planning found none."""
    options: CageOptions
    """What the report ran with."""
    planned: bool = False
    """The plan was planned here (not read from a file)."""
    problems: list[PlanProblem] = field(default_factory=list)
    """Why the scene's model rejects a plan read from a file (empty: it does not)."""
    profile: CageProfile | None = None
    """The cage of every state the plan passes (None: no plan)."""
    margins: NDArray[np.float64] | None = None
    """Each profiled state's friction margin in its leg's contact mode (rad)."""
    smallest_margin: float | None = None
    """The plan's own smallest friction margin (rad), as plan and bench report it."""

    @property
    def weakest(self) -> CageMinimum | None:
        """Where the escape energy is smallest along the plan (None: no plan)."""
        return None if self.profile is None else self.profile.weakest(self.plan)

    def summary(self) -> str:
        """What the command prints: the plan's line, warnings, the profile's table, its weakest state."""
        scene, plan, o = self.scene, self.plan, self.options
        lines = [f"warning: the model rejects this plan for {scene.name}: {p}" for p in self.problems]
        if not plan.solved:
            return "\n".join(lines + [plan.summary()])
        if self.planned:
            lines.append(f"planned {scene.name} with {plan.planner} (seed {plan.seed}): {len(plan.primitives)} "
                         f"primitives, cost {plan.cost:.2f}")
        if o.start_psi_offset is not None:
            start = plan.states[0]
            held = scene.diagnose(start)
            lines.append(f"deviated start: psi {math.degrees(start[2]):.1f} deg, the thumb turned further than planned "
                         f"({held.describe('it')}; friction margin {float(scene.margin(start).friction_deg[0]):.2f} deg "
                         "with every contact sticking)")
        profile, margins = self.profile, self.margins
        cage0 = profile.cages[0]
        lines.append(f"energy-bounded cage of {scene.name} along the plan (docs/model.md 4.5): if the contacts let go, "
                     f"could the object escape the digits and the table under "
                     + (f"gravity and a {o.squeeze:g} N squeeze where the finger presses" if o.squeeze else "gravity alone")
                     + f"? {len(profile.cages)} states checked, the object's poses on a grid of "
                     f"{cage0.spacing[0] * 1000:.2f} mm and {math.degrees(cage0.spacing[2]):.2f} deg over a whole turn, "
                     f"overlapping the digits or the table by up to {cage0.tolerance * 1000:.2f} mm")
        lines.append("  escape energy: what the object must gain to get away (infinite: it cannot; 0: it falls out "
                     "freely); friction margin: how far every friction cone could narrow before a contact slips")
        lines.append(f"  {'state (theta deg, d, psi deg)':<30} {'primitive':<9}  {'cage':<11}  {'escape energy':>13}  "
                     f"{'friction margin':>15}")
        last = None
        for k, (q, c) in enumerate(zip(profile.samples.states, profile.cages)):
            prim = plan.primitives[profile.samples.primitive[k]].type
            row = (prim, c.outcome.value, round(c.escape_energy_mj, 4))
            if row == last and k != len(profile.cages) - 1:
                continue  # where something changes, and the last state
            last = row
            energy = "infinite" if math.isinf(c.escape_energy) else f"{c.escape_energy_mj:.4f} mJ"
            lines.append(f"  ({math.degrees(q[0]):5.1f}, {q[1]:.3f}, {math.degrees(q[2]):5.1f}){'':<9} {prim:<9}  "
                         f"{c.outcome.label:<11}  {energy:>13}  {math.degrees(margins[k]):>11.2f} deg")
        start_energy = "infinite" if math.isinf(cage0.escape_energy) else f"{cage0.escape_energy_mj:.4f} mJ"
        lines.append(f"at the start: {cage0.outcome.describe()} (escape energy {start_energy})")
        lines.append(f"{self.weakest.describe()}; the smallest friction margin along the path is "
                     f"{math.degrees(self.smallest_margin):.3f} deg")
        return "\n".join(lines)

    def write(self, directory: str | os.PathLike[str]) -> list[Path]:
        """Write cage.json and cage.png into directory (atomically); returns their paths."""
        from ..plots.cage_profile import draw_cage_profile  # matplotlib: loaded when a picture is drawn

        out = Path(directory)
        if out.exists() and not out.is_dir():
            raise InputError("out", f"{out} exists and is not a directory")
        profile, o = self.profile, self.options
        doc = {"scene": self.scene.name, "squeeze_n": o.squeeze, "refine": o.refine,
               "states": [[float(x) for x in q] for q in profile.samples.states],
               "primitive": [int(p) for p in profile.samples.primitive],
               "friction_margin_deg": [float(math.degrees(m)) for m in self.margins],
               "min_friction_margin_deg": math.degrees(self.smallest_margin),
               "cage": [c.to_dict() for c in profile.cages], "weakest": self.weakest.to_dict()}
        write_text_atomic(out / "cage.json", json.dumps(doc, indent=1) + "\n")
        draw_cage_profile(self.scene.name, self.plan, profile, self.margins, out / "cage.png")
        return [out / "cage.json", out / "cage.png"]


@dataclass(frozen=True)
class CageProgress:
    """How far the cage profile has got."""

    done: int
    """States whose cage is computed (count)."""
    total: int
    """States along the plan (count)."""


#: Chunks of states per worker process (so that the workers stay busy to the end, and the progress
#: advances in steps of a few states).
CHUNKS_PER_JOB = 4


def _chunk_cages(task: tuple[Scene, NDArray[np.float64], CageGrid, float]) -> list[Cage]:
    """The cages of a chunk of states (a worker's task: Scene.cage)."""
    scene, states, grid, squeeze = task
    return scene.cage(states, grid, squeeze)


def profile_cages(scene: Scene, plan: Plan, grid: CageGrid, squeeze: float = 0.0, jobs: int = 1,
                  progress: Callable[[CageProgress], None] | None = None) -> CageProfile:
    """planning.cage_profile.cage_profile with the states' cages computed in chunks, jobs worker processes at
    a time (this process for one job); progress is called after each chunk. squeeze in newtons. Raises the cage's InputError (a grid too fine)."""
    samples = plan_samples(plan)
    n = len(samples.states)
    pieces = [k for k in np.array_split(np.arange(n), min(n, max(10, CHUNKS_PER_JOB * jobs))) if len(k)]
    tasks = [(scene, samples.states[k], grid, squeeze) for k in pieces]
    cages: list[list[Cage] | None] = [None] * len(tasks)
    runner = InlineRunner() if jobs == 1 or len(tasks) == 1 else LocalRunner(min(jobs, len(tasks)), fresh=False)
    done = 0
    if progress:
        progress(CageProgress(0, n))
    with closing(runner.run(_chunk_cages, tasks)) as outcomes:
        for outcome in outcomes:
            cages[outcome.index] = outcome.unwrap()
            done += len(pieces[outcome.index])
            if progress:
                progress(CageProgress(done, n))
    return CageProfile(samples, [c for chunk in cages for c in chunk])


def cage_report(scene: Scene, options: CageOptions = CageOptions(),
                progress: Callable[[CageProgress], None] | None = None) -> CageReport:
    """Plan the scene (or read options.plan: one made for another scene only with options.force),
    deviate its start if asked, and profile its cage (options.run's worker processes; progress
    called as states are done) and friction margins; a report without a profile when planning
    finds no plan. Raises InputError naming the option or the scene field before any work."""
    o = options.validated(scene)
    if o.plan is not None:
        result = read_plan_for(scene, o.plan, o.force)
        report = CageReport(scene, result, o, problems=plan_problems(scene, result))
    else:
        result = planning.plan(scene, o.planner)
        report = CageReport(scene, result, o, planned=True)
        if not result.solved:
            return report
    if o.finger_tip is not None:
        report.scene = scene = scene.with_digits(finger_tip=o.finger_tip)
    if o.start_psi_offset is not None:
        report.plan = result = deviated_plan(result, o.start_psi_offset)
    try:
        report.profile = profile_cages(scene, result, CageGrid().refined(o.refine), o.squeeze, o.run.workers,
                                       progress)
    except InputError as exc:
        if exc.field != "grid":
            raise
        raise InputError("refine", exc.reason) from None
    report.margins = plan_friction_margins(scene, report.profile.samples)
    report.smallest_margin = path_friction_margin(scene, result).smallest
    return report
