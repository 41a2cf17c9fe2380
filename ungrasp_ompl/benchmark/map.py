"""``map``: a feasibility map over two parameters of a scene, digit asymmetry and friction.

Each cell of the grid (alpha, friction scale) is one task, run by worker processes (OMPL's
random numbers seeded afresh for each) on this machine or on a Ray cluster. A task carries its cell's
scene and its seeds (the planner's, the trials'), so its row does not depend on where it ran. Per cell:

* the exact lattice verdict: whether a secure primitive path exists at the scene's resolution
  (:func:`~ungrasp_ompl.planning.lattice.lattice_search`), with its optimum; or why the start
  or the goal rules one out;
* the planner's outcome and cost, seeded like ``plan --seed`` (a fixed iteration budget, so
  reproducible). Where the lattice proves that no secure path exists the planner is not run:
  it plans on the same lattice and could not succeed;
* with ``simulate`` trials, the simulated success rate of the planner's plan (MuJoCo, seeded
  perturbations), where the plan exists and the robot can execute it.

Rows stream to ``map.csv`` as cells finish (:class:`~ungrasp_ompl.parallel.stream.RowStream`), so an
interrupted map resumes where it stopped; at the end ``map.csv`` is rewritten in grid order
and ``map.png`` drawn. alpha is over the object length; the friction scale multiplies the
scene's friction coefficients at G, A and B; costs are in reference units.
"""

from __future__ import annotations

import copy
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..parallel.options import RunOptions, check_seed
from ..parallel.runner import TaskStatus, open_runner
from ..parallel.stream import RowStream
from ..planning.result import PlanOutcome
from ..planning.setup import (LATTICE, PlannerOptions, UngraspSetup, hang_deadline, lattice_plan,
                              scene_objective)
from ..plots.common import cell_edges, pyplot, save_png
from ..scene import Scene
from ..scene.loader import read_yaml
from ..scene.perturbation import preset
from ..sim.plan_trials import plan_trials
from .ompl_log import cost_units
from .options import check_jobs, check_out, check_time, validate_planners

#: Seconds a cell may take per simulated trial before it counts as hung.
SIM_TRIAL_GRACE_S = 120.0
#: The most cells a map may have.
MAX_CELLS = 1_000_000


@dataclass(frozen=True)
class MapOptions:
    """What ``map`` computes over its grid and how it runs."""

    alphas: tuple[float, ...] = ()
    """Digit asymmetry values (finger minus thumb length, over the object length): the grid's columns."""
    friction_scales: tuple[float, ...] = (1.0,)
    """Factors on every friction coefficient of the scene (dimensionless, > 0): the grid's rows."""
    start_theta_deg: float | None = None
    """The start pinch's theta (deg) in every cell; None: the scene's."""
    planner: PlannerOptions = PlannerOptions(time=0.5, seed=1)
    """The planner run in each cell (planning.setup.PlannerOptions): an OMPL geometric planner by name,
    or ``lattice``; its time per cell (s: a seeded run's iteration budget, as for ``plan --seed``) and
    its seed (OMPL's RNG, goal samples; an integer: every cell is reproducible; map.csv's planner_seed)."""
    simulate: int = 0
    """Simulated trials per cell with a plan (count); 0: none."""
    perturb: str = "paper"
    """The simulated trials' perturbation preset (see ``simulate --perturb``)."""
    run: RunOptions = RunOptions()
    """How the cells run: run.seed seeds the simulated trials' perturbations (map.csv's trial_seed;
    the planner's is planner.seed); run.jobs cells at a time on this
    machine (child processes; None: all cores; unused on a cluster); run.cluster a Ray cluster's
    address ("local" starts one here; None: child processes on this machine)."""
    resume: bool = False
    """Keep the cells already done in out/map.csv and run only the others."""
    out: str | os.PathLike[str] = "map"
    """Output directory for map.csv and map.png."""

    def validated(self) -> "MapOptions":
        """These options checked, run.jobs None as all cores; InputError naming the option otherwise."""
        p = self.planner
        (planner,) = validate_planners([p.planner], "planner")
        check_time(p.time)
        run = self.run
        check_jobs(run.workers)
        check_seed(p.seed)
        run = replace(run.validated(), jobs=run.workers)
        if planner != LATTICE:
            p = p.validated()
        if isinstance(self.simulate, bool) or not isinstance(self.simulate, int) or not 0 <= self.simulate <= 10000:
            raise InputError("simulate", f"must be a number of trials in [0, 10000], got {self.simulate!r}")
        if self.start_theta_deg is not None and not (math.isfinite(self.start_theta_deg)
                                                     and 0.0 <= self.start_theta_deg <= 90.0):
            raise InputError("start_theta_deg", f"must be an angle in [0, 90] deg, got {self.start_theta_deg!r}")
        if not self.alphas:
            raise InputError("alphas", "gives no value")
        if not self.friction_scales:
            raise InputError("friction_scales", "gives no value")
        for s in self.friction_scales:
            if not (math.isfinite(s) and s > 0):
                raise InputError("friction_scales", f"must be positive factors, got {s:g}")
        if len(self.alphas) * len(self.friction_scales) > MAX_CELLS:
            raise InputError("alphas", f"and --friction-scale give more than {MAX_CELLS} cells")
        check_out(self.out)
        if self.simulate:
            preset(self.perturb)  # InputError("perturb") for an unknown preset
        return replace(self, planner=p, run=run, alphas=tuple(map(float, self.alphas)),
                       friction_scales=tuple(map(float, self.friction_scales)))


