"""``bench``: planners on scenes, every run a task of worker processes, written as OMPL's benchmark logs,
the database, a summary and plots.

Outputs in the options' ``out`` directory: ``<scene>.log`` per scene in OMPL's benchmark log
format (its parser reads one experiment per file), ``benchmark.db`` made from the logs,
``summary.csv``, ``success_vs_time.png``, ``final_cost.png``, and ``runs.csv`` (every run's
row, streamed as runs finish, which ``resume`` reads back). Times in seconds, costs in
reference units.
"""

from __future__ import annotations

import os
import re
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from datetime import datetime
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import write_text_atomic
from ..parallel.runner import open_runner
from ..parallel.stream import RowStream
from ..planning.setup import LATTICE
from ..plots.common import legend_below, panels, save_png
from ..scene import Scene
from .database import logs_to_database
from .ompl_log import Experiment, cost_units
from .options import BenchmarkOptions
from .statistics import SUMMARY_COLUMNS, SummaryRow, limitation_notes, summarise
from .table import TABLE_WIDTH, format_table, write_csv
from .tasks import RUN_COLUMNS, RUN_KEY_COLUMNS, Progress, RunResult, Task, lattice_yardstick, run_tasks, task_key


@dataclass
class BenchmarkResult:
    """What a benchmark measured and wrote."""

    runs: list[RunResult]
    """Every planner run (lattice yardstick runs left out), in task order."""
    optima: dict[str, float | None]
    """Per scene key: the lattice optimum (reference units); None: no secure path."""
    summary: list[SummaryRow]
    """One row per scene and planner."""
    units: list[str]
    """The costs' units, one per distinct weighting of the scenes."""
    out: Path
    """The output directory."""
    files: dict[str, Path] = field(default_factory=dict)
    """The files written, by role (runs, log:<scene>, db, summary, success_plot, cost_plot)."""

    @property
    def table(self) -> str:
        """The summary as a text table, with what its columns mean and the planners' known limitations."""
        lines = [format_table(SUMMARY_COLUMNS, self.summary),
                 *textwrap.wrap("times in s over the solved runs: OMPL planners from the start of solve(); lattice: "
                                "building the lattice plus the exact search.", TABLE_WIDTH),
                 *textwrap.wrap(f"costs: {' or '.join(self.units)}; gap = median cost / lattice optimum - 1 (the "
                                "optimum on the planners' own lattice).", TABLE_WIDTH)]
        notes = limitation_notes(self.summary)
        if notes:
            lines.append("known limitations (why these planners solve nothing here):")
            lines += [line for n in notes for line in textwrap.wrap(n, TABLE_WIDTH, initial_indent="  ",
                                                                    subsequent_indent="    ")]
        return "\n".join(lines)


def scene_key(name: str, taken: set[str]) -> str:
    """A file-name-safe key for a scene, unique among taken (which it joins): its log's name."""
    base = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "scene"
    key, k = base, 2
    while key in taken:
        key, k = f"{base}_{k}", k + 1
    taken.add(key)
    return key


def run_benchmark(scene_paths: Sequence[str | os.PathLike[str]], options: BenchmarkOptions,
                  progress: Progress | None = None) -> BenchmarkResult:
    """Benchmark the options' planners on the scenes: ``runs`` runs each per scene and planner,
    each with OMPL seeded with run.seed + run index, run.jobs at a time here or
    on the Ray cluster at run.cluster. Each run's row is appended to ``runs.csv`` as it arrives;
    with ``resume`` the runs already there are kept, not run again.

    ``lattice`` among the planners is the exact search; the optimum it finds (reference cost
    units, and its path's smallest friction margin) is also the yardstick of the gap column,
    computed once per scene when ``lattice`` is not benchmarked. Every planner, the yardstick
    included, optimises the options' objective. Writes the files (see the module) and returns the result. Raises
    InputError naming the options field (``planners``, ``runs``, ...) or the scene, before
    anything runs.
    """
    options = options.validated()
    out = Path(options.out)
    if not scene_paths:
        raise InputError("scene", "no scene given")
    taken: set[str] = set()
    scenes = {}
    for p in scene_paths:
        scene = Scene.from_file(p)
        scenes[scene_key(scene.name, taken)] = scene
    names = list(options.planners)
    p, run = options.planner, options.run
    limit = float(p.time)
    tasks = [Task(key, scene, replace(p, planner=name, seed=run.seed + k), k)
             for key, scene in scenes.items() for name in names for k in range(options.runs)]
    if LATTICE not in names:
        yardstick = replace(p, planner=LATTICE, seed=run.seed, iterations=None)
        tasks += [Task(key, scene, yardstick, -1) for key, scene in scenes.items()]
    started = datetime.now()
    with open_runner(run.jobs, run.cluster, fresh=False) as runner, \
            RowStream(out / "runs.csv", RUN_COLUMNS, RUN_KEY_COLUMNS, resume=options.resume) as stream:
        results = run_tasks(tasks, runner, progress, stream)
    stream.finish([task_key(t) for t in tasks])

    experiments, margins, tolerances = [], {}, {}
    for key, scene in scenes.items():
        lattice = lattice_yardstick(results, key)
        margins[key] = lattice.min_margin_deg
        tolerances[key] = lattice.tolerance
        by_planner = {name: [r for r in results if r.group == key and r.planner == name and r.run >= 0]
                      for name in names}
        experiments.append(Experiment(key, scene, names, by_planner, lattice.cost, lattice.status, run.seed,
                                      limit, options.runs, started, run.jobs))
    files: dict[str, Path] = {"runs": stream.path}
    for exp in experiments:
        files[f"log:{exp.key}"] = out / f"{exp.key}.log"
        write_text_atomic(files[f"log:{exp.key}"], exp.log_text())
    files["db"] = out / "benchmark.db"
    logs_to_database([p for k, p in files.items() if k.startswith("log:")], files["db"])

    summary = [summarise(exp.key, name, exp.runs[name], exp.optimum, margins[exp.key], tolerances[exp.key])
               for exp in experiments for name in names]
    files["summary"] = out / "summary.csv"
    write_csv(files["summary"], SUMMARY_COLUMNS, summary)
    files["success_plot"] = out / "success_vs_time.png"
    plot_success_vs_time(experiments, files["success_plot"])
    files["cost_plot"] = out / "final_cost.png"
    plot_final_cost(experiments, files["cost_plot"])
    units = sorted({cost_units(scene) for scene in scenes.values()})
    optima = {exp.key: exp.optimum for exp in experiments}
    return BenchmarkResult([r for r in results if r.run >= 0], optima, summary, units, out, files)


