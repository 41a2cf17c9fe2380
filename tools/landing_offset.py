"""Measure, per object scene, how far the release lands beyond what the model of the fall predicts.

The model (mechanics.release) sees the friction and nothing else of the set-up's errors; a grasp
turned a degree in the pinch, for one, moves the puzzle piece's mean landing a millimetre toward G
(tools/landing_errors.py, docs/model.md 11.17). robot.landing_offset keeps that part per object and
digits, as a cell would keep it from a few releases measured with a ruler: the modelled aim moves the
hand back by it beyond the model's offset (robot.pipeline.modelled_aim).

For each scene and each plan seed (RRT*, the scene's own objective; seeds 11, 12 and 13 by default,
none of them a campaign's plan), the plan's release is simulated unaimed, its mean landing taken
over --pairs antithetic pairs of `paper` draws in worlds of their own (friction x0.7-1.3 drawn, the
cones alternating: sim.landing.expected_landing, the draws from its own seed stream, which no
campaign trial reaches), and the model's mean over the same range (predict_landing) subtracted,
along GB. The scene's offset is the mean over its plans, rounded to 0.01 mm.

A layout (the tangram) keeps an offset per piece (pieces[i].landing_offset, record 0134): for each
plan seed the layout is tiled with RRT* plans (tile, piece k planned with seed + k), and each piece's
release is measured as above where the tiling puts it, unaimed, the walls the only other solids
(sim.tiling.tiling_setups); a piece's offset is the mean over the tilings.

    python tools/landing_offset.py [--scenes guitar_pick,puzzle_piece,fabric_chalk] [--plan-seeds 11,12,13]
                                   [--pairs 8] [--jobs 2] [--results] [--write-scenes]

--results writes docs/results/landing_offset.json (the markdown beside it rendered from it);
--write-scenes sets robot.landing_offset in each scene file, or landing_offset in each piece of a
layout's file (its other lines and comments kept).
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from landing_check import unaimed_scene  # noqa: E402
from ungrasp_ompl.io import edited_yaml, parse_yaml, write_text_atomic  # noqa: E402
from ungrasp_ompl.layout.model import Layout  # noqa: E402
from ungrasp_ompl.layout.tiler import TilingOptions, tile  # noqa: E402
from ungrasp_ompl.parallel import RunOptions  # noqa: E402
from ungrasp_ompl.planning import plan as make_plan  # noqa: E402
from ungrasp_ompl.planning.predicted_landing import predict_landing  # noqa: E402
from ungrasp_ompl.planning.setup import PlannerOptions  # noqa: E402
from ungrasp_ompl.robot.pipeline import execute_sequence  # noqa: E402
from ungrasp_ompl.sim.landing import expected_landing  # noqa: E402
from ungrasp_ompl.sim.plan_trials import placement  # noqa: E402
from ungrasp_ompl.sim.tiling import tiling_setups  # noqa: E402

SCENES = ("guitar_pick", "puzzle_piece", "fabric_chalk")
LAYOUTS = ("tangram",)
RESULTS = ROOT / "docs" / "results" / "landing_offset.json"
FORMATS = {**{k: "{:+.2f}" for k in ("model_mm", "sim_mm", "residual_mm", "offset_mm", "sim_across_mm")},
           "residual_sd_mm": "{:.2f}", "sim_turn_deg": "{:+.2f}", "pairs": "{}", "seconds": "{:.0f}",
           "minutes": "{:.0f}"}


def measured(name: str, seed: int, pairs: int, jobs: int) -> dict:
    """One plan's row: the model's mean landing along GB, the simulated mean, their difference (mm)."""
    scene = unaimed_scene(name)
    result = make_plan(scene, planner="RRTstar", time=1.0, seed=seed)
    if not result.solved:
        return {"label": f"{name}, plan seed {seed}", "scene": name, "plan_seed": seed, "unsolved": result.reason}
    row = {"label": f"{name}, plan seed {seed}", "scene": name, "plan_seed": seed}
    return {**row, **_landing(scene, result, placement(scene, result)[1], pairs, jobs)}


def measured_layout(name: str, seed: int, pairs: int, jobs: int) -> list[dict]:
    """Each piece's row (as measured's) in the layout's tiling with RRT* plans at seed, each release
    where the tiling puts it, unaimed, the walls the only other solids."""
    layout = Layout.from_file(ROOT / "scenes" / f"{name}.yaml")
    tiling = tile(layout, TilingOptions(planner=PlannerOptions(planner="RRTstar", seed=seed)))
    if not tiling.solved:
        return [{"label": f"{name}, plan seed {seed}", "scene": name, "plan_seed": seed,
                 "unsolved": f"no tiling: {tiling.failed_piece} cannot be placed"}]
    execution = execute_sequence([(p.scene, p.plan) for p in tiling.placements],
                                 labels=[p.name for p in tiling.placements])
    setups = tiling_setups(layout, tiling, execution.trajectory, execution.robot)
    return [{"label": f"{name} {p.name}, plan seed {seed}", "scene": name, "piece": p.name, "plan_seed": seed,
             **_landing(p.scene, p.plan, setup, pairs, jobs)} for p, (_, setup) in zip(tiling.placements, setups)]


def _landing(scene, result, setup, pairs: int, jobs: int) -> dict:
    """The plan's model mean landing along GB, the simulated mean of its unaimed release (setup)
    along and across GB and its turn, and their difference (mm, deg)."""
    model = predict_landing(scene, result)
    landing = expected_landing(setup, pairs, RunOptions(jobs=jobs))
    (ux, uy), (ox, oy) = model.direction, landing.offset
    along, across = ux * ox + uy * oy, ux * oy - uy * ox
    return {"primitives": " ".join(str(p.type) for p in result.primitives), "pairs": landing.pairs,
            "model_mm": model.along * 1e3, "sim_mm": along * 1e3, "sim_across_mm": across * 1e3,
            "sim_turn_deg": float(np.degrees(landing.turn)), "residual_mm": (along - model.along) * 1e3}


def offset_row(label: str, name: str, plans: list[dict]) -> tuple[float, dict]:
    """The offset (m, the plans' mean residual rounded to 0.01 mm) and its row; SystemExit when no
    plan was measured."""
    residuals = [p["residual_mm"] for p in plans if "residual_mm" in p]
    if not residuals:
        raise SystemExit(f"{label}: no plan solved")
    offset = round(float(np.mean(residuals)) * 1e-3, 5)
    print(f"{label}: landing_offset {offset * 1e3:+.2f} mm", flush=True)
    return offset, {"label": label, "scene": name, "offset_mm": offset * 1e3,
                    "residual_sd_mm": float(np.std(residuals, ddof=1)) if len(residuals) > 1 else None}


def write_offset(name: str, offset: float) -> Path:
    """Set robot.landing_offset (m) in the scene's file, every other line kept."""
    path = ROOT / "scenes" / f"{name}.yaml"
    text = path.read_text()
    robot = dict(parse_yaml(text).get("robot", {}))
    robot["landing_offset"] = offset
    write_text_atomic(path, edited_yaml(text, {"robot": robot}))
    return path


def write_piece_offsets(name: str, offsets: dict[str, float]) -> Path:
    """Set landing_offset (m) in each named piece of the layout's file, every other line kept: the
    entry is put after the piece's name line, or an existing one in its block rewritten."""
    path = ROOT / "scenes" / f"{name}.yaml"
    text = path.read_text()
    wanted = parse_yaml(text)
    for piece in wanted["pieces"]:
        if piece["name"] in offsets:
            piece["landing_offset"] = offsets[piece["name"]]
    lines, out, piece = text.splitlines(keepends=True), [], None
    for line in lines:
        if line.startswith("- name: "):
            piece = line[len("- name: "):].strip()
        elif not line.startswith("  "):
            piece = None
        if piece in offsets and line.startswith("  landing_offset:"):
            continue  # written again after the name
        out.append(line)
        if line.startswith("- name: ") and piece in offsets:
            out.append(f"  landing_offset: {offsets[piece]}\n")
    edited = "".join(out)
    if parse_yaml(edited) != wanted:
        raise SystemExit(f"{path}: its pieces could not be edited in place")
    write_text_atomic(path, edited)
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--plan-seeds", default="11,12,13", help="the plans' seeds, comma-separated")
    ap.add_argument("--pairs", type=int, default=8, help="antithetic pairs of drawn releases per plan (default 8)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--results", action="store_true", help="write docs/results/landing_offset.json and .md")
    ap.add_argument("--write-scenes", action="store_true", help="set robot.landing_offset in the scene files")
    args = ap.parse_args(argv)
    command = shlex.join(["python", "tools/landing_offset.py", *(sys.argv[1:] if argv is None else argv)])
    wall = time.perf_counter()
    rows = []
    seeds = [int(s) for s in args.plan_seeds.split(",")]
    for name in args.scenes.split(","):
        if name in LAYOUTS:
            plans = [row for s in seeds for row in measured_layout(name, s, args.pairs, args.jobs)]
        else:
            plans = [measured(name, s, args.pairs, args.jobs) for s in seeds]
        for p in plans:
            print(p["label"], "no plan" if "unsolved" in p else
                  f"model {p['model_mm']:+.2f} sim {p['sim_mm']:+.2f} residual {p['residual_mm']:+.2f} mm "
                  f"({p['pairs']} pairs)", flush=True)
        rows += plans
        if name in LAYOUTS:
            pieces = dict.fromkeys(p["piece"] for p in plans if "piece" in p)
            offsets = {}
            for piece in pieces:
                offsets[piece], row = offset_row(f"{name} {piece}", name, [p for p in plans if p.get("piece") == piece])
                rows.append({**row, "piece": piece})
            if args.write_scenes:
                print("wrote", write_piece_offsets(name, offsets))
            continue
        offset, row = offset_row(name, name, plans)
        rows.append(row)
        if args.write_scenes:
            print("wrote", write_offset(name, offset))
    if args.results:
        from campaign_results import merge_study

        scenes = args.scenes.split(",")  # the object scenes' study, or one of its own for other scenes
        study = "landing-offset" + ("" if set(scenes) <= set(SCENES) else "-" + "-".join(scenes))
        print("wrote", merge_study(RESULTS, study, command, time.perf_counter() - wall, rows, FORMATS,
                                   "tools/landing_offset.py: each scene's landing, and each layout piece's, "
                                   "beyond the model of the fall (docs/model.md 11.17)"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
