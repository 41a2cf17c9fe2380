"""How far the pinch's sliding contact walks across the plane, by friction cone: the object scenes'
base plans (RRT*, seed 1, as the campaign plans them) run under the `paper` errors with Coulomb's
cone and with pyramidal cones, each at its own step (sim.timestep, sim.pyramidal_timestep).

In a P_psi the thumb turns about B and B slides along the thumb's face. Under Coulomb's cone a
sliding contact resists a slip across its path in proportion to how fast it slips that way; under a
pyramid whose edges lie along the plane it resists it not at all until the slip across is as fast
as the slip along (docs/model.md 11.17, "The pyramid"). Per trial this reads, from the object's
recorded poses, B's position across the manipulation plane (along its normal, mm) where each P_psi
begins and ends, and where the object comes to rest against its target (along GB and across it,
mm); per object and cone it reports how far B moved across over the P_psi legs (the mean of the
trials' absolute drifts, the largest), how the landings spread across GB (standard deviation) and
their mean, and how many trials succeeded by the strict verdict. It asserts nothing.

    python tools/sliding_drift.py [--objects guitar_pick,puzzle_piece] [--trials 16] [--jobs 2]
        [--friction F] [--turn-target DEG] [--results [--study NAME]]

--friction F runs both cones in a world whose every friction is F times the scene's (sim.world;
the pairs it sets draw no friction error, record 0100).

--turn-target DEG turns each object's target by DEG about the vertical, as sim_campaigns.py's option
does (MuJoCo's pyramids lie along directions fixed in the world: docs/model.md 11.16).

--results writes the study into docs/results/sliding_drift.json (the markdown beside it rendered
from it); a study named otherwise than `drift` prefixes its rows' labels with its name.
"""

from __future__ import annotations

import argparse
import multiprocessing
import shlex
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from ungrasp_ompl.planning import plan  # noqa: E402
from ungrasp_ompl.scene.perturbation import PRESETS, trial_params  # noqa: E402
from ungrasp_ompl.sim.outcome import Outcome  # noqa: E402
from ungrasp_ompl.sim.plan_trials import placement  # noqa: E402
from ungrasp_ompl.sim.trial import run_trial  # noqa: E402
from ungrasp_ompl.sim.world import Cone, World  # noqa: E402

OBJECTS = ("guitar_pick", "puzzle_piece", "fabric_chalk")
CONES = (Cone.ELLIPTIC, Cone.PYRAMIDAL)
FORMATS = {"trials": "{}", "successes": "{}", "b_drift_mean_mm": "{:.2f}", "b_drift_max_mm": "{:.2f}",
           "landing_across_sd_mm": "{:.2f}", "landing_across_mean_mm": "{:.2f}", "landing_along_mean_mm": "{:.2f}"}
RESULTS = ROOT / "docs" / "results" / "sliding_drift.json"


def trial_drift(task: tuple) -> tuple[float, float, float, bool]:
    """One trial of setup with params: B's drift across the plane summed over the P_psi legs (mm,
    signed), the landing along GB and across it (mm), and whether it succeeded."""
    setup, params, k, seed = task
    record: list = []
    result = run_trial(setup, params, k, seed, record=record)
    target = np.asarray(setup.target_pose)
    normal = target[:3, 1]  # the plane's normal (the object lies flat at its target, GB along x), world
    b_body = np.append(np.asarray(setup.b_point), 1.0)
    times = np.array([t for t, _ in record])

    def b_across(t: float) -> float:
        pose = np.asarray(record[int(np.argmin(np.abs(times - t)))][1])
        return float((pose @ b_body)[:3] @ normal) * 1e3

    drift = sum(b_across(b) - b_across(a) for name, a, b in setup.drive.phases if name == "P_psi")
    return drift, result.offset_along_mm, result.offset_across_mm, result.outcome is Outcome.SUCCESS


def study(name: str, trials: int, seed: int, pool: ProcessPoolExecutor, friction: float = 1.0,
          turn_deg: float = 0.0) -> list[dict]:
    """The object's rows, one per cone, in a world of every friction times friction, its target
    turned by turn_deg about the vertical (sim_campaigns --turn-target)."""
    from sim_campaigns import _scene

    scene = _scene(name, turn_deg=turn_deg)
    result = plan(scene, planner="RRTstar", time=1.0, seed=1)
    setup = placement(scene, result)[1]
    params = trial_params(PRESETS["paper"], seed, trials)
    rows = []
    for cone in CONES:
        here = replace(setup, world=World(friction=friction, cone=cone))
        out = np.array(list(pool.map(trial_drift, [(here, p, k, seed) for k, p in enumerate(params)])))
        drift, along, across, ok = out[:, 0], out[:, 1], out[:, 2], out[:, 3].astype(bool)
        rows.append({"label": f"{name}, {cone.value}", "trials": trials, "successes": int(ok.sum()),
                     "b_drift_mean_mm": float(np.mean(np.abs(drift))), "b_drift_max_mm": float(np.max(np.abs(drift))),
                     "landing_across_sd_mm": float(np.std(across, ddof=1)),
                     "landing_across_mean_mm": float(np.mean(across)), "landing_along_mean_mm": float(np.mean(along))})
        r = rows[-1]
        print(f"{name:13} {cone.value:9} B across over P_psi: mean {r['b_drift_mean_mm']:.2f} mm, largest "
              f"{r['b_drift_max_mm']:.2f} mm; landing across: mean {r['landing_across_mean_mm']:+.2f}, sd "
              f"{r['landing_across_sd_mm']:.2f} mm; along: mean {r['landing_along_mean_mm']:+.2f} mm; "
              f"{r['successes']}/{trials}", flush=True)
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--objects", default=",".join(OBJECTS))
    ap.add_argument("--trials", type=int, default=16, help="trials per object and cone (default 16)")
    ap.add_argument("--seed", type=int, default=1, help="the trials' seed")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--results", action="store_true", help="write docs/results/sliding_drift.json")
    ap.add_argument("--friction", type=float, default=1.0,
                    help="every friction times this factor in both cones' worlds (default 1: the scene's)")
    ap.add_argument("--turn-target", type=float, default=0.0, metavar="DEG",
                    help="turn each object's target by DEG about the vertical (record 0138)")
    ap.add_argument("--study", default="drift", help="the study's name in the results file (default drift)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    rows: list[dict] = []
    with ProcessPoolExecutor(args.jobs, mp_context=multiprocessing.get_context("fork")) as pool:
        for name in args.objects.split(","):
            rows += study(name, args.trials, args.seed, pool, args.friction, args.turn_target)
    if args.results:
        from campaign_results import merge_study

        command = "python tools/sliding_drift.py " + shlex.join(sys.argv[1:])
        merge_study(RESULTS, args.study, command, time.perf_counter() - t0, rows, FORMATS,
                    "How far the sliding contact walks across the plane, by friction cone",
                    prefixed=args.study != "drift")
    return 0


if __name__ == "__main__":
    sys.exit(main())
