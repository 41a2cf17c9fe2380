"""Benchmarks: OMPL log and database, summary, plots, the lattice yardstick, the alpha sweep."""

from __future__ import annotations

import csv
import dataclasses
import sqlite3
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from conftest import assert_picture
from ungrasp_ompl.benchmark import BenchmarkOptions, SweepOptions, run_benchmark, run_sweep
from ungrasp_ompl.benchmark.ranges import parse_alpha_range
from ungrasp_ompl.benchmark.tasks import LATTICE, RunStatus, Task, run_task, run_tasks
from ungrasp_ompl.errors import InputError
from ungrasp_ompl.parallel import RunOptions
from ungrasp_ompl.parallel.runner import LocalRunner
from ungrasp_ompl.planning.setup import PlannerOptions
from ungrasp_ompl.planning.plan_tolerance import tolerance
from ungrasp_ompl.scene import Scene

SCENES = Path(__file__).parents[1] / "scenes"
SCENE = SCENES / "reference_asymmetric.yaml"
PLANNERS = ["RRTstar", "RRTConnect", LATTICE]


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    result = run_benchmark([SCENE], BenchmarkOptions(planners=tuple(PLANNERS), runs=2, planner=PlannerOptions(time=0.3),
                                                     run=RunOptions(jobs=2), out=out))
    return out, result


@pytest.mark.slow
def test_database_holds_every_run(bench):
    out, _ = bench
    with sqlite3.connect(out / "benchmark.db") as db:
        assert db.execute("select count(*) from runs").fetchone()[0] == 6
        names = {n for (n,) in db.execute("select name from plannerConfigs")}
        per_planner = dict(db.execute("select p.name, count(*) from runs r join plannerConfigs p "
                                      "on r.plannerid = p.id group by p.name"))
        experiment = db.execute("select name, runcount, timelimit, version from experiments").fetchall()
    assert names == {f"geometric_{p}" for p in PLANNERS}
    assert per_planner == {f"geometric_{p}": 2 for p in PLANNERS}
    assert experiment == [("reference_asymmetric", 2, 0.3, "OMPL 2.0.1")]
    assert (out / "reference_asymmetric.log").read_text().startswith("OMPL version ")


