"""How deep the simulated contacts sink: the object scenes' base plans (RRT*, seed 1, as the
campaign plans them) run under the `paper` errors for the trial seeds given, 40 trials each, and
the deepest any control tick of the primitives sank into a digit or the table, per object: the
deepest, the 95th percentile and the median, and the bound, the deepest over all objects rounded
up to the next hundredth of a millimetre. tests/test_sinking.py holds trials of another seed to
that bound.

    python tools/sinking_bound.py [--seeds 1,2,3] [--trials 40] [--jobs 2] [--results]

--results writes the study into docs/results/sinking.json (the markdown beside it rendered from it).
"""

from __future__ import annotations

import argparse
import math
import shlex
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from ungrasp_ompl import Scene  # noqa: E402
from ungrasp_ompl.parallel import RunOptions  # noqa: E402
from ungrasp_ompl.planning import plan  # noqa: E402
from ungrasp_ompl.scene.perturbation import PRESETS  # noqa: E402
from ungrasp_ompl.sim.campaign import simulate  # noqa: E402
from ungrasp_ompl.sim.plan_trials import placement  # noqa: E402

OBJECTS = ("guitar_pick", "puzzle_piece", "fabric_chalk")
FORMATS = {"trials": "{}", "deepest_mm": "{:.3f}", "p95_mm": "{:.3f}", "median_mm": "{:.3f}", "bound_mm": "{:.2f}"}
RESULTS = ROOT / "docs" / "results" / "sinking.json"


def depths(name: str, seeds: list[int], trials: int, jobs: int) -> list[float]:
    """The deepest sinking (mm) of each trial of the object's base plan, over the trial seeds."""
    scene = Scene.from_file(name)
    result = plan(scene, planner="RRTstar", time=1.0, seed=1)
    setup = placement(scene, result)[1].to_release()  # the ticks that measure the sinking, and no more
    return [t.max_penetration_mm for s in seeds
            for t in simulate(setup, PRESETS["paper"], trials, RunOptions(seed=s, jobs=jobs), scene=name).trials]


def bound_of(deepest_mm: float) -> float:
    """The bound a measured deepest sinking gives: rounded up to the next hundredth of a millimetre."""
    return math.ceil(deepest_mm * 100.0 - 1e-9) / 100.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="1,2,3", help="the trial seeds, comma-separated")
    ap.add_argument("--trials", type=int, default=40, help="trials per seed and object")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--results", action="store_true", help="write docs/results/sinking.json")
    args = ap.parse_args()
    seeds = [int(x) for x in args.seeds.split(",") if x]
    t0 = time.perf_counter()
    rows = []
    for name in OBJECTS:
        d = np.asarray(depths(name, seeds, args.trials, args.jobs))
        rows.append({"label": name, "trials": int(d.size), "deepest_mm": float(d.max()),
                     "p95_mm": float(np.percentile(d, 95)), "median_mm": float(np.median(d))})
        print(f"{name}: {d.size} trials, deepest {d.max():.3f} mm, 95th percentile {np.percentile(d, 95):.3f} mm",
              flush=True)
    deepest = max(r["deepest_mm"] for r in rows)
    rows.append({"label": "the bound", "trials": sum(r["trials"] for r in rows), "deepest_mm": deepest,
                 "bound_mm": bound_of(deepest)})
    print(f"bound: {bound_of(deepest):.2f} mm")
    if args.results:
        from campaign_results import merge_study

        command = "python tools/sinking_bound.py " + shlex.join(sys.argv[1:])
        merge_study(RESULTS, "sinking", command, time.perf_counter() - t0, rows, FORMATS,
                    "How deep the simulated contacts sink")
    return 0


if __name__ == "__main__":
    sys.exit(main())
