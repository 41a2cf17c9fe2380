"""Does the out-of-plane margin predict which trials fail in worlds the plan did not know?
(docs/model.md 11.18)

For each object scene's RRT* plan (seed 1, 1 s), the margin along the plan (scene/stability3d.py:
the start press and every leg, each state in its leg's contact mode) and the simulated outcome in
worlds the plan did not see (sim/world.py). Two predictions are printed:

* per world, from the world alone: the margin at the world's friction times the `paper` draw's
  lowest factor (0.8) at every contact whose friction the world leaves alone (a world that sets a
  pair's friction fixes it: docs/decisions/0100-a-world-fixes-its-friction.md), with the world's cone (pyramidal or elliptic), the grasp
  1 mm off GB: the plan is predicted to lose trials where it is negative somewhere;
* per trial, from the world and the trial's draw: the margin at the world's friction times that
  trial's drawn factors at G, A and B (where the world leaves them), the grasp off GB by the trial's own shift across it.

A trial counts as held unless it fails before the termination (grip lost, turned out of the plane,
B past the thumb's tip, a digit on the table); a placement off target is held. Also printed: the
planner's own view, the margin at the scene's friction range's low end (1 - u) with pyramidal cones.

With --cage, the same question for the energy-bounded cage (docs/model.md 4.5): over several plans
per object (RRT* seeds 1 to 6, the lattice's cost and margin plans), the cage along each plan (its
smallest escape energy, the share of its states fully caged, the escape energy at the start) and the
out-of-plane margin at the worst draw, against how many trials each plan holds in the worlds
friction x0.7 and pyramidal cones; Spearman's rank correlation of each measure with the trials held.
These placements aim the hand as planned (robot.landing: planned), which moves the whole motion
along the table and changes no contact, to keep the study to about 20 minutes of one core.

With --needed, the friction factor (on every contact's coefficient) each leg of the RRT* plans
needs for a margin of at least 0, with elliptic and with pyramidal cones, beside the factor planar
force closure needs (section 4). With --forces, a rigid-body reading of one trial of an object's
RRT* plan (the first of --objects; --plan-seed and --objective choose the plan, seed 1 and the
cost by default) in the nominal world, friction x0.7 and pyramidal cones: the
trial's outcome, and at chosen ticks of the settling (the start press) and after it, the turn out of
the plane (a roll about GB and a turn of GB about the vertical), G's slip across the plane, and each
contact's normal force, the ratios of its tangential force in the plane and across it to the normal,
and where it touches the object (MuJoCo's mj_contactForce in each contact's frame, summed over a
digit's contact points); --no-error reads the trial without any error, --impratio runs a copy of its
model with friction rows that much stiffer than the normal one (the simulator's 10).

--results also writes the study's rows into docs/results/world_failures.json (replacing the study's
earlier rows, keeping the other studies'), with its command, wall time and day, and renders
docs/results/world_failures.md from it (tools/campaign_results.py; docs/model.md 11.18 quotes it).

Usage (about 4 minutes of one core with 6 trials; --cage about 10; --needed 1; --forces under 1):

    .venv/bin/python tools/world_failures.py --trials 6
    .venv/bin/python tools/world_failures.py --trials 2 --objects guitar_pick --worlds friction=0.7
    .venv/bin/python tools/world_failures.py --cage --trials 3
    .venv/bin/python tools/world_failures.py --needed [--objective margin]
    .venv/bin/python tools/world_failures.py --forces --trial 0
    .venv/bin/python tools/world_failures.py --forces --trial 1 --objects puzzle_piece --ticks 0 0.1 0.2 0.3 0.4
    .venv/bin/python tools/world_failures.py --forces --no-error --impratio 1
"""

from __future__ import annotations

import argparse
import math
import re
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from ungrasp_ompl import planning
from ungrasp_ompl.scene.perturbation import PRESETS, preset, trial_params
from ungrasp_ompl.scene import Scene
from ungrasp_ompl.scene.stability3d import OutOfPlaneLoads, plan_out_of_plane, plan_states, out_of_plane_margin
from ungrasp_ompl.sim.outcome import Outcome
from ungrasp_ompl.sim.plan_trials import placement
from ungrasp_ompl.sim.trial import run_trial
from ungrasp_ompl.sim.world import World