def plot_success_vs_time(experiments: Sequence[Experiment], path: Path) -> None:
    """Write success_figure's picture to path (PNG)."""
    save_png(success_figure(experiments), path)


def success_figure(experiments: Sequence[Experiment]):
    """Per scene and planner: the fraction of runs whose first solution came by time t (s); one
    legend below the panels. Returns the matplotlib Figure."""
    fig, axes = panels(len(experiments))
    for ax, exp in zip(axes, experiments):
        times = [r.time_to_first_solution_s for runs in exp.runs.values() for r in runs if r.solved]
        t_max = max([exp.time_limit] + times) * 1.02
        t = np.linspace(0.0, t_max, 400)
        for planner in exp.planners:
            runs = exp.runs[planner]
            first = np.array([r.time_to_first_solution_s for r in runs if r.solved])
            frac = (first[None, :] <= t[:, None]).sum(axis=1) / len(runs)
            style = dict(color="black", linestyle="--", label="lattice (exact; builds the lattice too)") \
                if planner == LATTICE else dict(label=planner)
            ax.step(t, frac, where="post", **style)
        ax.axvline(exp.time_limit, color="grey", linestyle=":", label=f"time limit {exp.time_limit:g} s")
        ax.set(xlim=(0, t_max), ylim=(-0.02, 1.02), xlabel="time t (s)", ylabel="runs solved by time t (share of runs)",
               title=f"{exp.key}: first solution by time t")
    legend_below(fig, axes, ncol=4)
    return fig


def plot_final_cost(experiments: Sequence[Experiment], path: Path) -> None:
    """Write final_cost_figure's picture to path (PNG)."""
    save_png(final_cost_figure(experiments), path)


def final_cost_figure(experiments: Sequence[Experiment]):
    """Per scene: each planner's final costs (reference units) over its solved runs, a box and the
    runs themselves, with the lattice optimum as a line; one legend below the panels. Returns the
    matplotlib Figure."""
    fig, axes = panels(len(experiments))
    rng = np.random.default_rng(0)
    for ax, exp in zip(axes, experiments):
        labels = []
        for k, planner in enumerate(exp.planners):
            runs = exp.runs[planner]
            costs = np.array([r.cost for r in runs if r.solved])
            labels.append(f"{planner}\n{len(costs)}/{len(runs)} solved")
            if len(costs):
                box = ax.boxplot([costs], positions=[k], widths=0.5, showfliers=False)
                for line in (line for lines in box.values() for line in lines):
                    line.set_label("a planner's final costs: median, quartiles, range")
                ax.scatter(k + rng.uniform(-0.12, 0.12, len(costs)), costs, s=14, alpha=0.7, zorder=3,
                           color="tab:blue", label="one run's final cost")
        if exp.optimum is not None:
            ax.axhline(exp.optimum, color="black", linestyle="--", label=f"lattice optimum {exp.optimum:.2f}")
        ax.set_xticks(range(len(labels)), labels, fontsize=8)
        ax.set(xlim=(-0.6, len(labels) - 0.4), ylabel=f"final cost ({cost_units(exp.scene)})",
               title=f"{exp.key}: final cost after {exp.time_limit:g} s")
    legend_below(fig, axes, ncol=1)
    return fig
