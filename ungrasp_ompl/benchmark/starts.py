"""``starts``: where to hand the object over, the start's d from which B slides least.

In each P_psi B slides along the thumb's face, and how far is set by the start's d and the plan
(docs/model.md 11.18): a shorter slide leaves less for a push across the plane to walk B across
the face when the world's friction is not the model's (docs/decisions/0118). Per candidate d, in
steps of StartOptions.d_step over l within the goal's d range (the scene's theta and psi kept), as
one task on a runner: the exact lattice plan with the scene's planning options, B's slide
along the thumb summed over the plan's legs (b_slide), and what else a start trades: the plan's
friction margin, its tolerance of the `paper` errors (planning.plan_tolerance) and the spread of
its predicted landing over the scene's friction range and both cones (planning.predicted_landing).
The chosen start is the one whose plan is secure and slides B least (the larger d on a tie). With
StartOptions.both_tips a candidate counts only where the scene with the other finger tip (flat for
a rounded tip, rounded for a flat one: Scene.with_digits) has a secure lattice plan from it too,
the rule of docs/decisions/0121: the lowest starts may leave one tip no goal state to reach.
``StartChoice.write`` writes starts.csv and starts_scene.yaml (the scene file with the chosen
start, loadable by every command).
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import edited_yaml, parse_yaml, write_text_atomic
from ..mechanics.pincer import hand_s_b
from ..mechanics.release import ReleaseModelError
from ..parallel.options import RunOptions
from ..parallel.runner import TaskStatus, open_runner
from ..planning import plan
from ..planning.plan_tolerance import tolerance
from ..planning.predicted_landing import predict_landing
from ..planning.result import Plan, PlanOutcome
from ..scene import Scene
from ..scene.loader import read_yaml_text
from ..shipped import resolve
from .options import check_out

#: A candidate's task time (s) before it counts as hung.
CANDIDATE_DEADLINE_S = 300.0
#: The most candidates a search may have.
MAX_CANDIDATES = 1000
#: starts.csv's columns.
START_COLUMNS = ("d", "task_status", "outcome", "b_slide_mm", "min_margin_deg", "cost", "tolerance",
                 "landing_spread_mm", "other_tip_outcome", "chosen", "error")


@dataclass(frozen=True)
class StartOptions:
    """What ``starts`` searches and how it runs."""

    d_range: tuple[float, float] | None = None
    """The candidates' d bounds (over l, both included); None: the goal region's d range."""
    d_step: float = 0.01
    """Spacing of the candidates' d (over l)."""
    run: RunOptions = RunOptions()
    """run.seed the lattice plans' seed; run.jobs candidates at a time on this machine (None: all
    cores); run.cluster a Ray cluster's address (None: this machine)."""
    out: str | os.PathLike[str] = "starts"
    """Output directory for starts.csv and starts_scene.yaml."""
    both_tips: bool = False
    """Count a candidate only where the other finger tip's lattice plan from it is secure too
    (docs/decisions/0121)."""

    def candidates(self, scene: Scene) -> tuple[float, ...]:
        """The candidate d (over l) for scene, these options checked; InputError naming the option
        otherwise."""
        step = self.d_step
        if isinstance(step, bool) or not isinstance(step, (int, float)) or not (math.isfinite(step) and step > 0):
            raise InputError("d_step", f"must be a positive number (over l), got {step!r}")
        if self.d_range is None:
            lo, hi = scene.goal.box()
            low, high = float(lo[1]), float(hi[1])
        else:
            low, high = (float(x) for x in self.d_range)
            if not (math.isfinite(low) and math.isfinite(high) and 0.0 <= low <= high <= 1.0):
                raise InputError("d_range", f"must be two d in [0, 1] (over l), the first not above the second, "
                                            f"got {self.d_range!r}")
        first, last = math.ceil(low / step - 1e-9), math.floor(high / step + 1e-9)
        if last < first:
            raise InputError("d_range", f"holds no d in steps of {step:g}: [{low:g}, {high:g}]")
        if last - first + 1 > MAX_CANDIDATES:
            raise InputError("d_step", f"gives more than {MAX_CANDIDATES} candidates over [{low:g}, {high:g}]")
        check_out(self.out)
        self.run.validated()
        return tuple(round(k * step, 9) for k in range(first, last + 1))


