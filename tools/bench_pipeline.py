"""Benchmark of the whole pipeline, scene file to exported trajectory files; prints, asserts nothing.

For each shipped scene with an outline (and any given on the command line), in one fresh process
per scene as a user runs it: load the scene, plan (seeded), time the plan on the UR5e with TOPPRA
and Ruckig, and export CSV, JSON, ROS 2 YAML and URScript. Prints each stage's time and the total.

    python tools/bench_pipeline.py [SCENE ...] [--time 1.0] [--seed 1]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_SCENES = ("guitar_pick", "guitar_pick_1_5mm", "puzzle_piece", "fabric_chalk")

_CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
from ungrasp_ompl import Scene, plan
from ungrasp_ompl.robot.export import export_all
from ungrasp_ompl.robot.pipeline import execute
t1 = time.perf_counter()
scene = Scene.from_file(sys.argv[1])
t2 = time.perf_counter()
result = plan(scene, seed=int(sys.argv[3]), time=float(sys.argv[4]))
t3 = time.perf_counter()
ex = execute(scene, result)
t4 = time.perf_counter()
export_all(ex.trajectory, sys.argv[2])
t5 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "scene": t2 - t1, "plan": t3 - t2, "setup": result.setup_time_s,
                  "planning": result.planning_time_s, "execute": t4 - t3, "export": t5 - t4,
                  "total_after_import": t5 - t1, "duration": ex.trajectory.duration,
                  "v_frac": ex.velocity_fraction, "a_frac": ex.acceleration_fraction}))
sys.stdout.flush()
import os; os._exit(0)
"""


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scenes", nargs="*", help="scene files (default: the shipped objects)")
    p.add_argument("--time", type=float, default=1.0, help="planning time given to each plan (s)")
    p.add_argument("--seed", type=int, default=1)
    args = p.parse_args()
    scenes = args.scenes or [str(ROOT / "scenes" / f"{n}.yaml") for n in DEFAULT_SCENES]
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    print(f"{'scene':<22} {'import':>7} {'plan':>6} {'(setup':>7} {'search)':>8} {'execute':>8} {'export':>7} "
          f"{'total':>6}  trajectory")
    for scene in scenes:
        with tempfile.TemporaryDirectory() as out:
            proc = subprocess.run([sys.executable, "-c", _CHILD, scene, out, str(args.seed), str(args.time)],
                                  env=env, capture_output=True, text=True)
        if proc.returncode != 0:
            print(f"{Path(scene).stem:<22} failed: {proc.stderr.strip().splitlines()[-1]}")
            continue
        r = json.loads(proc.stdout.strip().splitlines()[-1])
        print(f"{Path(scene).stem:<22} {r['import']:7.2f} {r['plan']:6.2f} {r['setup']:7.2f} {r['planning']:8.2f} "
              f"{r['execute']:8.2f} {r['export']:7.2f} {r['total_after_import']:6.2f}  {r['duration']:.2f} s, "
              f"peak {100 * r['v_frac']:.0f}% vel / {100 * r['a_frac']:.0f}% acc")
    print("times in seconds; total = scene file to exported files, after the imports")


if __name__ == "__main__":
    main()
