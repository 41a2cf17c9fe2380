"""The ``ungrasp-ompl`` command.

Exit codes: 0 solved (or done); 2 bad input (one line naming the field and
the reason); 3 no solution (with the reason found), including a plan the
robot cannot execute (out of reach, or beyond its limits); 1 a tool the
command relies on is missing or failed (one line).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from pathlib import Path

from . import __version__
from .errors import EXIT_NO_SOLUTION, EXIT_OK, InputError, UngraspError
from .shipped import resolve, shipped_names, shipped_scenes


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line naming the argument, exit 2, no usage dump
        raise _argument_error(message)


def _argument_error(message: str) -> InputError:
    """argparse's complaint as an InputError naming the argument, e.g. "argument --time: invalid float
    value: 'x'" as "--time: must be a number, got 'x'"."""
    import re

    if m := re.fullmatch(r"argument (\S+): (.*)", message, re.S):
        name, reason = m[1].split("/")[-1], m[2]
        if kind := re.fullmatch(r"invalid (int|float) value: (.*)", reason):
            reason = f"must be {'an integer' if kind[1] == 'int' else 'a number'}, got {kind[2]}"
        elif choice := re.fullmatch(r"invalid choice: (.*) \(choose from (.*)\)", reason):
            reason = f"must be one of {choice[2].replace(chr(39), '')}, got {choice[1]}"
        return InputError(name, reason)
    if m := re.fullmatch(r"the following arguments are required: (.*)", message):
        return InputError(m[1], "is required")
    if m := re.fullmatch(r"unrecognized arguments: (.*)", message):
        return InputError(m[1].split()[0], "is not an argument of this command (see --help)")
    return InputError("arguments", message)