OBJECTS = ("guitar_pick", "puzzle_piece", "fabric_chalk")
#: The scene file each object's study reads: the pick's plans through a P_dpsi start where its
#: scene started before decision 0107 (scenes/guitar_pick_reference_start.yaml).
STUDY_SCENES = {"guitar_pick": "guitar_pick_reference_start"}
WORLDS = ("friction=1", "friction=0.7", "friction=1.3", "cone=pyramidal")
#: Outcomes that are not a failure to hold the object (placed, whether on target or not).
HELD = (Outcome.SUCCESS, Outcome.OFF_TARGET)


ROOT = Path(__file__).resolve().parents[1]
#: How the results file shows each field of its rows (tools/campaign_results.py renders them).
FORMATS = {"smallest_n": "{:+.2f}", "margin_min_n": "{:+.2f}", "factor_table": "{:.2f}", "factor_digits": "{:.2f}",
           "factor_g": "{:.2f}", "factor_a": "{:.2f}", "factor_b": "{:.2f}", "across_mm": "{:+.2f}",
           "elliptic": "{:.2f}", "pyramidal": "{:.2f}", "closure": "{:.2f}", "min_escape_mj": "{:.3f}",
           "caged_share": "{:.2f}", "start_mj": "{:.3f}", "margin_friction_n": "{:+.2f}",
           "margin_pyramidal_n": "{:+.2f}", "rho": "{:+.2f}", "p": "{:.3f}", "t_s": "{:+.2f}",
           "out_deg": "{:.2f}", "roll_deg": "{:+.2f}", "yaw_deg": "{:+.2f}", "theta_deg": "{:.2f}",
           "g_across_mm": "{:.3f}", "seconds": "{:.0f}", "minutes": "{:.0f}", "shift_across_mm": "{:+.2f}",
           **{f"{c}_{f}": fmt for c in "gab" for f, fmt in (("n", "{:.2f}"), ("in_plane", "{:.3f}"),
                                                           ("across", "{:.3f}"), ("mu", "{:.3f}"),
                                                           ("at_mm", "{:.1f}"))}}


def _finite(x: float) -> float | str:
    """A number as the results file holds it: "inf" and "-inf" as words (JSON has no infinity)."""
    return float(x) if math.isfinite(x) else ("inf" if x > 0 else "-inf")


def write_results(study: str, command: str, seconds: float, rows: list[dict], path: Path | None = None) -> Path:
    """Put one study's rows into the results file (docs/results/world_failures.json, the rows of
    the other studies kept) with the study's own row (its command, wall time in s, day), and render
    the markdown beside it; both written atomically."""
    sys.path.insert(0, str(ROOT / "tools"))
    from campaign_results import merge_study

    return merge_study(path or ROOT / "docs" / "results" / "world_failures.json", study, command, seconds, rows,
                       FORMATS, "tools/world_failures.py: the out-of-plane margin and the cage against the trials "
                                "in worlds the plan did not know (docs/model.md 11.18)")


def world_of(item: str) -> World:
    """The world of one KEY=VALUE item (friction=1 is the nominal world)."""
    return World.parse([item])


