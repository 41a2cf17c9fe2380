"""The paper's experiments (sec. 6.2) as simulation campaigns, with the paper's figures beside ours.

    python tools/sim_campaigns.py [--trials N] [--jobs N] [--seed S] [--only base,edge,...]

Campaigns: base (three objects, rounded fingertip), edge (the same, flat fingertip), subset
(the 1.5 mm pick run with the 0.96 mm pick's motion), caging (the plan started with psi
larger, rounded against flat fingertip), and the negative controls (equal digits; a fifth of
the friction). Every plan is RRT*'s with the seed; every trial draws the `paper` perturbation
unless the campaign says otherwise. Prints one markdown table.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ungrasp_ompl import Scene  # noqa: E402
from ungrasp_ompl.planning import plan  # noqa: E402
from ungrasp_ompl.robot.pipeline import execute  # noqa: E402
from ungrasp_ompl.sim.campaign import deviated_plan, plan_problems, simulate  # noqa: E402
from ungrasp_ompl.sim.perturb import PRESETS  # noqa: E402
from ungrasp_ompl.sim.setup import Variant, trial_setup  # noqa: E402

SCENES = ROOT / "scenes"
OBJECTS = ("guitar_pick", "puzzle_piece", "fabric_chalk")
#: Extra psi at the start of the caging campaign (deg).
CAGING_PSI_DEG = 15.0


def _scene(name: str, tip: str | None = None) -> Scene:
    scene = Scene.from_file(SCENES / f"{name}.yaml")
    if tip is not None:
        dg = scene.digits
        scene = replace(scene, digits=replace(dg, flat_finger_tip=tip == "flat",
                                              finger_tip_radius=0.0 if tip == "flat" else dg.finger_tip_thickness / 2))
    return scene


def run(name: str, trials: int, jobs: int, seed: int, tip: str | None = None, variant: Variant = Variant(),
        psi_offset_deg: float | None = None, perturb: str = "paper"):
    """One campaign row: plan, execute, simulate; returns (report, the model's verdict on the plan)."""
    scene = _scene(name, tip)
    result = plan(scene, planner="RRTstar", time=1.0, seed=seed)
    if not result.solved:
        raise SystemExit(f"{name}: {result.reason}")
    if psi_offset_deg:
        result = deviated_plan(result, math.radians(psi_offset_deg))
    problems = plan_problems(scene, result)
    ex = execute(scene, result)
    setup = trial_setup(scene, result, ex.trajectory, ex.robot, variant)
    report = simulate(setup, PRESETS[perturb], trials, seed, jobs, scene=name, variant=variant)
    return report, problems


def tangram(attempts: int, jobs: int, seed: int, tip: str) -> tuple[int, int, str]:
    """The shipped tangram tiled (exact lattice plans), then simulated attempt by attempt."""
    import collections

    import yaml

    from ungrasp_ompl.layout import Layout
    from ungrasp_ompl.robot.pipeline import execute_sequence
    from ungrasp_ompl.sim.tiling import simulate_tiling, tiling_setups
    from ungrasp_ompl.tiling import TilingOptions, tile

    doc = yaml.safe_load((SCENES / "tangram.yaml").read_text())
    doc["digits"]["finger_tip"] = tip
    layout = Layout.from_dict(doc, source="tangram.yaml")
    tiling = tile(layout, TilingOptions(planner="lattice", seed=seed))
    ex = execute_sequence([(p.scene, p.plan) for p in tiling.placements], labels=[p.name for p in tiling.placements])
    results = simulate_tiling(layout, tiling_setups(layout, tiling, ex.trajectory, ex.robot), PRESETS["paper"],
                              attempts, seed, jobs)
    causes = collections.Counter(a.cause().split(" at ")[0] for a in results if not a.success)
    return sum(a.success for a in results), attempts, "; ".join(f"{n} {c}" for c, n in causes.most_common()) or "-"


def _row(label: str, report, paper: str, problems: list[str]) -> str:
    s = report.to_dict()
    err = s["position_error_mm"]
    errs = f"{err['mean']:.2f} / {err['max']:.2f}" if err["mean"] is not None else "-"
    causes = "; ".join(f"{n} {c}" for c, n in report.causes().items()) or "-"
    model = "secure" if not problems else "rejected: " + problems[0].split(": ", 1)[1][:60]
    return f"| {label} | {report.successes}/{len(report.trials)} | {errs} | {paper} | {model} | {causes} |"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=40, help="trials per row (default 40)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--only", default="base,edge,subset,caging,controls,tangram")
    ap.add_argument("--attempts", type=int, default=10, help="tangram attempts per row (default 10)")
    args = ap.parse_args()
    only = set(args.only.split(","))
    n, j, s = args.trials, args.jobs, args.seed
    started = time.perf_counter()
    print("| campaign | ours: placed | error mm (mean / max) | paper | the model on the plan | failures |")
    print("|---|---|---|---|---|---|")
    if "base" in only:
        for name in OBJECTS:
            rep, pr = run(name, n, j, s, tip="rounded")
            print(_row(f"base: {name}, rounded tip", rep, "109/120 over the objects, mean < 2.6 mm", pr), flush=True)
    if "edge" in only:
        for name in OBJECTS:
            rep, pr = run(name, n, j, s, tip="flat")
            print(_row(f"edge contact: {name}, flat tip", rep, "better than point contact", pr), flush=True)
    if "subset" in only:
        thick = Scene.from_file(SCENES / "guitar_pick_1_5mm.yaml").object_thickness
        rep, pr = run("guitar_pick", n, j, s, variant=Variant(thickness=thick))
        print(_row("subset: 1.5 mm pick, 0.96 mm pick's motion", rep, "placed", pr), flush=True)
    if "caging" in only:
        for tip, paper in (("rounded", "4/40"), ("flat", "34/40")):
            rep, pr = run("guitar_pick", n, j, s, tip=tip, psi_offset_deg=CAGING_PSI_DEG)
            print(_row(f"caging: pick, start psi +{CAGING_PSI_DEG:g} deg, {tip} tip", rep, paper, pr), flush=True)
    if "controls" in only:
        rep, pr = run("guitar_pick", n, j, s, variant=Variant(equal_digits=True))
        print(_row("control: pick, equal digits", rep, "not placeable", pr), flush=True)
        rep, pr = run("guitar_pick", n, j, s, variant=Variant(friction_scale=0.2))
        print(_row("control: pick, a fifth of the friction", rep, "(must fail)", pr), flush=True)
    if "tangram" in only:
        for tip in ("rounded", "flat"):
            ok, total, causes = tangram(args.attempts, j, s, tip)
            print(f"| tangram, {tip} tip (lattice plans) | {ok}/{total} attempts | - | 9/10 | secure | {causes} |",
                  flush=True)
    print(f"\n{time.perf_counter() - started:.0f} s in all; {n} trials per row, seed {s}, {j} jobs")


if __name__ == "__main__":
    main()
