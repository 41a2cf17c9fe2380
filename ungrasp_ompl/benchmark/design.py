"""``design``: the digits for an object, from a grid of designs.

Each design is the scene's digits with another asymmetry alpha (the finger's extra length over
the thumb, over the object length l) and, for a rounded finger tip, another dome radius (a larger
dome thickens the tip to its diameter; Scene.with_digits). Per design, as one task on a runner
(worker processes here, or a Ray cluster):

* the exact lattice plan (deterministic, so a design's row does not depend on where it ran) and
  its cost; or why no plan exists (the digits, the start, the goal, or no secure path);
* the plan's tolerance (planning.plan_tolerance: the largest scale of the ``paper`` error box under
  which every state of the plan stays secure) and the grasp shift it tolerates (mm);
* with ``simulate`` trials, the simulated successes of the plan (sim.plan_trials) and their
  Wilson 95 % interval.

The chosen design has the largest tolerance (with trials: the highest Wilson lower bound, the
tolerance breaking ties; then the lower cost). ``DesignResult.write`` writes design.csv,
design.png (a heat map over the grid, the chosen design and the scene's own marked) and
design_scene.yaml (the scene file with the chosen digits, loadable by every command).
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..io import edited_yaml, parse_yaml, write_text_atomic
from ..parallel.options import RunOptions
from ..parallel.runner import TaskStatus, open_runner
from ..planning.plan_tolerance import tolerance
from ..planning.result import PlanOutcome
from ..planning.setup import lattice_plan
from ..plots.common import cell_edges, pyplot, save_png
from ..scene import Scene
from ..scene.loader import read_yaml_text
from ..scene.perturbation import preset
from ..scene.tolerance import ToleranceReason
from ..shipped import resolve
from ..sim.campaign import wilson_interval
from ..sim.plan_trials import plan_trials
from .map import NOT_EXECUTABLE
from .options import check_jobs, check_out

#: A task's grace (s) per simulated trial before it counts as hung, besides the plan's.
TRIAL_GRACE_S = 120.0
#: A design task's time (s) without trials before it counts as hung.
CELL_DEADLINE_S = 300.0
#: The most designs a grid may have.
MAX_DESIGNS = 10_000


@dataclass(frozen=True)
class DesignOptions:
    """What ``design`` searches and how it runs."""

    alphas: tuple[float, ...] = ()
    """Digit asymmetry values (over the object length): the grid's columns; empty: five about the scene's own."""
    tip_radii: tuple[float, ...] = ()
    """Rounded finger-tip radii (m): the grid's rows; empty: five about the scene's own (flat tip: none)."""
    finger_tip: str = "rounded"
    """rounded (a dome: point contact at A) or flat (an edge across the width; no radius to vary)."""
    goal: str = "free"
    """free: each design's goal lets d and psi take any value in the bounds (where its digits can let
    go; Scene.with_free_goal); scene: the scene's own goal region."""
    simulate: int = 0
    """Simulated trials per design with a plan (count); 0: ranked by tolerance alone."""
    perturb: str = "paper"
    """The simulated trials' error preset (see ``simulate --perturb``)."""
    run: RunOptions = RunOptions()
    """How the designs run: run.seed seeds the simulated trials' errors (the lattice plans need none);
    run.jobs designs at a time on this machine (child processes; None: all cores; unused on a
    cluster); run.cluster a Ray cluster's address ("local" starts one here; None: this machine)."""
    out: str | os.PathLike[str] = "design"
    """Output directory for design.csv, design.png and design_scene.yaml."""

    def validated(self, scene: Scene) -> "DesignOptions":
        """These options checked, the grid filled in about the scene's digits where empty;
        InputError naming the option otherwise."""
        if self.finger_tip not in ("rounded", "flat"):
            raise InputError("finger_tip", f"must be rounded or flat, got {self.finger_tip!r}")
        if self.goal not in ("free", "scene"):
            raise InputError("goal", f"must be free or scene, got {self.goal!r}")
        check_jobs(self.run.workers)
        check_out(self.out)
        run = replace(self.run.validated(), jobs=self.run.workers)
        if isinstance(self.simulate, bool) or not isinstance(self.simulate, int) or not 0 <= self.simulate <= 10000:
            raise InputError("simulate", f"must be a number of trials in [0, 10000], got {self.simulate!r}")
        if self.simulate:
            preset(self.perturb)
            if scene.object_thickness <= 0.0:
                raise InputError("simulate", "the simulator needs a scene with an object thickness (m)")
        dg, l = scene.digits, scene.object_length
        alphas = self.alphas or tuple(round(dg.alpha + k * 0.05, 6) for k in (-2, -1, 0, 1, 2))
        if self.finger_tip == "flat":
            if self.tip_radii:
                raise InputError("tip_radii", "needs finger_tip rounded (a flat tip has no radius)")
            radii: tuple[float, ...] = (0.0,)
        else:
            own = dg.finger_tip_radius * l if not dg.flat_finger_tip and dg.finger_tip_radius > 0 \
                else dg.finger_tip_thickness * l / 2
            radii = self.tip_radii or tuple(own * f for f in (0.5, 0.75, 1.0, 1.5, 2.0))
        for a in alphas:
            if not math.isfinite(a):
                raise InputError("alphas", f"must be finite numbers, got {a!r}")
        for r in radii:
            if not (math.isfinite(r) and r >= 0.0):
                raise InputError("tip_radii", f"must be lengths >= 0 m, got {r!r}")
        if len(alphas) * len(radii) > MAX_DESIGNS:
            raise InputError("alphas", f"and tip_radii give more than {MAX_DESIGNS} designs")
        return replace(self, alphas=tuple(map(float, alphas)), tip_radii=tuple(map(float, radii)), run=run)


