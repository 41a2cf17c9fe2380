"""The benchmark's and the sweep's pictures (PNG, written atomically): success against time, and
success and cost against alpha; the map's and the design search's heat maps. Each drawing
function returns a matplotlib Figure; plot_* writes it."""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..io import write_atomic
from ..planning.setup import LATTICE
from .ompl_log import Experiment, cost_units

if TYPE_CHECKING:
    from .design import DesignResult
    from .map import MapResult
    from .sweep import SweepResult


def pyplot():
    """matplotlib.pyplot on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_png(fig, path: Path) -> None:
    """Write the figure to path atomically and close it."""
    write_atomic(path, lambda tmp: fig.savefig(tmp, format="png", dpi=110))
    pyplot().close(fig)


def _panels(n: int, width: float = 6.0, height: float = 4.0):
    """A figure of n panels in a grid of ceil(sqrt(n)) columns (unused cells left blank), laid out
    with room for a legend below; returns it and the n axes."""
    plt = pyplot()
    cols = max(1, math.ceil(math.sqrt(n)))
    rows = max(1, math.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(width * cols, height * rows + 0.8), squeeze=False,
                             layout="constrained")
    for ax in axes.flat[n:]:
        ax.set_axis_off()
    return fig, list(axes.flat[:n])


def _legend_below(fig, axes, ncol: int = 3) -> None:
    """One legend under the panels, outside the data, naming each label of the axes' marks once."""
    from ..plotting import legend_marks

    marks = legend_marks(*axes)
    if marks:
        fig.legend(marks.values(), marks.keys(), loc="outside lower center", ncol=ncol, fontsize=8)


def plot_success_vs_time(experiments: Sequence[Experiment], path: Path) -> None:
    """Write success_figure's picture to path (PNG)."""
    save_png(success_figure(experiments), path)


def success_figure(experiments: Sequence[Experiment]):
    """Per scene and planner: the fraction of runs whose first solution came by time t (s); one
    legend below the panels. Returns the matplotlib Figure."""
    fig, axes = _panels(len(experiments))
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
    _legend_below(fig, axes, ncol=4)
    return fig


def plot_final_cost(experiments: Sequence[Experiment], path: Path) -> None:
    """Write final_cost_figure's picture to path (PNG)."""
    save_png(final_cost_figure(experiments), path)


def final_cost_figure(experiments: Sequence[Experiment]):
    """Per scene: each planner's final costs (reference units) over its solved runs, a box and the
    runs themselves, with the lattice optimum as a line; one legend below the panels. Returns the
    matplotlib Figure."""
    fig, axes = _panels(len(experiments))
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
    _legend_below(fig, axes, ncol=1)
    return fig


def plot_sweep(result: "SweepResult", time_limit: float, path: Path) -> None:
    """Write sweep_figure's picture to path (PNG)."""
    save_png(sweep_figure(result, time_limit), path)


def sweep_figure(result: "SweepResult", time_limit: float):
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
    _legend_below(fig, [top, bottom], ncol=2)
    return fig


def _edges(values: Sequence[float]) -> np.ndarray:
    """Cell edges around grid values (midpoints; a single value gets a unit-wide cell)."""
    v = np.asarray(values, dtype=float)
    if len(v) == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5]) if v[0] == 0 else np.array([v[0] * 0.9, v[0] * 1.1])
    mid = (v[1:] + v[:-1]) / 2
    return np.concatenate([[v[0] - (mid[0] - v[0])], mid, [v[-1] + (v[-1] - mid[-1])]])


def plot_map(result: "MapResult", path: Path) -> None:
    """Write map_figure's picture to path (PNG)."""
    save_png(map_figure(result), path)


#: map_reasons' key for a cell whose plan the robot cannot execute (so it was not simulated).
NOT_EXECUTABLE = "not executable"


def map_reasons() -> dict:
    """Why a cell of the map shows no value, each with its label and marker: the cell's task
    (TaskStatus), the exact lattice's verdict or the planner's outcome (PlanOutcome), or the
    robot (the plan is not executable)."""
    from ..planning.result import PlanOutcome
    from ..runner import TaskStatus

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
    from ..planning.result import PlanOutcome
    from ..runner import TaskStatus

    if cell.task_status is not TaskStatus.DONE:
        return cell.task_status
    if cell.lattice_outcome is not PlanOutcome.SOLVED:
        return cell.lattice_outcome
    if panel >= 1 and cell.planner_outcome is not PlanOutcome.SOLVED:
        return cell.planner_outcome
    if panel == 2 and cell.executable is False:
        return NOT_EXECUTABLE
    return None


def map_figure(result: "MapResult"):
    """Heat maps over (alpha, friction scale): the lattice optimum where a secure path exists, the
    planner's cost where it found one, and with simulation the simulated success rate. Grey: no
    secure path; red: a path exists but the planner found none; black: the cell's task failed;
    on each cell without a value a marker says why (map_reason). A star marks the scene's own
    (alpha, friction scale 1). Returns the matplotlib Figure."""
    from matplotlib.collections import QuadMesh
    from matplotlib.colors import ListedColormap

    from ..planning.result import PlanOutcome
    from ..runner import TaskStatus

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
              (f"{o.planner} ({o.time:g} s, seed {o.seed}): cost where solved", cost, "viridis",
               f"cost ({result.units})")]
    if o.simulate:
        rate = grid(lambda c: None if c.sim_successes is None else c.sim_successes / o.simulate)
        panels.append((f"simulated success rate ({o.simulate} trials, {o.perturb})", rate, "RdYlGn",
                       "success rate (share of trials placed)"))
    x, y = _edges(alphas), _edges(scales)
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


__all__ = ["final_cost_figure", "map_figure", "map_reason", "map_reasons", "plot_final_cost", "plot_map", "plot_success_vs_time", "plot_sweep", "pyplot",
           "save_png", "success_figure", "sweep_figure"]


def plot_design(result: "DesignResult", path: Path) -> None:
    """Write design_figure's picture to path (PNG)."""
    save_png(design_figure(result), path)


def design_figure(result: "DesignResult"):
    """A heat map over the designs (alpha across, the tip's radius up): the plan's tolerance, or
    with trials the simulated success rate; on each design without a plan a marker says why; a
    star marks the chosen design and a circle the scene's own digits. Returns the Figure."""
    from ..planning.result import PlanOutcome

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

    def edges(v: list[float]) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        if len(v) == 1:
            return np.array([v[0] - 0.5, v[0] + 0.5]) if v[0] == 0 else np.array([v[0] * 0.9, v[0] * 1.1])
        mid = (v[1:] + v[:-1]) / 2
        return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])

    mesh = ax.pcolormesh(edges(alphas), edges(radii), np.ma.masked_invalid(value), cmap="viridis", shading="flat")
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