def scene_variant(doc: dict, alpha: float, friction_scale: float, start_theta_deg: float | None,
                  source: str | None, name: str) -> Scene:
    """The scene of a YAML document with digits.alpha set, every friction coefficient times
    friction_scale (angles turned into coefficients) and the start's theta set (deg) if given.
    Raises InputError naming the option that makes the scene invalid."""
    base = copy.deepcopy(doc)
    if not isinstance(base, dict) or not isinstance(base.get("digits"), dict):
        return Scene.from_dict(base, source=source, default_name=name)  # the scene's own error
    base["digits"]["alpha"] = alpha
    base["digits"].pop("finger_length", None)
    if start_theta_deg is not None and isinstance(base.get("start"), dict):
        base["start"]["theta_deg"] = start_theta_deg
    try:
        Scene.from_dict(base, source=source, default_name=name)
    except InputError as exc:
        if exc.field.startswith("digits"):
            raise InputError("alphas", f"{alpha:g}: {exc.field}: {exc.reason}") from None
        if exc.field.startswith("start"):
            raise InputError("start_theta_deg", f"{start_theta_deg:g}: {exc.field}: {exc.reason}") from None
        raise
    friction = base.pop("friction", None)
    angles = base.pop("friction_angle_deg", None)
    if isinstance(angles, dict):
        friction = {c: v if c == "uncertainty" else math.tan(math.radians(float(v))) for c, v in angles.items()}
    # the coefficients scaled; how far they are known (a fraction of each) kept
    base["friction"] = {c: v if c == "uncertainty" else float(v) * friction_scale for c, v in (friction or {}).items()}
    try:
        return Scene.from_dict(base, source=source, default_name=name)
    except InputError as exc:
        raise InputError("friction_scales", f"{friction_scale:g}: {exc.field}: {exc.reason}") from None


@dataclass(frozen=True)
class MapTask:
    """One cell: its scene, planner and seeds; it needs nothing else, wherever it runs."""

    index: int
    """The cell's index in grid order (friction scale by friction scale, alpha by alpha)."""
    alpha: float
    """Digit asymmetry (over the object length)."""
    friction_scale: float
    """Factor on the scene's friction coefficients."""
    scene: Scene
    """The cell's scene."""
    planner: PlannerOptions
    """How the cell's planner runs: its name (or ``lattice``), time (s: the seeded iteration budget's
    size) and seed (OMPL's RNG; map.csv's planner_seed)."""
    trial_seed: int
    """The seed of the simulated trials' perturbations (the map's run.seed; map.csv's trial_seed)."""
    trials: int = 0
    """Simulated trials (count)."""
    perturb: str = "paper"
    """The trials' perturbation preset."""


