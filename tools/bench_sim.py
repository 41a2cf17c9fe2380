"""Speed of simulated execution: wall and CPU time of one trial, per object, as campaigns run them.

    python tools/bench_sim.py [--trials N] [--perturb paper] [--timestep S] [--objects NAME,...]
                              [--engine mujoco|drake [--drake-hull large-fanned|convex|fanned]] [--results]

Plans each shipped object once (RRT*, seed 1), builds its trajectory, then times N trials with the
preset's errors (seed 1, trial k drawn as campaigns draw it): model compile, settle, drive, and the
end as a campaign has it (at a failure, or once everything lies still in the retreat). Prints the
median and the largest wall time, the median CPU time of this process (on a machine shared with
other work, the CPU time is what one free core takes), the simulated time and how many trials
were placed. Trial 0 without errors is timed too, run to the end even if it fails: the cost of a
trial that goes the whole way. --timestep S times the trials at MuJoCo's step S (s) in place of the
scenes' own (sim.timestep), to see what a finer step costs. --engine drake times the trials in
Drake (sim.drake_trial) and prints beside them the most polygons the thumb's and the table's
contact patches with the object had at a control tick; --drake-hull says how the object's hull
reaches Drake (sim.drake_world.HULLS): large-fanned, the builder's (record 0116), convex (Drake's
Convex) or fanned (record 0115, refused). --results merges the rows into
docs/results/bench_sim.json (.md beside), one study per engine and hull, for the pages to quote.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from ungrasp_ompl import Scene  # noqa: E402
from ungrasp_ompl.scene.perturbation import TrialParams, preset, trial_params  # noqa: E402
from ungrasp_ompl.planning import plan  # noqa: E402
from ungrasp_ompl.robot.pipeline import execute  # noqa: E402
from ungrasp_ompl.sim.setup import trial_setup  # noqa: E402
from ungrasp_ompl.sim.trial import run_trial  # noqa: E402


#: The most polygons of each hydroelastic pair of the object seen at a control tick in Drake
#: (the pair's kinds, "table" or "thumb") since the last reset.
POLYGONS: dict[str, int] = {}


def timed(setup, params, k, stop_at_failure=True, engine="mujoco"):
    t, c = time.perf_counter(), time.process_time()
    if engine == "drake":
        from ungrasp_ompl.sim.drake_trial import run_drake_trial
        r = run_drake_trial(setup, params, k, 1, stop_at_failure=stop_at_failure)
    else:
        r = run_trial(setup, params, k, 1, stop_at_failure=stop_at_failure)
    return r, time.perf_counter() - t, time.process_time() - c


def count_polygons() -> None:
    """Wrap Drake's contact reader (sim.drake_trial._DrakeWatch) to keep POLYGONS."""
    from ungrasp_ompl.sim import drake_trial

    read = drake_trial._DrakeWatch._contacts

    def counted(watch):
        results = watch.plant.get_contact_results_output_port().Eval(watch.ctx)
        for i in range(results.num_hydroelastic_contacts()):
            surface = results.hydroelastic_contact_info(i).contact_surface()
            kinds = {watch.kind.get(surface.id_M()), watch.kind.get(surface.id_N())}
            if "object" in kinds:
                other = next(iter(kinds - {"object"}), "object")
                POLYGONS[other] = max(POLYGONS.get(other, 0), surface.num_faces())
        return read(watch)

    drake_trial._DrakeWatch._contacts = counted


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=10)
    ap.add_argument("--perturb", default="paper")
    ap.add_argument("--timestep", type=float, default=None, help="MuJoCo's step (s; default: the scenes' own)")
    ap.add_argument("--objects", default="guitar_pick,puzzle_piece,fabric_chalk", help="the object scenes timed")
    ap.add_argument("--engine", choices=("mujoco", "drake"), default="mujoco")
    ap.add_argument("--drake-hull", choices=("large-fanned", "convex", "fanned"), default="large-fanned",
                    help="with --engine drake: how the object's hull reaches Drake (sim.drake_world.HULLS)")
    ap.add_argument("--results", action="store_true", help="merge the rows into docs/results/bench_sim.json")
    args = ap.parse_args()
    started = time.perf_counter()
    rows = []
    if args.engine == "drake":
        from ungrasp_ompl.sim import drake_world

        drake_world.HULLS = args.drake_hull
        count_polygons()
    print(f"{'object':<14} {'wall s (median)':>15} {'wall s (max)':>12} {'CPU s (median)':>14} {'CPU s (max)':>11} "
          f"{'simulated s (max)':>17} {'placed':>7} | {'whole trial: wall s':>19} {'simulated s':>11}"
          + (" | most polygons: thumb, table" if args.engine == "drake" else ""))
    for name in args.objects.split(","):
        POLYGONS.clear()
        scene = Scene.from_file(ROOT / "scenes" / f"{name}.yaml")
        if args.timestep is not None:
            scene = scene.with_sim(timestep=args.timestep)
        result = plan(scene, planner="RRTstar", time=1.0, seed=1)
        ex = execute(scene, result)
        setup = trial_setup(scene, result, ex.trajectory, ex.robot)
        runs = [timed(setup, p, k, engine=args.engine)
                for k, p in enumerate(trial_params(preset(args.perturb), 1, args.trials))]
        walls, cpus = [w for _, w, _ in runs], [c for _, _, c in runs]
        whole, whole_wall, _ = timed(setup, TrialParams(), 0, stop_at_failure=False, engine=args.engine)
        print(f"{name:<14} {statistics.median(walls):>15.3f} {max(walls):>12.3f} {statistics.median(cpus):>14.3f} "
              f"{max(cpus):>11.3f} {max(r.sim_time_s for r, _, _ in runs):>17.2f} "
              f"{sum(r.success for r, _, _ in runs):>3}/{len(runs):<3} | {whole_wall:>19.3f} {whole.sim_time_s:>11.2f}"
              + (f" | {POLYGONS.get('thumb', 0)}, {POLYGONS.get('table', 0)}" if args.engine == "drake" else ""))
        rows.append({"label": f"{args.engine}{'' if args.engine == 'mujoco' else ', hull ' + args.drake_hull}: {name}",
                     "object": name, "trials": len(runs), "wall_median_s": statistics.median(walls),
                     "wall_max_s": max(walls), "cpu_median_s": statistics.median(cpus), "cpu_max_s": max(cpus),
                     "placed": sum(r.success for r, _, _ in runs), "whole_trial_wall_s": whole_wall,
                     **({"thumb_polygons_max": POLYGONS.get("thumb", 0), "table_polygons_max": POLYGONS.get("table", 0)}
                        if args.engine == "drake" else {})})
    if args.results:
        import shlex

        from campaign_results import merge_study

        study = args.engine + ("" if args.engine == "mujoco" else f"-hull-{args.drake_hull}")
        formats = {k: "{:.2f}" for k in ("wall_median_s", "wall_max_s", "cpu_median_s", "cpu_max_s", "whole_trial_wall_s")}
        path = merge_study(ROOT / "docs" / "results" / "bench_sim.json", study,
                           shlex.join(["python", "tools/bench_sim.py", *sys.argv[1:]]), time.perf_counter() - started,
                           rows, formats, "The cost of a simulated trial, per engine (tools/bench_sim.py)")
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
