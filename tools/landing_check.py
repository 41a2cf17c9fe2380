"""Hold the release model's landing (mechanics.release) to the simulator's.

For each object scene (guitar_pick, puzzle_piece, fabric_chalk) the RRT* plan of seed 1 is executed
with the hand as planned (robot.landing: planned) and its release simulated in four worlds (nominal,
friction x0.7, friction x1.3, pyramidal cones): once with no error drawn and with --draws `paper`
draws. Beside each, the model's landing from the plan's last state (what predict_landing gives the
plan) and, as a diagnosis, from the object's pose the simulation actually reached when the
termination began (the simulated P_dpsi carries the object with the hand, docs/model.md 11.13).
Offsets are the outline centroid's, in the manipulation plane's frame (along GB, + toward B;
across), mm. Columns: planned (the model from the plan's last state), model (from where the carry
through the plan's P_dpsi leaves the object: what predict_landing gives), sim start (from the pose
the simulation reached), sim 0-err (the simulated landing along GB with no error drawn), model-sim,
across (the simulated landing across GB), outcome (the no-error trial's), model mean and sim mean
(over the no-error trial and the drawn ones that placed the object, the model at each draw's
friction), n (how many), and the simulation's G (mm), theta (deg) and s_B (mm, from the commanded
thumb tip) when the termination began; and the termination's phases, the simulator's (from the
no-error trial, its contacts logged) beside the model's: when the pinch lets go (the finger's
force gone; ms from the termination's start), how far the servo's command has opened by then (the
model: the squeeze and what the final press opened the digits, record 0131), G's travel while it holds, the tilt then, and G's travel from then
to the landing (PHASE_FIELDS). The results file also holds each scene's
robot.landing_offset and the model's mean with it less the simulated mean (record 0122). A
pyramidal world's model is the pyramid's two bounds.
A world that sets the friction fixes it (docs/decisions/0100-a-world-fixes-its-friction.md): its
drawn trials draw no friction error, and the model at such a draw takes the world's friction alone.

    python tools/landing_check.py [--objects guitar_pick,puzzle_piece] [--draws 4] [--worlds LABEL,...]
        [--json out.json] [--results]

--worlds runs only the worlds it names: those above, or friction x0.7 or x1.3 under the pyramid at
once ("friction x0.7 under pyramidal", "friction x1.3 under pyramidal", record 0135).

--results writes the study into docs/results/landing_check.json (the markdown beside it rendered
from it; a study's earlier rows replaced, the other studies' kept): "landing", with --forbid-partial
"landing, no P_dpsi", with --no-spread-bound (the scenes' plans without planning.max_landing_spread,
which keep their P_dpsi) "landing, no spread bound"; --study NAME names it otherwise, its rows'
labels then starting with the name.

--scene-starts reads every object's shipped scene, the pick's too, and plans under the scene's own
planning.objective, as tools/sim_campaigns.py plans the campaign's rows; without it the pick starts
where its scene started before decision 0107 and every plan optimises the cost.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from ungrasp_ompl.mechanics.release import (  # noqa: E402
    STEP,
    PyramidReach,
    ReleaseStart,
    fall,
)
from ungrasp_ompl.planning.predicted_landing import carried_start, predict_landing, release_setup  # noqa: E402
from ungrasp_ompl.scene.perturbation import PRESETS, TrialParams  # noqa: E402
from ungrasp_ompl.planning import plan as make_plan  # noqa: E402
from ungrasp_ompl.scene import Scene  # noqa: E402
from ungrasp_ompl.scene.options import Landing  # noqa: E402
from ungrasp_ompl.sim.landing import landing_offset  # noqa: E402
from ungrasp_ompl.sim.plan_trials import placement  # noqa: E402
from ungrasp_ompl.sim.trial import placement_turn, run_trial  # noqa: E402
from ungrasp_ompl.sim.world import Cone, World  # noqa: E402

OBJECTS = ("guitar_pick", "puzzle_piece", "fabric_chalk")
#: The scene file each object's study reads: the pick's plans through a P_dpsi start where its
#: scene started before decision 0107 (scenes/guitar_pick_reference_start.yaml).
STUDY_SCENES = {"guitar_pick": "guitar_pick_reference_start"}
WORLDS = {"nominal": World(), "friction x0.7": World(friction=0.7), "friction x1.3": World(friction=1.3),
          "pyramidal": World(cone=Cone.PYRAMIDAL)}
#: Worlds --worlds may name beside WORLDS: the friction's range under the pyramid at once (record 0135).
COMPOUND_WORLDS = {"friction x0.7 under pyramidal": World(friction=0.7, cone=Cone.PYRAMIDAL),
                   "friction x1.3 under pyramidal": World(friction=1.3, cone=Cone.PYRAMIDAL)}


def in_plane(frame: np.ndarray, offset: np.ndarray) -> tuple[float, float]:
    """A world (x, y) offset as (along GB, across GB) in the plane's frame (m)."""
    return float(offset @ frame[:2, 0]), float(offset @ frame[:2, 1])


