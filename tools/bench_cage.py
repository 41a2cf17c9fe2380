"""How long the energy-bounded cage takes: one state, and a whole plan's profile. Prints figures,
asserts nothing.

    python tools/bench_cage.py [SCENE ...] [--repeat 3]

For each scene (default: the shipped objects with a thickness) the exact lattice plan is sampled
as `cage` samples it (robustness.plan_samples) and Scene.cage runs over all samples (the profile)
and on each sample alone (one state: median and slowest), best of --repeat.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from ungrasp_ompl.planning.setup import lattice_plan
from ungrasp_ompl.robustness import plan_samples
from ungrasp_ompl.scene import Scene

SCENES = Path(__file__).resolve().parents[1] / "scenes"
DEFAULT = ("guitar_pick", "guitar_pick_1_5mm", "puzzle_piece", "fabric_chalk")


def _best(fn, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", default=DEFAULT, help="scene names or files (default: the shipped objects)")
    ap.add_argument("--repeat", type=int, default=3, help="timings per figure, the best kept (default 3)")
    args = ap.parse_args()
    for name in args.scenes:
        path = Path(name) if Path(name).suffix else SCENES / f"{name}.yaml"
        scene = Scene.from_file(path)
        plan = lattice_plan(scene)
        states = plan_samples(plan).states
        scene.cage(states[:1])  # scipy and the grid's first use outside the timing
        whole = _best(lambda: scene.cage(states), args.repeat)
        each = [_best(lambda q=q: scene.cage(q[None]), args.repeat) for q in states]
        print(f"{scene.name:<20} {len(states):3d} states: profile {whole:.2f} s; one state median "
              f"{1000 * statistics.median(each):.1f} ms, slowest {1000 * max(each):.1f} ms")


if __name__ == "__main__":
    main()
