"""``sweep``: one planner's success and cost against the digit asymmetry alpha, with the exact
lattice search's verdict on whether a secure path exists at each alpha.

Outputs in the options' ``out`` directory: ``sweep.csv`` and ``sweep.png``. Costs in
reference units; alpha over the object length.
"""

from __future__ import annotations

import os
import textwrap
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..errors import InputError
from ..parallel.runner import open_runner
from ..parallel.stream import RowStream
from ..planning.setup import LATTICE
from ..plots.common import legend_below, pyplot, save_png
from ..scene import Scene
from .ompl_log import cost_units
from .options import SweepOptions
from .statistics import median
from .table import Column, format_table, write_csv
from .tasks import RUN_COLUMNS, RUN_KEY_COLUMNS, Progress, RunResult, Task, lattice_yardstick, run_tasks, task_key


@dataclass(frozen=True)
class SweepPoint:
    """One alpha: the planner's runs and the lattice search's run (costs in reference units)."""

    alpha: float
    """Digit asymmetry (over the object length)."""
    runs: list[RunResult]
    """The planner's runs at this alpha."""
    lattice: RunResult
    """The exact lattice search at this alpha."""

    @property
    def success_rate(self) -> float:
        """Share of the planner's runs with a re-validated path (0-1)."""
        return sum(r.solved for r in self.runs) / len(self.runs)

    @property
    def median_cost(self) -> float | None:
        """Median cost of the solved runs (reference units)."""
        return median([r.cost for r in self.runs if r.solved])

    @property
    def lattice_optimum(self) -> float | None:
        """The exact optimum on the lattice (reference units); None: no secure path."""
        return self.lattice.cost

    @property
    def lattice_reachable(self) -> bool:
        """A secure path exists on the lattice."""
        return self.lattice.cost is not None


#: The sweep's columns, in the printed table and sweep.csv.
SWEEP_COLUMNS = (
    Column("alpha", "alpha", lambda p: p.alpha, "g"),
    Column("success", "success_rate", lambda p: p.success_rate, ".0%"),
    Column("median cost", "median_cost", lambda p: p.median_cost, ".2f"),
    Column("lattice optimum", "lattice_optimum", lambda p: p.lattice_optimum, ".2f"),
    Column("secure path exists", "lattice_reachable", lambda p: p.lattice_reachable),
)


@dataclass
class SweepResult:
    """The sweep over alpha: one point per alpha and the files written."""

    scene: str
    """The scene's name."""
    planner: str
    """The planner swept."""
    points: list[SweepPoint]
    """One point per alpha, in the order given."""
    units: str
    """The costs' units."""
    options: SweepOptions
    """What the sweep ran with (validated)."""
    files: dict[str, Path] = field(default_factory=dict)
    """The files written, by role (runs, csv, plot)."""

    @property
    def table(self) -> str:
        """The points as a text table."""
        return format_table(SWEEP_COLUMNS, self.points)

    def summary(self) -> str:
        """What was swept, and the table."""
        o = self.options
        return (f"{self.scene}: {o.planner.planner}, {o.runs} run(s) of {o.planner.time:g} s per alpha; costs in "
                f"{self.units}\n"
                + self.table)


def run_sweep(scene_path: str | os.PathLike[str], options: SweepOptions, progress: Progress | None = None
              ) -> SweepResult:
    """For each alpha of the options: ``runs`` runs of the planner (OMPL seeded
    with run.seed + run index; here or on the Ray cluster at run.cluster) and the exact lattice search
    once. Streams every run to ``runs.csv`` (``resume`` keeps those already there); writes
    ``sweep.csv`` and ``sweep.png`` and returns the result. Raises InputError naming the option or the scene."""
    options = options.validated()
    out = Path(options.out)
    base = Scene.from_file(scene_path)
    scenes = [_with_alpha(base, a) for a in options.alphas]
    p, run = options.planner, options.run
    limit = float(p.time)
    groups = [repr(a) for a in options.alphas]
    yardstick = replace(p, planner=LATTICE, seed=run.seed, iterations=None)
    tasks = [Task(g, scene, yardstick, -1) for g, scene in zip(groups, scenes)]
    tasks += [Task(g, scene, replace(p, seed=run.seed + k), k) for g, scene in zip(groups, scenes)
              for k in range(options.runs)]
    with open_runner(run.jobs, run.cluster, fresh=False) as runner, \
            RowStream(out / "runs.csv", RUN_COLUMNS, RUN_KEY_COLUMNS, resume=options.resume) as stream:
        results = run_tasks(tasks, runner, progress, stream)
    stream.finish([task_key(t) for t in tasks])
    points = [SweepPoint(a, [r for r in results if r.group == g and r.run >= 0], lattice_yardstick(results, g))
              for g, a in zip(groups, options.alphas)]
    result = SweepResult(base.name, p.planner, points, cost_units(base), options)
    result.files["runs"] = stream.path
    result.files["csv"] = out / "sweep.csv"
    write_csv(result.files["csv"], SWEEP_COLUMNS, points)
    result.files["plot"] = out / "sweep.png"
    plot_sweep(result, limit, result.files["plot"])
    return result


def _with_alpha(scene: Scene, alpha: float) -> Scene:
    """The scene with digits.alpha replaced (Scene.with_digits); InputError("alphas") if invalid."""
    try:
        return scene.with_digits(alpha=alpha)
    except InputError as exc:
        raise InputError("alphas", f"{alpha:g}: {exc.reason}") from None


def plot_sweep(result: SweepResult, time_limit: float, path: Path) -> None:
    """Write sweep_figure's picture to path (PNG)."""
    save_png(sweep_figure(result, time_limit), path)


def sweep_figure(result: SweepResult, time_limit: float):
    """Success rate and cost (reference units) against alpha, the y-axes' names wrapped to their
    panels' height and one legend below. Returns the matplotlib Figure."""
    plt = pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(6.5, 7.0), sharex=True, layout="constrained")
    alphas = [p.alpha for p in result.points]
    nan = float("nan")
    top.plot(alphas, [p.success_rate for p in result.points], "o-", label=f"{result.planner} success rate")
    top.set(ylim=(-0.05, 1.05), title=f"{result.scene}: sweep over alpha")
    top.set_ylabel(textwrap.fill(f"success rate (share of runs of {time_limit:g} s)", 28))
    bottom.plot(alphas, [nan if p.median_cost is None else p.median_cost for p in result.points], "o-",
                label=f"{result.planner} median cost")
    bottom.plot(alphas, [nan if p.lattice_optimum is None else p.lattice_optimum for p in result.points], "k--x",
                label="lattice optimum")
    blocked = [p.alpha for p in result.points if not p.lattice_reachable]
    for a in blocked:
        bottom.axvline(a, color="0.8", linewidth=3, zorder=0, label="no secure path")
    bottom.set_xlabel("alpha: finger - thumb length (fraction of l)")
    bottom.set_ylabel(textwrap.fill(f"cost ({result.units})", 28))
    legend_below(fig, [top, bottom], ncol=2)
    return fig