@dataclass(frozen=True)
class MapCell:
    """What one cell found. Costs in reference units."""

    alpha: float
    """Digit asymmetry (over the object length)."""
    friction_scale: float
    """Factor on the scene's friction coefficients."""
    task_status: TaskStatus
    """How the cell's task ended (DONE, or FAILED, HUNG, DIED: then error says why)."""
    lattice_outcome: PlanOutcome | None = None
    """The exact search's verdict: SOLVED (a secure path exists), START_NOT_HELD, GOAL_EMPTY, NO_SECURE_PATH."""
    lattice_optimum: float | None = None
    """The cheapest secure path's cost on the lattice (reference units); None: none."""
    planner_outcome: PlanOutcome | None = None
    """The planner's outcome; None: not run (no secure path exists) or the task failed."""
    planner_cost: float | None = None
    """The planner's path cost (reference units); None: no path."""
    sim_successes: int | None = None
    """Successful simulated trials (count); None: not simulated (no plan, or the robot cannot execute it)."""
    executable: bool | None = None
    """Whether the robot could execute the cell's plan (None: not tried: no plan, or no trials asked)."""
    error: str = ""
    """Why the task failed, or why a plan was not simulated (the robot's reason); empty otherwise."""

    @property
    def secure_path(self) -> bool | None:
        """A secure path exists (None: unknown, the task failed)."""
        return None if self.lattice_outcome is None else self.lattice_optimum is not None

    @property
    def planner_solved(self) -> bool | None:
        """The planner found a re-validated path (None: unknown, the task failed)."""
        if self.task_status is not TaskStatus.DONE:
            return None
        return self.planner_outcome is PlanOutcome.SOLVED


#: map.csv's columns; the first two identify a cell. planner_seed: the planner's seed (OMPL's RNG);
#: trial_seed: the seed the cell's simulated trials drew their perturbations from (empty without trials).
MAP_COLUMNS = ("alpha", "friction_scale", "task_status", "secure_path", "lattice_outcome", "lattice_optimum",
               "planner", "planner_outcome", "planner_solved", "planner_cost", "sim_trials", "sim_successes",
               "sim_success_rate", "planner_seed", "trial_seed", "time_s", "executable", "error")
#: The columns of map.csv that hold a cell's options: a resumed map keeps a row only if they match.
OPTION_COLUMNS = ("planner", "sim_trials", "planner_seed", "trial_seed", "time_s")


def cell_key(alpha: float, friction_scale: float) -> tuple[str, str]:
    """A cell's key in map.csv: its alpha and friction scale as written."""
    return repr(float(alpha)), repr(float(friction_scale))


def task_options(task: MapTask) -> dict[str, str]:
    """A cell's options as map.csv writes them (OPTION_COLUMNS)."""
    return dict(planner=task.planner.planner, sim_trials=str(task.trials), planner_seed=str(task.planner.seed),
                trial_seed=str(task.trial_seed) if task.trials else "", time_s=repr(float(task.planner.time)))


def cell_row(cell: MapCell, task: MapTask) -> list[object]:
    """A cell's map.csv row (MAP_COLUMNS): booleans 0/1, None for missing."""

    def flag(b: bool | None) -> int | None:
        return None if b is None else int(b)

    rate = None if cell.sim_successes is None or not task.trials else cell.sim_successes / task.trials
    alpha, friction_scale = cell_key(cell.alpha, cell.friction_scale)
    named = task_options(task) | dict(
        alpha=alpha, friction_scale=friction_scale, task_status=cell.task_status.value,
        secure_path=flag(cell.secure_path),
        lattice_outcome=cell.lattice_outcome.value if cell.lattice_outcome else None,
        lattice_optimum=cell.lattice_optimum,
        planner_outcome=cell.planner_outcome.value if cell.planner_outcome else None,
        planner_solved=flag(cell.planner_solved), planner_cost=cell.planner_cost,
        sim_successes=cell.sim_successes, sim_success_rate=rate, executable=flag(cell.executable),
        error=cell.error.replace("\n", " "))
    return [named[c] for c in MAP_COLUMNS]


