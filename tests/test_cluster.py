"""Campaigns on Ray: a local cluster on 127.0.0.1, started here, gives the same results as the local
pool cell by cell and run by run; a worker killed mid-campaign is replaced and the campaign
completes; a task that keeps failing is reported; an interrupted map resumes without redoing
what is done."""

from __future__ import annotations

import csv
import os
import signal
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path

import pytest

from conftest import SCENES, run_cli, run_process
from ungrasp_ompl.benchmark import BenchmarkOptions, run_benchmark
from ungrasp_ompl.benchmark.map import MapOptions, run_map
from ungrasp_ompl.benchmark.tasks import RUN_COLUMNS
from ungrasp_ompl.planning.setup import PlannerOptions
from ungrasp_ompl.parallel import RunOptions
from ungrasp_ompl.parallel.runner import RayRunner, TaskStatus
from ungrasp_ompl.parallel.stream import RowStream

ray = pytest.importorskip("ray")

SCENE = SCENES / "reference_asymmetric.yaml"
#: A 2 x 2 map around the scene's own alpha 0.47: secure paths at friction x1, none at x0.8.
SMALL_MAP = dict(alphas=(0.3, 0.47), friction_scales=(0.8, 1.0), planner=PlannerOptions(time=0.3, seed=3))
#: Where SMALL_MAP runs: two workers here, or on the cluster given.
SMALL_RUN = RunOptions(seed=3, jobs=2)
#: runs.csv's columns that hold no time measurement: equal wherever a seeded run ran.
UNTIMED = ("group", "planner", "run", "seed", "status", "cost", "mode_switches", "iterations")


@pytest.fixture(scope="module")
def cluster():
    """A Ray cluster of 2 CPUs on 127.0.0.1; this module's functions travel by value to its workers."""
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False,
             _node_ip_address="127.0.0.1")
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
    yield "local"  # RayRunner("local") uses the Ray this process is connected to
    ray.shutdown()


def _rows(path: Path, columns=None) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return [{k: r[k] for k in columns} for r in rows] if columns else rows


@pytest.mark.slow
def test_a_map_on_ray_matches_the_local_pool_cell_by_cell(cluster, tmp_path):
    here = run_map(SCENE, MapOptions(**SMALL_MAP, run=SMALL_RUN, out=tmp_path / "here"))
    there = run_map(SCENE, MapOptions(**SMALL_MAP, run=replace(SMALL_RUN, cluster=cluster), out=tmp_path / "ray"))
    assert (tmp_path / "ray" / "map.csv").read_bytes() == (tmp_path / "here" / "map.csv").read_bytes()
    assert here.cells == there.cells and there.ran == 4
    cells = {(c.alpha, c.friction_scale): c for c in there.cells}
    reference = cells[(0.47, 1.0)]
    assert reference.secure_path and reference.lattice_optimum == pytest.approx(84.5)  # docs/model.md 8.2
    assert reference.planner_solved and reference.planner_cost >= 84.5 - 1e-9
    assert not cells[(0.47, 0.8)].secure_path and cells[(0.47, 0.8)].planner_outcome is None
    assert all(c.task_status is TaskStatus.DONE for c in there.cells)


@pytest.mark.slow
def test_a_bench_on_ray_matches_the_local_pool_run_by_run(cluster, tmp_path):
    options = dict(planners=("RRTConnect", "lattice"), runs=2, planner=PlannerOptions(time=0.3, iterations=1500))
    run = RunOptions(seed=5, jobs=2)
    run_benchmark([SCENE], BenchmarkOptions(**options, run=run, out=tmp_path / "here"))
    result = run_benchmark([SCENE], BenchmarkOptions(**options, run=replace(run, cluster=cluster), out=tmp_path / "ray"))
    here = _rows(tmp_path / "here" / "runs.csv", UNTIMED)
    assert _rows(tmp_path / "ray" / "runs.csv", UNTIMED) == here
    assert len(here) == 4 and all(r["status"] == "exact" for r in here)
    assert result.optima == {"reference_asymmetric": pytest.approx(84.5)}


def _nap(task: tuple[str, int]) -> tuple[int, int]:
    """A task that leaves its pid in a file named after the task, naps, and returns (index, pid)."""
    folder, index = task
    Path(folder, f"{index}-{os.getpid()}").touch()
    time.sleep(1.5)
    return index, os.getpid()


@pytest.mark.slow
def test_a_worker_killed_during_a_campaign_is_replaced_and_the_campaign_completes(cluster, tmp_path):
    killed = []

    def kill_the_first_worker() -> None:
        end = time.monotonic() + 60
        while not killed and time.monotonic() < end:
            started = sorted(tmp_path.iterdir())
            if started:
                index, pid = started[0].name.split("-")
                os.kill(int(pid), signal.SIGKILL)
                killed.append((int(index), int(pid)))
            time.sleep(0.05)

    thread = threading.Thread(target=kill_the_first_worker)
    thread.start()
    outcomes = list(RayRunner(cluster, fresh=True, max_retries=2).run(_nap, [(str(tmp_path), k) for k in range(4)]))
    thread.join()
    assert killed, "no worker started"
    index, pid = killed[0]
    assert sorted(o.index for o in outcomes) == [0, 1, 2, 3]
    assert all(o.status is TaskStatus.DONE for o in outcomes)
    redone = next(o for o in outcomes if o.index == index)
    assert redone.value[0] == index and redone.value[1] != pid  # run again in another worker
    assert len(list(tmp_path.glob(f"{index}-*"))) == 2


def _fail(task: str) -> int:
    """A task that raises, dies every time, or overstays its deadline."""
    if task == "raise":
        raise ValueError("no good")
    if task == "die":
        os._exit(3)
    if task == "nap":
        time.sleep(60)
    return 1


