"""Does a plan's tolerance (docs/model.md, section 4.6) predict its simulated success? Plans of
each object scene by the lattice and by RRT* over several seeds, with the cost, margin, balanced
and tolerance objectives, each simulated under the `paper` perturbation; beside each its tolerance.

    python tools/tolerance_study.py [--seeds N] [--trials N] [--jobs N] [--scenes a,b] [--out DIR]
                                    [--setup shipped|bare]

Every plan's plan.json and every trial (its outcome, phase and drawn errors) are written to DIR
(default tolerance_study/) as they are simulated: plans.csv and trials.csv. A second run with
the same DIR simulates only the plans not there yet, so the tolerance can be recomputed after a
change of its definition without simulating again. Prints one markdown row per plan, then
Spearman's rank correlation of the success count with the tolerance, pooled and per scene, and
beside it with B's least distance from the thumb's tip along the path (mm, the kinematic margin
`thumb_tip`), the measure the failed trials point to (docs/model.md 4.6). Last, per scene, a
chi-square test of whether its plans' success rates differ at all: where they do not, no measure
of the plan can rank them, whatever its definition. A statistic that is undefined (every plan
with the same measure, or the same successes) is printed as "-".

--setup bare plans and simulates the same scenes without the set-up that makes the shipped plans
robust (no clearance over the table, no margin from the thumb's tip or inside the supports across
the plane, no start press), into the same DIR beside the shipped set-up's plans: the rows and the
correlations then cover both, and per scene and set-up, so that the measure meets plans that differ.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy.stats import chi2_contingency, spearmanr

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ungrasp_ompl import Scene  # noqa: E402
from ungrasp_ompl.mechanics.margin import kinematic_margins  # noqa: E402
from ungrasp_ompl.planning import plan  # noqa: E402
from ungrasp_ompl.mechanics.path import plan_samples  # noqa: E402
from ungrasp_ompl.planning.result import Plan  # noqa: E402
from ungrasp_ompl.planning.plan_tolerance import tolerance  # noqa: E402

OBJECTS = ("guitar_pick", "puzzle_piece", "fabric_chalk")
OBJECTIVES = ("cost", "margin", "balanced", "tolerance")
PLAN_FIELDS = ("key", "scene", "planner", "seed", "objective", "cost", "trials", "successes")


SETUPS = ("shipped", "bare")


def plan_key(scene: str, planner: str, seed: int | None, objective: str, setup: str = "shipped") -> str:
    stem = scene if setup == "shipped" else f"{scene}+{setup}"
    return f"{stem}-{planner}-{seed if seed is not None else 'x'}-{objective}"


def load_scene(name: str, setup: str) -> Scene:
    """The shipped object scene NAME run open loop (no touch-off: the tolerance's box holds the
    arm's whole calibration error, docs/model.md 4.6 and 11.14), or with setup bare also without
    its clearances, margins and press."""
    import yaml

    path = ROOT / "scenes" / f"{name}.yaml"
    doc = yaml.safe_load(path.read_text())
    robot = doc.setdefault("robot", {})
    robot["touch_off"] = False
    if setup == "shipped":
        return Scene.from_dict(doc, source=f"{path.name}, open loop")
    doc.setdefault("planning", {}).update(table_clearance=0.0, thumb_tip_margin=0.0, across_margin=0.0)
    robot.pop("end_press", None)
    robot["start_press"] = 0.0
    return Scene.from_dict(doc, source=f"{path.name}, bare set-up")


def simulate_plan(scene: Scene, result: Plan, trials: int, jobs: int):
    """The trials of one plan under the paper perturbation, seed 1."""
    from ungrasp_ompl.parallel import RunOptions
    from ungrasp_ompl.scene.perturbation import PRESETS
    from ungrasp_ompl.sim.campaign import simulate
    from ungrasp_ompl.sim.plan_trials import placement

    return simulate(placement(scene, result)[1], PRESETS["paper"], trials, RunOptions(seed=1, jobs=jobs),
                    scene=scene.name)


def thumb_tip_mm(scene: Scene, result: Plan) -> float:
    """B's least distance from the thumb's tip over the plan's sampled states, mm."""
    q = plan_samples(result, np.asarray(scene.options.resolution)).states
    return 1000 * float(kinematic_margins(q[:, 0], q[:, 1], q[:, 2], scene.digits, scene.object_length)["thumb_tip"].min())


def _append(path: Path, fields: list[str], rows: list[dict]) -> None:
    new = not path.exists()
    with path.open("a", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        if new:
            w.writeheader()
        w.writerows(rows)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=3, help="RRT* seeds 1..N per objective")
    ap.add_argument("--trials", type=int, default=40, help="simulated trials per plan (seed 1)")
    ap.add_argument("--jobs", type=int, default=1, help="simulation workers")
    ap.add_argument("--scenes", default=",".join(OBJECTS), help="comma-separated shipped object scenes")
    ap.add_argument("--out", default="tolerance_study", help="directory for plans and trials (reused)")
    ap.add_argument("--no-simulate", action="store_true", help="only the plans already simulated in --out")
    ap.add_argument("--setup", choices=SETUPS, default="shipped",
                    help="plan and simulate this set-up (bare: no clearances, margins or press); the rows of "
                         "every set-up already in --out are reported too")
    args = ap.parse_args()
    out = Path(args.out)
    (out / "plans").mkdir(parents=True, exist_ok=True)
    done = {}
    if (out / "plans.csv").exists():
        with (out / "plans.csv").open() as f:
            done = {r["key"]: r for r in csv.DictReader(f)}
    rows = []
    print("| scene | planner | seed | objective | cost | tolerance | shift mm | binds | component | B to thumb tip mm "
          "| placed |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    names = args.scenes.split(",")
    scenes = {(name, setup): load_scene(name, setup) for name in names for setup in SETUPS}
    runs = [("lattice", None)] + [("RRTstar", s) for s in range(1, args.seeds + 1)]
    # the objects in turn, so that a run stopped early has plans of each
    order = [(name, planner, seed, objective, setup) for setup in SETUPS for planner, seed in runs
             for objective in OBJECTIVES for name in names]
    for name, planner, seed, objective, setup in order:
        scene = scenes[name, setup]
        key = plan_key(name, planner, seed, objective, setup)
        label = name if setup == "shipped" else f"{name}, {setup}"
        path = out / "plans" / f"{key}.json"
        if key in done and path.exists():
            result = Plan.from_dict(json.loads(path.read_text()))
            successes, trials = int(done[key]["successes"]), int(done[key]["trials"])
        elif args.no_simulate or setup != args.setup:
            continue
        else:
            result = plan(scene, planner=planner, time=1.0, seed=seed, objective=objective)
            if not result.solved:
                print(f"<!-- {key}: {result.reason} -->", flush=True)
                continue
            path.write_text(result.to_json())
            report = simulate_plan(scene, result, args.trials, args.jobs)
            successes, trials = report.successes, len(report.trials)
            trial_rows = []
            for t in report.trials:
                trial_rows.append({"key": key, "trial": t.trial, "outcome": t.outcome.value,
                                   "phase": t.phase or "", "position_error_mm": t.position_error_mm,
                                   **t.params})
            _append(out / "trials.csv", list(trial_rows[0]), trial_rows)
            _append(out / "plans.csv", list(PLAN_FIELDS),
                    [{"key": key, "scene": label, "planner": planner, "seed": seed, "objective": objective,
                      "cost": result.cost, "trials": trials, "successes": successes}])
        tol = tolerance(scene, result)
        tip = thumb_tip_mm(scene, result)
        rows.append((name, planner, seed, objective, result.cost, tol, successes, trials, tip, label))
        print(f"| {label} | {planner} | {seed if seed is not None else '-'} | {objective} | {result.cost:.1f} | "
              f"{tol.scale:.3f} | {tol.physical['shift_mm']:.3f} | {tol.reason.value} | {tol.component} | {tip:.2f} | "
              f"{successes}/{trials} |", flush=True)
    print()
    print("| scene | plans | rho(tolerance, successes) | rho(B to thumb tip, successes) | plans differ (chi-square p) |")
    print("|---|---|---|---|---|")
    several = len({r[9] for r in rows}) > len({r[0] for r in rows})  # more than one set-up: each alone too
    groups = {"pooled": rows, **{f"{n}, every set-up" if several else n: [r for r in rows if r[0] == n]
                                 for n in dict.fromkeys(r[0] for r in rows)}}
    if several:
        groups.update({n: [r for r in rows if r[9] == n] for n in dict.fromkeys(r[9] for r in rows)})
    for name, got in groups.items():
        y = [r[6] for r in got]
        rhos = [spearmanr(x, y).statistic if len(set(x)) > 1 and len(set(y)) > 1 else math.nan
                for x in ([r[5].scale for r in got], [r[8] for r in got])]
        table = [[r[6], r[7] - r[6]] for r in got]
        differ = chi2_contingency(table).pvalue if name != "pooled" and 0 < sum(y) < sum(r[7] for r in got) else math.nan
        print(f"| {name} | {len(got)} | {_shown(rhos[0], '+.2f')} | {_shown(rhos[1], '+.2f')} | {_shown(differ, '.3f')} |")
    return 0


def _shown(value: float, spec: str) -> str:
    """A statistic for the table, or '-' where it is undefined (nan: the measure, or the successes,
    are the same for every plan of the row)."""
    return "-" if math.isnan(value) else format(value, spec)


if __name__ == "__main__":
    sys.exit(main())