def cell_from_row(row: dict[str, str]) -> MapCell:
    """A MapCell from a map.csv row (as csv.DictReader gives it)."""

    def number(key: str) -> float | None:
        return float(row[key]) if row[key] else None

    return MapCell(alpha=float(row["alpha"]), friction_scale=float(row["friction_scale"]),
                   task_status=TaskStatus(row["task_status"]),
                   lattice_outcome=PlanOutcome(row["lattice_outcome"]) if row["lattice_outcome"] else None,
                   lattice_optimum=number("lattice_optimum"),
                   planner_outcome=PlanOutcome(row["planner_outcome"]) if row["planner_outcome"] else None,
                   planner_cost=number("planner_cost"),
                   sim_successes=int(row["sim_successes"]) if row["sim_successes"] else None,
                   executable=bool(int(row["executable"])) if row["executable"] else None, error=row["error"])


def run_cell(task: MapTask) -> MapCell:
    """Compute one cell (UngraspSetup seeds OMPL's random numbers with the task's seed)."""
    scene = task.scene
    done = dict(alpha=task.alpha, friction_scale=task.friction_scale, task_status=TaskStatus.DONE)
    if task.planner.planner == LATTICE:
        plan = lattice_plan(scene, task.planner.seed, objective=scene_objective(task.planner.objective, scene, LATTICE))
        exists = plan.lattice_optimum is not None
        verdict = PlanOutcome.SOLVED if exists else plan.outcome
        cell = MapCell(**done, lattice_outcome=verdict, lattice_optimum=plan.lattice_optimum,
                       planner_outcome=plan.outcome, planner_cost=plan.cost)
    else:
        setup = UngraspSetup(scene, task.planner)
        problem = setup.ends_problem()
        if problem:
            return MapCell(**done, lattice_outcome=problem.outcome)
        optimum = setup.lattice_optimum  # the exact search, the planner's yardstick
        if optimum is None:
            return MapCell(**done, lattice_outcome=PlanOutcome.NO_SECURE_PATH)
        plan = setup.solve()
        cell = MapCell(**done, lattice_outcome=PlanOutcome.SOLVED, lattice_optimum=optimum,
                       planner_outcome=plan.outcome, planner_cost=plan.cost)
    if task.trials and plan.solved:
        cell = _simulated(cell, task, plan)
    return cell


def _simulated(cell: MapCell, task: MapTask, plan) -> MapCell:
    """The cell with the simulated trials of its plan counted (or why the robot cannot execute it)."""
    run = plan_trials(task.scene, plan, task.trials, task.perturb, task.trial_seed)
    if not run.executable:
        return replace(cell, executable=False, error=f"not executable: {run.unexecutable}")
    return replace(cell, executable=True, sim_successes=run.successes)


@dataclass(frozen=True)
class MapProgress:
    """How far a map has got, for a progress line."""

    done: int
    """Cells done, those of an earlier run included (count)."""
    total: int
    """Cells in the grid (count)."""
    resumed: int
    """Cells taken from an earlier run's map.csv (count)."""
    failed: int
    """Cells whose task failed, hung or died (count)."""
    last: MapCell | None
    """The cell that just finished (None before the first)."""