def _seconds(text: str) -> float:
    """A --time value: a finite number of seconds > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of seconds > 0, got {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    if value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a finite number of seconds, got {text}")
    return value


#: Planners `bench` runs by default: OMPL's asymptotically optimal and feasibility planners
#: that work with Python callbacks, and the exact lattice search as the yardstick.
BENCH_PLANNERS = ("RRTstar", "InformedRRTstar", "BITstar", "FMT", "AORRTC", "RRTConnect", "lattice")


def _parser() -> argparse.ArgumentParser:
    from .planning import PLANNERS

    p = _Parser(prog="ungrasp-ompl", description="Plan dexterous ungrasping with OMPL.")
    p.add_argument("--version", action="version", version=f"ungrasp-ompl {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    pl = sub.add_parser("plan", help="plan a scene; print a summary, write plan.json and cspace.png")
    pl.add_argument("scene", help="scene file (YAML), or the name of a shipped scene (see `scenes`)")
    pl.add_argument("--planner", default="RRTstar", help=f"OMPL planner ({', '.join(PLANNERS)}) or lattice")
    pl.add_argument("--objective", default="cost", choices=("cost", "margin", "balanced"),
                    help="cost (default), margin (the largest smallest friction margin along the path, then fewest "
                         "primitive changes, then the least length spent near that margin, then cost) or balanced "
                         "(cost plus planning.margin_weight times a penalty growing as the margin shrinks)")
    pl.add_argument("--time", type=_seconds, default=1.0, help="planning time in seconds (default 1)")
    pl.add_argument("--seed", type=int, default=None,
                    help="seed: the same seed gives the same plan (default: one drawn at random, printed and "
                         "stored in plan.json)")
    pl.add_argument("--iterations", type=int, default=None,
                    help="planner iterations (default with a seed: 6000 per second of --time; "
                         "1000 for PRM and PRMstar)")
    pl.add_argument("--out", default=None, help="directory for plan.json and cspace.png")
    pl.add_argument("--export", default=None, metavar="DIR",
                    help="also time the plan on the UR5e and its gripper and write the joint trajectory "
                         "(CSV, JSON, ROS 2 YAML, URScript) and plan.json to DIR")
    pl.add_argument("--cage", action="store_true",
                    help="also find the smallest escape energy (the energy-bounded cage, gravity only) along the "
                         "plan and where (takes seconds; in plan.json under cage)")
    pl.add_argument("--certify", type=int, default=None, metavar="N",
                    help="plan several candidates (--candidates), simulate N trials of each with the paper "
                         "perturbation, and keep the one with the highest Wilson 95 %% lower bound on success "
                         "(in plan.json under certification)")
    pl.add_argument("--candidates", type=int, default=None, metavar="K",
                    help="candidate plans with --certify (default 4): objectives in turn (--objective first), "
                         "for each the planner with --seed then the lattice; then the planner with seed + 1, + 2, ...")
    pl.add_argument("--jobs", type=int, default=None,
                    help="parallel trials with --certify (default: all cores)")

    bn = sub.add_parser("bench", help="benchmark OMPL planners (and the exact lattice search) on scenes")
    bn.add_argument("scenes", nargs="+", help="scene files (YAML) or names of shipped scenes")
    bn.add_argument("--planners", default=",".join(BENCH_PLANNERS),
                    help=f"comma-separated planners (default {','.join(BENCH_PLANNERS)})")
    bn.add_argument("--runs", type=int, default=10, help="runs per scene and planner (default 10)")
    bn.add_argument("--time", type=_seconds, default=1.0, help="seconds per run (default 1)")
    bn.add_argument("--jobs", type=int, default=2, help="parallel worker processes (default 2)")
    bn.add_argument("--seed", type=int, default=1, help="seed of the first run; run k gets seed + k")
    bn.add_argument("--iterations", type=int, default=None,
                    help="planner iterations per run: runs become reproducible like plan --seed (5x --time as a "
                         "hard cap); default: stop on wall time, like OMPL's Benchmark")
    bn.add_argument("--out", default="benchmark", help="output directory (default ./benchmark)")
    bn.add_argument("--cluster", default=None, metavar="ADDRESS", help="run on the Ray cluster at HOST:PORT (or the RAY_ADDRESS variable); local: start one here")
    bn.add_argument("--resume", action="store_true", help="keep the runs already in OUT/runs.csv, run the others")
    bn.add_argument("--objective", default="cost", choices=("cost", "margin", "balanced"),
                    help="what every planner (and the lattice yardstick) optimises, as for plan (default cost)")

    sw = sub.add_parser("sweep", help="success and cost against digit asymmetry alpha")
    sw.add_argument("scene", help="scene file (YAML) or the name of a shipped scene")
    sw.add_argument("--alpha", required=True, help="START:STOP:STEP over the object length, e.g. 0:0.6:0.05")
    sw.add_argument("--planner", default="RRTstar")
    sw.add_argument("--runs", type=int, default=5, help="runs per alpha (default 5)")
    sw.add_argument("--time", type=_seconds, default=1.0, help="seconds per run (default 1)")
    sw.add_argument("--jobs", type=int, default=2)
    sw.add_argument("--seed", type=int, default=1, help="seed of the first run; run k gets seed + k")
    sw.add_argument("--iterations", type=int, default=None,
                    help="planner iterations per run (reproducible runs); default: stop on wall time")
    sw.add_argument("--out", default="sweep", help="output directory (default ./sweep)")
    sw.add_argument("--cluster", default=None, metavar="ADDRESS", help="run on the Ray cluster at HOST:PORT (or the RAY_ADDRESS variable); local: start one here")
    sw.add_argument("--resume", action="store_true", help="keep the runs already in OUT/runs.csv, run the others")

    mp = sub.add_parser("map", help="a feasibility map over digit asymmetry and friction: the exact verdict, the "
                        "planner's success and cost (and simulated success) per cell")
    mp.add_argument("scene", help="scene file (YAML) or the name of a shipped scene")
    mp.add_argument("--alpha", required=True, help="START:STOP:STEP over the object length, e.g. 0:0.6:0.05")
    mp.add_argument("--friction-scale", default="1", metavar="START:STOP:STEP",
                    help="factors on every friction coefficient of the scene, e.g. 0.5:1.5:0.1 (default 1)")
    mp.add_argument("--start-theta", type=float, default=None, metavar="DEG",
                    help="the start pinch's theta in degrees in every cell (default the scene's)")
    mp.add_argument("--planner", default="RRTstar", help="planner per cell (an OMPL planner, or lattice)")
    mp.add_argument("--time", type=_seconds, default=0.5,
                    help="planning time per cell in seconds, as a seeded iteration budget (default 0.5)")
    mp.add_argument("--seed", type=int, default=1, help="seed of the planner and the simulated trials (default 1)")
    mp.add_argument("--simulate", type=int, default=0, metavar="N",
                    help="also simulate N trials of each cell's plan (needs an object thickness)")
    mp.add_argument("--perturb", default="paper", help="perturbation preset of the simulated trials (default paper)")
    mp.add_argument("--jobs", type=int, default=2, help="cells at a time on this machine (default 2)")
    mp.add_argument("--cluster", default=None, metavar="ADDRESS", help="run on the Ray cluster at HOST:PORT (or the RAY_ADDRESS variable); local: start one here")
    mp.add_argument("--resume", action="store_true", help="keep the cells already done in OUT/map.csv")
    mp.add_argument("--out", default="map", help="output directory (default ./map): map.csv and map.png")

    dn = sub.add_parser("design", help="the digits for an object: plan a grid of digit asymmetries and finger-tip radii, "
                        "choose the most tolerant plan (or the most successful with --simulate)")
    dn.add_argument("scene", help="scene file (YAML) or the name of a shipped scene")
    dn.add_argument("--alpha", default=None, metavar="START:STOP:STEP",
                    help="digit asymmetry over the object length (default five values 0.05 apart about the scene's)")
    dn.add_argument("--tip-radius", default=None, metavar="START:STOP:STEP",
                    help="the rounded finger tip's dome radius in mm (default 0.5, 0.75, 1, 1.5 and 2 times the scene's)")
    dn.add_argument("--finger-tip", default="rounded", choices=("rounded", "flat"),
                    help="rounded (point contact at A, the radius varies) or flat (edge contact)")
    dn.add_argument("--goal", default="free", choices=("free", "scene"),
                    help="free: each design lets go wherever its digits can (d and psi within the bounds); scene: "
                    "the scene's own goal region (default free)")
    dn.add_argument("--simulate", type=int, default=0, metavar="N",
                    help="also simulate N trials of each design's plan and choose by success (Wilson lower bound)")
    dn.add_argument("--perturb", default="paper", help="error preset of the simulated trials (default paper)")
    dn.add_argument("--seed", type=int, default=1, help="seed of the simulated trials' errors (default 1)")
    dn.add_argument("--jobs", type=int, default=2, help="designs at a time on this machine (default 2)")
    dn.add_argument("--cluster", default=None, metavar="ADDRESS",
                    help="run on the Ray cluster at HOST:PORT (or the RAY_ADDRESS variable); local: start one here")
    dn.add_argument("--out", default="design", help="output directory (default ./design): design.csv, design.png, "
                    "design_scene.yaml")

    st = sub.add_parser("stability", help="print the 3D stability analysis of a scene with an object outline")
    st.add_argument("scene", help="scene file (YAML) with object.outline, or the name of a shipped scene")

    cg = sub.add_parser("cage", help="the energy-bounded cage (escape energy) and the friction margin along a plan")
    cg.add_argument("scene", help="scene file (YAML) of an object with a thickness, or the name of a shipped scene")
    cg.add_argument("--plan", default=None, help="plan.json to examine, or a directory holding one (plan --export "
                    "DIR); default: plan the scene, as plan does")
    cg.add_argument("--planner", default="RRTstar", help="planner when no --plan is given (default RRTstar)")
    cg.add_argument("--time", type=_seconds, default=1.0, help="planning time in seconds when planning (default 1)")
    cg.add_argument("--seed", type=int, default=1, help="seed when planning (default 1)")
    cg.add_argument("--squeeze", type=float, default=0.0,
                    help="a constant force (N) pressing the object where the finger does (default 0: gravity only)")
    cg.add_argument("--finger-tip", choices=("rounded", "flat"), default=None,
                    help="the finger's tip instead of the scene's (rounded: point contact; flat: edge contact)")
    cg.add_argument("--start-psi-offset-deg", type=float, default=None,
                    help="start the plan with psi this much larger (the paper's deviated start, sec. 6.2.3)")
    cg.add_argument("--refine", type=float, default=1.0, metavar="FACTOR",
                    help="divide the pose grid's steps (and its penetration tolerance) by FACTOR, to see whether "
                         "the answer holds on a finer grid (default 1; 2 takes about 8 times as long)")
    cg.add_argument("--out", default=None, help="directory for cage.png and cage.json")

    tl = sub.add_parser("tile", help="put every piece of a layout into its frame: order, planes, plans, one trajectory")
    tl.add_argument("layout", help="layout file (YAML): a frame and its pieces; or the name of a shipped layout")
    tl.add_argument("--planner", default="RRTstar", help="planner per piece (an OMPL planner, or lattice)")
    tl.add_argument("--time", type=_seconds, default=1.0, help="planning time per piece in seconds (default 1)")
    tl.add_argument("--seed", type=int, default=None,
                    help="seed: piece k is planned with seed + k (default: one drawn at random and printed)")
    tl.add_argument("--range", type=float, default=1.0,
                    help="the planner's longest motion per piece, state units (default 1.0)")
    tl.add_argument("--approaches", type=int, default=6, help="manipulation planes tried per piece (default 6)")
    tl.add_argument("--out", default="tiling", help="output directory (default ./tiling): tiling.json, "
                    "layout.png, a C-space picture per piece and the exported trajectory")

    sm = sub.add_parser("simulate", help="execute a plan in MuJoCo: success rate and placement errors over "
                        "perturbed trials")
    sm.add_argument("scene", help="scene file (YAML) with an object thickness, or a layout (every piece in "
                    "turn), or the name of a shipped one")
    sm.add_argument("--plan", default=None, help="plan.json (or a directory holding one) to execute instead of "
                    "planning (may be one the model rejects for this scene: a warning says why)")
    sm.add_argument("--planner", default="RRTstar", help="planner when no --plan is given (default RRTstar)")
    sm.add_argument("--time", type=_seconds, default=1.0, help="planning time in seconds (default 1)")
    sm.add_argument("--trials", type=int, default=10, help="trials (default 10)")
    sm.add_argument("--seed", type=int, default=1, help="seed of the plan and of the trials' perturbations (default 1)")
    sm.add_argument("--perturb", default="paper", help="perturbation preset: paper (default), none, grasp, "
                    "friction, mass, thickness")
    sm.add_argument("--jobs", type=int, default=None, help="parallel worker processes (default: all cores)")
    sm.add_argument("--out", default="simulation", help="output directory (default ./simulation)")
    sm.add_argument("--cluster", default=None, metavar="ADDRESS", help="run on the Ray cluster at HOST:PORT (or the RAY_ADDRESS variable); local: start one here")
    sm.add_argument("--finger-tip", choices=("rounded", "flat"), default=None,
                    help="the finger's tip instead of the scene's (rounded: point contact; flat: edge contact)")
    sm.add_argument("--start-psi-offset-deg", type=float, default=None,
                    help="start the plan with psi this much larger, outside force closure (caging experiment)")
    sm.add_argument("--friction-scale", type=float, default=1.0,
                    help="simulate with every friction coefficient times this, in (0, 1] (a control)")
    sm.add_argument("--thickness", type=float, default=None,
                    help="simulate an object of this thickness (m) with the motion planned for the scene's")
    sm.add_argument("--equal-digits", action="store_true",
                    help="simulate a thumb as long as the finger (alpha 0), the motion unchanged (a control)")

    vw = sub.add_parser("view", help="an animated 3D view (one offline HTML page) of what plan --export, tile or "
                        "simulate wrote")
    vw.add_argument("dir", metavar="DIR", help="a directory holding trajectory.json (plan --export DIR, tile --out DIR, "
                    "simulate --out DIR)")
    vw.add_argument("--out", default=None, help="the HTML file to write (default DIR/view.html)")
    vw.add_argument("--frames", type=int, default=None, metavar="K",
                    help="also write a PNG strip of K key frames beside it (view_frames.png)")

    rg = sub.add_parser("regions", help="draw the C-space map (free, not force-closed, in collision)")
    rg.add_argument("scene", help="scene file (YAML) or the name of a shipped scene")
    rg.add_argument("--out", required=True, help="PNG file to write")

    sub.add_parser("scenes", help="list the shipped scenes and layouts, which every command takes by name")
    return p


def _plan(args: argparse.Namespace) -> int:
    path = resolve(args.scene, "scene")  # before the imports: a wrong name is answered at once
    from .scene import Scene
    from .sim.campaign import default_jobs
    from .sim.certify import CertifyOptions
    from .workflows.plan import PlanOptions, plan_scene

    scene = Scene.from_file(path)
    out = Path(args.out) if args.out else None
    export = Path(args.export) if args.export else None
    for flag, path in (("--out", out), ("--export", export)):
        if path is not None and path.exists() and not path.is_dir():
            raise InputError(flag, f"{path} exists and is not a directory")
    if args.certify is None:
        for flag in ("candidates", "jobs"):
            if getattr(args, flag) is not None:
                raise InputError(f"--{flag}", "applies only with --certify N")
    if args.cage and scene.object_thickness <= 0.0:  # before a seed is drawn
        raise InputError("--cage", "the cage's potential energy needs an object with a thickness (object.thickness)",
                         scene.source)
    seed = _seed(args.seed)
    certify = None if args.certify is None else CertifyOptions(
        trials=args.certify, candidates=4 if args.candidates is None else args.candidates, planner=args.planner,
        objective=args.objective, time=args.time, iterations=args.iterations, seed=seed,
        jobs=default_jobs() if args.jobs is None else args.jobs)
    options = PlanOptions(planner=args.planner, time=args.time, seed=seed, iterations=args.iterations,
                          objective=args.objective, cage=args.cage, certify=certify)
    bars = {"planning": _Progress("candidates", "planning"), "simulating": _Progress("trials", "simulate")}
    result = plan_scene(scene, options, lambda p: bars[p.stage].show(p.done, p.total))
    print(result.summary())
    if out is not None and (result.certification is None or result.certification.certified):
        files = result.write(out)
        print(f"wrote {files['plan']} and {files['cspace']}")
    if not result.solved:
        return EXIT_NO_SOLUTION
    if export is not None:
        if scene.planar_only:
            print(f"note: {scene.name} is planar-only: {scene.planar_only}")
        execution = result.execute()
        print(execution.summary())
        paths = result.export(export, execution)
        print("wrote " + ", ".join(str(p) for p in paths.values()))
        print(f"view it: ungrasp-ompl view {export}  (writes {export / 'view.html'})")
    return EXIT_OK


def _seed(given: int | None) -> int:
    """The seed to plan with: the one given, else one drawn at random and printed, so that every run
    can be repeated."""
    if given is not None:
        return given
    import secrets

    seed = 1 + secrets.randbelow(9999)
    print(f"seed {seed} (pass --seed {seed} to repeat)")
    return seed


def _stability(args: argparse.Namespace) -> int:
    import math

    from .scene import Scene
    from .scene.stability import analyse

    scene = Scene.from_file(resolve(args.scene, "scene"))
    if scene.plane is None:
        raise InputError("object.outline", "is missing: the stability analysis needs the object's outline", scene.source)
    plane = scene.plane
    g, b = plane.g.point * 1000, plane.b.point * 1000
    print(f"{scene.name}: object {scene.object3d.thickness * 1000:.2f} mm thick, l = |GB| = {plane.length * 1000:.2f} mm")
    print(f"  G ({g[0]:.2f}, {g[1]:.2f}) mm, B ({b[0]:.2f}, {b[1]:.2f}) mm, friction margin "
          f"{math.degrees(plane.margin):.2f} deg{' (fixed by the scene)' if plane.fixed else ''}")
    print(f"  effective friction: mu'_G {plane.mu_g:.4f} (from {scene.mu_contacts[0]:.4f}), "
          f"mu'_B {plane.mu_b:.4f} (from {scene.mu_contacts[2]:.4f})")
    goal_lo, goal_hi = scene.goal.box()
    states = [("start", scene.start), ("goal centre", (goal_lo + goal_hi) / 2)]
    report = analyse(scene, states)
    print("\n".join(report.lines()))
    print("  legs: P_theta and P_psi keep full stability (at most one sliding contact); P_dpsi partial "
          f"(two sliding, no z-moments){'; forbidden by the scene' if scene.options.forbid_partial else ''}")
    verdict = "self-restoring" if report.self_restoring else "NOT self-restoring"
    print(f"verdict: the grasp is {verdict} in roll; x-moments {'held' if report.x_stable else 'NOT held'}")
    return EXIT_OK




def _cage(args: argparse.Namespace) -> int:
    import math

    from .cage_report import CageOptions, cage_report
    from .scene import Scene

    scene = Scene.from_file(resolve(args.scene, "scene"))
    out = Path(args.out) if args.out else None
    if out is not None and out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a directory")
    offset = None if args.start_psi_offset_deg is None else math.radians(args.start_psi_offset_deg)
    options = CageOptions(plan=args.plan, planner=args.planner, time=args.time, seed=args.seed, squeeze=args.squeeze,
                          refine=args.refine, finger_tip=args.finger_tip, start_psi_offset=offset)
    report = cage_report(scene, options)
    print(report.summary())
    if not report.plan.solved:
        return EXIT_NO_SOLUTION
    if out is not None:
        files = report.write(out)
        print(f"wrote {files[0]} and {files[1]}")
    return EXIT_OK


def _bench(args: argparse.Namespace) -> int:
    from .benchmark import BenchmarkOptions, run_benchmark

    planners = tuple(p.strip() for p in args.planners.split(",") if p.strip())
    scenes = [resolve(s, "scene") for s in args.scenes]
    options = BenchmarkOptions(planners=planners, runs=args.runs, time=args.time, jobs=args.jobs, seed=args.seed,
                               out=args.out, iterations=args.iterations, cluster=_cluster(args), resume=args.resume,
                               objective=args.objective)
    result = run_benchmark(scenes, options, progress=_Progress("runs", "bench").show)
    print(result.table)
    print(f"wrote {', '.join(p.name for p in result.files.values())} to {result.out}")
    return EXIT_OK


def _sweep(args: argparse.Namespace) -> int:
    from .benchmark import SweepOptions, parse_alpha_range, run_sweep

    options = SweepOptions(alphas=tuple(parse_alpha_range(args.alpha)), planner=args.planner, runs=args.runs,
                           time=args.time, jobs=args.jobs, seed=args.seed, out=args.out, iterations=args.iterations,
                           cluster=_cluster(args), resume=args.resume)
    result = run_sweep(resolve(args.scene, "scene"), options, progress=_Progress("runs", "sweep").show)
    o = result.options
    print(f"{result.scene}: {o.planner}, {o.runs} run(s) of {o.time:g} s per alpha; costs in {result.units}")
    print(result.table)
    print(f"wrote {', '.join(p.name for p in result.files.values())} to {o.out}")
    return EXIT_OK


def _map(args: argparse.Namespace) -> int:
    from .benchmark.map import MapOptions, run_map
    from .benchmark.ranges import parse_range
    from .errors import EXIT_FAILURE

    options = MapOptions(alphas=tuple(parse_range(args.alpha, "--alpha")),
                         friction_scales=tuple(parse_range(args.friction_scale, "--friction-scale")),
                         start_theta_deg=args.start_theta, planner=args.planner, time=args.time, seed=args.seed,
                         simulate=args.simulate, perturb=args.perturb, jobs=args.jobs, cluster=_cluster(args),
                         resume=args.resume, out=args.out)
    bar = _Progress("cells", "map")
    result = run_map(resolve(args.scene, "scene"), options,
                     progress=lambda p: bar.show(p.done, p.total, _map_progress(p)))
    o, cells = result.options, result.cells
    exists = sum(bool(c.secure_path) for c in cells)
    solved = sum(bool(c.planner_solved) for c in cells)
    print(f"{result.scene}: {len(o.alphas)} x {len(o.friction_scales)} cells (alpha x friction scale), "
          f"{result.ran} computed now, {len(cells) - result.ran} kept from {result.files['csv']}")
    print(f"  a secure path exists in {exists}; {o.planner} ({o.time:g} s, seed {o.seed}) solved {solved}"
          + (f"; simulated {o.simulate} trials per solved cell ({o.perturb})" if o.simulate else ""))
    if result.failed:
        print(f"  {len(result.failed)} cells failed (task_status in map.csv), e.g. alpha {result.failed[0].alpha:g}, "
              f"friction x{result.failed[0].friction_scale:g}: {result.failed[0].error}; --resume runs them again")
    print(f"wrote {result.files['csv']} and {result.files['plot']}")
    return EXIT_FAILURE if result.failed else EXIT_OK




def _design(args: argparse.Namespace) -> int:
    from .benchmark.design import DesignOptions, run_design
    from .benchmark.ranges import parse_range

    radii = tuple(r / 1000 for r in parse_range(args.tip_radius, "--tip-radius")) if args.tip_radius else ()
    options = DesignOptions(alphas=tuple(parse_range(args.alpha, "--alpha")) if args.alpha else (), tip_radii=radii,
                            finger_tip=args.finger_tip, goal=args.goal, simulate=args.simulate, perturb=args.perturb, seed=args.seed,
                            jobs=args.jobs, cluster=_cluster(args), out=args.out)
    bar = _Progress("designs", "design")
    result = run_design(args.scene, options, progress=lambda p: bar.show(p.done, p.total))
    files = result.write(result.options.out)
    print(result.summary())
    print(f"wrote {', '.join(str(p) for p in files.values())}")
    return EXIT_OK if result.best is not None else EXIT_NO_SOLUTION


def _map_progress(p) -> str:
    """How a map stands, beside its count (p: benchmark.map.MapProgress)."""
    words = []
    if p.resumed:
        words.append(f"{p.resumed} from an earlier run")
    if p.failed:
        words.append(f"{p.failed} failed")
    if p.last is not None:
        verdict = ("failed" if p.last.secure_path is None else
                   "secure path" if p.last.secure_path else "no secure path")
        words.append(f"last alpha {p.last.alpha:g}, friction x{p.last.friction_scale:g}: {verdict}")
    return "; ".join(words)


class _Progress:
    """How far a long command has got, on stderr: on a terminal a tqdm bar (count, rate, time left)
    redrawn in place; in a pipe or a log a plain line at each tenth (never a carriage return). A
    new stage starts a new bar. A bar ends when done reaches total, and is wiped when the command
    ends with an error (run() closes it), so that the error's line is the one left."""

    open: list["_Progress"] = []  #: bars on the terminal now

    def __init__(self, unit: str, stage: str = "") -> None:
        self.unit = unit
        """What is counted (runs, trials, cells, pieces)."""
        self.stage = stage
        """What is being done, shown before the count."""
        self.bar = None
        self.tenth = 0  # tenths reported in a log (none at the start)
        self.started = time.monotonic()

    def show(self, done: int, total: int, status: str = "", stage: str | None = None) -> None:
        """done of total units so far; status: a few words on the latest one."""
        if stage is not None and stage != self.stage:
            self.close()
            self.stage, self.tenth, self.started = stage, 0, time.monotonic()
        if sys.stderr.isatty():
            if self.bar is None:
                import shutil

                from tqdm import tqdm

                cols, rows = shutil.get_terminal_size()  # 80 x 24 where a terminal says 0 x 0 (tqdm would hide)
                self.bar = tqdm(total=total, desc=self.stage or None, unit=f" {self.unit}", file=sys.stderr,
                                ncols=cols, nrows=rows)
                _Progress.open.append(self)
            self.bar.total = total
            self.bar.set_postfix_str(status, refresh=False)
            self.bar.update(done - self.bar.n)
        elif total and 10 * done // total > self.tenth:
            self.tenth = 10 * done // total
            spent = time.monotonic() - self.started
            left = f", about {spent * (total - done) / done:.0f} s left" if 0 < done < total else ""
            print(f"{self.stage + ': ' if self.stage else ''}{done}/{total} {self.unit} after {spent:.0f} s{left}"
                  + (f"; {status}" if status else ""), file=sys.stderr, flush=True)
        if done >= total:
            self.close()

    def close(self, ok: bool = True) -> None:
        """End the bar: kept on its line (ok) or wiped (the command ends with an error)."""
        if self.bar is not None:
            self.bar.leave = ok
            self.bar.close()
            self.bar = None
            _Progress.open.remove(self)