@dataclass(frozen=True)
class DesignTask:
    """One design: its scene (None when the digits are invalid, with why), and its trials."""

    index: int
    """The design's index in grid order (radius by radius, alpha by alpha)."""
    alpha: float
    """Digit asymmetry (over the object length)."""
    tip_radius: float
    """The finger tip's dome radius (m; 0: flat)."""
    scene: Scene | None
    """The design's scene; None: the digits are invalid (invalid says why)."""
    invalid: str = ""
    """Why the digits cannot be built (the scene's field and reason)."""
    trials: int = 0
    """Simulated trials (count)."""
    perturb: str = "paper"
    """The trials' error preset."""
    seed: int = 1
    """The trials' seed."""


@dataclass(frozen=True)
class Design:
    """What one design gave. Costs in reference units."""

    alpha: float
    """Digit asymmetry (over the object length)."""
    tip_radius: float
    """The finger tip's dome radius (m; 0: flat)."""
    task_status: TaskStatus = TaskStatus.DONE
    """How the design's task ended (DONE, or FAILED, HUNG, DIED: error says why)."""
    outcome: PlanOutcome | None = None
    """The exact lattice plan's outcome; None: invalid digits (error says why) or the task failed."""
    cost: float | None = None
    """The plan's cost; None: no plan."""
    tolerance: float | None = None
    """The plan's tolerance: the scale of the paper error box it stays secure under; None: no plan."""
    tolerated_shift_mm: float | None = None
    """The grasp shift along and across GB tolerated at that scale (mm)."""
    binding: str = ""
    """The check that binds the tolerance (ToleranceReason's value)."""
    trials: int = 0
    """Simulated trials (count); 0: none."""
    successes: int | None = None
    """Successful trials (count); None: not simulated (no plan, or the robot cannot execute it)."""
    digits_valid: bool = True
    """The digits can be built (False: error gives the scene's field and reason)."""
    executable: bool | None = None
    """Whether the robot could execute the plan (None: not tried: no plan, or no trials asked)."""
    error: str = ""
    """Why the digits are invalid, the task failed or the plan was not simulated; empty otherwise."""

    @property
    def wilson(self) -> tuple[float, float] | None:
        """Wilson's 95 % interval of the success rate (None: not simulated)."""
        if self.successes is None or not self.trials:
            return None

        return wilson_interval(self.successes, self.trials)

    def rank(self, simulated: bool) -> tuple:
        """The key the chosen design maximises: (Wilson lower bound with trials,) tolerance, -cost."""
        tol = -math.inf if self.tolerance is None else self.tolerance
        cost = -math.inf if self.cost is None else -self.cost
        if simulated:
            low = self.wilson[0] if self.wilson is not None else -math.inf
            return (low, tol, cost)
        return (tol, cost)


