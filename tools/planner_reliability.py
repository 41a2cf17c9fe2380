"""How often the default planner solves a scene: seeds 1..N of `plan SCENE --seed S` (RRT*, the
default budget), each scene at its own planner range and, with --ranges, at others; the lattice
optimum beside the costs found.

    python tools/planner_reliability.py go_stone coin [--seeds 20] [--ranges 0.3,0.1] [--results [--study NAME]]

--results writes the study into docs/results/planner_reliability.json (the markdown beside it
rendered from it), where docs/model.md quotes it.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from ungrasp_ompl import Scene  # noqa: E402
from ungrasp_ompl.planning.setup import DEFAULT_RANGE, plan  # noqa: E402

FORMATS = {"range": "{:.2f}", "solved": "{}", "seeds": "{}", "cost": "{:.2f}", "lattice_optimum": "{:.2f}"}


def reliability(name: str, seeds: int, planner_range: float | None) -> dict:
    """The row of one scene at one range (None: the scene's own): solved of seeds, the costs found."""
    scene = Scene.from_file(name)
    used = planner_range if planner_range is not None else (scene.options.range or DEFAULT_RANGE["cost"])
    plans = [plan(scene, seed=s, range=used) for s in range(1, seeds + 1)]
    costs = [p.cost for p in plans if p.solved]
    optimum = next((p.lattice_optimum for p in plans if p.lattice_optimum is not None), None)
    if optimum is None:
        optimum = next((p.evidence.get("lattice_optimum") for p in plans if not p.solved), None)
    return {"label": f"{name} range {used:.2f}", "scene": name, "range": used, "solved": len(costs), "seeds": seeds,
            "cost": [min(costs), max(costs)] if costs else None, "lattice_optimum": optimum,
            "own_range": planner_range is None}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--ranges", default="", help="other planner ranges to try, comma-separated (state units)")
    ap.add_argument("--results", action="store_true", help="write docs/results/planner_reliability.json")
    ap.add_argument("--study", default="reliability", help="the study's name in the results file (default reliability)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    others = [float(x) for x in args.ranges.split(",") if x]
    rows = []
    for name in args.scenes:
        own = reliability(name, args.seeds, None)
        new = [own] + [reliability(name, args.seeds, r) for r in others if abs(r - own["range"]) > 1e-12]
        rows += new
        for r in new:
            print(f"{r['label']}: {r['solved']}/{r['seeds']}, cost {r['cost']}, optimum {r['lattice_optimum']}",
                  flush=True)
    if args.results:
        from campaign_results import merge_study

        command = "python tools/planner_reliability.py " + shlex.join(sys.argv[1:])
        if args.study != "reliability":  # a row's key is unique in the file: another study's rows say whose they are
            rows = [{**r, "label": f"{args.study}: {r['label']}"} for r in rows]
        merge_study(ROOT / "docs" / "results" / "planner_reliability.json", args.study, command,
                    time.perf_counter() - t0, rows, FORMATS, "How often the default planner solves a scene")
    return 0


if __name__ == "__main__":
    sys.exit(main())