def _cluster(args: argparse.Namespace) -> str | None:
    """The Ray cluster to run on: --cluster, else the RAY_ADDRESS variable, else None (this machine)."""
    return args.cluster or os.environ.get("RAY_ADDRESS") or None


def _tile(args: argparse.Namespace) -> int:
    from .layout import Layout
    from .tiling import TilingOptions
    from .workflows.tile import check_tiling_options, tile_layout

    layout = Layout.from_file(resolve(args.layout, "layout"))
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a directory")
    options = check_tiling_options(TilingOptions(planner=args.planner, time=args.time, seed=args.seed,
                                                 range=args.range, approaches=args.approaches))
    seed = _seed(args.seed)
    result = tile_layout(layout, dataclasses.replace(options, seed=seed), _tile_progress(_Progress("pieces")))
    print(result.summary())
    doc, picture, cspaces = result.write(out)
    print(f"wrote {doc}, {picture} and {len(cspaces)} C-space pictures")
    if result.execution is None:
        return EXIT_NO_SOLUTION
    print("wrote " + ", ".join(str(p) for p in result.export(out).values()))
    print(f"view it: ungrasp-ompl view {out}  (writes {out / 'view.html'})")
    return EXIT_OK


def _tile_progress(bar: _Progress):
    """tile()'s progress (p: tiling.TilingProgress) on the bar: a stage for the search, one for the plans."""
    def show(p) -> None:
        if p.stage == "search":
            bar.show(p.done, p.total, f"{p.checks} approaches checked ({p.piece})", "searching an order")
        else:
            bar.show(p.done, p.total, p.piece, "planning")
    return show




