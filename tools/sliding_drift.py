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
their mean, and how many trials succeeded by the strict verdict. It also reports how far B travelled
along the thumb over the P_psi legs, executed and planned, and on the object (the plan keeps it
still there), the means over the trials that held both digits at two ticks of every P_psi
(sim.outcome.ContactTravel: between a leg's first and last such ticks), the first also over those
of them that failed, and along the thumb over the other legs (planned still), the mean over the legs
measured. It asserts nothing.

    python tools/sliding_drift.py [--objects guitar_pick,puzzle_piece] [--trials 16] [--jobs 2]
        [--friction F] [--world KEY=VALUE ...] [--turn-target DEG] [--results [--study NAME]]

--friction F runs both cones in a world whose every friction is F times the scene's (sim.world;
the pairs it sets draw no friction error, record 0100). --world KEY=VALUE (repeatable, as
`simulate --world`, but for `cone`) sets more of both cones' worlds, e.g. the table's and the
digits' friction apart (record 0140).

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
           "landing_across_sd_mm": "{:.2f}", "landing_across_mean_mm": "{:.2f}", "landing_along_mean_mm": "{:.2f}",
           "b_on_thumb_psi_mm": "{:+.2f}", "b_on_thumb_psi_plan_mm": "{:+.2f}", "b_on_object_psi_mm": "{:+.2f}",
           "b_on_thumb_other_mm": "{:+.2f}", "b_on_thumb_psi_failed_mm": "{:+.2f}", "b_held_psi": "{}"}
RESULTS = ROOT / "docs" / "results" / "sliding_drift.json"


def trial_drift(task: tuple) -> tuple[float, ...]:
    """One trial of setup with params: B's drift across the plane summed over the P_psi legs (mm,
    signed), the landing along GB and across it (mm), whether it succeeded, and B's travel over the
    P_psi legs along the thumb (executed, planned) and on the object, and along the thumb over the
    other legs, which hold it still (mm, summed; NaN where a leg did not hold both digits at two
    ticks)."""
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
    legs = [c for c in result.contacts if c.primitive == "P_psi"]
    travel = [sum(getattr(c, f) for c in legs) for f in ("b_on_thumb", "b_on_thumb_plan", "b_on_object")]
    others = sum(c.b_on_thumb for c in result.contacts if c.primitive != "P_psi")  # planned still
    return (drift, result.offset_along_mm, result.offset_across_mm, result.outcome is Outcome.SUCCESS, *travel, others)


def study(name: str, trials: int, seed: int, pool: ProcessPoolExecutor, friction: float = 1.0,
          turn_deg: float = 0.0, world: World = World()) -> list[dict]:
    """The object's rows, one per cone, in world (its cone aside) with every friction times friction
    besides, its target turned by turn_deg about the vertical (sim_campaigns --turn-target)."""
    from sim_campaigns import _scene

    scene = _scene(name, turn_deg=turn_deg)
    result = plan(scene, planner="RRTstar", time=1.0, seed=1)
    setup = placement(scene, result)[1]
    params = trial_params(PRESETS["paper"], seed, trials)
    rows = []
    for cone in CONES:
        here = replace(setup, world=replace(world, friction=world.friction * friction, cone=cone))
        out = np.array(list(pool.map(trial_drift, [(here, p, k, seed) for k, p in enumerate(params)])))
        drift, along, across, ok = out[:, 0], out[:, 1], out[:, 2], out[:, 3].astype(bool)
        held = ~np.isnan(out[:, 4])  # trials that held both digits at two ticks of every P_psi

        def mean(k: int, which: np.ndarray) -> float | None:
            values = out[which, k]
            values = values[~np.isnan(values)]
            return float(np.mean(values)) if len(values) else None

        thumb, thumb_plan, on_object = (mean(k, held) for k in (4, 5, 6))
        elsewhere, failed = mean(7, np.full(len(out), True)), mean(4, held & ~ok)
        rows.append({"label": f"{name}, {cone.value}", "trials": trials, "successes": int(ok.sum()),
                     "b_drift_mean_mm": float(np.mean(np.abs(drift))), "b_drift_max_mm": float(np.max(np.abs(drift))),
                     "landing_across_sd_mm": float(np.std(across, ddof=1)),
                     "landing_across_mean_mm": float(np.mean(across)), "landing_along_mean_mm": float(np.mean(along)),
                     "b_on_thumb_psi_mm": thumb, "b_on_thumb_psi_plan_mm": thumb_plan, "b_on_object_psi_mm": on_object,
                     "b_on_thumb_other_mm": elsewhere, "b_on_thumb_psi_failed_mm": failed,
                     "b_held_psi": int(held.sum())})
        r = rows[-1]
        print(f"{name:13} {cone.value:9} B across over P_psi: mean {r['b_drift_mean_mm']:.2f} mm, largest "
              f"{r['b_drift_max_mm']:.2f} mm; landing across: mean {r['landing_across_mean_mm']:+.2f}, sd "
              f"{r['landing_across_sd_mm']:.2f} mm; along: mean {r['landing_along_mean_mm']:+.2f} mm; "
              f"{r['successes']}/{trials}; B over P_psi along the thumb {_mm(thumb)} (planned {_mm(thumb_plan)}), "
              f"on the object {_mm(on_object)} mm ({r['b_held_psi']} trials held B), in the trials that failed "
              f"{_mm(failed)} mm; along the thumb over the other legs {_mm(elsewhere)} mm", flush=True)
    return rows


def _mm(x: float | None) -> str:
    return "-" if x is None else f"{x:+.2f}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--objects", default=",".join(OBJECTS))
    ap.add_argument("--trials", type=int, default=16, help="trials per object and cone (default 16)")
    ap.add_argument("--seed", type=int, default=1, help="the trials' seed")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--results", action="store_true", help="write docs/results/sliding_drift.json")
    ap.add_argument("--friction", type=float, default=1.0,
                    help="every friction times this factor in both cones' worlds (default 1: the scene's)")
    ap.add_argument("--world", action="append", default=[], metavar="KEY=VALUE",
                    help="more of both cones' worlds, as simulate --world (not cone; repeatable)")
    ap.add_argument("--turn-target", type=float, default=0.0, metavar="DEG",
                    help="turn each object's target by DEG about the vertical (record 0138)")
    ap.add_argument("--study", default="drift", help="the study's name in the results file (default drift)")
    args = ap.parse_args()
    world = World.parse(args.world)
    if any(item.partition("=")[0].strip() == "cone" for item in args.world):
        ap.error("--world: the study runs both cones; cone is not a key here")
    t0 = time.perf_counter()
    rows: list[dict] = []
    with ProcessPoolExecutor(args.jobs, mp_context=multiprocessing.get_context("fork")) as pool:
        for name in args.objects.split(","):
            rows += study(name, args.trials, args.seed, pool, args.friction, args.turn_target, world)
    if args.results:
        from campaign_results import merge_study

        command = "python tools/sliding_drift.py " + shlex.join(sys.argv[1:])
        merge_study(RESULTS, args.study, command, time.perf_counter() - t0, rows, FORMATS,
                    "How far the sliding contact walks across the plane, by friction cone",
                    prefixed=args.study != "drift")
    return 0


if __name__ == "__main__":
    sys.exit(main())