def termination_pose(setup, record, frame) -> tuple[float, float, float]:
    """From a recorded trial: the object's G (plane x, m) and tilt (rad) when the termination
    began, and B's distance from the commanded thumb tip along the face (m)."""
    drive = setup.drive
    t0 = drive.phase_start("termination")
    k = int(np.argmin([abs(t - t0) for t, _ in record]))
    inv = np.linalg.inv(frame)
    pose = inv @ np.array(record[k][1])
    x = pose[:3, 0]
    theta = math.atan2(x[2], math.hypot(x[0], x[1]))
    b = pose[:3, :3] @ setup.b_point + pose[:3, 3]
    i = int(np.argmin(np.abs(drive.times - t0)))
    palm = inv @ drive.palm[i]
    tip = palm[:3, 3] - drive.opening[i] / 2 * palm[:3, 0] + setup.spec.gripper.thumb_length * palm[:3, 2]
    s_b = float((tip - b) @ palm[:3, 2])
    return float(pose[0, 3]), theta, s_b


#: The kinds of geometry whose forces on the object are the finger's (sim.trial._Watch.forces).
FINGER_KINDS = ("finger", "finger_tip")


def let_go(setup, record, log, frame) -> tuple[float, float, float, float]:
    """From a trial recorded with its contacts logged: when the pinch lets go (the first control
    tick after the termination began at which the finger exerts no force on the object; s from the
    termination's start), how far the servo's command has opened by then (m), and the object's G
    (plane x, m) and tilt (rad) then. The termination's end and the pose there where the finger
    never lets go."""
    drive = setup.drive
    t0 = drive.phase_start("termination")
    inv = np.linalg.inv(frame)
    poses = dict(record)
    t = next((t for t, forces in log if t > t0 and not any(k in forces for k in FINGER_KINDS)), log[-1][0])
    opened = float(np.interp(t, drive.times, drive.opening) - np.interp(t0, drive.times, drive.opening))
    pose = inv @ np.array(poses.get(t, record[-1][1]))
    x = pose[:3, 0]
    return t - t0, opened, float(pose[0, 3]), math.atan2(x[2], math.hypot(x[0], x[1]))


def model_phases(setup, mu_g: float, mu_b: float, world: World) -> list[tuple[float, float, float, float]]:
    """The model's phases of the termination in world (as model_worlds, one per cone bound): when
    the pinch lets go (s from the termination's start), G's travel while it holds (m), the tilt
    then (rad) and G's travel from then to the landing (m)."""
    out = []
    for mg, mb in world_coefficients(setup, mu_g, mu_b, world):
        f = fall(setup, mg, mb, trace=True)
        theta = float(f.states[0, 3]) if len(f.states) else setup.start.theta
        out.append((setup.hand.released, f.carried, theta, f.offset - setup.start.g - f.carried))
    return out


def drawn_scale(world: World, params: TrialParams) -> tuple[float, float]:
    """The factors a draw puts on (mu_G, mu_B) in world: none on a pair whose friction the world
    sets (decision 0100), as sim.trial.trial_spec builds the trial."""
    fg, _, fb = params.friction_scale
    table_fixed, digits_fixed = world.fixed_friction
    return (1.0 if table_fixed else fg), (1.0 if digits_fixed else fb)