def _simulate(args: argparse.Namespace) -> int:
    import math

    from .layout import Layout
    from .scene import Scene, read_yaml
    from .workflows.simulate import SimulateOptions, simulate_layout, simulate_scene

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a directory")
    shipped = next((s for s in shipped_scenes() if s.name == args.scene), None)
    path = resolve(args.scene, shipped.kind if shipped and not Path(args.scene).exists() else "scene")
    offset = None if args.start_psi_offset_deg is None else math.radians(args.start_psi_offset_deg)
    options = SimulateOptions(trials=args.trials, perturb=args.perturb, seed=args.seed, jobs=args.jobs,
                              cluster=_cluster(args), plan=args.plan, planner=args.planner, time=args.time,
                              finger_tip=args.finger_tip, start_psi_offset=offset, friction_scale=args.friction_scale,
                              thickness=args.thickness, equal_digits=args.equal_digits)
    doc = read_yaml(path, "scene")
    if isinstance(doc, dict) and "frame" in doc and "pieces" in doc:
        layout = Layout.from_file(path)
        run = simulate_layout(layout, options, _progress(args.trials))
        print(run.summary())
        if run.execution is None:
            return EXIT_NO_SOLUTION
        files = run.write(out)
        print(f"wrote {files['summary']} and the trajectory")
        return EXIT_OK
    scene = Scene.from_dict(doc, source=str(path), default_name=path.stem)
    run = simulate_scene(scene, options, _progress(args.trials))
    print(run.summary())
    if run.report is None:
        return EXIT_NO_SOLUTION
    files = run.write(out)
    print(f"wrote {files['trials']}, {files['summary']}, {files['picture']}, plan.json, the trajectory, "
          f"view_scene.json, trial_poses.json (trial 0's object poses) and model.xml (trial 0's world, keyframe "
          f"'start': python -m mujoco.viewer --mjcf={files['model']})")
    print(f"view it: ungrasp-ompl view {out}  (trial 0 beside the plan)")
    return EXIT_OK