def b_slide(scene: Scene, result: Plan) -> float:
    """How far B slides along the thumb's face over a solved plan (m): |delta s_B| summed over the
    waypoints of every leg (mechanics.pincer.hand_s_b: a pincer's own, a curved section's own)."""
    l = scene.object_length
    ways = np.array([w for p in result.primitives for w in p.waypoints], dtype=float)
    pincer = None if scene.robot.gripper is None else scene.robot.gripper.scaled(l)
    along = hand_s_b(ways[:, 0], ways[:, 1], ways[:, 2], scene.digits, pincer)
    return float(np.sum(np.abs(np.diff(along)))) * l  # each leg begins where the last ended: joins add nothing


@dataclass(frozen=True)
class StartCandidate:
    """One candidate start: its d, its plan's outcome and, where secure, what the plan does."""

    d: float
    """The start's d (over l)."""
    task_status: TaskStatus = TaskStatus.DONE
    """How the candidate's task ended (a hung or crashed task has no plan)."""
    outcome: PlanOutcome | None = None
    """The lattice plan's outcome; None when the task did not finish."""
    b_slide_m: float | None = None
    """B's slide along the thumb over the plan (m); None without a secure plan."""
    min_margin_deg: float | None = None
    """The plan's smallest friction margin (deg); None without a secure plan."""
    cost: float | None = None
    """The plan's cost; None without a secure plan."""
    tolerance: float | None = None
    """The largest scale of the `paper` error box under which every state of the plan stays secure."""
    landing_spread_m: float | None = None
    """How far the predicted landing moves over the friction range and both cones (m); None
    without a secure plan, a thickness, or a termination the model of the fall covers."""
    other_tip_outcome: PlanOutcome | None = None
    """With both_tips, the other finger tip's lattice plan's outcome; None when not planned."""
    error: str = ""
    """Why the candidate has no plan, for a person ("" when it has one)."""


@dataclass(frozen=True)
class StartTask:
    """One candidate's work: the scene from that start, and the lattice's seed; with both_tips, the
    same scene with the other finger tip (other), which must plan too."""

    index: int
    d: float
    scene: Scene
    seed: int
    other: Scene | None = None


def start_cell(task: StartTask) -> StartCandidate:
    """Plan one candidate start exactly (the scene's planning options) and measure B's slide; with
    the other finger tip's scene, plan that too, and count the candidate only where both plans are
    secure."""
    result = plan(task.scene, planner="lattice", seed=task.seed)  # a start not held: an outcome, not an error
    if not result.solved:
        return StartCandidate(task.d, outcome=result.outcome, error=result.reason or result.outcome.value)
    if task.other is not None:
        other = plan(task.other, planner="lattice", seed=task.seed)
        if not other.solved:
            tip = "flat" if task.other.digits.flat_finger_tip else "rounded"
            return StartCandidate(task.d, outcome=result.outcome, other_tip_outcome=other.outcome,
                                  error=f"with a {tip} finger tip: {other.reason or other.outcome.value}")
    other_outcome = None if task.other is None else PlanOutcome.SOLVED
    spread = None
    if task.scene.object_thickness > 0.0:
        try:
            spread = predict_landing(task.scene, result).spread
        except ReleaseModelError:  # a termination the model of the fall does not cover (rotate)
            pass
    return StartCandidate(task.d, outcome=result.outcome, b_slide_m=b_slide(task.scene, result),
                          min_margin_deg=result.min_margin_deg, cost=result.cost,
                          tolerance=tolerance(task.scene, result).scale, landing_spread_m=spread,
                          other_tip_outcome=other_outcome)