def world_coefficients(setup, mu_g: float, mu_b: float, world: World, scale: tuple[float, float] = (1.0, 1.0)
                       ) -> list[tuple[float, float]]:
    """The model's (mu_G, mu_B) in world, the coefficients also times scale (a draw's factors on
    mu_G and mu_B, drawn_scale): one pair with Coulomb's cone, the pyramid's two bounds with
    pyramidal cones."""
    table, digits = world.friction_factors
    g, b = table * mu_g * scale[0], digits * mu_b * scale[1]
    if world.cone is Cone.ELLIPTIC:
        return [(g, b)]
    reach = PyramidReach.of(np.array(setup.frame), setup.hand.axis)
    return [(g * reach.table[k], b * reach.thumb[k]) for k in (0, 1)]


def model_worlds(setup, mu_g: float, mu_b: float, world: World, scale: tuple[float, float] = (1.0, 1.0),
                 step: float = STEP) -> list[float]:
    """The model's landings (plane x of G, m) in world (world_coefficients), integrated in steps of
    step (s)."""
    return [fall(setup, g, b, step).offset for g, b in world_coefficients(setup, mu_g, mu_b, world, scale)]


#: The coarser and the finer step against which the model's landings are checked (s).
STEP_CHECK = (1e-3, 1e-4)


def unaimed_scene(stem: str | Scene) -> Scene:
    """scenes/STEM.yaml (or that scene, read already) with the hand as planned (robot.landing
    planned, no landing offset): the release the studies measure, where no aim moves it."""
    scene = stem if isinstance(stem, Scene) else Scene.from_file(str(ROOT / "scenes" / f"{stem}.yaml"))
    return replace(scene, robot=replace(scene.robot, landing=Landing.PLANNED, landing_offset=0.0))


