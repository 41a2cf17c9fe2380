"""Which margin of a plan predicts its simulated success: plans of each object scene by the lattice
and by RRT* over several seeds, with the cost and the margin objective, each simulated under the
`paper` perturbation, and beside each its smallest friction margin and its kinematic margins
along the legs where a contact slides (docs/model.md, section 4.4).

    python tools/margin_study.py [--seeds N] [--trials N] [--jobs N] [--scenes a,b]

Prints one markdown row per plan, then per scene Spearman's rank correlation of the success count
with each margin (ties averaged; a constant column gives nan).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ungrasp_ompl import Scene  # noqa: E402
from ungrasp_ompl.parallel import RunOptions  # noqa: E402
from ungrasp_ompl.planning import plan  # noqa: E402
from ungrasp_ompl.robot.pipeline import execute  # noqa: E402
from ungrasp_ompl.sim.campaign import simulate  # noqa: E402
from ungrasp_ompl.scene.perturbation import PRESETS  # noqa: E402
from ungrasp_ompl.sim.setup import trial_setup  # noqa: E402

OBJECTS = ("guitar_pick", "puzzle_piece", "fabric_chalk")
#: Samples per leg when the kinematic margins are taken along it.
SAMPLES = 40
FEATURES = ("friction_deg", "thumb_tip_mm", "table_mm", "slide_theta_deg")


def features(scene: Scene, result) -> dict[str, float]:
    """The plan's smallest friction margin (deg), and along its sliding legs (P_psi, P_dpsi) the
    smallest distance of B from the thumb's tip and of the digits from the table (mm) and the
    lowest theta (deg) at which a contact slides."""
    sliding = []
    for p in result.primitives:
        if p.type == "P_theta":
            continue
        w = np.asarray(p.waypoints, dtype=float)
        sliding.append(np.concatenate([np.linspace(a, b, SAMPLES) for a, b in zip(w[:-1], w[1:])]))
    if not sliding:
        return {"friction_deg": result.min_margin_deg, "thumb_tip_mm": math.inf, "table_mm": math.inf,
                "slide_theta_deg": math.nan}
    q = np.concatenate(sliding)
    kin = scene.margin(q).kinematic
    return {"friction_deg": result.min_margin_deg, "thumb_tip_mm": float(kin["thumb_tip"].min() * 1000),
            "table_mm": float(kin["table"].min() * 1000), "slide_theta_deg": float(np.degrees(q[:, 0].min()))}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=5, help="RRT* seeds 1..N per objective")
    ap.add_argument("--trials", type=int, default=40, help="simulated trials per plan (seed 1)")
    ap.add_argument("--jobs", type=int, default=None, help="simulation workers (default: all cores)")
    ap.add_argument("--scenes", default=",".join(OBJECTS), help="comma-separated shipped object scenes")
    args = ap.parse_args()
    jobs = args.jobs or max(1, os.cpu_count() or 1)
    print("| scene | planner | seed | objective | cost | " + " | ".join(FEATURES) + " | placed |")
    print("|---|---|---|---|---|" + "---|" * len(FEATURES) + "---|")
    rows: dict[str, list[tuple[dict[str, float], int]]] = {}
    for name in args.scenes.split(","):
        scene = Scene.from_file(ROOT / "scenes" / f"{name}.yaml")
        runs = [("lattice", None)] + [("RRTstar", s) for s in range(1, args.seeds + 1)]
        for planner, seed in runs:
            for objective in ("cost", "margin"):
                result = plan(scene, planner=planner, time=1.0, seed=seed, objective=objective)
                if not result.solved:
                    print(f"| {name} | {planner} | {seed} | {objective} | {result.reason} |")
                    continue
                f = features(scene, result)
                ex = execute(scene, result)
                report = simulate(trial_setup(scene, result, ex.trajectory, ex.robot), PRESETS["paper"],
                                  args.trials, RunOptions(seed=1, jobs=jobs), scene=name)
                rows.setdefault(name, []).append((f, report.successes))
                print(f"| {name} | {planner} | {seed if seed is not None else '-'} | {objective} | {result.cost:.1f} | "
                      + " | ".join(f"{f[k]:.2f}" for k in FEATURES) + f" | {report.successes}/{args.trials} |",
                      flush=True)
    print()
    print("| scene | plans | " + " | ".join(f"rho({k})" for k in FEATURES) + " |")
    print("|---|---|" + "---|" * len(FEATURES))
    for name, got in rows.items():
        placed = [s for _, s in got]
        rhos = []
        for k in FEATURES:
            x = [f[k] for f, _ in got]
            rhos.append(spearmanr(x, placed).statistic if len(set(x)) > 1 and len(set(placed)) > 1 else math.nan)
        print(f"| {name} | {len(got)} | " + " | ".join(f"{r:+.2f}" for r in rhos) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