def _progress(total: int):
    """A progress bar of total trials (or attempts), advanced by each call."""
    bar, done = _Progress("trials", "simulate"), [0]

    def step(_) -> None:
        done[0] += 1
        bar.show(done[0], total)

    return step


def _view(args: argparse.Namespace) -> int:
    from .view import make_view

    files = make_view(args.dir, args.out, args.frames)
    for note in files.notes:
        print(f"note: {note}")
    print(f"wrote {files.page} (open it in a browser; it works offline)")
    if files.frames is not None:
        times = ", ".join(f"{t:.2f}" for t in files.key_times)
        print(f"wrote {files.frames}: {len(files.key_times)} key frames at {times} s")
    return EXIT_OK


def _regions(args: argparse.Namespace) -> int:
    from .plotting import draw_regions
    from .scene import Scene

    scene = Scene.from_file(resolve(args.scene, "scene"))
    if not args.out.lower().endswith(".png"):
        raise InputError("--out", "must name a .png file")
    draw_regions(scene, args.out)
    print(f"wrote {args.out}")
    return EXIT_OK


def _scenes(args: argparse.Namespace) -> int:
    shipped = shipped_scenes()
    width = max([len("name")] + [len(s.name) for s in shipped])
    print(f"{'name':<{width}}  {'kind':<6}  {'robot':<6}  description")
    for s in shipped:
        print(f"{s.name:<{width}}  {s.kind:<6}  {'planar' if s.planar_only else 'ready':<6}  {s.description}")
        if s.planar_only:
            print(f"{'':<{width + 18}}planar only: {s.planar_only}")
    if shipped:
        print(f"\nrun one by name (ungrasp-ompl plan guitar_pick, ungrasp-ompl tile tangram); "
              f"the files are in {shipped[0].path.parent}")
    return EXIT_OK