@dataclass(frozen=True)
class StartChoice:
    """Every candidate start in order of d, the chosen one, and the scene file to rewrite."""

    scene: str
    """The scene's name."""
    own_d: float
    """The scene's own start d (over l)."""
    candidates: list[StartCandidate]
    """Every candidate, by increasing d."""
    chosen: int | None
    """Index of the chosen candidate; None: no candidate has a secure plan."""
    source: str | None = field(default=None, repr=False)
    """The scene file's text, which starts_scene.yaml is edited from (io.edited_yaml)."""

    @property
    def best(self) -> StartCandidate | None:
        """The chosen candidate (None: none has a secure plan)."""
        return None if self.chosen is None else self.candidates[self.chosen]

    def summary(self) -> str:
        """What a person reads: the candidates, the chosen start against the scene's own."""
        secure = sum(c.b_slide_m is not None for c in self.candidates)
        lines = [f"{self.scene}: {len(self.candidates)} starts in d "
                 f"{self.candidates[0].d:g}-{self.candidates[-1].d:g}, {secure} with a secure lattice plan"]
        own = next((c for c in self.candidates if math.isclose(c.d, self.own_d, abs_tol=1e-9)), None)
        for label, c, missing in (("chosen, B slides least", self.best, "no start has a secure plan"),
                                  ("the scene's own start", own, "not among the candidates")):
            if c is None:
                lines.append(f"  {label}: {missing}")
            elif c.b_slide_m is None:
                lines.append(f"  {label}: d {c.d:g}: {c.error}")
            else:
                spread = "" if c.landing_spread_m is None else \
                    f", predicted landing spread {c.landing_spread_m * 1000:.2f} mm"
                lines.append(f"  {label}: d {c.d:g}: B slides {c.b_slide_m * 1000:.2f} mm along the thumb, "
                             f"friction margin {c.min_margin_deg:.2f} deg, tolerance {c.tolerance:.3f}{spread}, "
                             f"cost {c.cost:.2f}")
        return "\n".join(lines)

    def rows(self) -> list[list[object]]:
        """starts.csv's rows (START_COLUMNS)."""
        return [[repr(c.d), c.task_status.value, "" if c.outcome is None else c.outcome.value,
                 None if c.b_slide_m is None else round(c.b_slide_m * 1000, 6), c.min_margin_deg, c.cost,
                 c.tolerance, None if c.landing_spread_m is None else round(c.landing_spread_m * 1000, 6),
                 "" if c.other_tip_outcome is None else c.other_tip_outcome.value,
                 int(k == self.chosen), c.error.replace("\n", " ")] for k, c in enumerate(self.candidates)]

    def scene_yaml(self) -> str:
        """The scene file with the chosen start's d, headed by what it was chosen by; its other
        lines, comments included, as they were (io.edited_yaml)."""
        c = self.best
        if c is None or self.source is None:
            raise InputError("starts", "no start has a secure plan: no scene to recommend")
        start = {**parse_yaml(self.source)["start"], "d": c.d}
        head = (f"# Start chosen by `ungrasp-ompl starts` for {self.scene}: d {c.d:g}, from which B slides "
                f"{c.b_slide_m * 1000:.2f} mm along the thumb\n# (the scene's own d {self.own_d:g}); friction "
                f"margin {c.min_margin_deg:.2f} deg.\n")
        return head + edited_yaml(self.source, {"start": start})

    def write(self, directory: str | os.PathLike[str]) -> dict[str, Path]:
        """Write starts.csv and (with a chosen start) starts_scene.yaml atomically into directory;
        returns them by role."""
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        text = io.StringIO()
        w = csv.writer(text, lineterminator="\n")
        w.writerow(START_COLUMNS)
        w.writerows([["" if v is None else v for v in row] for row in self.rows()])
        files = {"csv": out / "starts.csv"}
        write_text_atomic(files["csv"], text.getvalue())
        if self.best is not None:
            files["scene"] = out / "starts_scene.yaml"
            write_text_atomic(files["scene"], self.scene_yaml())
        return files


def choose_start(scene_path: str | os.PathLike[str], options: StartOptions = StartOptions(),
                 progress: Callable[[int, int], None] | None = None) -> StartChoice:
    """The scene file's (or shipped scene's) candidate starts planned and one chosen
    (search_starts), with the file's text for starts_scene.yaml."""
    path = resolve(scene_path, "scene")
    return replace(search_starts(Scene.from_file(path), options, progress), source=read_yaml_text(path, "scene"))


def search_starts(scene: Scene, options: StartOptions = StartOptions(),
                  progress: Callable[[int, int], None] | None = None) -> StartChoice:
    """Plan every candidate start of scene (see the module) on a runner and choose one. Raises
    InputError naming the option before anything runs; writes nothing (see StartChoice.write).
    progress(done, total) after each candidate."""
    ds = options.candidates(scene)
    other = None
    if options.both_tips:
        other = scene.with_digits(finger_tip="rounded" if scene.digits.flat_finger_tip else "flat")
    tasks = [StartTask(k, d, scene.with_start_d(d), options.run.seed, other and other.with_start_d(d))
             for k, d in enumerate(ds)]
    found: dict[int, StartCandidate] = {}
    with open_runner(options.run.workers, options.run.cluster, fresh=False) as runner:
        for outcome in runner.run(start_cell, tasks, CANDIDATE_DEADLINE_S):
            task = tasks[outcome.index]
            found[task.index] = outcome.value if outcome.status is TaskStatus.DONE else StartCandidate(
                task.d, task_status=outcome.status, error=f"the candidate's task {outcome.status.value}")
            if progress:
                progress(len(found), len(tasks))
    ordered = [found[t.index] for t in tasks]
    secure = [k for k, c in enumerate(ordered) if c.b_slide_m is not None]
    chosen = min(secure, key=lambda k: (ordered[k].b_slide_m, -ordered[k].d)) if secure else None
    return StartChoice(scene.name, float(scene.start[1]), ordered, chosen)