def design_cell(task: DesignTask) -> Design:
    """Plan one design exactly, measure its plan's tolerance and, with trials, simulate it."""
    if task.scene is None:
        return Design(task.alpha, task.tip_radius, digits_valid=False, error=task.invalid)
    scene = task.scene
    plan = lattice_plan(scene, task.seed)
    if not plan.solved:
        return Design(task.alpha, task.tip_radius, outcome=plan.outcome)
    tol = tolerance(scene, plan)
    found = Design(task.alpha, task.tip_radius, outcome=plan.outcome, cost=plan.cost, tolerance=tol.scale,
                   tolerated_shift_mm=tol.physical["shift_mm"], binding=tol.reason.value)
    if not task.trials:
        return found

    run = plan_trials(scene, plan, task.trials, task.perturb, task.seed)
    if not run.executable:
        return replace(found, trials=task.trials, executable=False, error=f"not executable: {run.unexecutable}")
    return replace(found, trials=task.trials, executable=True, successes=run.successes)


#: design.csv's columns.
DESIGN_COLUMNS = ("alpha", "tip_radius_mm", "finger_tip", "task_status", "outcome", "cost", "tolerance",
                  "tolerated_shift_mm", "binding", "trials", "successes", "wilson_low", "wilson_high", "chosen",
                  "error")


@dataclass
class DesignResult:
    """The designs in grid order, the chosen one, and what the scene file needs to be rewritten."""

    scene: str
    """The scene's name."""
    options: DesignOptions
    """What the search ran with (validated; the grid filled in)."""
    designs: list[Design]
    """Every design, radius by radius, alpha by alpha."""
    chosen: int | None
    """Index of the chosen design; None: no design has a plan."""
    own: tuple[float, float]
    """The scene's own (alpha, tip radius m)."""
    length: float
    """The object's length l (m), over which alpha is measured."""
    source: str | None = field(default=None, repr=False)
    """The scene file's text, which design_scene.yaml is edited from (io.edited_yaml)."""
    goal: Any = None
    """The goal region the designs were planned to (GoalSpec)."""

    @property
    def best(self) -> Design | None:
        """The chosen design (None: none has a plan)."""
        return None if self.chosen is None else self.designs[self.chosen]

    def summary(self) -> str:
        """What a person reads: the grid's size, the chosen digits against the scene's own."""
        o, n = self.options, len(self.designs)
        planned = sum(d.outcome is PlanOutcome.SOLVED for d in self.designs)
        radii = (f" x {len(o.tip_radii)} radii of the finger's rounded tip" if o.finger_tip == "rounded"
                 else " with a flat finger tip")
        goal = ("that lets go wherever its digits can (d and psi anywhere within the bounds)" if o.goal == "free"
                else "to the scene's goal region")
        lines = [f"{self.scene}: {n} digit designs ({len(o.alphas)} digit asymmetries alpha, the finger's length beyond "
                 f"the thumb's over l,{radii}), {planned} with a secure plan {goal}"
                 + (f"; each plan simulated {o.simulate} times ({o.perturb} errors)" if o.simulate else "")]
        own = next((d for d in self.designs if math.isclose(d.alpha, self.own[0], abs_tol=1e-9)
                    and math.isclose(d.tip_radius, self.own[1], abs_tol=1e-12)), None)
        chosen = ("chosen, the most successful in simulation" if o.simulate
                  else "chosen, the plan most tolerant of errors")
        for label, d, missing in ((chosen, self.best, "no design has a secure plan"),
                                  ("the scene's own digits", own, "not in the grid")):
            if d is None:
                lines.append(f"  {label}: {missing}")
                continue
            tip = f", tip radius {d.tip_radius * 1000:g} mm" if o.finger_tip == "rounded" else ""
            text = f"  {label}: alpha {d.alpha:g}{tip}: "
            if d.outcome is not PlanOutcome.SOLVED:
                text += d.error or (d.outcome.describe() if d.outcome else f"its task {d.task_status.value}")
            else:
                beyond = (ToleranceReason(d.binding).describe() if d.binding in {r.value for r in ToleranceReason}
                          else d.binding)
                text += (f"its plan costs {d.cost:.2f} and survives errors up to {d.tolerance:.3f} times the paper's "
                         f"bounds (the grasp {d.tolerated_shift_mm:.3f} mm off); beyond that, {beyond}")
                if d.wilson is not None:
                    low, high = d.wilson
                    text += (f"; {d.successes}/{d.trials} simulated trials placed the object (95 % confidence "
                             f"interval {low:.0%}-{high:.0%})")
            lines.append(text)
        return "\n".join(lines)

    def rows(self) -> list[list[object]]:
        """design.csv's rows (DESIGN_COLUMNS)."""
        out = []
        for k, d in enumerate(self.designs):
            w = d.wilson
            out.append([repr(d.alpha), repr(round(d.tip_radius * 1000, 9)), self.options.finger_tip, d.task_status.value,
                        d.outcome.value if d.outcome else "", d.cost, d.tolerance, d.tolerated_shift_mm, d.binding,
                        d.trials, d.successes, None if w is None else w[0], None if w is None else w[1],
                        int(k == self.chosen), d.error.replace("\n", " ")])
        return out

    def scene_yaml(self) -> str:
        """The scene file with the chosen digits (alpha; the tip's kind, radius and thickness in
        metres), headed by the digits to print in millimetres."""
        d = self.best
        if d is None or self.source is None:
            raise InputError("design", "no design has a secure plan: no scene to recommend")
        dig = parse_yaml(self.source)["digits"]
        goal: dict = {}
        dig.pop("finger_length", None)
        dig["alpha"] = d.alpha
        dig["finger_tip"] = self.options.finger_tip
        dig.pop("finger_tip_radius", None)
        if self.options.finger_tip == "rounded":
            dig["finger_tip_radius"] = d.tip_radius
            tip = float(dig.get("finger_tip_thickness", 0.0))
            if 2 * d.tip_radius > tip:
                dig["finger_tip_thickness"] = 2 * d.tip_radius
        if self.options.goal == "free" and self.goal is not None:  # the goal the chosen plan was found with
            g = self.goal
            goal = {"goal": {"theta_max_deg": round(math.degrees(g.theta_max), 9), "d": [g.d[0], g.d[1]],
                             "psi_deg": [round(math.degrees(g.psi[0]), 9), round(math.degrees(g.psi[1]), 9)]}}
        thumb = float(dig["thumb_length"])
        finger = thumb + d.alpha * self.length
        head = [f"# Digits chosen by `ungrasp-ompl design` for {self.scene} (to print, in mm): thumb {thumb * 1000:.2f} long, "
                f"finger {finger * 1000:.2f} long", f"# ({self.options.finger_tip} tip"
                + (f", dome radius {d.tip_radius * 1000:.2f}" if self.options.finger_tip == "rounded" else "")
                + f"); tolerance {d.tolerance:.3f} of the paper error box, cost {d.cost:.2f}"
                + (f"; {d.successes}/{d.trials} simulated trials placed ({self.options.perturb} errors, seed "
                   f"{self.options.run.seed})." if d.successes is not None else ".")]
        return "\n".join(head) + "\n" + edited_yaml(self.source, {"digits": dig, **goal})

    def write(self, directory: str | os.PathLike[str]) -> dict[str, Path]:
        """Write design.csv, design.png and (with a chosen design) design_scene.yaml atomically
        into directory; returns them by role."""
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        text = io.StringIO()
        w = csv.writer(text, lineterminator="\n")
        w.writerow(DESIGN_COLUMNS)
        w.writerows([["" if v is None else v for v in row] for row in self.rows()])
        files = {"csv": out / "design.csv", "plot": out / "design.png"}
        write_text_atomic(files["csv"], text.getvalue())
        plot_design(self, files["plot"])
        if self.best is not None:
            files["scene"] = out / "design_scene.yaml"
            write_text_atomic(files["scene"], self.scene_yaml())
        return files


