"""What Ray costs a campaign: its overhead per task once the cluster is up, the cost of a map cell,
and a map on 2 workers against 1. Prints figures, asserts nothing.

    python tools/bench_ray.py [--cells-alpha 20] [--cells-friction 10] [--time 0.5] [--tasks 400]

1. overhead: --tasks empty tasks through RayRunner on a warm local cluster of 2 CPUs, on the pooled
   workers campaigns use (each seeded task reseeds OMPL), per task, with and without a deadline;
2. a map of cells-alpha x cells-friction cells of reference_asymmetric (alpha 0.005 ... by 0.03,
   friction scale 0.6 ... by 0.1) on a local cluster of 1 CPU, then of 2 CPUs: wall time, time
   per cell, speed-up. A cell is the lattice verdict and a seeded RRT* run of --time seconds.

It writes no results file (docs/cli.md, "Campaigns on a cluster", says how to run on one); the
machine's load while it runs (other processes) lowers the speed-up.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from contextlib import closing
from dataclasses import replace
from pathlib import Path

import ray

from ungrasp_ompl.benchmark.map import MapOptions, run_map
from ungrasp_ompl.parallel import RunOptions
from ungrasp_ompl.parallel.runner import RayRunner
from ungrasp_ompl.planning.setup import PlannerOptions

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "reference_asymmetric.yaml"


def _empty(task: int) -> int:
    return task


def _start(cpus: int) -> None:
    ray.init(address="local", num_cpus=cpus, include_dashboard=False, log_to_driver=False)


def overhead(tasks: int) -> None:
    """Seconds per empty task on a warm cluster of 2 CPUs, pooled workers, with and without a
    deadline (a deadline runs the task in a thread of its worker)."""
    _start(2)
    try:
        for deadline in (None, 60.0):
            runner = RayRunner("local", fresh=False)
            list(runner.run(_empty, range(4), deadline))  # warm: workers started, the function exported
            t0 = time.perf_counter()
            with closing(runner.run(_empty, range(tasks), deadline)) as outcomes:
                done = sum(1 for _ in outcomes)
            wall = time.perf_counter() - t0
            kind = "without a deadline" if deadline is None else f"with a {deadline:g} s deadline"
            print(f"overhead, pooled workers {kind}: {tasks} empty tasks in {wall:.2f} s = "
                  f"{1000 * wall / done:.1f} ms per task (2 CPUs)")
    finally:
        ray.shutdown()


def timed_map(cpus: int, alphas: int, frictions: int, time_s: float) -> float:
    """Wall time (s) of the map on a local cluster of cpus CPUs (started first, not timed)."""
    options = MapOptions(alphas=tuple(round(0.005 + 0.03 * k, 10) for k in range(alphas)),
                         friction_scales=tuple(round(0.6 + 0.1 * k, 10) for k in range(frictions)),
                         planner=PlannerOptions(time=time_s, seed=1), run=RunOptions(seed=1, cluster="local"))
    _start(cpus)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            result = run_map(SCENE, replace(options, out=tmp))
            wall = time.perf_counter() - t0
    finally:
        ray.shutdown()
    cells = len(result.cells)
    exists = sum(bool(c.secure_path) for c in result.cells)
    print(f"map of {cells} cells ({exists} with a secure path) on {cpus} CPU(s): {wall:.1f} s, "
          f"{wall / cells:.2f} s per cell wall, {cpus * wall / cells:.2f} CPU-s per cell")
    return wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tasks", type=int, default=400, help="empty tasks for the overhead (default 400)")
    ap.add_argument("--cells-alpha", type=int, default=20, help="alphas of the map (default 20)")
    ap.add_argument("--cells-friction", type=int, default=10, help="friction scales of the map (default 10)")
    ap.add_argument("--time", type=float, default=0.5, help="planning time per cell, s (default 0.5)")
    ap.add_argument("--skip-map", action="store_true", help="only the overhead")
    args = ap.parse_args()
    print(f"ray {ray.__version__}, {os.cpu_count()} logical CPUs, load average {os.getloadavg()[0]:.2f} at the start")
    overhead(args.tasks)
    if args.skip_map:
        return
    one = timed_map(1, args.cells_alpha, args.cells_friction, args.time)
    two = timed_map(2, args.cells_alpha, args.cells_friction, args.time)
    print(f"speed-up of 2 workers over 1: {one / two:.2f}x (load average {os.getloadavg()[0]:.2f} at the end)")


if __name__ == "__main__":
    main()