def check(name: str, draws: int, seed: int, planning_time: float, forbid_partial: bool = False,
          spread_bound: bool = True, scene_start: bool = False, worlds: dict[str, World] | None = None,
          turn_deg: float = 0.0) -> dict:
    """The comparison for one object scene (forbid_partial: planned without P_dpsi; spread_bound:
    False plans without the scene's planning.max_landing_spread, so that a plan keeps its P_dpsi;
    scene_start: the shipped scene and its own objective, as the campaign plans it; turn_deg: its
    target turned that far about the vertical, as sim_campaigns --turn-target) in worlds
    (label -> World; None: WORLDS)."""
    stem = name if scene_start else STUDY_SCENES.get(name, name)
    from sim_campaigns import _scene

    shipped = _scene(stem, turn_deg=turn_deg)
    offset = shipped.robot.landing_offset
    scene = unaimed_scene(shipped)
    if forbid_partial:
        scene = scene.with_options(forbid_partial=True)
    if not spread_bound:
        scene = scene.with_options(max_landing_spread=None)
    plan = make_plan(scene, planner="RRTstar", time=planning_time, seed=1,
                     objective=None if scene_start else "cost")
    if not plan.solved:
        return {"object": name, "unsolved": plan.reason}
    wall = time.perf_counter()
    prediction = predict_landing(scene, plan)
    predict_s = time.perf_counter() - wall
    _, setup = placement(scene, plan)
    frame = np.asarray(setup.target_pose)
    mu_g, _, mu_b = scene.mu_contacts or scene.mu
    base = release_setup(scene, tuple(plan.states[-1]))
    carried = replace(base, start=carried_start(scene, plan, base))
    rows = []
    for label, world in (WORLDS if worlds is None else worlds).items():
        here = replace(setup, world=world)
        record: list = []
        log: list = []
        nominal = run_trial(here, TrialParams(), record=record, contact_log=log)
        along, across = in_plane(frame, landing_offset(here, np.array(nominal.final_pose)))
        g0, th0, sb0 = termination_pose(here, record, frame)
        t_go, opened, g_go, th_go = let_go(here, record, log, frame)
        phases = model_phases(carried, mu_g, mu_b, world)
        # the model from the pose the simulation reached: G and theta there, the thumb's face through
        # its B at its distance from the tip
        ex, ez = base.hand.axis
        bx, bz = g0 + base.body.length * math.cos(th0), base.body.length * math.sin(th0)
        measured = replace(base, start=ReleaseStart(g0, th0),
                           hand=replace(base.hand, tip=(bx + sb0 * ex, bz + sb0 * ez)))
        planned = model_worlds(base, mu_g, mu_b, world)
        through = model_worlds(carried, mu_g, mu_b, world)
        coarse, fine = (model_worlds(carried, mu_g, mu_b, world, step=dt) for dt in STEP_CHECK)
        from_sim = model_worlds(measured, mu_g, mu_b, world)
        rng = np.random.default_rng(seed)
        drawn, modelled, outcomes = [], [float(np.mean(through))] if nominal.placed else [], []
        for _ in range(draws):
            params = PRESETS["paper"].sample(rng)
            r = run_trial(here, params)
            outcomes.append(r.outcome.value + ("" if r.phase is None else " in " + r.phase))
            if r.placed:
                drawn.append(in_plane(frame, landing_offset(here, np.array(r.final_pose))))
                modelled.append(float(np.mean(model_worlds(carried, mu_g, mu_b, world, drawn_scale(world, params)))))
        everything = ([(along, across)] if nominal.placed else []) + drawn
        mean = (lambda values: float(np.mean(values)) * 1e3 if values else None)  # noqa: E731
        rows.append({"world": label, "sim_along_mm": along * 1e3, "sim_across_mm": across * 1e3,
                     "sim_turn_deg": math.degrees(placement_turn(np.array(nominal.final_pose), frame)),
                     "sim_outcome": nominal.outcome.value,
                     "sim_mean_along_mm": mean([a for a, _ in everything]),
                     "sim_mean_across_mm": mean([c for _, c in everything]),
                     "sim_draws_placed": len(drawn), "model_mean_mm": mean(modelled),
                     "sim_placed": nominal.placed, "draw_outcomes": outcomes,
                     "sim_start_g_mm": g0 * 1e3, "sim_start_theta_deg": math.degrees(th0), "sim_start_sb_mm": sb0 * 1e3,
                     "model_planned_mm": [x * 1e3 for x in planned], "model_mm": [x * 1e3 for x in through],
                     "model_from_sim_start_mm": [x * 1e3 for x in from_sim],
                     "step_change_mm": max(abs(a - b) for a, b in zip(coarse, fine)) * 1e3,
                     "sim_let_go_ms": t_go * 1e3, "sim_hold_mm": (g_go - g0) * 1e3,
                     "sim_let_go_theta_deg": math.degrees(th_go), "sim_fall_mm": (along - g_go) * 1e3,
                     "sim_let_go_opening_mm": opened * 1e3, "model_let_go_opening_mm": carried.hand.held * 1e3,
                     "model_let_go_ms": phases[0][0] * 1e3, "model_hold_mm": [p[1] * 1e3 for p in phases],
                     "model_let_go_theta_deg": [math.degrees(p[2]) for p in phases],
                     "model_fall_mm": [p[3] * 1e3 for p in phases]})
    return {"object": name, "predict_s": predict_s, "landing_offset_mm": offset * 1e3,
            "primitives": [str(p.type) for p in plan.primitives],
            "carried_start_g_mm": carried.start.g * 1e3, "carried_start_theta_deg": math.degrees(carried.start.theta),
            "plan_start_theta_deg": math.degrees(base.start.theta),
            "plan_sb_mm": float(np.dot(np.subtract(base.hand.tip, (base.body.length * math.cos(base.start.theta),
                                                                   base.body.length * math.sin(base.start.theta))),
                                       base.hand.axis)) * 1e3,
            "prediction": prediction.to_dict(), "worlds": rows}