def legs_line(result) -> str:
    """'press +0.65, P_theta +0.65, ...' (N), the smallest push of each leg."""
    return ", ".join(f"{name} {value:+.2f}" if math.isfinite(value) else f"{name} -inf"
                     for name, value in result.of_legs())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=6)
    parser.add_argument("--seed", type=int, default=1, help="the trials' seed (the plans use seed 1)")
    parser.add_argument("--objects", nargs="+", default=list(OBJECTS))
    parser.add_argument("--worlds", nargs="+", default=list(WORLDS))
    parser.add_argument("--cage", action="store_true", help="the cage study over several plans per object")
    parser.add_argument("--needed", action="store_true", help="the friction each leg needs")
    parser.add_argument("--forces", action="store_true", help="the contact forces of one trial (of the first of --objects)")
    parser.add_argument("--trial", type=int, default=0, help="the trial --forces reads")
    parser.add_argument("--plan-seed", type=int, default=1, help="the seed of the RRT* plan --forces reads")
    parser.add_argument("--objective", choices=("cost", "margin"), default="cost",
                        help="what the RRT* plan --forces and --needed read optimises")
    parser.add_argument("--no-error", action="store_true", help="--forces reads a trial without any error")
    parser.add_argument("--impratio", type=float, default=None,
                        help="--forces runs a copy of the trial's model with this impratio (the simulator's is 10)")
    parser.add_argument("--ticks", type=float, nargs="+", default=[-0.29, -0.25, -0.20, -0.15, -0.10, 0.0, 0.3],
                        help="when --forces reads it (s from the first primitive's start; negative: the settling)")
    parser.add_argument("--results", action="store_true",
                        help="also write the study into docs/results/world_failures.json and .md (its rows replace "
                             "the study's earlier ones)")
    args = parser.parse_args(argv)
    command = " ".join(["python tools/world_failures.py", *(sys.argv[1:] if argv is None else argv)])
    wall = time.perf_counter()
    rows: list[dict] = []
    if args.cage:
        study, code = "cage", cage_study(args.objects, args.trials, args.seed, rows)
    elif args.needed:
        study, code = "needed", friction_needed(args.objects, rows, args.objective)
    elif args.forces:
        study = forces_run(args.objects[0], args.trial, args.no_error, args.impratio, args.plan_seed, args.objective)
        code = contact_forces(args.objects[0], args.trial, args.seed, tuple(args.ticks), args.no_error, args.impratio,
                              rows, study, args.plan_seed, args.objective)
    else:
        study, code = "trials", world_trials(args, rows)
    if args.results:
        print(f"wrote {write_results(study, command, time.perf_counter() - wall, rows)}")
    return code