@dataclass(frozen=True)
class DesignProgress:
    """How far a design search has got, for a progress line."""

    done: int
    """Designs done (count)."""
    total: int
    """Designs in the grid (count)."""
    last: Design | None
    """The design that just finished (None before the first)."""


def run_design(scene_path: str | os.PathLike[str], options: DesignOptions = DesignOptions(),
               progress: Callable[[DesignProgress], None] | None = None) -> DesignResult:
    """Plan every design of the grid (see the module) on a runner and choose one. Raises
    InputError naming the option or the scene before anything runs; writes nothing (see
    DesignResult.write)."""
    path = resolve(scene_path, "scene")
    scene_file = Scene.from_file(path)
    source = read_yaml_text(path, "scene")
    opts = options.validated(scene_file)
    base = scene_file.with_free_goal() if opts.goal == "free" else scene_file
    tasks = []
    for r in opts.tip_radii:
        for a in opts.alphas:
            try:
                scene = base.with_digits(alpha=a, finger_tip=opts.finger_tip,
                                         finger_tip_radius=r if opts.finger_tip == "rounded" else None)
                why = ""
            except InputError as exc:
                scene, why = None, f"invalid digits: {exc.field}: {exc.reason}"
            tasks.append(DesignTask(len(tasks), a, r, scene, why, opts.simulate, opts.perturb, opts.run.seed))
    designs: dict[int, Design] = {}
    deadline = CELL_DEADLINE_S + TRIAL_GRACE_S * opts.simulate
    with open_runner(opts.run.jobs, opts.run.cluster, fresh=False) as runner:
        if progress:
            progress(DesignProgress(0, len(tasks), None))
        for outcome in runner.run(design_cell, tasks, deadline):
            task = tasks[outcome.index]
            d = outcome.value if outcome.status is TaskStatus.DONE else Design(
                task.alpha, task.tip_radius, outcome.status, error=f"the design's task {outcome.status.value}")
            designs[task.index] = d
            if progress:
                progress(DesignProgress(len(designs), len(tasks), d))
    ordered = [designs[t.index] for t in tasks]
    simulated = bool(opts.simulate)
    candidates = [k for k, d in enumerate(ordered) if d.outcome is PlanOutcome.SOLVED]
    chosen = max(candidates, key=lambda k: ordered[k].rank(simulated)) if candidates else None
    own_radius = 0.0 if base.digits.flat_finger_tip else base.digits.finger_tip_radius * base.object_length
    return DesignResult(base.name, opts, ordered, chosen, (base.digits.alpha, own_radius), base.object_length, source,
                        base.goal)


