"""How long the energy-bounded cage takes: one state, and a whole plan's profile. Prints figures,
asserts nothing.

    python tools/bench_cage.py [SCENE ...] [--repeat 3]

For each scene (default: the shipped objects with a thickness) the exact lattice plan is sampled
as `cage` samples it (mechanics.path.plan_samples) and Scene.cage runs over all samples (the profile)
and on each sample alone (one state: median and slowest), best of --repeat. Each figure is wall
time, and in brackets the process's CPU time, which other work on a shared machine disturbs less.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from ungrasp_ompl.planning.setup import lattice_plan
from ungrasp_ompl.mechanics.path import plan_samples
from ungrasp_ompl.scene import Scene

SCENES = Path(__file__).resolve().parents[1] / "scenes"
DEFAULT = ("guitar_pick", "guitar_pick_1_5mm", "puzzle_piece", "fabric_chalk")


def _best(fn, repeat: int) -> tuple[float, float]:
    """The shortest wall time and the shortest CPU time of repeat runs of fn, s."""
    wall, cpu = float("inf"), float("inf")
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall, cpu = min(wall, time.perf_counter() - w0), min(cpu, time.process_time() - c0)
    return wall, cpu


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
        each = np.array([_best(lambda q=q: scene.cage(q[None]), args.repeat) for q in states]) * 1000
        print(f"{scene.name:<20} {len(states):3d} states: profile {whole[0]:.2f} s ({whole[1]:.2f}); one state "
              f"median {np.median(each[:, 0]):.1f} ms ({np.median(each[:, 1]):.1f}), slowest {each[:, 0].max():.1f} ms "
              f"({each[:, 1].max():.1f})")


if __name__ == "__main__":
    main()