def world_trials(args, rows: list[dict]) -> int:
    """The margin's predictions against the trials (the default study); its rows into rows."""
    draw_low = 1.0 - PRESETS["paper"].friction
    totals: dict[str, list[int]] = {}
    per_trial_rows = []
    for name in args.objects:
        scene = Scene.from_file(STUDY_SCENES.get(name, name))
        plan = planning.plan(scene, planner="RRTstar", time=1.0, seed=1, objective="cost")
        if not plan.solved:
            print(f"{name}: RRT* found no plan")
            continue
        u = scene.friction_uncertainty
        low = plan_out_of_plane(scene, plan, scene.plane_friction(1.0 - u), "pyramidal")
        print(f"\n{name}: RRT* seed 1, {' '.join(str(p.type) for p in plan.primitives)}")
        print(f"  planner's view (friction x{1 - u:g}, pyramidal, 1 mm off): {legs_line(low)}")
        t0 = time.perf_counter()
        _, setup = placement(scene, plan)
        print(f"  placement {time.perf_counter() - t0:.0f} s")
        states = plan_states(scene, plan)
        params = trial_params(preset("paper"), args.seed, args.trials)
        for item in args.worlds:
            world = world_of(item)
            cone = str(world.cone)
            table, digits = world.friction_factors
            fixed_table, fixed_digits = world.fixed_friction  # the world's factor is the pair's error
            low_g, low_d = (1.0 if fixed_table else draw_low), (1.0 if fixed_digits else draw_low)
            worst = (table * low_g, digits * low_d, digits * low_d)
            mu = _plane_mu(scene, worst)
            res = plan_out_of_plane(scene, plan, mu, cone)
            first = res.first_below()
            verdict = "holds" if first is None else f"fails in {first[0]}"
            print(f"  {world.describe():24s} predicted (draw's worst, x{worst[0]:.2f}/{worst[1]:.2f}): {verdict}; "
                  f"{legs_line(res)}")
            counts = totals.setdefault(f"{name} {world.describe()}", [0, 0, 0, 0, 0])
            outcomes: dict[str, int] = {}
            legs = res.of_legs()
            low_leg = min(legs, key=lambda item: item[1])
            world_row = {"label": f"trials: {name}, {world.describe()}", "study": "trials", "object": name,
                         "world": world.describe(), "primitives": " ".join(str(p.type) for p in plan.primitives),
                         "factor_table": worst[0], "factor_digits": worst[1],
                         "first_below": "none" if first is None else first[0], "smallest_n": _finite(low_leg[1]),
                         "smallest_leg": low_leg[0], "legs": [[leg, _finite(v)] for leg, v in legs]}
            rows.append(world_row)
            for k, p in enumerate(params):
                drawn = (1.0 if fixed_table else p.friction_scale[0],
                         *((1.0, 1.0) if fixed_digits else p.friction_scale[1:]))
                factors = tuple(f * g for f, g in zip((table, digits, digits), drawn))
                own = out_of_plane_margin(scene, states.states, states.a_sign, states.b_sign, _plane_mu(scene, factors),
                                          cone, OutOfPlaneLoads(offset=abs(p.shift_across_mm) / 1000), states.slide)
                below = np.flatnonzero(own.push < 0.0)
                leg = None if not len(below) else ("press" if states.primitive[below[0]] < 0
                                                   else states.names[states.primitive[below[0]]])
                t1 = time.perf_counter()
                r = run_trial(replace(setup, world=world), p, k, args.seed)
                held = r.outcome in HELD
                predicted = leg is None
                counts[0] += 1
                counts[1] += held
                counts[2] += predicted
                counts[3] += held == predicted
                counts[4] += (not held) and (not predicted)
                print(f"    trial {k}: friction x{factors[0]:.2f}/{factors[1]:.2f}/{factors[2]:.2f}, across "
                      f"{p.shift_across_mm:+.2f} mm -> predicted {'held' if predicted else 'lost in ' + leg}, "
                      f"margin min {own.push.min():+.2f} N; simulated {r.outcome.value}"
                      f"{'' if r.phase is None else ' in ' + r.phase} ({time.perf_counter() - t1:.1f} s)", flush=True)
                per_trial_rows.append((name, world.describe(), k, predicted, held))
                what = "held" if held else r.outcome.value + ("" if r.phase is None else " in " + r.phase)
                outcomes[what] = outcomes.get(what, 0) + 1
                rows.append({"label": f"trial: {name}, {world.describe()}, {k}", "study": "trials", "object": name,
                             "world": world.describe(), "trial": k, "factor_g": factors[0], "factor_a": factors[1],
                             "factor_b": factors[2], "across_mm": p.shift_across_mm,
                             "predicted": "held" if predicted else leg, "margin_min_n": _finite(own.push.min()),
                             "outcome": r.outcome.value, "phase": r.phase, "held": held})
            n, held_n, pred_n, right_n, caught_n = counts
            world_row.update({"trials": n, "held": held_n, "predicted_held": pred_n, "right": right_n,
                              "failures": n - held_n, "failures_predicted": caught_n,
                              "outcomes": sorted(([c, w] for w, c in outcomes.items()), key=lambda x: (-x[0], x[1]))})
    for label, chosen in (("all worlds", per_trial_rows),
                          ("the friction worlds", [t for t in per_trial_rows if "pyramidal" not in t[1]])):
        right = sum(p == h for *_, p, h in chosen)
        rows.append({"label": f"trials: {label}", "study": "trials", "trials": len(chosen), "right": right,
                     "failures": sum(not h for *_, h in chosen),
                     "failures_predicted": sum((not p) and (not h) for *_, p, h in chosen),
                     "predicted_failures": sum(not p for *_, p, _ in chosen)})
    print("\nper trial: object, world: trials, held, predicted held, predictions right, failures predicted")
    for key, (n, held, pred, right, caught) in totals.items():
        print(f"  {key:42s} {n:3d} {held:5d} {pred:9d} {right:9d} {caught:5d}/{n - held}")
    n = len(per_trial_rows)
    if n:
        right = sum(p == h for *_, p, h in per_trial_rows)
        tp = sum((not p) and (not h) for *_, p, h in per_trial_rows)
        fails = sum(not h for *_, _, h in per_trial_rows)
        alarms = sum((not p) for *_, p, _ in per_trial_rows)
        print(f"overall: {right}/{n} right; {tp}/{fails} failures predicted; {tp}/{alarms} predicted failures real")
    return 0


CAGE_PLANS = (tuple(("RRTstar", seed, "cost") for seed in range(1, 7))
              + (("lattice", 1, "cost"), ("lattice", 1, "margin")))