@pytest.mark.slow
def test_summary_lists_the_planners(bench):
    out, result = bench
    with open(out / "summary.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["planner"] for r in rows] == PLANNERS
    assert all(r["scene"] == "reference_asymmetric" and r["runs"] == "2" for r in rows)
    assert float(rows[-1]["success_rate"]) == 1.0 and float(rows[-1]["gap_to_optimum_percent"]) == 0.0
    for planner in PLANNERS:
        assert planner in result.table


@pytest.mark.slow
def test_no_planner_beats_the_lattice_optimum(bench):
    out, result = bench
    optimum = result.optima["reference_asymmetric"]
    assert optimum == pytest.approx(84.5)  # docs/model.md 8.2: 84.5 at 0.5 deg / 0.005 (one bent P_dpsi)
    solved = [r for r in result.runs if r.solved]
    assert solved
    for r in solved:
        assert r.cost >= optimum - 1e-9, (r.planner, r.run, r.cost)
    lattice = [r for r in result.runs if r.planner == LATTICE]
    assert len(lattice) == 2 and all(r.solved and r.cost == optimum for r in lattice)
    with sqlite3.connect(out / "benchmark.db") as db:
        costs = db.execute("select best_cost from runs r join plannerConfigs p on r.plannerid = p.id "
                           "where p.name = 'geometric_lattice'").fetchall()
        logged = db.execute("select lattice_optimum from experiments").fetchone()[0]
    assert costs == [(optimum,), (optimum,)] and logged == optimum


@pytest.mark.slow
def test_margin_objective_bench_keeps_no_planner_above_the_lattice_bottleneck(tmp_path):
    """bench --objective margin: the lattice yardstick finds the widest path, and no planner's run,
    every one re-validated on the same lattice, keeps a larger smallest margin than it."""
    guitar = SCENES / "guitar_pick.yaml"
    options = BenchmarkOptions(planners=("RRTstar", LATTICE), runs=2,
                               planner=PlannerOptions(time=0.3, iterations=6000, objective="margin"),
                               run=RunOptions(jobs=2), out=tmp_path / "b")
    result = run_benchmark([guitar], options)
    rows = {r.planner: r for r in result.summary}
    widest = rows[LATTICE].lattice_margin
    assert widest is not None and widest > 0
    solved = [r for r in result.runs if r.solved]
    assert {r.planner for r in solved} == {"RRTstar", LATTICE}
    assert all(r.min_margin_deg <= widest + 1e-9 for r in solved)
    assert all(r.min_margin_deg == pytest.approx(widest) for r in solved if r.planner == LATTICE)
    with open(tmp_path / "b" / "runs.csv") as f:
        assert {row["objective"] for row in csv.DictReader(f)} == {"margin"}
    assert all(r.tolerance is None for r in result.runs)  # measured under the tolerance objective only


@pytest.mark.slow
def test_tolerance_objective_bench_reports_each_run_s_tolerance(tmp_path):
    """bench --objective tolerance: each solved run carries its path's tolerance, the lattice's is
    the tolerance plan's own, the summary's median is the runs', and runs.csv reads back whole."""
    from ungrasp_ompl.benchmark.statistics import median
    from ungrasp_ompl.benchmark.tasks import result_from_row
    from ungrasp_ompl.planning.setup import lattice_plan

    guitar = SCENES / "guitar_pick.yaml"
    options = BenchmarkOptions(planners=("RRTstar",), runs=1,
                               planner=PlannerOptions(time=0.3, iterations=6000, objective="tolerance"),
                               run=RunOptions(jobs=2), out=tmp_path / "b")
    result = run_benchmark([guitar], options)
    scene = Scene.from_file(guitar)
    (row,) = result.summary
    assert row.lattice_tolerance == tolerance(scene, lattice_plan(scene, objective="tolerance")).scale
    solved = [r for r in result.runs if r.solved and r.planner == "RRTstar"]
    assert solved and all(r.tolerance is not None and r.tolerance >= 0 for r in solved)
    assert row.tolerance_median == median([r.tolerance for r in solved])
    with open(tmp_path / "b" / "runs.csv") as f:
        rows = list(csv.reader(f))[1:]
    assert [result_from_row(r) for r in rows if r[1] == "RRTstar"] == [r for r in result.runs if r.planner == "RRTstar"]


def test_a_cost_only_planner_is_refused_a_robust_objective(tmp_path):
    options = BenchmarkOptions(planners=("PRM",), runs=1, planner=PlannerOptions(time=0.3, objective="margin"),
                               run=RunOptions(jobs=2), out=tmp_path / "o")
    with pytest.raises(InputError) as err:
        run_benchmark([SCENE], options)
    assert err.value.field == "objective" and "PRM" in err.value.reason
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_plots_are_png(bench):
    out, _ = bench
    for name in ("success_vs_time.png", "final_cost.png"):
        assert_picture(out / name)


@pytest.mark.parametrize("planners, named", [(["RRTstar", "NoSuchPlanner"], "NoSuchPlanner"),
                                             (["LazyPRMstar"], "LazyPRMstar"), ([], None)])
def test_bad_planner_is_refused_before_running(tmp_path, planners, named):
    out = tmp_path / "out"
    with pytest.raises(InputError) as err:
        run_benchmark([SCENE], BenchmarkOptions(planners=tuple(planners), runs=1, planner=PlannerOptions(time=0.3),
                                                 run=RunOptions(jobs=2), out=out))
    assert err.value.field == "planners"
    assert named is None or named in err.value.reason  # the planner refused is named
    assert not out.exists()


@pytest.mark.parametrize("kwargs, field", [(dict(runs=0), "runs"), (dict(planner=PlannerOptions(time=-1.0)), "time"),
                                           (dict(run=RunOptions(jobs=0)), "jobs"),
                                           (dict(planner=PlannerOptions(time=0.3, iterations=0)), "iterations"),
                                           (dict(run=RunOptions(seed=-1, jobs=2)), "seed"),
                                           (dict(planner=PlannerOptions(time=0.3, range=-0.1)), "range"),
                                           (dict(planner=PlannerOptions(time=0.3, goal_bias=2.0)), "goal_bias")])
def test_bad_options_are_refused(tmp_path, kwargs, field):
    good = dict(planners=("RRTstar",), runs=1, planner=PlannerOptions(time=0.3), run=RunOptions(jobs=2), out=tmp_path / "o")
    options = BenchmarkOptions(**(good | kwargs))
    with pytest.raises(InputError) as err:
        run_benchmark([SCENE], options)
    assert err.value.field == field
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("text, expected", [
    ("0:0.6:0.05", [round(0.05 * k, 10) for k in range(13)]),
    ("0.1:0.1:0.05", [0.1]),
    ("0:0.5:0.2", [0.0, 0.2, 0.4]),
    ("0.2:0.8:0.3", [0.2, 0.5, 0.8]),
    (" 0.47 ", [0.47]),
    ("-0.2:0:0.1", [-0.2, -0.1, 0.0]),
])
def test_parse_alpha_range(text, expected):
    assert parse_alpha_range(text) == expected


def test_parse_alpha_range_ends_exactly_on_stop():
    values = parse_alpha_range("0:0.6:0.05")
    assert len(values) == 13 and values[-1] == 0.6 and values[3] == 0.15


@pytest.mark.parametrize("text", ["", "0:1", "0:1:0.1:2", "a:b:c", "0:1:0", "0:1:-0.1", "1:0:0.1", "0:nan:0.1",
                                  "0:inf:0.1", "0:1:1e-9"])
def test_parse_alpha_range_errors(text):
    with pytest.raises(InputError) as err:
        parse_alpha_range(text)
    assert err.value.field == "alphas"


@pytest.mark.slow
def test_sweep_over_alpha(tmp_path):
    result = run_sweep(SCENE, SweepOptions(alphas=(0.0, 0.47), runs=1, planner=PlannerOptions(time=0.3),
                                          run=RunOptions(jobs=2), out=tmp_path))
    equal, reference = result.points
    assert equal.alpha == 0.0 and not equal.lattice_reachable and equal.lattice_optimum is None
    assert equal.success_rate == 0.0 and equal.median_cost is None
    assert reference.alpha == 0.47 and reference.lattice_reachable and reference.success_rate == 1.0
    assert reference.median_cost >= reference.lattice_optimum - 1e-9
    with open(tmp_path / "sweep.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["alpha"] for r in rows] == ["0.0", "0.47"]
    assert rows[0]["lattice_optimum"] == "" and rows[0]["lattice_reachable"] == "0"
    assert float(rows[1]["lattice_optimum"]) == pytest.approx(84.5) and rows[1]["lattice_reachable"] == "1"
    assert_picture(tmp_path / "sweep.png")


def test_sweep_refuses_a_bad_alpha(tmp_path):
    with pytest.raises(InputError) as err:
        run_sweep(SCENE, SweepOptions(alphas=(1.5,), runs=1, planner=PlannerOptions(time=0.3), run=RunOptions(jobs=2),
                                      out=tmp_path))
    assert err.value.field == "alphas"


def test_a_run_status_comes_from_the_plans_outcome():
    """The lattice run's status on scenes whose outcome is known: solved, a goal region that holds
    no state (equal digits: no goal state is force-closed), a start that cannot be held."""
    reference = Scene.from_file(SCENE)
    equal = Scene.from_file(SCENES / "reference_equal_digits.yaml")
    unheld = dataclasses.replace(reference, start=np.array([0.1, 0.8, 0.0]))  # the finger in the table
    assert unheld.diagnose(unheld.start).state_class.name == "COLLISION"
    lattice = PlannerOptions(planner=LATTICE, time=0.3, seed=1)
    solved = run_task(Task("r", reference, lattice, -1))
    assert solved.status is RunStatus.EXACT and solved.cost == pytest.approx(84.5)
    assert run_task(Task("e", equal, lattice, -1)).status is RunStatus.UNSOLVABLE_START_OR_GOAL
    assert run_task(Task("u", unheld, lattice, -1)).status is RunStatus.UNSOLVABLE_START_OR_GOAL


@pytest.mark.slow
def test_seeded_runs_are_reproducible_in_fresh_and_reused_processes():
    """With an iteration budget, a run's result depends on its seed only: the same seed in
    another process, or later in the same worker after other seeds, gives the same path cost,
    iterations and primitive changes."""
    scene = Scene.from_file(SCENE)
    tasks = [Task("r", scene, PlannerOptions(time=0.5, seed=seed, iterations=1500), k)
             for k, seed in enumerate((3, 4, 3, 4))]
    fresh = run_tasks(tasks, LocalRunner(2, fresh=True))
    reused = run_tasks(tasks, LocalRunner(1, fresh=False))  # one worker: 3, 4, 3, 4 in a row
    key = [(r.cost, r.iterations, r.mode_switches) for r in fresh]
    assert all(r.status is RunStatus.EXACT for r in fresh + reused)
    assert key == [(r.cost, r.iterations, r.mode_switches) for r in reused]
    assert key[0] == key[2] and key[1] == key[3]
    assert fresh[0].iterations == 1500 and fresh[0].cost >= 84.5 - 1e-9


def test_scene_with_digits_changes_only_the_digits_asked_and_checks_them():
    scene = Scene.from_file(SCENE)
    changed = scene.with_digits(alpha=0.2)
    assert changed.digits.alpha == 0.2 and scene.digits.alpha == 0.47
    assert replace(changed.digits, alpha=scene.digits.alpha) == scene.digits and changed.mu == scene.mu
    flat = scene.with_digits(finger_tip="flat")
    assert flat.digits.flat_finger_tip and flat.digits.finger_tip_radius == 0.0
    rounded = flat.with_digits(finger_tip="rounded")  # back to a dome across the tip's thickness
    assert rounded.digits == replace(scene.digits, finger_tip_radius=scene.digits.finger_tip_thickness / 2)
    big = scene.with_digits(finger_tip_radius=0.003)  # a 3 mm dome needs a 6 mm tip
    assert big.digits.finger_tip_radius * big.object_length == pytest.approx(0.003)
    assert big.digits.finger_tip_thickness * big.object_length == pytest.approx(0.006)
    for kwargs, field in ((dict(alpha=1.0), "digits.alpha"), (dict(alpha=-0.99), "digits.alpha"),
                          (dict(finger_tip="pointy"), "digits.finger_tip"),
                          (dict(finger_tip="flat", finger_tip_radius=0.001), "digits.finger_tip_radius"),
                          (dict(finger_tip_radius=-0.001), "digits.finger_tip_radius")):
        with pytest.raises(InputError) as err:
            scene.with_digits(**kwargs)
        assert err.value.field == field


class _Stop(Exception):
    """Raised by a stand-in run_tasks once it has the tasks a campaign built."""


def test_each_run_gets_the_planner_options_whole_and_keeps_its_runs_csv_key(monkeypatch, tmp_path):
    """bench hands every run the options' PlannerOptions whole (range and goal bias included),
    only the planner's name and the run's seed (run.seed + k) replaced, the lattice yardstick
    without the iteration budget; runs.csv's key of each task stays as written before."""
    from ungrasp_ompl.benchmark import bench as bench_module
    from ungrasp_ompl.benchmark.tasks import task_key

    built = []

    def capture(tasks, runner, progress=None, stream=None):
        built.extend(tasks)
        raise _Stop

    monkeypatch.setattr(bench_module, "run_tasks", capture)
    planner = PlannerOptions(time=0.4, iterations=1500, objective="margin", range=0.2, goal_bias=0.3)
    with pytest.raises(_Stop):
        run_benchmark([SCENE], BenchmarkOptions(planners=("RRTstar",), runs=2, planner=planner,
                                                run=RunOptions(seed=5, jobs=1), out=tmp_path))
    assert [t.planner for t in built] == [replace(planner, planner="RRTstar", seed=5),
                                          replace(planner, planner="RRTstar", seed=6),
                                          replace(planner, planner=LATTICE, seed=5, iterations=None)]
    assert [task_key(t) for t in built] == [
        ("reference_asymmetric", "RRTstar", "0", "5", "0.4", "1500", "margin"),
        ("reference_asymmetric", "RRTstar", "1", "6", "0.4", "1500", "margin"),
        ("reference_asymmetric", LATTICE, "-1", "5", "0.4", "", "margin")]
    assert [t.deadline for t in built] == [72.0, 72.0, 60.4]  # 30 x 0.4 s with a budget, else 0.4 s; + 60 s grace


def test_a_task_needs_a_seed():
    with pytest.raises(InputError) as err:
        Task("r", Scene.from_file(SCENE), PlannerOptions(time=0.3), 0)
    assert err.value.field == "seed"


def test_a_map_row_records_the_seed_its_trials_used(monkeypatch):
    """map.csv's trial_seed is the seed the cell's simulated trials were handed (the map's
    run.seed), planner_seed the planner's: given different values, each lands in its column."""
    from ungrasp_ompl.benchmark import map as feasibility
    from ungrasp_ompl.sim.plan_trials import PlanTrials

    handed = []

    def trials(scene, plan, n, perturb, seed):  # no simulation: only the seed it is given counts here
        handed.append(seed)
        return PlanTrials(results=())

    monkeypatch.setattr(feasibility, "plan_trials", trials)
    task = feasibility.MapTask(0, 0.47, 1.0, Scene.from_file(SCENE), PlannerOptions(planner=LATTICE, time=0.3, seed=3),
                               trial_seed=11, trials=2)
    row = dict(zip(feasibility.MAP_COLUMNS, feasibility.cell_row(feasibility.run_cell(task), task)))
    assert handed == [11]
    assert row["trial_seed"] == "11" and row["planner_seed"] == "3"
    untried = replace(task, trials=0)  # no trials: no trial seed recorded
    assert dict(zip(feasibility.MAP_COLUMNS, feasibility.cell_row(feasibility.run_cell(untried), untried)))[
        "trial_seed"] == ""


@pytest.mark.slow
def test_a_map_row_s_trials_rerun_with_its_trial_seed_give_its_successes(tmp_path):
    """A map with the planner seeded 1 and the trials 7 records both; the cell's plan rerun through
    the same trials with the recorded trial_seed places as many as the row counts."""
    from ungrasp_ompl.benchmark.map import MapOptions, run_map, scene_variant
    from ungrasp_ompl.planning.setup import lattice_plan
    from ungrasp_ompl.scene.loader import read_yaml
    from ungrasp_ompl.sim.plan_trials import plan_trials

    guitar = SCENES / "guitar_pick.yaml"
    run_map(guitar, MapOptions(alphas=(0.47,), planner=PlannerOptions(planner=LATTICE, time=0.3, seed=1), simulate=2,
                               run=RunOptions(seed=7, jobs=1), out=tmp_path))
    with open(tmp_path / "map.csv", newline="") as f:
        (row,) = list(csv.DictReader(f))
    assert (row["planner_seed"], row["trial_seed"], row["sim_trials"]) == ("1", "7", "2")
    scene = scene_variant(read_yaml(guitar, "scene"), 0.47, 1.0, None, str(guitar), "guitar_pick")
    plan = lattice_plan(scene, int(row["planner_seed"]), objective=scene.options.objective)
    rerun = plan_trials(scene, plan, 2, "paper", int(row["trial_seed"]))
    assert rerun.successes == int(row["sim_successes"])
