"""Benchmarks: OMPL log and database, summary, plots, the lattice yardstick, the alpha sweep."""

from __future__ import annotations

import csv
import sqlite3
from pathlib import Path

import pytest

from conftest import assert_picture
from ungrasp_ompl.benchmark import LATTICE, parse_alpha_range, run_benchmark, run_sweep
from ungrasp_ompl.errors import InputError

SCENES = Path(__file__).parents[1] / "scenes"
SCENE = SCENES / "reference_asymmetric.yaml"
PLANNERS = ["RRTstar", "RRTConnect", LATTICE]


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    result = run_benchmark([SCENE], PLANNERS, runs=2, time_limit=0.3, jobs=2, out_dir=out, progress=False)
    return out, result


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


def test_summary_lists_the_planners(bench):
    out, result = bench
    with open(out / "summary.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["planner"] for r in rows] == PLANNERS
    assert all(r["scene"] == "reference_asymmetric" and r["runs"] == "2" for r in rows)
    assert float(rows[-1]["success_rate"]) == 1.0 and float(rows[-1]["gap_to_optimum_percent"]) == 0.0
    for planner in PLANNERS:
        assert planner in result.table


def test_no_planner_beats_the_lattice_optimum(bench):
    out, result = bench
    optimum = result.optima["reference_asymmetric"]
    assert optimum == pytest.approx(85.5)  # README: 85.5 at 0.5 deg / 0.005
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


def test_plots_are_png(bench):
    out, _ = bench
    for name in ("success_vs_time.png", "cost_vs_time.png"):
        assert_picture(out / name)


@pytest.mark.parametrize("planners, words", [(["RRTstar", "NoSuchPlanner"], ["unknown planner", "NoSuchPlanner"]),
                                             (["LazyPRMstar"], ["unknown planner", "LazyPRMstar"]),
                                             ([], ["no planner"])])
def test_bad_planner_is_refused_before_running(tmp_path, planners, words):
    out = tmp_path / "out"
    with pytest.raises(InputError) as err:
        run_benchmark([SCENE], planners, runs=1, time_limit=0.3, jobs=2, out_dir=out, progress=False)
    assert err.value.field == "--planners"
    assert all(w in str(err.value) for w in words), str(err.value)
    assert not out.exists()


@pytest.mark.parametrize("kwargs, field", [(dict(runs=0), "--runs"), (dict(time_limit=-1.0), "--time"),
                                           (dict(jobs=0), "--jobs")])
def test_bad_options_are_refused(tmp_path, kwargs, field):
    args = dict(scene_paths=[SCENE], planners=["RRTstar"], runs=1, time_limit=0.3, jobs=2, out_dir=tmp_path / "o",
                progress=False) | kwargs
    with pytest.raises(InputError) as err:
        run_benchmark(**args)
    assert err.value.field == field


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
    assert err.value.field == "--alpha"


def test_sweep_over_alpha(tmp_path):
    result = run_sweep(SCENE, [0.0, 0.47], runs=1, time_limit=0.3, jobs=2, out_dir=tmp_path, progress=False)
    equal, reference = result.points
    assert equal.alpha == 0.0 and not equal.lattice_reachable and equal.lattice_optimum is None
    assert equal.success_rate == 0.0 and equal.median_cost is None
    assert reference.alpha == 0.47 and reference.lattice_reachable and reference.success_rate == 1.0
    assert reference.median_cost >= reference.lattice_optimum - 1e-9
    with open(tmp_path / "sweep.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["alpha"] for r in rows] == ["0.0", "0.47"]
    assert rows[0]["lattice_optimum"] == "" and rows[0]["lattice_reachable"] == "0"
    assert float(rows[1]["lattice_optimum"]) == pytest.approx(85.5) and rows[1]["lattice_reachable"] == "1"
    assert_picture(tmp_path / "sweep.png")


def test_sweep_refuses_a_bad_alpha(tmp_path):
    with pytest.raises(InputError) as err:
        run_sweep(SCENE, [1.5], runs=1, time_limit=0.3, jobs=2, out_dir=tmp_path, progress=False)
    assert err.value.field == "--alpha"