CAGE_WORLDS = ("friction=0.7", "cone=pyramidal")


def cage_study(objects: list[str], trials: int, seed: int, out: list[dict] | None = None) -> int:
    """Print, per plan, the cage's measures, the out-of-plane margin at the worst draw of each world
    (the draw's lowest factor only where the world leaves a pair's friction alone) and the trials
    held in each world; then Spearman's rank correlations with the trials held. The rows go into out."""
    out = [] if out is None else out
    from scipy.stats import spearmanr

    from ungrasp_ompl.planning.cage_profile import cage_profile
    from ungrasp_ompl.scene.options import Landing

    draw_low = 1.0 - PRESETS["paper"].friction
    rows = []
    print("object, plan: primitives | cage: min escape (mJ), fully caged share, start (mJ) | "
          "margin at the worst draw (N) per world | trials held per world")
    for name in objects:
        scene = Scene.from_file(STUDY_SCENES.get(name, name))
        scene = replace(scene, robot=replace(scene.robot, landing=Landing.PLANNED))
        params = trial_params(preset("paper"), seed, trials)
        for planner, plan_seed, objective in CAGE_PLANS:
            options = {"objective": objective}
            plan = planning.plan(scene, planner=planner, time=1.0, seed=plan_seed, **options)
            label = f"{planner}{'' if planner == 'lattice' else ' seed ' + str(plan_seed)} {objective}"
            if not plan.solved:
                print(f"{name}, {label}: no plan")
                continue
            energy = cage_profile(scene, plan).escape_energy
            caged = float(np.isinf(energy).mean())
            margins, held = [], []
            try:
                _, setup = placement(scene, plan)
            except Exception as exc:  # the robot cannot execute it: no trials
                print(f"{name}, {label}: not executable ({exc})")
                continue
            for item in CAGE_WORLDS:
                world = world_of(item)
                table, digits = world.friction_factors
                fixed_table, fixed_digits = world.fixed_friction  # the world's factor is the pair's error
                table, digits = table * (1.0 if fixed_table else draw_low), digits * (1.0 if fixed_digits else draw_low)
                mu = _plane_mu(scene, (table, digits, digits))
                margins.append(plan_out_of_plane(scene, plan, mu, str(world.cone)).smallest)
                held.append(sum(run_trial(replace(setup, world=world), p, k, seed).outcome in HELD
                                for k, p in enumerate(params)))
            fmt = lambda e: "inf" if math.isinf(e) else f"{e * 1000:.3f}"  # noqa: E731
            print(f"{name}, {label}: {' '.join(str(p.type) for p in plan.primitives)} | {fmt(energy.min())}, "
                  f"{caged:.2f}, {fmt(energy[0])} | " + ", ".join(f"{m:+.2f}" for m in margins)
                  + " | " + ", ".join(f"{h}/{trials}" for h in held), flush=True)
            rows.append((name, float(energy.min()), caged, float(energy[0]), margins, held))
            out.append({"label": f"cage: {name}, {label}", "study": "cage", "object": name, "plan": label,
                        "primitives": " ".join(str(p.type) for p in plan.primitives),
                        "min_escape_mj": _finite(1000 * float(energy.min())), "caged_share": caged,
                        "start_mj": _finite(1000 * float(energy[0])), "margin_friction_n": _finite(margins[0]),
                        "margin_pyramidal_n": _finite(margins[1]), "trials": trials, "held_friction": held[0],
                        "held_pyramidal": held[1]})
    print("\nSpearman's rank correlation with the trials held (rho, p; nan: a measure without spread)")
    for group in [None, *objects]:
        mine = [r for r in rows if group is None or r[0] == group]
        for w, item in enumerate(CAGE_WORLDS):
            held = [r[5][w] for r in mine]
            for label, values in (("cage min escape", [r[1] for r in mine]),
                                  ("cage fully caged share", [r[2] for r in mine]),
                                  ("out-of-plane margin", [r[4][w] for r in mine])):
                ranked = [v if math.isfinite(v) else (1e9 if v > 0 else -1e9) for v in values]
                spread = len(set(ranked)) > 1 and len(set(held)) > 1
                rho, p = spearmanr(ranked, held) if spread else (math.nan, math.nan)
                print(f"  {group or 'all objects':13s} {item:16s} {label:24s} rho {rho:+.2f} p {p:.3f} over "
                      f"{len(mine)} plans, {sum(held)}/{trials * len(mine)} trials held")
                out.append({"label": f"cage rho: {group or 'all objects'}, {world_of(item).describe()}, {label}",
                            "study": "cage", "object": group, "world": world_of(item).describe(), "measure": label,
                            "rho": None if math.isnan(rho) else float(rho), "p": None if math.isnan(p) else float(p),
                            "plans": len(mine), "held": sum(held), "trials": trials * len(mine)})
    return 0


