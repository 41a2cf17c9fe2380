"""How often the default planner solves a scene: seeds 1..N of `plan SCENE --seed S` (RRT*, the
default budget), each scene at its own planner range and, with --ranges, at others; the lattice
optimum beside the costs found. A margin plan whose planner finds no path in its budget takes the
lattice's widest (docs/decisions/0120): `found` counts the seeds whose planner found one itself.
With --objective margin, also how many plans keep the widest margin the lattice holds: the kept
plans, and those whose path is the planner's own (the rest took the lattice's widest path,
docs/decisions/0104).

    python tools/planner_reliability.py go_stone coin [--seeds 20] [--ranges 0.3,0.1] [--objective margin]
        [--results [--study NAME]]

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
from ungrasp_ompl.planning.result import PathSource  # noqa: E402
from ungrasp_ompl.planning.setup import DEFAULT_RANGE, plan  # noqa: E402

FORMATS = {"range": "{:.2f}", "solved": "{}", "found": "{}", "seeds": "{}", "cost": "{:.2f}",
           "lattice_optimum": "{:.2f}", "widest": "{}", "planner_widest": "{}", "bottleneck_deg": "{:.3f}"}


def reliability(name: str, seeds: int, planner_range: float | None, objective: str) -> dict:
    """The row of one scene at one range (None: the scene's own) under objective (cost: the
    scene's own where it names one): solved of seeds, found (by the planner itself), the costs
    found; with the margin objective,
    how many keep the lattice's widest margin (widest), and of those how many by the planner's own
    path (planner_widest)."""
    scene = Scene.from_file(name)
    used = planner_range if planner_range is not None else (scene.options.range or DEFAULT_RANGE["cost"])
    plans = [plan(scene, seed=s, range=used, objective=objective) for s in range(1, seeds + 1)]
    costs = [p.cost for p in plans if p.solved]
    optimum = next((p.lattice_optimum for p in plans if p.lattice_optimum is not None), None)
    if optimum is None:
        optimum = next((p.evidence.get("lattice_optimum") for p in plans if not p.solved), None)
    found = sum(p.solved and p.path_from is not PathSource.LATTICE_FALLBACK for p in plans)
    row = {"label": f"{name} range {used:.2f}", "scene": name, "range": used, "solved": len(costs), "found": found,
           "seeds": seeds,
           "cost": [min(costs), max(costs)] if costs else None, "lattice_optimum": optimum,
           "own_range": planner_range is None}
    if objective == "margin":
        forced = [p for p in plans if p.solved and p.margin_forced]
        row.update(label=f"{name} range {used:.2f}, margin", widest=len(forced),
                   planner_widest=sum(p.path_from not in (PathSource.LATTICE, PathSource.LATTICE_FALLBACK)
                                      for p in forced),
                   bottleneck_deg=next((p.margin_bottleneck_deg for p in plans if p.solved), None))
    return row


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--ranges", default="", help="other planner ranges to try, comma-separated (state units)")
    ap.add_argument("--results", action="store_true", help="write docs/results/planner_reliability.json")
    ap.add_argument("--objective", default=None, choices=("cost", "margin"),
                    help="the plans' objective (default: each scene's own)")
    ap.add_argument("--study", default="reliability", help="the study's name in the results file (default reliability)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    others = [float(x) for x in args.ranges.split(",") if x]
    rows = []
    for name in args.scenes:
        own = reliability(name, args.seeds, None, args.objective)
        new = [own] + [reliability(name, args.seeds, r, args.objective) for r in others
                       if abs(r - own["range"]) > 1e-12]
        rows += new
        for r in new:
            widest = f", widest margin {r['widest']} ({r['planner_widest']} the planner's own)" if "widest" in r else ""
            print(f"{r['label']}: {r['solved']}/{r['seeds']} ({r['found']} found by the planner), cost {r['cost']}, "
                  f"optimum {r['lattice_optimum']}{widest}", flush=True)
    if args.results:
        from campaign_results import merge_study

        command = "python tools/planner_reliability.py " + shlex.join(sys.argv[1:])
        merge_study(ROOT / "docs" / "results" / "planner_reliability.json", args.study, command,
                    time.perf_counter() - t0, rows, FORMATS, "How often the default planner solves a scene",
                    prefixed=args.study != "reliability")
    return 0


if __name__ == "__main__":
    sys.exit(main())