def _span(values: list[float]) -> str:
    """One value, or the range of two (mm)."""
    return f"{values[0]:.2f}" if len(values) == 1 else f"{min(values):.2f}..{max(values):.2f}"


def _or_dash(value: float | None) -> str:
    """A value to the hundredth, or "-" for none (mm)."""
    return "-" if value is None else f"{value:.2f}"


def table(results: list[dict]) -> str:
    """The comparison as a text table (mm): the model from the plan's last state (planned), from the
    carried start (model, what predict_landing gives), from the pose the simulation reached (from sim
    start); the simulation with no error drawn (along and across GB, its outcome) and its mean with
    the drawn trials that placed the object; model - sim mean; the simulation's pose when the
    termination began (G mm, theta deg, s_B mm)."""
    head = (f"{'object':<13} {'world':<14} {'planned':>8} {'model':>13} {'sim start':>13} {'sim 0-err':>9} "
            f"{'model-sim':>9} {'across':>7} {'outcome':<12} {'model mean':>10} {'sim mean':>8} {'n':>2} "
            f"{'sim G, theta, s_B':>22}")
    lines = [head, "-" * len(head)]
    for res in results:
        if "unsolved" in res:
            lines.append(f"{res['object']:<13} no plan: {res['unsolved']}")
            continue
        for row in res["worlds"]:
            m = sum(row["model_mm"]) / len(row["model_mm"])
            diff = f"{m - row['sim_along_mm']:>9.2f}" if row["sim_placed"] else f"{'-':>9}"
            lines.append(f"{res['object']:<13} {row['world']:<14} {_span(row['model_planned_mm']):>8} "
                         f"{_span(row['model_mm']):>13} {_span(row['model_from_sim_start_mm']):>13} "
                         f"{row['sim_along_mm']:>9.2f} {diff} {row['sim_across_mm']:>7.2f} {row['sim_outcome']:<12.12} "
                         f"{_or_dash(row['model_mean_mm']):>10} {_or_dash(row['sim_mean_along_mm']):>8} "
                         f"{row['sim_draws_placed'] + row['sim_placed']:>2} {row['sim_start_g_mm']:>7.2f} "
                         f"{row['sim_start_theta_deg']:>6.2f} {row['sim_start_sb_mm']:>7.2f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--objects", default=",".join(OBJECTS))
    parser.add_argument("--draws", type=int, default=4, help="`paper` draws per world (default 4)")
    parser.add_argument("--seed", type=int, default=1, help="the draws' seed")
    parser.add_argument("--time", type=float, default=1.0, help="RRT*'s planning time (s)")
    parser.add_argument("--forbid-partial", action="store_true", help="plan without P_dpsi (planning.forbid_partial)")
    parser.add_argument("--no-spread-bound", action="store_true",
                        help="plan without the scene's planning.max_landing_spread (its plan may keep a P_dpsi)")
    parser.add_argument("--scene-starts", action="store_true",
                        help="the shipped scenes and their own objective, as the campaign plans them")
    parser.add_argument("--worlds", help="only these worlds, by label, comma-separated (default: "
                        f"{', '.join(WORLDS)}; also {', '.join(COMPOUND_WORLDS)})")
    parser.add_argument("--turn-target", type=float, default=0.0, metavar="DEG",
                        help="turn each scene's target by DEG about the vertical (record 0138)")
    parser.add_argument("--study", help="the study's name in the results file, which starts its rows' labels")
    parser.add_argument("--json", help="write the results there")
    parser.add_argument("--results", action="store_true", help="also write the study into "
                                                               "docs/results/landing_check.json and .md")
    args = parser.parse_args(argv)
    known = {**WORLDS, **COMPOUND_WORLDS}
    worlds = None
    if args.worlds:
        labels = [w.strip() for w in args.worlds.split(",")]
        unknown = [w for w in labels if w not in known]
        if unknown:
            parser.error(f"--worlds: unknown {', '.join(unknown)} (known: {', '.join(known)})")
        worlds = {w: known[w] for w in labels}
    command = shlex.join(["python", "tools/landing_check.py", *(sys.argv[1:] if argv is None else argv)])
    wall = time.perf_counter()
    results = []
    for name in args.objects.split(","):
        res = check(name, args.draws, args.seed, args.time, args.forbid_partial, not args.no_spread_bound,
                    args.scene_starts, worlds, args.turn_target)
        results.append(res)
        if "unsolved" in res:
            print(f"{name}: no plan ({res['unsolved']})", flush=True)
            continue
        p = res["prediction"]
        print(f"{name}: predicted {p['along_m'] * 1e3:.2f} mm along GB (nominal {p['nominal_m'] * 1e3:.2f}, spread "
              f"{p['spread_m'] * 1e3:.2f}, carried {p['carried_m'] * 1e3:.2f}) in {res['predict_s'] * 1e3:.0f} ms; the "
              f"plan's pressed start theta {res['plan_start_theta_deg']:.2f} deg, s_B {res['plan_sb_mm']:.2f} mm; "
              f"carried start G {res['carried_start_g_mm']:.2f} mm, theta {res['carried_start_theta_deg']:.2f} deg; "
              "primitives "
              + " ".join(res["primitives"]),
              flush=True)
    print(table(results))
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    if args.results:
        study = args.study or ("landing" + (", no P_dpsi" if args.forbid_partial else "")
                               + (", no spread bound" if args.no_spread_bound else ""))
        print(f"wrote {write_results(study, command, time.perf_counter() - wall, study_rows(study, results))}")
    return 0