def friction_needed(objects: list[str], out: list[dict] | None = None, objective: str = "cost") -> int:
    """Print, per leg of each object's RRT* plan (seed 1, the objective given), the least factor on the contacts' coefficients at
    which the out-of-plane margin (1 mm off) is at least 0, elliptic and pyramidal, and at which
    planar force closure holds (bisection to 1e-3 on [0.3, 1.5])."""
    from ungrasp_ompl.mechanics.force_closure import Friction
    from ungrasp_ompl.mechanics.margin import friction_margin

    def least(holds) -> float:
        lo, hi = 0.3, 1.5
        if holds(lo):
            return lo
        while hi - lo > 1e-3:
            mid = (lo + hi) / 2
            lo, hi = (lo, mid) if holds(mid) else (mid, hi)
        return hi

    out = [] if out is None else out
    print("object: leg needs factor (margin elliptic / pyramidal / planar force closure; 0.30: at most that)")
    for name in objects:
        scene = Scene.from_file(STUDY_SCENES.get(name, name))
        plan = planning.plan(scene, planner="RRTstar", time=1.0, seed=1, objective=objective)
        if not plan.solved:
            print(f"  {name}: no {objective} plan at seed 1 ({plan.reason})")
            continue
        st = plan_states(scene, plan)
        cells = []
        for leg in sorted(set(st.primitive.tolist())):
            m = st.primitive == leg
            q, sa, sb, sl = st.states[m], st.a_sign[m], st.b_sign[m], st.slide[m]
            need = [least(lambda f, c=cone: out_of_plane_margin(scene, q, sa, sb, scene.plane_friction(f), c,
                                                                OutOfPlaneLoads(), sl).push.min() >= 0.0)
                    for cone in ("elliptic", "pyramidal")]
            need.append(least(lambda f: friction_margin(q[:, 0], q[:, 1], q[:, 2], sa, sb, Friction(
                scene.plane_friction(f), scene.options.sliding_model)).min() > 0.0))
            cells.append(f"{'press' if leg < 0 else st.names[leg]} {need[0]:.2f}/{need[1]:.2f}/{need[2]:.2f}")
            out.append({"label": f"needed: {name}, {len(cells) - 1}", "study": "needed", "object": name,
                        "leg": "press" if leg < 0 else st.names[leg], "order": len(cells) - 1, "elliptic": need[0],
                        "pyramidal": need[1], "closure": need[2]})
        print(f"  {name}: " + ", ".join(cells))
    return 0


def forces_run(name: str, trial: int, no_error: bool, impratio: float | None, plan_seed: int = 1,
               objective: str = "cost") -> str:
    """The study's name of one --forces reading ("forces: guitar_pick, trial 0", "forces: guitar_pick,
    no error, impratio 1", "forces: go_stone, margin plan seed 3, trial 9")."""
    plan = "" if (plan_seed, objective) == (1, "cost") else f", {objective} plan seed {plan_seed}"
    return (f"forces: {name}{plan}, {'no error' if no_error else f'trial {trial}'}"
            + ("" if impratio is None else f", impratio {impratio:g}"))