@dataclass
class MapResult:
    """The map: its cells in grid order and the files written."""

    scene: str
    """The scene's name."""
    reference: tuple[float, float]
    """The scene's own (alpha, friction scale 1)."""
    options: MapOptions
    """What the map ran with (validated)."""
    cells: list[MapCell]
    """Every cell, friction scale by friction scale, alpha by alpha."""
    ran: int
    """Cells computed by this run (count); the others came from an earlier run (--resume)."""
    units: str
    """The costs' units."""
    files: dict[str, Path] = field(default_factory=dict)
    """The files written, by role (csv, plot)."""

    @property
    def failed(self) -> list[MapCell]:
        """The cells whose task failed, hung or died."""
        return [c for c in self.cells if c.task_status is not TaskStatus.DONE]

    @property
    def simulated(self) -> tuple[int, int, int]:
        """Over the cells: (simulated trials that placed the object, simulated trials, cells whose
        plan the robot cannot execute) (counts)."""
        sims = [c.sim_successes for c in self.cells if c.sim_successes is not None]
        return sum(sims), len(sims) * self.options.simulate, sum(c.executable is False for c in self.cells)

    def summary(self) -> str:
        """What the map found, in a few lines: cells computed and kept, where a secure path exists
        and the planner solved, the cells that failed."""
        o, cells = self.options, self.cells
        exists = sum(bool(c.secure_path) for c in cells)
        solved = sum(bool(c.planner_solved) for c in cells)
        lines = [f"{self.scene}: {len(o.alphas)} x {len(o.friction_scales)} cells (alpha x friction scale), "
                 f"{self.ran} computed now, {len(cells) - self.ran} kept from {self.files['csv']}",
                 f"  a secure path exists in {exists}; {o.planner.planner} ({o.planner.time:g} s, "
                 f"seed {o.planner.seed}) solved {solved}"
                 + (f"; simulated {o.simulate} trials per solved cell ({o.perturb}, seed {o.run.seed}): "
                    f"{self.simulated[0]}/{self.simulated[1]} placed, {self.simulated[2]} cells not executable"
                    if o.simulate else "")]
        if self.failed:
            first = self.failed[0]
            lines.append(f"  {len(self.failed)} cells failed (task_status in map.csv), e.g. alpha {first.alpha:g}, "
                         f"friction x{first.friction_scale:g}: {first.error}; --resume runs them again")
        return "\n".join(lines)


def run_map(scene_path: str | os.PathLike[str], options: MapOptions,
            progress: Callable[[MapProgress], None] | None = None) -> MapResult:
    """Compute every cell of the grid (see the module), streaming rows to out/map.csv; then
    rewrite map.csv in grid order and draw map.png. Raises InputError naming the option or the
    scene before anything runs or is written."""

    options = options.validated()
    source = str(scene_path)
    doc = read_yaml(scene_path, "scene")
    base = Scene.from_dict(doc, source=source, default_name=Path(source).stem)
    if options.simulate and base.object_thickness <= 0.0:
        raise InputError("simulate", "the simulator needs a scene with an object thickness (m)")
    grid = [(a, f) for f in options.friction_scales for a in options.alphas]
    tasks = [MapTask(i, a, f, scene_variant(doc, a, f, options.start_theta_deg, source, base.name), options.planner,
                     options.run.seed, options.simulate, options.perturb) for i, (a, f) in enumerate(grid)]
    out = Path(options.out)
    stream = RowStream(out / "map.csv", MAP_COLUMNS, key_columns=2, resume=options.resume)
    by_key = {cell_key(t.alpha, t.friction_scale): t for t in tasks}
    kept = {k: row for k, row in stream.rows.items()
            if k in by_key and dict(zip(MAP_COLUMNS, row))["task_status"] == TaskStatus.DONE.value}
    for key, row in kept.items():
        named = dict(zip(MAP_COLUMNS, row))
        if {c: named[c] for c in OPTION_COLUMNS} != task_options(by_key[key]):
            raise InputError("resume", f"{stream.path} was made with other options (planner, --time, --seed or "
                             "--simulate); use another --out or leave out --resume")
    stream.rows = dict(kept)
    resumed = len(kept)
    todo = [t for t in tasks if cell_key(t.alpha, t.friction_scale) not in kept]
    cells: dict[int, MapCell] = {}
    failed = 0
    deadline = hang_deadline(options.planner.time, budgeted=True) + SIM_TRIAL_GRACE_S * options.simulate
    with open_runner(options.run.jobs, options.run.cluster, fresh=False) as runner, stream:
        if progress:
            progress(MapProgress(resumed, len(tasks), resumed, 0, None))
        for outcome in runner.run(run_cell, todo, deadline):
            task = todo[outcome.index]
            cell = outcome.value if outcome.status is TaskStatus.DONE else MapCell(
                task.alpha, task.friction_scale, outcome.status, error=_why(outcome))
            failed += cell.task_status is not TaskStatus.DONE
            cells[task.index] = cell
            stream.append(cell_row(cell, task))
            if progress:
                progress(MapProgress(resumed + len(cells), len(tasks), resumed, failed, cell))
    stream.finish([cell_key(t.alpha, t.friction_scale) for t in tasks])
    ordered = [cells.get(t.index) or cell_from_row(dict(zip(MAP_COLUMNS, kept[cell_key(t.alpha, t.friction_scale)])))
               for t in tasks]
    result = MapResult(base.name, (base.digits.alpha, 1.0), options, ordered, len(cells), cost_units(base))
    result.files["csv"] = stream.path
    result.files["plot"] = out / "map.png"
    plot_map(result, result.files["plot"])
    return result