#: How the results file shows each field of its rows (tools/campaign_results.py renders them).
FORMATS = {**{k: "{:.2f}" for k in ("planned_mm", "model_mm", "from_sim_start_mm", "sim_along_mm", "sim_across_mm",
                                    "model_mean_mm", "sim_mean_mm", "sim_start_g_mm", "sim_start_theta_deg",
                                    "sim_start_sb_mm", "sim_turn_deg", "predicted_mm", "nominal_mm", "spread_mm",
                                    "carried_g_mm", "carried_theta_deg", "plan_theta_deg", "plan_sb_mm",
                                    "model_span_mm", "sim_span_mm", "sim_across_abs_mm", "carried_mm")},
           "step_change_mm": "{:.3f}",
           **{k: "{:+.2f}" for k in ("model_minus_sim_mm", "mean_model_minus_sim_mm", "from_sim_start_minus_sim_mm",
                                    "mean_kept_minus_sim_mm", "landing_offset_mm")},
           "predict_ms": "{:.0f}", "seconds": "{:.0f}", "minutes": "{:.0f}",
           **{k: "{:.0f}" for k in ("sim_let_go_ms", "model_let_go_ms")},
           **{k: "{:.2f}" for k in ("sim_let_go_opening_mm", "model_let_go_opening_mm")},
           **{k: "{:+.2f}" for k in ("sim_hold_mm", "model_hold_mm", "sim_fall_mm", "model_fall_mm")},
           **{k: "{:.2f}" for k in ("sim_let_go_theta_deg", "model_let_go_theta_deg")}}
#: The phases of the termination, the simulator's (the no-error trial) and the model's (per cone
#: bound): when the pinch lets go (ms from the termination's start), how far the servo's command has
#: opened then (mm), G's travel while it holds, the tilt when it lets go, G's travel from then to the
#: landing (mm, deg).
PHASE_FIELDS = ("sim_let_go_ms", "model_let_go_ms", "sim_let_go_opening_mm", "model_let_go_opening_mm", "sim_hold_mm",
                "model_hold_mm", "sim_let_go_theta_deg", "model_let_go_theta_deg", "sim_fall_mm", "model_fall_mm")
#: The worlds over which a plan's landing spreads (the model's Coulomb worlds of the scenes' range).
SPREAD_WORLDS = ("nominal", "friction x0.7", "friction x1.3")