def contact_forces(name: str, trial: int, seed: int, ticks: tuple[float, ...], no_error: bool = False,
                   impratio: float | None = None, out: list[dict] | None = None, study: str = "forces",
                   plan_seed: int = 1, objective: str = "cost") -> int:
    """Print the rigid-body reading of one trial of an object's RRT* plan (of plan_seed, optimising
    objective; see the module docstring), and the trial's outcome in each world; no_error: the trial
    without any error; impratio: run a
    copy of the trial's model with that impratio instead of the simulator's (not a world of
    sim/world.py: a probe of how stiffly friction holds). The rows go into out, labelled by study."""
    out = [] if out is None else out
    from ungrasp_ompl.scene.perturbation import TrialParams
    from ungrasp_ompl.sim import trial as sim_trial

    if impratio is not None:
        build = sim_trial.build_mjcf
        sim_trial.build_mjcf = lambda spec, key=None: re.sub(r'impratio="[^"]*"', f'impratio="{impratio:g}"',
                                                             build(spec, key))


    obj = name
    scene = Scene.from_file(STUDY_SCENES.get(name, name))
    plan = planning.plan(scene, planner="RRTstar", time=1.0, seed=plan_seed, objective=objective)
    _, setup = placement(scene, plan)
    params = TrialParams() if no_error else trial_params(preset("paper"), seed, trial + 1)[trial]
    out.append({"label": study, "study": study, "object": obj, "trial": None if no_error else trial,
                "shift_across_mm": params.shift_across_mm, "factor_g": params.friction_scale[0],
                "factor_a": params.friction_scale[1], "factor_b": params.friction_scale[2], "impratio": impratio})
    frame = setup.target_pose[:3, :3]  # the plane's: x toward B, y across, z up
    print(f"{name}, RRT* seed {plan_seed} ({objective}), trial {trial}: shift across {params.shift_across_mm:+.2f} mm, friction "
          f"factors {', '.join(f'{f:.2f}' for f in params.friction_scale)}")
    for item in ("friction=1", "friction=0.7", "cone=pyramidal"):
        world = world_of(item)
        result = run_trial(replace(setup, world=world), params, trial, seed)
        print(f"== {world.describe()}: {result.outcome.value}{'' if result.phase is None else ' in ' + result.phase}")
        out.append({"label": f"{study}: {world.describe()}", "study": study, "object": obj,
                    "world": world.describe(), "outcome": result.outcome.value, "phase": result.phase})
        for t, pose, contacts in _replay(replace(setup, world=world), params, ticks):
            rel = frame.T @ pose[:3, :3]
            yaw = math.degrees(math.atan2(rel[1, 0], rel[0, 0]))
            roll = math.degrees(math.asin(max(-1.0, min(1.0, rel[2, 1]))))
            out_deg = math.degrees(math.acos(min(1.0, abs(rel[1, 1]))))
            theta = math.degrees(math.asin(max(-1.0, min(1.0, rel[2, 0]))))
            cells = []
            row = {"label": f"{study}: {world.describe()}, t {t:+.2f}", "study": study, "object": obj,
                   "world": world.describe(), "t_s": t, "out_deg": out_deg, "roll_deg": roll, "yaw_deg": yaw,
                   "theta_deg": theta, "g_across_mm": contacts["_g_across"] * 1000}
            out.append(row)
            for name in "GAB":
                row.update({f"{name.lower()}_{f}": None for f in ("n", "in_plane", "across", "mu", "at_mm")})
                if name not in contacts:
                    cells.append(f"{name} -")
                    continue
                force, normal, where, mu = contacts[name]
                n_force = abs(force @ normal)
                if n_force < 1e-6:
                    cells.append(f"{name} -")
                    continue
                tang = force - (force @ normal) * normal
                row.update({f"{name.lower()}_n": float(n_force),
                            f"{name.lower()}_in_plane": float(math.hypot(tang[0], tang[2]) / n_force),
                            f"{name.lower()}_across": float(abs(tang[1]) / n_force), f"{name.lower()}_mu": mu,
                            f"{name.lower()}_at_mm": float(where[0] * 1000)})
                cells.append(f"{name} N {n_force:.2f} in-plane {math.hypot(tang[0], tang[2]) / n_force:.3f} "
                             f"across {abs(tang[1]) / n_force:.3f} (mu {mu:.3f}) at ({where[0] * 1000:.1f}, "
                             f"{where[1] * 1000:+.2f}) mm")
            print(f"  t {t:+.2f} s: out {out_deg:.2f} deg (roll {roll:+.2f}, yaw {yaw:+.2f}), theta {theta:.2f}, "
                  f"G across {contacts['_g_across'] * 1000:+.3f} mm | " + "; ".join(cells))
    return 0