def _why(outcome) -> str:
    """One line on a task that did not finish."""
    if outcome.status is TaskStatus.HUNG:
        return f"killed after {outcome.wall_time_s:.0f} s without an answer"
    if outcome.error is None:
        return "its process ended without an answer"
    return f"{type(outcome.error).__name__}: {str(outcome.error).splitlines()[0] if str(outcome.error) else ''}"


def plot_map(result: MapResult, path: Path) -> None:
    """Write map_figure's picture to path (PNG)."""
    save_png(map_figure(result), path)


#: map_reasons' key for a cell whose plan the robot cannot execute (so it was not simulated).
NOT_EXECUTABLE = "not executable"


def map_reasons() -> dict:
    """Why a cell of the map shows no value, each with its label and marker: the cell's task
    (TaskStatus), the exact lattice's verdict or the planner's outcome (PlanOutcome), or the
    robot (the plan is not executable)."""
    return {TaskStatus.FAILED: ("task raised an error", "X"), TaskStatus.HUNG: ("task hung (killed)", "H"),
            TaskStatus.DIED: ("task's process died", "P"),
            PlanOutcome.START_NOT_HELD: ("start not held", "v"), PlanOutcome.GOAL_EMPTY: ("goal region empty", "s"),
            PlanOutcome.NO_SECURE_PATH: ("no secure path on the lattice", "d"),
            PlanOutcome.NOT_FOUND: ("planner found none in its budget", "o"),
            PlanOutcome.INVALID_PATH: ("planner's path failed re-validation", ">"),
            PlanOutcome.HUNG: ("planner hung (killed)", "<"),
            NOT_EXECUTABLE: ("robot cannot execute the plan", "^")}


def map_reason(cell, panel: int):
    """Why the cell has no value in a panel of the map (0: the lattice's optimum, 1: the planner's
    cost, 2: the simulated success rate), as a key of the map's reasons; None: it has one."""
    if cell.task_status is not TaskStatus.DONE:
        return cell.task_status
    if cell.lattice_outcome is not PlanOutcome.SOLVED:
        return cell.lattice_outcome
    if panel >= 1 and cell.planner_outcome is not PlanOutcome.SOLVED:
        return cell.planner_outcome
    if panel == 2 and cell.executable is False:
        return NOT_EXECUTABLE
    return None