def study_rows(study: str, results: list[dict]) -> list[dict]:
    """The results file's rows of one study: per object its plan, the model's prediction and
    start, the spread of model and simulation over the Coulomb worlds; per object and world the
    landings (mm) and the simulation's pose when the termination began."""
    rows = []
    for res in results:
        name = res["object"]
        if "unsolved" in res:
            rows.append({"label": f"{study}: {name}", "study": study, "object": name, "unsolved": res["unsolved"]})
            continue
        p, worlds = res["prediction"], {w["world"]: w for w in res["worlds"]}
        spread = [worlds[w] for w in SPREAD_WORLDS if w in worlds]
        placed = [w["sim_along_mm"] for w in spread if w["sim_placed"]]
        model = [float(np.mean(w["model_mm"])) for w in spread]
        rows.append({"label": f"{study}: {name}", "study": study, "object": name,
                     "primitives": " ".join(res["primitives"]), "predicted_mm": p["along_m"] * 1e3,
                     "nominal_mm": p["nominal_m"] * 1e3, "spread_mm": p["spread_m"] * 1e3,
                     "predict_ms": res["predict_s"] * 1e3, "carried_g_mm": res["carried_start_g_mm"],
                     "carried_theta_deg": res["carried_start_theta_deg"], "plan_theta_deg": res["plan_start_theta_deg"],
                     "plan_sb_mm": res["plan_sb_mm"], "carried_mm": p["carried_m"] * 1e3,
                     "landing_offset_mm": res["landing_offset_mm"],
                     "step_change_mm": max(w["step_change_mm"] for w in res["worlds"]),
                     "model_span_mm": max(model) - min(model) if model else None,
                     "sim_span_mm": max(placed) - min(placed) if placed and len(placed) == len(spread) else None})
        for w in res["worlds"]:
            rows.append({
                "label": f"{study}: {name}, {w['world']}", "study": study, "object": name, "world": w["world"],
                "planned_mm": w["model_planned_mm"], "model_mm": w["model_mm"],
                "from_sim_start_mm": w["model_from_sim_start_mm"], "sim_outcome": w["sim_outcome"],
                "sim_placed": w["sim_placed"], "sim_along_mm": w["sim_along_mm"] if w["sim_placed"] else None,
                "sim_across_mm": w["sim_across_mm"] if w["sim_placed"] else None,
                "sim_across_abs_mm": abs(w["sim_across_mm"]) if w["sim_placed"] else None,
                "sim_turn_deg": w["sim_turn_deg"] if w["sim_placed"] else None,
                "model_minus_sim_mm": [m - w["sim_along_mm"] for m in w["model_mm"]] if w["sim_placed"] else None,
                "from_sim_start_minus_sim_mm": ([m - w["sim_along_mm"] for m in w["model_from_sim_start_mm"]]
                                                if w["sim_placed"] else None),
                "n": w["sim_draws_placed"] + w["sim_placed"], "model_mean_mm": w["model_mean_mm"],
                "sim_mean_mm": w["sim_mean_along_mm"],
                "mean_model_minus_sim_mm": (None if w["sim_mean_along_mm"] is None
                                            else w["model_mean_mm"] - w["sim_mean_along_mm"]),
                "mean_kept_minus_sim_mm": (None if w["sim_mean_along_mm"] is None else
                                           w["model_mean_mm"] + res["landing_offset_mm"] - w["sim_mean_along_mm"]),
                "draw_outcomes": w["draw_outcomes"], "sim_start_g_mm": w["sim_start_g_mm"],
                "sim_start_theta_deg": w["sim_start_theta_deg"], "sim_start_sb_mm": w["sim_start_sb_mm"],
                **{k: w[k] for k in PHASE_FIELDS if k in w}})
    return rows


def write_results(study: str, command: str, seconds: float, rows: list[dict]) -> Path:
    """Put one study's rows into docs/results/landing_check.json (the other study's rows kept) and
    render the markdown beside it; both written atomically."""
    from campaign_results import merge_study

    return merge_study(ROOT / "docs" / "results" / "landing_check.json", study, command, seconds, rows, FORMATS,
                       "tools/landing_check.py: the release model's landing against the simulator's "
                       "(docs/model.md 11.17)")


if __name__ == "__main__":
    raise SystemExit(main())