@pytest.mark.slow
def test_a_task_that_keeps_failing_is_reported_not_lost(cluster):
    tasks = ["raise", "die", "ok"]
    outcomes = {o.index: o for o in RayRunner(cluster, fresh=True, max_retries=1).run(_fail, tasks)}
    assert outcomes[0].status is TaskStatus.FAILED and isinstance(outcomes[0].error, ValueError)
    assert "no good" in str(outcomes[0].error)
    assert outcomes[1].status is TaskStatus.DIED and outcomes[1].error is not None
    assert outcomes[2].status is TaskStatus.DONE and outcomes[2].value == 1
    (hung,) = RayRunner(cluster).run(_fail, ["nap"], deadline=2.0)
    assert hung.status is TaskStatus.HUNG and hung.wall_time_s < 30


@pytest.mark.slow
def test_an_interrupted_map_resumes_without_redoing_what_is_done(cluster, tmp_path):
    out = tmp_path / "map"

    def interrupt_after_two(p) -> None:
        if p.done - p.resumed >= 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_map(SCENE, MapOptions(**SMALL_MAP, run=replace(SMALL_RUN, cluster=cluster), out=out), progress=interrupt_after_two)
    assert len(_rows(out / "map.csv")) == 2  # streamed as they arrived
    seen = []
    resumed = run_map(SCENE, MapOptions(**SMALL_MAP, run=replace(SMALL_RUN, cluster=cluster), out=out, resume=True), progress=seen.append)
    assert resumed.ran == 2 and seen[0].resumed == 2 and seen[-1].done == 4
    whole = run_map(SCENE, MapOptions(**SMALL_MAP, run=SMALL_RUN, out=tmp_path / "whole"))
    assert (out / "map.csv").read_bytes() == (tmp_path / "whole" / "map.csv").read_bytes()
    assert whole.cells == resumed.cells
    again = run_map(SCENE, MapOptions(**SMALL_MAP, run=SMALL_RUN, out=out, resume=True))
    assert again.ran == 0


def test_a_stream_keeps_whole_rows_and_drops_a_cut_one(tmp_path):
    path = tmp_path / "rows.csv"
    with RowStream(path, RUN_COLUMNS, 2) as stream:
        stream.append(["a", "b"] + ["1"] * (len(RUN_COLUMNS) - 2))
        stream.append(["c", "d"] + [None] * (len(RUN_COLUMNS) - 2))
    with open(path, "a") as f:
        f.write("e,f,1,2")  # an interruption mid-line
    kept = RowStream(path, RUN_COLUMNS, 2, resume=True).rows
    assert list(kept) == [("a", "b"), ("c", "d")] and kept[("c", "d")][2:] == [""] * (len(RUN_COLUMNS) - 2)
    assert RowStream(path, RUN_COLUMNS, 2).rows == {}
    (tmp_path / "other.csv").write_text("x,y\n1,2\n")
    with pytest.raises(Exception, match="resume"):
        RowStream(tmp_path / "other.csv", RUN_COLUMNS, 2, resume=True)


@pytest.mark.parametrize("args, option", [
    (("--alpha", "0:0.6"), "--alpha"), (("--alpha", "a:b:c"), "--alpha"), (("--alpha", "0:0.6:0"), "--alpha"),
    (("--alpha", "0.4", "--friction-scale", "0.5:1.5:0"), "--friction-scale"),
    (("--alpha", "0.4", "--cluster", "nohost"), "--cluster"),
    (("--alpha", "0.4", "--cluster", "127.0.0.1:1"), "--cluster"),
])
def test_map_answers_bad_input_with_one_line(tmp_path, args, option):
    proc = run_process("map", str(SCENE), *args, "--out", str(tmp_path / "m"))  # no Ray connected yet
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert proc.stderr.startswith("ungrasp-ompl: error: " + option) and "Traceback" not in proc.stderr
    assert not (tmp_path / "m").exists()


def test_the_map_command_writes_its_csv_and_picture(tmp_path):
    from conftest import assert_picture

    out = tmp_path / "m"
    proc = run_cli("map", "reference_asymmetric", "--alpha", "0.3:0.5:0.1", "--time", "0.3", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    rows = _rows(out / "map.csv")
    assert [(r["alpha"], r["friction_scale"], r["secure_path"], r["lattice_outcome"]) for r in rows] == [
        ("0.3", "1.0", "0", "goal_empty"), ("0.4", "1.0", "1", "solved"), ("0.5", "1.0", "1", "solved")]
    assert "map: 3/3 cells" in proc.stderr and "a secure path exists in 2" in proc.stdout
    assert_picture(out / "map.png", colours=((0.8, 0.8, 0.8),))


def test_a_map_with_a_planner_that_does_not_optimise_gives_the_optimum_beside_it(tmp_path):
    """RRTConnect's setup does not search the lattice optimum (nothing stops there), so each cell
    searches it to report it: every cell used to fail with an AttributeError instead."""
    from ungrasp_ompl import Scene
    from ungrasp_ompl.planning.atlas import SecurityAtlas, planning_box
    from ungrasp_ompl.planning.lattice import lattice_search

    result = run_map(SCENE, MapOptions(alphas=(0.47,), planner=PlannerOptions(planner="RRTConnect", time=0.3, seed=1),
                                       run=RunOptions(jobs=1), out=tmp_path / "m"))
    (cell,) = result.cells
    assert cell.task_status is TaskStatus.DONE, cell.error
    scene = Scene.from_file(SCENE)
    assert cell.lattice_optimum == pytest.approx(lattice_search(SecurityAtlas(scene, planning_box(scene)),
                                                                scene.goal.box()).cost, abs=1e-9)
    assert cell.planner_cost is not None and cell.planner_cost >= cell.lattice_optimum - 1e-9
