"""The ``cage`` command's workflow: the energy-bounded cage and the friction margin along a plan.

:func:`cage_report` takes a scene and :class:`CageOptions`, plans the scene (or reads a plan),
optionally starts it deviated, computes the cage of every state the plan passes
(robustness.cage_profile) and each state's friction margin, and returns a :class:`CageReport`
whose ``summary()`` is what the command prints and whose ``write(dir)`` writes cage.json and
cage.png. Energies in joules (mJ where named), angles in radians (degrees where named), forces
in newtons.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..io import write_text_atomic
from ..planning.deviate import PlanProblem, check_psi_offset, deviated_plan, plan_problems
from ..planning.result import Plan, read_plan
from ..robustness import CageMinimum, CageProfile, cage_profile
from ..scene import Scene


@dataclass(frozen=True)
class CageOptions:
    """What ``cage`` examines and how finely."""

    plan: str | os.PathLike[str] | None = None
    """plan.json to examine, or a directory holding one; None: plan the scene."""
    planner: str = "RRTstar"
    """The planner when planning here (an OMPL planner, or lattice)."""
    time: float = 1.0
    """Planning time (s) when planning here."""
    seed: int = 1
    """The planner's seed when planning here."""
    squeeze: float = 0.0
    """A constant force (N) pressing the object where the finger does; 0: gravity only."""
    refine: float = 1.0
    """Factor dividing the pose grid's steps and its penetration tolerance (dimensionless, > 0)."""
    finger_tip: str | None = None
    """rounded or flat instead of the scene's finger tip; None: the scene's."""
    start_psi_offset: float | None = None
    """Start the plan with psi larger by this (rad; the paper's deviated start); None: as planned."""

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
            lines.append(f"planned {scene.name} with {plan.planner} (seed {plan.seed}): cost {plan.cost:.2f}")
        if o.start_psi_offset is not None:
            start = plan.states[0]
            held = scene.diagnose(start)
            lines.append(f"deviated start: psi {math.degrees(start[2]):.1f} deg ({held.describe('it')}; friction margin "
                         f"{float(scene.margin(start).friction_deg[0]):.2f} deg with every contact sticking)")
        profile, margins = self.profile, self.margins
        cage0 = profile.cages[0]
        lines.append(f"cage of {scene.name} along the plan: {len(profile.cages)} states, grid "
                     f"{cage0.spacing[0] * 1000:.2f} mm / {math.degrees(cage0.spacing[2]):.2f} deg over the whole turn, "
                     f"penetration tolerance {cage0.tolerance * 1000:.2f} mm"
                     + (f", squeeze {o.squeeze:g} N" if o.squeeze else ", gravity only"))
        lines.append(f"  {'state (theta deg, d, psi deg)':<34} {'primitive':<8} {'cage':<12} {'escape mJ':>10} "
                     f"{'margin deg':>10}")
        last = None
        for k, (q, c) in enumerate(zip(profile.samples.states, profile.cages)):
            prim = plan.primitives[profile.samples.primitive[k]].type
            row = (prim, c.outcome.value, round(c.escape_energy_mj, 4))
            if row == last and k != len(profile.cages) - 1:
                continue  # where something changes, and the last state
            last = row
            energy = "inf" if math.isinf(c.escape_energy) else f"{c.escape_energy_mj:.4f}"
            lines.append(f"  ({math.degrees(q[0]):5.1f}, {q[1]:.3f}, {math.degrees(q[2]):5.1f}){'':<13} {prim:<8} "
                         f"{c.outcome.value:<12} {energy:>10} {math.degrees(margins[k]):>10.2f}")
        start_energy = "inf" if math.isinf(cage0.escape_energy) else f"{cage0.escape_energy_mj:.4f}"
        lines.append(f"start: {cage0.outcome.value.replace('_', ' ')} (escape energy {start_energy} mJ)")
        lines.append(f"{self.weakest.describe()}; smallest friction margin along the path "
                     f"{math.degrees(self.smallest_margin):.3f} deg")
        return "\n".join(lines)

    def write(self, directory: str | os.PathLike[str]) -> list[Path]:
        """Write cage.json and cage.png into directory (atomically); returns their paths."""
        from ..robustness_plot import draw_cage_profile

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


def cage_report(scene: Scene, options: CageOptions = CageOptions()) -> CageReport:
    """Plan the scene (or read options.plan), deviate its start if asked, and profile its cage
    and friction margins; a report without a profile when planning finds no plan. Raises
    InputError naming the option or the scene field before any work."""
    from ..mechanics.cage import CageGrid
    from ..planning import plan as plan_scene
    from ..planning.path_margin import path_friction_margin, plan_friction_margins

    o = options.validated(scene)
    if o.plan is not None:
        result = read_plan(o.plan)
        report = CageReport(scene, result, o, problems=plan_problems(scene, result))
    else:
        result = plan_scene(scene, planner=o.planner, time=o.time, seed=o.seed)
        report = CageReport(scene, result, o, planned=True)
        if not result.solved:
            return report
    if o.finger_tip is not None:
        report.scene = scene = scene.with_digits(finger_tip=o.finger_tip)
    if o.start_psi_offset is not None:
        report.plan = result = deviated_plan(result, o.start_psi_offset)
    try:
        report.profile = cage_profile(scene, result, grid=CageGrid().refined(o.refine), squeeze=o.squeeze)
    except InputError as exc:
        if exc.field != "grid":
            raise
        raise InputError("refine", exc.reason) from None
    report.margins = plan_friction_margins(scene, report.profile.samples)
    report.smallest_margin = path_friction_margin(scene, result).smallest
    return report


__all__ = ["CageOptions", "CageReport", "cage_report"]