def plot_design(result: DesignResult, path: Path) -> None:
    """Write design_figure's picture to path (PNG)."""
    save_png(design_figure(result), path)


def design_figure(result: DesignResult):
    """A heat map over the designs (alpha across, the tip's radius up): the plan's tolerance, or
    with trials the simulated success rate; on each design without a plan a marker says why; a
    star marks the chosen design and a circle the scene's own digits. Returns the Figure."""
    plt = pyplot()
    o = result.options
    alphas, radii = list(o.alphas), [r * 1000 for r in o.tip_radii]
    cells = np.array(result.designs, dtype=object).reshape(len(radii), len(alphas))
    simulated = bool(o.simulate)
    if simulated:
        value = np.array([[np.nan if d.successes is None else d.successes / d.trials for d in row] for row in cells])
        label, title = "simulated success rate (share of trials)", f"{result.scene}: success over {o.simulate} trials ({o.perturb})"
    else:
        value = np.array([[np.nan if d.tolerance is None else d.tolerance for d in row] for row in cells])
        label, title = "tolerance (scale of the paper error box)", f"{result.scene}: tolerance of each design's plan"
    fig, ax = plt.subplots(figsize=(7.5, 5.0), constrained_layout=True)

    mesh = ax.pcolormesh(cell_edges(alphas), cell_edges(radii), np.ma.masked_invalid(value), cmap="viridis", shading="flat")
    fig.colorbar(mesh, ax=ax, label=label)
    reasons = {"invalid digits": ("digits cannot be built", "x"),
               PlanOutcome.START_NOT_HELD: ("start not held", "v"), PlanOutcome.GOAL_EMPTY: ("goal region empty", "s"),
               PlanOutcome.NO_SECURE_PATH: ("no secure path", "d"), NOT_EXECUTABLE: ("robot cannot execute it", "^"),
               "failed": ("task failed", "X")}
    placed: dict = {}
    for i, row in enumerate(cells):
        for j, d in enumerate(row):
            if d.outcome is PlanOutcome.SOLVED and not (simulated and d.successes is None):
                continue
            key = ("invalid digits" if not d.digits_valid else NOT_EXECUTABLE if d.executable is False
                   else d.outcome if d.outcome else "failed")
            placed.setdefault(key, []).append((alphas[j], radii[i]))
    for key, points in placed.items():
        text, marker = reasons[key]
        xs, ys = zip(*points)
        ax.scatter(xs, ys, marker=marker, color="white", edgecolors="black", s=60, label=text)
    own_a, own_r = result.own[0], result.own[1] * 1000
    ax.scatter([own_a], [own_r], marker="o", facecolors="none", edgecolors="red", s=220, linewidths=2,
               label="the scene's own digits")
    if result.best is not None:
        ax.scatter([result.best.alpha], [result.best.tip_radius * 1000], marker="*", color="orange",
                   edgecolors="black", s=320, label="chosen design")
    ax.set(xlabel="alpha: finger minus thumb length, over the object length",
           ylabel="finger tip's dome radius (mm)" if o.finger_tip == "rounded" else "flat finger tip (no radius)",
           title=title)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3)
    return fig
