"""Pictures a reader understands: every mark drawn is named by a legend (or shown on a colour
bar), axes are named in words with units, and the stability print names each roll direction.
Read from the matplotlib Figures the drawing functions build (no pixels)."""

from __future__ import annotations

import math
import re

import matplotlib.pyplot as plt
import numpy as np
import pytest
from figure_marks import all_texts, axis_names, drawn_extents, legend_texts, overlap, unexplained_marks

from conftest import SCENES, pick_before_0107
from ungrasp_ompl import Scene, plan
from ungrasp_ompl.plots.cspace import REGION_CLASSES, plan_figure, regions_figure
from ungrasp_ompl.plots.trials import TRIAL_PARAM_LABELS, trials_figure

#: An axis name in words (no snake_case) ending in its unit in parentheses.
_NAMED = re.compile(r"^(?!.*[a-z]_[a-z])[A-Za-z].* \(([^()]*\b(deg|mm|m|s|mJ|N)\b[^()]*|fraction of l\b[^()]*|"
                    r"x the scene's[^()]*|reference units|share of [^()]+|index)\)$")


def assert_named_axes(fig) -> None:
    names = axis_names(fig)
    assert names
    for name in names:
        assert _NAMED.match(name.replace("\n", " ")), name


@pytest.fixture(scope="module")
def asymmetric():
    scene = Scene.from_file(SCENES / "reference_asymmetric.yaml")
    return scene, plan(scene, planner="lattice", seed=1)


def test_cspace_legend_names_every_mark(asymmetric):
    scene, result = asymmetric
    assert result.solved
    fig = plan_figure(scene, result, max_points=500)
    try:
        assert unexplained_marks(fig) == []
        texts = legend_texts(fig)
        assert len(texts) == len(set(texts))
        kinds = {p.type for p in result.primitives}
        assert len(kinds) >= 2
        assert kinds <= set(texts)
        assert {"start", "end", "goal region (box)"} <= set(texts)
        dots = [t for t in texts if t.startswith("free, force-closed lattice state")]
        assert dots == [f"free, force-closed lattice state (500 of {int(result.holdable_map.holdable.sum())} drawn)"]
        assert_named_axes(fig)
        assert any("theta: object-table angle" in n for n in axis_names(fig))
    finally:
        plt.close(fig)


def test_regions_legend_has_each_class_colour():
    scene = Scene.from_file(SCENES / "reference_asymmetric.yaml")
    fig = regions_figure(scene, d_values=2, step_deg=5.0)
    try:
        (legend,) = fig.legends
        assert [t.get_text() for t in legend.get_texts()][:len(REGION_CLASSES)] == list(REGION_CLASSES)
        assert unexplained_marks(fig) == []
        images = [im for ax in fig.axes for im in ax.images]
        assert len(images) == 2
        for im in images:
            drawn = np.unique(np.asarray(im.get_array()))
            assert set(drawn.tolist()) <= set(range(len(REGION_CLASSES)))  # scene.StateClass values
            for cls in drawn:
                colour = im.cmap(im.norm(cls))
                handle = legend.legend_handles[int(cls)]
                np.testing.assert_allclose(handle.get_facecolor(), colour)
        assert_named_axes(fig)
    finally:
        plt.close(fig)


@pytest.fixture(scope="module")
def pick():
    """The pick from its start before decision 0107 and its lattice plan of seed 1, whose P_dpsi
    moves d: a path that holds several values of d, each drawn solid on its own slice."""
    scene = Scene.from_dict(pick_before_0107())
    return scene, plan(scene, planner="lattice", seed=1)


def _passes_through(line, points: np.ndarray) -> bool:
    """The line's drawn (finite) points include every one of points (N, 2)."""
    xy = np.column_stack([np.asarray(v, dtype=float) for v in line.get_data()])
    xy = xy[np.isfinite(xy).all(axis=1)]
    return len(xy) > 0 and all(np.min(np.hypot(*(xy - p).T)) < 1e-6 for p in points)


