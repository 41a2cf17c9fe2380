"""How far the tangram's pieces reach behind G at their start, and how low a start the hand allows:
the shipped layout tiled with lattice plans (seed 1, as the campaign's lattice row), and per piece
in the tiling's order:

- the free room behind G its approach has: the ray cast the tiler ranks approaches by, from G and
  from half the digits' width to either side of it, back along GB to the frame's walls and the
  pieces down at their targets (mm; layout.tiler.approaches);
- how far the piece's edge face reaches behind G at the start's tilt: its top edge lies t sin theta
  behind G where G touches the table (mm), and the room that leaves (mm);
- how far back the `paper` errors' grasp may carry the piece's rear at their bounds: the shift along
  GB, and the turn about G over the outline's farthest corner on G's line across GB (mm);
- the lowest start tilt, in whole degrees from the layout's down to the goal's theta_max, at which
  the start state (the layout's d and psi) can be held: kinematically valid, force-closed and free
  of the table, the walls and the pieces down grown by placed_clearance (Scene.diagnose); how far
  back the edge face reaches there (mm); and what the tilt a degree below it fails on (its state
  class and the solids it meets).

It asserts nothing.

    python tools/tangram_starts.py [--results]

--results writes the study into docs/results/tangram_starts.json (the markdown beside it rendered
from it).
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

from ungrasp_ompl.layout.model import Layout  # noqa: E402
from ungrasp_ompl.layout.tiler import TilingOptions, tile  # noqa: E402
from ungrasp_ompl.planning.setup import PlannerOptions  # noqa: E402
from ungrasp_ompl.scene.model import StateClass  # noqa: E402
from ungrasp_ompl.scene.perturbation import PRESETS  # noqa: E402
from ungrasp_ompl.shipped import resolve  # noqa: E402

RESULTS = ROOT / "docs" / "results" / "tangram_starts.json"
FORMATS = {"order": "{}", "room_behind_g_mm": "{:.2f}", "start_deg": "{:.0f}", "reach_behind_g_mm": "{:.2f}",
           "room_left_mm": "{:.2f}", "grasp_reach_mm": "{:.2f}", "lowest_start_deg": "{:.0f}",
           "reach_at_lowest_mm": "{:.2f}"}


def lowest_start(scene) -> tuple[int | None, str]:
    """The lowest whole-degree tilt, from the scene's start down to its goal's theta_max, at which
    the start (its d and psi) can be held, and what the tilt a degree below fails on."""
    theta0, d0, psi0 = (float(x) for x in scene.start)
    floor = math.ceil(math.degrees(scene.goal.box()[1][0]))
    lowest, below = None, "-"
    for deg in range(round(math.degrees(theta0)), floor - 1, -1):
        found = scene.diagnose(np.array([math.radians(deg), d0, psi0]))
        if found.state_class is not StateClass.HELD:
            what = ", ".join(found.contacts) or ", ".join(found.failed_checks)
            below = f"{found.state_class.name.lower()}: {what}" if what else found.state_class.name.lower()
            break
        lowest = deg
    return lowest, below


def grasp_reach(placement) -> float:
    """How far back (m) the `paper` errors' grasp may carry the piece's rear at their bounds: its shift
    along GB, and its turn about G over the outline's corners on G's line across GB (or behind it)."""
    errors = PRESETS["paper"]
    g, b = np.asarray(placement.approach.g, dtype=float), np.asarray(placement.approach.b, dtype=float)
    u = (b - g) / np.linalg.norm(b - g)
    rel = np.asarray(placement.scene.object3d.outline.vertices, dtype=float) - g
    rear = rel[rel @ u <= 1e-6]
    lever = float(np.abs(rear @ np.array([-u[1], u[0]])).max(initial=0.0))
    return errors.shift_mm / 1000 + lever * math.sin(math.radians(errors.yaw_deg))


def study(seed: int) -> list[dict]:
    """One row per piece, in the tiling's order (see the module docstring)."""
    layout = Layout.from_file(resolve("tangram", "layout"))
    tiling = tile(layout, TilingOptions(planner=PlannerOptions(planner="lattice", seed=seed)))
    if not tiling.solved:
        raise SystemExit("the tangram found no tiling")
    rows = []
    for p in tiling.placements:
        theta0 = float(p.scene.start[0])
        thickness = p.scene.object3d.thickness  # the edge face reaches thickness sin(theta) behind G
        reach = thickness * math.sin(theta0)
        lowest, below = lowest_start(p.scene)
        rows.append({"label": p.name, "order": p.order, "room_behind_g_mm": round(p.approach.room_g * 1000, 3),
                     "start_deg": round(math.degrees(theta0), 3), "reach_behind_g_mm": round(reach * 1000, 3),
                     "room_left_mm": round((p.approach.room_g - reach) * 1000, 3),
                     "grasp_reach_mm": round(grasp_reach(p) * 1000, 3), "lowest_start_deg": lowest,
                     "reach_at_lowest_mm": None if lowest is None else
                     round(thickness * math.sin(math.radians(lowest)) * 1000, 3),
                     "a_degree_below": below})
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=1, help="the lattice plans' seed (default 1, the campaign's)")
    ap.add_argument("--results", action="store_true", help="write docs/results/tangram_starts.json")
    args = ap.parse_args()
    t0 = time.perf_counter()
    rows = study(args.seed)
    for r in rows:
        print(r)
    if args.results:
        from campaign_results import merge_study

        command = "python tools/tangram_starts.py " + shlex.join(sys.argv[1:])
        merge_study(RESULTS, "starts", command.strip(), time.perf_counter() - t0, rows, FORMATS,
                    "How far the tangram's pieces reach behind G at their start, and how low a start the hand allows")
    return 0


if __name__ == "__main__":
    sys.exit(main())
