"""Speed of simulated execution: wall time of one trial and the real-time factor, per object.

    python tools/bench_sim.py [--repeat N]

Plans each shipped object once (RRT*, seed 1), builds its trajectory, then times N whole trials
without perturbation (model compile, settle, drive, rest; poses recorded, so that a trial runs to
the end even where it fails) and prints the best and median wall time and the median CPU time of
this process (on a machine shared with other work, the CPU time is what one free core takes).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ungrasp_ompl import Scene  # noqa: E402
from ungrasp_ompl.planning import plan  # noqa: E402
from ungrasp_ompl.robot.pipeline import execute  # noqa: E402
from ungrasp_ompl.perturbation import TrialParams  # noqa: E402
from ungrasp_ompl.sim.setup import trial_setup  # noqa: E402
from ungrasp_ompl.sim.trial import run_trial  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    print(f"{'object':<14} {'simulated s':>11} {'wall s (best)':>13} {'wall s (median)':>15} {'CPU s (median)':>14} "
          f"{'real-time factor':>16}")
    for name in ("guitar_pick", "puzzle_piece", "fabric_chalk"):
        scene = Scene.from_file(ROOT / "scenes" / f"{name}.yaml")
        result = plan(scene, planner="RRTstar", time=1.0, seed=1)
        ex = execute(scene, result)
        setup = trial_setup(scene, result, ex.trajectory, ex.robot)
        walls, cpus, sim = [], [], 0.0
        for _ in range(args.repeat):
            t, c = time.perf_counter(), time.process_time()
            r = run_trial(setup, TrialParams(), record=[])  # recorded: a failing trial still runs to the end
            walls.append(time.perf_counter() - t)
            cpus.append(time.process_time() - c)
            sim = r.sim_time_s
        med = statistics.median(walls)
        print(f"{name:<14} {sim:>11.2f} {min(walls):>13.3f} {med:>15.3f} {statistics.median(cpus):>14.3f} "
              f"{sim / med:>16.1f}")


if __name__ == "__main__":
    main()