def map_figure(result: MapResult):
    """Heat maps over (alpha, friction scale): the lattice optimum where a secure path exists, the
    planner's cost where it found one, and with simulation the simulated success rate. Grey: no
    secure path; red: a path exists but the planner found none; black: the cell's task failed;
    on each cell without a value a marker says why (map_reason). A star marks the scene's own
    (alpha, friction scale 1). Returns the matplotlib Figure."""
    from matplotlib.collections import QuadMesh  # matplotlib: loaded when a picture is drawn
    from matplotlib.colors import ListedColormap  # matplotlib, as above

    plt = pyplot()
    o = result.options
    alphas, scales = list(o.alphas), list(o.friction_scales)
    shape = (len(scales), len(alphas))
    cells = np.array(result.cells, dtype=object).reshape(shape)

    def grid(value) -> np.ndarray:
        return np.array([[np.nan if value(c) is None else value(c) for c in row] for row in cells], dtype=float)

    failed = grid(lambda c: 1.0 if c.task_status is not TaskStatus.DONE else None)
    blocked = grid(lambda c: 1.0 if c.secure_path is False else None)
    missed = grid(lambda c: 1.0 if c.secure_path and c.planner_outcome is not PlanOutcome.SOLVED else None)
    optimum = grid(lambda c: c.lattice_optimum)
    cost = grid(lambda c: c.planner_cost if c.planner_outcome is PlanOutcome.SOLVED else None)
    panels = [("exact lattice: optimum where a secure path exists", optimum, "viridis", f"cost ({result.units})"),
              (f"{o.planner.planner} ({o.planner.time:g} s, seed {o.planner.seed}): cost where solved", cost, "viridis",
               f"cost ({result.units})")]
    if o.simulate:
        rate = grid(lambda c: None if c.sim_successes is None else c.sim_successes / o.simulate)
        panels.append((f"simulated success rate ({o.simulate} trials, {o.perturb})", rate, "RdYlGn",
                       "success rate (share of trials placed)"))
    x, y = cell_edges(alphas), cell_edges(scales)
    fig, axes = plt.subplots(1, len(panels), figsize=(5.6 * len(panels), 5.0), squeeze=False,
                             constrained_layout=True)
    finite = np.concatenate([optimum[np.isfinite(optimum)], cost[np.isfinite(cost)]])
    vmin, vmax = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    fills = [(blocked, "0.8", "grey: the lattice rules out a secure path"), (missed, "#d62728", "red: a path exists, the planner found none"),
             (failed, "black", "black: the cell's task failed")]
    reasons = map_reasons()
    for k, (ax, (title, values, cmap, label)) in enumerate(zip(axes[0], panels)):
        for mask, colour, name in fills:
            if (k == 1 or mask is not missed) and np.isfinite(mask).any():
                ax.pcolormesh(x, y, mask, cmap=ListedColormap([colour]), vmin=0, vmax=1, label=name)
        bounds = dict(vmin=0.0, vmax=1.0) if cmap == "RdYlGn" else dict(vmin=vmin, vmax=vmax)
        mesh = ax.pcolormesh(x, y, np.ma.masked_invalid(values), cmap=cmap, **bounds)
        fig.colorbar(mesh, ax=ax, label=label)
        why = {}
        for cell in result.cells:
            reason = map_reason(cell, k)
            if reason is not None:
                why.setdefault(reason, []).append((cell.alpha, cell.friction_scale))
        for reason, at in why.items():
            name, marker = reasons[reason]
            ax.scatter(*np.array(at).T, marker=marker, s=46, facecolor="white", edgecolor="black",
                       linewidth=0.9, zorder=4, label=name)
        ref_alpha, ref_scale = result.reference
        ax.plot([ref_alpha], [ref_scale], marker="*", markersize=22, markerfacecolor="none", markeredgecolor="black",
                linestyle="none", label=f"the scene (alpha {ref_alpha:g}, friction x1)")
        ax.set(xlim=(x[0], x[-1]), ylim=(y[0], y[-1]), xlabel="alpha: finger - thumb length (fraction of l)",
               ylabel="friction scale (x the scene's coefficients)", title=title)
        ax.title.set_fontsize(9)
    marks: dict = {}
    for artist in [a for ax in axes[0] for a in ax.collections] + [a for ax in axes[0] for a in ax.lines]:
        if not isinstance(artist, QuadMesh) and not artist.get_label().startswith("_"):  # meshes: proxies below
            marks.setdefault(artist.get_label(), artist)
    drawn = {a.get_label() for ax in axes[0] for a in ax.collections if isinstance(a, QuadMesh)}
    handles = [plt.Rectangle((0, 0), 1, 1, color=colour, label=name) for _, colour, name in fills if name in drawn]
    handles += marks.values()
    fig.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=8)
    fig.suptitle(f"{result.scene}: feasibility over digit asymmetry and friction")
    return fig