#: Options fields whose flag is not --field-name (the library names its options' fields).
_FIELD_FLAGS = {"alphas": "--alpha", "tip_radii": "--tip-radius", "friction_scales": "--friction-scale",
                "start_psi_offset": "--start-psi-offset-deg", "start_theta_deg": "--start-theta",
                "plan.trials": "--certify"}


def _as_flag(exc: InputError, parser: argparse.ArgumentParser, args: argparse.Namespace) -> InputError:
    """The error of a library option named by the flag a person typed for it, when the command
    has that flag (an error in a file names the flag when that flag gave the file); any other
    error (a scene's field) as it is."""
    if not exc.field.isidentifier():
        return exc
    flag = _FIELD_FLAGS.get(f"{args.command}.{exc.field}", _FIELD_FLAGS.get(exc.field, "--" + exc.field.replace("_", "-")))
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[args.command]
    action = next((a for a in sub._actions if flag in a.option_strings), None)
    if action is None:
        return exc
    if exc.source is None:
        return InputError(flag, exc.reason)
    given = getattr(args, action.dest, None)
    return InputError(flag, exc.reason, exc.source) if given and exc.source.startswith(str(given)) else exc


def run(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    parser = _parser()
    args = None
    try:
        args = parser.parse_args(argv)
        commands = {"plan": _plan, "regions": _regions, "stability": _stability, "cage": _cage, "bench": _bench,
                    "sweep": _sweep,
                    "map": _map, "design": _design, "tile": _tile, "simulate": _simulate, "scenes": _scenes, "view": _view}
        return commands[args.command](args)
    except UngraspError as exc:
        for bar in list(_Progress.open):
            bar.close(ok=False)
        if isinstance(exc, InputError) and args is not None:
            exc = _as_flag(exc, parser, args)
        print(f"ungrasp-ompl: error: {shipped_names(str(exc))}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        for bar in list(_Progress.open):
            bar.close(ok=False)
        print("ungrasp-ompl: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader went away (e.g. piped into head)
        return EXIT_OK


def main(argv: list[str] | None = None) -> None:
    """Console entry point. Leaves through os._exit so that nanobind's reports of objects
    still alive at interpreter exit (noise to a user) are not printed."""
    code = run(argv)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    main()