def _replay(setup, params, times):
    """Step one trial as sim.trial.run_trial does (its settling and drive; no verdict) and yield, at
    the tick nearest each of times (s from the first primitive's start, negative in the settling),
    (t, the object's world pose, {contact: (force on the object in the plane frame summed over the
    digit's points (N), the contact's normal in the plane frame, where it touches in the object's
    frame (m), mu), '_g_across': G's slip across the plane since the settling began (m)})."""
    import mujoco

    from ungrasp_ompl.sim import trial as T

    spec, model, data, ids, palm, offset = T._start(setup, params)
    drive = setup.drive
    quats = T._palm_quats(palm)
    frame = setup.target_pose[:3, :3]
    kind = {g: "A" for g in ids.finger_geoms} | {g: "B" for g in ids.thumb_geoms} | {ids.table_geom: "G"}
    f6 = np.zeros(6)
    wanted = sorted(times)
    g0 = data.xpos[ids.object_body].copy()

    def look(t):
        pose = T._pose(data, ids.object_body)
        found = {"_g_across": float((frame.T @ (pose[:3, 3] - g0))[1])}
        sums: dict[str, list] = {}
        for i in range(data.ncon):
            c = data.contact[i]
            g1, g2 = int(c.geom[0]), int(c.geom[1])
            if ids.object_geom not in (g1, g2) or kind.get(g2 if g1 == ids.object_geom else g1) is None:
                continue
            name = kind[g2 if g1 == ids.object_geom else g1]
            mujoco.mj_contactForce(model, data, i, f6)
            rows = c.frame.reshape(3, 3)
            sign = 1.0 if g2 == ids.object_geom else -1.0  # the force on the object
            entry = sums.setdefault(name, [np.zeros(3), sign * rows[0], [], float(c.friction[0])])
            entry[0] = entry[0] + sign * (rows.T @ f6[:3])
            entry[2].append(pose[:3, :3].T @ (c.pos - pose[:3, 3]))
        for name, (force, normal, points, mu) in sums.items():
            found[name] = (frame.T @ force, frame.T @ normal, np.mean(points, axis=0), mu)
        return t, pose, found

    steps = max(1, round(setup.sim.settle_time / model.opt.timestep))
    moving = steps // 2 if np.any(offset) else 0
    quat = T._palm_quats(palm[0][None])[0]
    target = np.round((np.array([w for w in wanted if w < 0]) + setup.sim.settle_time) / model.opt.timestep).astype(int)
    for i in range(steps):
        if i < moving:
            frac = (i + 1) / moving
            pos = palm[0][:3, 3] + offset * (1.0 - frac)
            data.mocap_pos[ids.palm_mocap], data.mocap_quat[ids.palm_mocap] = pos, quat
        mujoco.mj_step(model, data)
        if i + 1 in target:
            yield look((i + 1) * model.opt.timestep - setup.sim.settle_time)
    period = float(drive.times[1] - drive.times[0])
    substeps = max(1, round(period / spec.timestep))
    later = [w for w in wanted if w >= 0]
    for k in range(1, len(drive.times)):
        if not later:
            return
        data.ctrl[ids.actuator] = max(drive.opening[k] - setup.servo_squeeze, 0.0)
        T._move_palm(model, data, ids, (palm[k - 1][:3, 3], quats[k - 1]), (palm[k][:3, 3], quats[k]), substeps)
        t = float(drive.times[k])
        if t >= later[0] - 1e-9:
            later.pop(0)
            yield look(t)

def _plane_mu(scene: Scene, factors: tuple[float, float, float]) -> tuple[float, float, float]:
    """The plane's coefficients at G, A, B with the contacts' own scaled by factors (each reduced
    to the plane as Scene.plane_friction reduces them)."""
    per = [scene.plane_friction(f) for f in factors]
    return per[0][0], per[1][1], per[2][2]

if __name__ == "__main__":
    sys.exit(main())