@pytest.mark.parametrize("with_plan", [True, False])
def test_regions_slices_carry_information_and_show_start_goal_and_path(pick, with_plan):
    """guitar_pick's C-space is one class (kinematically invalid) at d >= 0.85 l: no such slice
    is drawn. Every slice shows the start, the goal's theta-psi box and (given a plan) the whole
    path, all within its limits; and the path is drawn solid on a slice at each d it holds."""
    scene, result = pick
    assert result.solved
    fig = regions_figure(scene, step_deg=3.0, plan=result if with_plan else None)
    try:
        slices = [ax for ax in fig.axes if ax.images]
        assert 2 <= len(slices) <= 6
        to_deg = np.array([math.degrees(1), math.degrees(1)])
        start = scene.start[[0, 2]] * to_deg
        glo, ghi = scene.goal.box()
        corner, size = glo[[0, 2]] * to_deg, (ghi - glo)[[0, 2]] * to_deg
        ways = [result.primitives[0].start] + [w for p in result.primitives for w in p.waypoints[1:]]
        vertices = np.array(ways)[:, [0, 2]] * to_deg
        solid = set()
        for ax in slices:
            (image,) = ax.images
            cls = np.asarray(image.get_array())
            counts = np.bincount(cls.ravel().astype(int))
            assert np.count_nonzero(counts) >= 2 and counts.max() <= 0.97 * cls.size  # not (nearly) one class
            assert any(_passes_through(line, [start]) and len(line.get_xdata()) == 1 for line in ax.lines)
            boxes = [p for p in ax.patches if isinstance(p, plt.Rectangle)]
            assert any(np.allclose(b.get_xy(), corner) and np.allclose((b.get_width(), b.get_height()), size)
                       for b in boxes)
            (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
            shown = np.vstack([start, corner, corner + size] + ([vertices] if with_plan else []))
            assert np.all((shown[:, 0] > x0) & (shown[:, 0] < x1) & (shown[:, 1] > y0) & (shown[:, 1] < y1))
            if with_plan:
                assert any(_passes_through(line, vertices) for line in ax.lines)  # the whole path
                for line in ax.lines:
                    if len(line.get_xdata()) > 1 and not _passes_through(line, vertices):  # the part at this d
                        solid |= {k for k, v in enumerate(vertices) if _passes_through(line, [v])}
            else:
                assert all(len(line.get_xdata()) == 1 for line in ax.lines)
        if with_plan:
            assert solid == set(range(len(vertices)))  # every corner of the path is solid on a slice at its d
        assert unexplained_marks(fig) == []
        assert_named_axes(fig)
    finally:
        plt.close(fig)


def _report(successes: list[bool]):
    """A SimulationReport of trials with the paper's perturbations drawn (seed 3) and outcomes and
    final poses as given (placed: on the target; failed: 5 mm off)."""
    from ungrasp_ompl.sim.campaign import SimulationReport
    from ungrasp_ompl.sim.outcome import Outcome, TrialResult
    from ungrasp_ompl.scene.perturbation import preset, trial_params
    from ungrasp_ompl.sim.setup import Variant

    trials = []
    for k, (ok, params) in enumerate(zip(successes, trial_params(preset("paper"), 3, len(successes)))):
        pose = np.eye(4)
        pose[0, 3] = 0.0 if ok else 0.005
        outcome = Outcome.SUCCESS if ok else Outcome.GRIP_LOST
        trials.append(TrialResult(outcome, outcome, None, None, None, 0.0, 0.0, 0.0, 0.0,
                                  params=params.to_dict(), trial=k, final_pose=pose.tolist()))
    return SimulationReport("demo", preset("paper"), Variant(), 3, trials)


def test_trials_legend_names_every_mark_and_each_error_in_words():
    report = _report([True, False, True, False, False])
    outline = np.array([[0.0, 0.0], [0.03, 0.0], [0.03, 0.01], [0.0, 0.01]])
    fig = trials_figure(report, outline, np.eye(4))
    try:
        assert unexplained_marks(fig) == []
        texts = set(legend_texts(fig))
        assert {"target outline", "final outline, placed", "final outline, failed", "trial placed",
                "trial failed"} <= texts
        drawn = [k for k in report.trials[0].params if len({t.params[k] for t in report.trials}) > 1]
        xlabels = {ax.get_xlabel().replace("\n", " ") for ax in fig.axes[1:]}
        assert xlabels == {TRIAL_PARAM_LABELS[k] for k in drawn}
        assert_named_axes(fig)
    finally:
        plt.close(fig)


def test_trials_picture_is_a_grid_of_readable_panels():
    """The paper's errors draw 16 of them: their panels go in a grid of ceil(sqrt(16 + 4)) columns
    (the outlines take 2 x 2 cells), each readable, in a picture at most 1600 px wide."""
    from ungrasp_ompl.plots.common import DPI

    report = _report([k % 3 != 0 for k in range(16)])
    keys = [k for k in report.trials[0].params if len({t.params[k] for t in report.trials}) > 1]
    assert len(keys) == 16
    fig = trials_figure(report, np.array([[0.0, 0.0], [0.03, 0.0], [0.03, 0.01], [0.0, 0.01]]), np.eye(4))
    try:
        assert fig.get_size_inches()[0] * DPI <= 1600
        panels = fig.axes[1:]
        assert len(panels) == len(keys)
        ((rows, cols),) = {ax.get_subplotspec().get_gridspec().get_geometry() for ax in panels}
        assert cols == math.ceil(math.sqrt(len(keys) + 4)) and rows * cols >= len(keys) + 4
        assert len({ax.get_subplotspec().rowspan.start for ax in panels}) == rows
        for box in drawn_extents(fig, panels):  # display pixels at the figure's dpi, scaled to the picture's
            assert box.width * DPI / fig.dpi >= 200 and box.height * DPI / fig.dpi >= 140
    finally:
        plt.close(fig)


def test_every_trial_error_has_a_label_with_its_unit():
    from ungrasp_ompl.scene.perturbation import TrialParams

    keys = set(TrialParams().to_dict())
    assert keys == set(TRIAL_PARAM_LABELS)
    for key, label in TRIAL_PARAM_LABELS.items():
        assert _NAMED.match(label), label
        unit = key.rsplit("_", 1)[1]
        if unit in ("mm", "deg"):
            assert label.endswith(f"({unit})"), label
        elif unit == "n":  # newtons
            assert label.endswith("(N)"), label
        elif unit == "seed":  # a draw's seed: a number naming it
            assert label.endswith("(index)"), label
        else:
            assert "x the scene's" in label, label


def _map_result():
    """A 4 x 3 map whose cells end each way a cell can: solved, each lattice verdict, each
    planner outcome, a plan the robot cannot execute, each failed task."""
    from ungrasp_ompl.benchmark.map import MapCell, MapOptions, MapResult
    from ungrasp_ompl.planning.result import PlanOutcome as P
    from ungrasp_ompl.parallel.runner import TaskStatus as T

    solved = dict(lattice_outcome=P.SOLVED, lattice_optimum=80.0)
    kinds = [dict(solved, planner_outcome=P.SOLVED, planner_cost=82.0, sim_successes=3),
             dict(lattice_outcome=P.START_NOT_HELD), dict(lattice_outcome=P.GOAL_EMPTY),
             dict(lattice_outcome=P.NO_SECURE_PATH), dict(solved, planner_outcome=P.NOT_FOUND),
             dict(solved, planner_outcome=P.INVALID_PATH), dict(solved, planner_outcome=P.HUNG),
             dict(solved, planner_outcome=P.SOLVED, planner_cost=90.0, executable=False, error="not executable: out of reach"),
             dict(task_status=T.FAILED, error="ValueError: x"), dict(task_status=T.HUNG), dict(task_status=T.DIED),
             dict(solved, planner_outcome=P.SOLVED, planner_cost=85.0, sim_successes=5)]
    alphas, scales = (0.0, 0.1, 0.2, 0.3), (0.5, 1.0, 1.5)
    grid = [(f, a) for f in scales for a in alphas]
    cells = [MapCell(alpha=a, friction_scale=f, **{"task_status": T.DONE, **k}) for (f, a), k in zip(grid, kinds)]
    options = MapOptions(alphas=alphas, friction_scales=scales, simulate=5)
    return MapResult("demo", (0.1, 1.0), options, cells, len(cells), "reference units")


def test_map_marks_each_failed_cell_with_its_reason():
    from ungrasp_ompl.benchmark.map import map_figure, map_reason, map_reasons

    result = _map_result()
    reasons = map_reasons()
    assert len({marker for _, marker in reasons.values()}) == len(reasons)  # a marker of its own each
    fig = map_figure(result)
    try:
        assert unexplained_marks(fig) == []
        texts = set(legend_texts(fig))
        panels = [ax for ax in fig.axes if ax.get_xlabel().startswith("alpha")]
        assert len(panels) == 3
        seen = set()
        for k, ax in enumerate(panels):
            marked = {c.get_label(): {tuple(p) for p in np.asarray(c.get_offsets()).tolist()}
                      for c in ax.collections if type(c).__name__ == "PathCollection"}
            want: dict = {}
            for cell in result.cells:
                reason = map_reason(cell, k)
                if reason is not None:
                    want.setdefault(reasons[reason][0], set()).add((cell.alpha, cell.friction_scale))
            assert marked == want  # one marker kind per reason, on exactly the cells failing for it
            assert set(want) <= texts
            seen |= set(want)
        assert seen == {label for label, _ in reasons.values()}  # every reason occurs in this map
        assert_named_axes(fig)
    finally:
        plt.close(fig)


def test_stability_names_each_roll_direction():
    """The prism roll's +1 direction (a right-handed turn about G->B) lifts the side left of
    G->B seen from the finger (+z, the top face): so the print's words say which range is which."""
    from ungrasp_ompl.mechanics.roll import ROLL_WAYS, _rotate, describe_restoring
    from ungrasp_ompl.scene.stability import analyse, describe_roll

    x, left = np.array([1.0, 0.0, 0.0]), np.array([[0.5, 1.0, 0.0]])  # +y: left of +x seen from +z
    assert np.cross(x, left[0] - [0.5, 0, 0]) @ [0, 0, 1] > 0
    assert _rotate(left, np.zeros(3), x, np.array([math.radians(10)]))[0, 0, 2] > 0  # +1: left side rises
    assert _rotate(left, np.zeros(3), x, np.array([-math.radians(10)]))[0, 0, 2] < 0
    assert ROLL_WAYS == {1: "left side up", -1: "right side up"}
    assert describe_restoring({1: (0.25, 30.0), -1: None}) == (
        "left side up 0.25..30.00 deg, right side up none (sides of G->B seen from the finger)")

    words = describe_roll({1: (0.25, 30.0), -1: None}, False, 30.0)  # each way named with its range
    assert re.search(r"0\.25 to 30\.00 deg with its left side up and at no tilt with its right side up", words), words

    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    report = analyse(scene, [("start", scene.start)])
    start = f"theta 30.0 deg, d {scene.start[1]:.3f}, psi 0.0 deg"
    (line,) = [ln for ln in report.lines() if start in ln]  # the scene's start
    ranges = [report.rolls[0].ranges_deg()[k] for k in (0, 1)]
    assert all(f"{r[0]:.2f} to {r[1]:.2f} deg" in line for r in ranges), line


@pytest.mark.slow
def test_cage_picture_names_every_mark():
    from ungrasp_ompl.planning.cage_profile import cage_profile
    from ungrasp_ompl.planning.path_margin import plan_friction_margins
    from ungrasp_ompl.plots.cage_profile import cage_figure

    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    result = plan(scene, planner="lattice", seed=1)
    profile = cage_profile(scene, result)
    fig = cage_figure(scene.name, result, profile, plan_friction_margins(scene, profile.samples))
    try:
        assert unexplained_marks(fig) == []
        texts = legend_texts(fig)
        assert {c.outcome.value.replace("_", " ") for c in profile.cages} <= set(texts)
        assert "infinite energy (fully caged), drawn at the top" in texts
        assert_named_axes(fig)
    finally:
        plt.close(fig)


def _run(planner: str, k: int, cost: float | None):
    from ungrasp_ompl.benchmark.tasks import RunResult, RunStatus

    status = RunStatus.EXACT if cost is not None else RunStatus.TIMEOUT
    return RunResult("demo", planner, k, k, status, cost, 2 if cost else None, 0.01 * (k + 1) if cost else None,
                     0.5, 0.1, 100, 0.7)


def _captured(monkeypatch) -> list:
    """The figures the benchmark's plot functions save, kept open instead of written."""
    from ungrasp_ompl.benchmark import bench, design, map, sweep

    figures: list = []
    for module in (bench, design, map, sweep):
        monkeypatch.setattr(module, "save_png", lambda fig, path: figures.append(fig))
    return figures


def test_bench_pictures_name_every_mark(monkeypatch):
    from datetime import datetime

    from ungrasp_ompl.benchmark.ompl_log import Experiment
    from ungrasp_ompl.benchmark.bench import plot_final_cost, plot_success_vs_time
    from ungrasp_ompl.benchmark.tasks import RunStatus

    scene = Scene.from_file(SCENES / "reference_asymmetric.yaml")
    runs = {"RRTstar": [_run("RRTstar", k, c) for k, c in enumerate((86.0, 87.5, None))],
            "lattice": [_run("lattice", 0, 85.5)]}
    exp = Experiment("demo", scene, list(runs), runs, 85.5, RunStatus.EXACT, 1, 0.5, 3, datetime(2026, 1, 1), 1)
    figures = _captured(monkeypatch)
    plot_success_vs_time([exp], None)
    plot_final_cost([exp], None)
    assert len(figures) == 2
    for fig in figures:
        try:
            assert unexplained_marks(fig) == []
            assert_named_axes(fig)
        finally:
            plt.close(fig)


def _seven_planners():
    """An experiment of the default planners on the pick, some runs unsolved."""
    from datetime import datetime

    from ungrasp_ompl.benchmark.ompl_log import Experiment
    from ungrasp_ompl.benchmark.tasks import RunStatus

    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    names = ["RRTstar", "InformedRRTstar", "BITstar", "FMT", "AORRTC", "RRTConnect", "lattice"]
    runs = {p: [_run(p, k, None if (k + i) % 4 == 0 else 78.0 + k) for k in range(8)] for i, p in enumerate(names)}
    return Experiment("pick", scene, names, runs, 77.5, RunStatus.EXACT, 1, 0.5, 8, datetime(2026, 1, 1), 2)


def _sweep_result():
    from ungrasp_ompl.benchmark.ompl_log import cost_units
    from ungrasp_ompl.benchmark.options import SweepOptions
    from ungrasp_ompl.benchmark.sweep import SweepPoint, SweepResult

    points = [SweepPoint(a, [_run("RRTstar", k, c) for k, c in enumerate(costs)], _run("lattice", 0, optimum))
              for a, costs, optimum in ((0.1, (None, None), None), (0.2, (86.0, 87.0), 85.5),
                                        (0.3, (84.0, 85.0), 83.5), (0.4, (None, None), None))]
    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    return SweepResult("pick", "RRTstar", points, cost_units(scene), SweepOptions(alphas=(0.1, 0.2, 0.3, 0.4)))


@pytest.mark.parametrize("picture", ["success", "final_cost", "sweep"])
def test_bench_legends_leave_the_data_clear(monkeypatch, picture):
    """No legend lies over a panel's data area (seven planners' steps reach every corner)."""
    from ungrasp_ompl.benchmark.bench import plot_final_cost, plot_success_vs_time
    from ungrasp_ompl.benchmark.sweep import plot_sweep

    figures = _captured(monkeypatch)
    if picture == "success":
        plot_success_vs_time([_seven_planners()], None)
    elif picture == "final_cost":
        plot_final_cost([_seven_planners()], None)
    else:
        plot_sweep(_sweep_result(), 0.5, None)
    (fig,) = figures
    try:
        panels = [ax for ax in fig.axes if ax.lines]
        legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
        assert panels and legends
        boxes = drawn_extents(fig, legends + panels)
        for legend in boxes[:len(legends)]:
            assert not any(overlap(legend, panel) for panel in boxes[len(legends):])
            assert fig.bbox.contains(legend.x0, legend.y0) and fig.bbox.contains(legend.x1, legend.y1)
    finally:
        plt.close(fig)


def test_sweep_axis_names_do_not_overlap(monkeypatch):
    from ungrasp_ompl.benchmark.sweep import plot_sweep

    figures = _captured(monkeypatch)
    plot_sweep(_sweep_result(), 0.5, None)
    (fig,) = figures
    try:
        top, bottom = drawn_extents(fig, [ax.yaxis.label for ax in fig.axes])
        assert not overlap(top, bottom)
        for box in (top, bottom):
            assert fig.bbox.contains(box.x0, box.y0) and fig.bbox.contains(box.x1, box.y1)
    finally:
        plt.close(fig)


def test_bench_writes_pictures_of_what_it_recorded_and_a_table_that_fits(monkeypatch, tmp_path):
    """bench (its runs made up): no picture stands in for data not recorded, and the summary
    table fits 100 columns with no column empty in every row."""
    import dataclasses

    from ungrasp_ompl.benchmark import BenchmarkOptions, bench, run_benchmark
    from ungrasp_ompl.benchmark.statistics import SUMMARY_COLUMNS
    from ungrasp_ompl.parallel import RunOptions
    from ungrasp_ompl.planning import PlannerOptions
    from ungrasp_ompl.benchmark.table import format_table

    def made_up(tasks, runner, progress=None, stream=None):
        return [dataclasses.replace(_run(t.planner.planner, max(t.run, 0), None if t.run == 1 else 86.0 + t.run),
                                    group=t.group, seed=t.planner.seed) for t in tasks]

    monkeypatch.setattr(bench, "run_tasks", made_up)
    figures = _captured(monkeypatch)
    planners = ("RRTstar", "InformedRRTstar", "BITstar", "RRTConnect")
    result = run_benchmark([SCENES / "reference_asymmetric.yaml"],
                           BenchmarkOptions(planners=planners, runs=3, planner=PlannerOptions(time=0.5),
                                            run=RunOptions(jobs=1), out=tmp_path / "b"))
    try:
        assert figures
        for fig in figures:
            assert not any("not recorded" in text for text in all_texts(fig))
    finally:
        for fig in figures:
            plt.close(fig)
    filled = [c for c in SUMMARY_COLUMNS if any(c.value(r) is not None for r in result.summary)]
    assert len(filled) < len(SUMMARY_COLUMNS)  # some are empty here (the tolerance objective's)
    lines = format_table(SUMMARY_COLUMNS, result.summary).split("\n")
    assert max(map(len, lines)) <= 100
    blocks = "\n".join(lines).split("\n\n")
    shown = 0
    for block in blocks:
        rows = [re.split(r"\s{2,}", row.strip()) for row in block.split("\n")[-len(result.summary):]]
        assert len({len(r) for r in rows}) == 1  # one cell per column in every row
        columns = list(zip(*rows))
        assert columns[:2] == [tuple(r.scene for r in result.summary), tuple(r.planner for r in result.summary)]
        assert all(any(cell != "-" for cell in column) for column in columns)  # no empty column
        shown += len(columns) - 2
    assert shown == len(filled) - 2  # every column with a value, once (scene and planner in every block)


def test_sweep_picture_names_every_mark(monkeypatch):
    from ungrasp_ompl.benchmark.options import SweepOptions
    from ungrasp_ompl.benchmark.sweep import plot_sweep
    from ungrasp_ompl.benchmark.sweep import SweepPoint, SweepResult

    points = [SweepPoint(a, [_run("RRTstar", k, c) for k, c in enumerate(costs)], _run("lattice", 0, optimum))
              for a, costs, optimum in ((0.1, (None, None), None), (0.2, (86.0, 87.0), 85.5),
                                        (0.3, (None, None), None))]
    result = SweepResult("demo", "RRTstar", points, "reference units", SweepOptions(alphas=(0.1, 0.2, 0.3)))
    figures = _captured(monkeypatch)
    plot_sweep(result, 0.5, None)
    (fig,) = figures
    try:
        assert unexplained_marks(fig) == []
        assert legend_texts(fig).count("no secure path") == 1  # two alphas blocked, named once
        assert_named_axes(fig)
    finally:
        plt.close(fig)


def _square_layout(clearance: float):
    """One tangram square alone in a square frame that leaves clearance (m) on every side."""
    import yaml

    from ungrasp_ompl.layout.model import Layout

    doc = yaml.safe_load((SCENES / "tangram.yaml").read_text())
    square = next(p for p in doc["pieces"] if p["name"] == "square")
    half = float(np.max(np.abs(np.asarray(square["outline"]["polygon"])))) + clearance
    square["target"] = {"position": [half, half], "yaw_deg": 0}
    doc["pieces"] = [square]
    doc["frame"]["inner_size"] = 2 * half
    return Layout.from_dict(doc)


@pytest.mark.parametrize("clearance, placed", [(0.015, True), (0.0005, False)])
def test_layout_picture_names_every_mark(clearance, placed):
    from ungrasp_ompl.plots.layout import layout_figure
    from ungrasp_ompl.layout.tiler import TilingOptions, tile
    from ungrasp_ompl.planning import PlannerOptions

    layout = _square_layout(clearance)
    tiling = tile(layout, TilingOptions(planner=PlannerOptions(planner="lattice", seed=1)))
    assert tiling.solved is placed
    fig = layout_figure(layout, tiling)
    try:
        assert unexplained_marks(fig) == []
        texts = legend_texts(fig)
        assert ("piece placed (number and shade: order)" in texts) is placed
        assert ("piece that cannot be placed" in texts) is not placed
        assert_named_axes(fig)
    finally:
        plt.close(fig)
