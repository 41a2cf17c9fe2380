"""The command line's arguments: one sub-parser per command, with its help; argparse's complaints
as one-line InputErrors naming the argument."""

from __future__ import annotations

import argparse
import re

from .. import __version__
from ..errors import InputError
from ..planning.names import PLANNERS


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line naming the argument, exit 2, no usage dump
        raise _argument_error(message)


def _argument_error(message: str) -> InputError:
    """argparse's complaint as an InputError naming the argument, e.g. "argument --time: invalid float
    value: 'x'" as "--time: must be a number, got 'x'"."""
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


#: The longest --time any command takes (s): a day. A planner's budget beyond it is a typo (1e12),
#: not a plan worth waiting for.
MAX_SECONDS = 86400.0


def _seconds(text: str) -> float:
    """A --time value: a number of seconds in (0, MAX_SECONDS]."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of seconds > 0, got {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    if value == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a finite number of seconds, got {text}")
    if value > MAX_SECONDS:
        raise argparse.ArgumentTypeError(f"must be at most {MAX_SECONDS:.0f} s (a day), got {text}")
    return value


#: Planners `bench` runs by default: OMPL's asymptotically optimal and feasibility planners
#: that work with Python callbacks, and the exact lattice search as the yardstick.
#: planning.margins.OBJECTIVES by name, spelled out so that --help does not import OMPL (a test
#: holds them equal).
OBJECTIVE_NAMES = ("cost", "margin", "balanced", "tolerance")
BENCH_PLANNERS = ("RRTstar", "InformedRRTstar", "BITstar", "FMT", "AORRTC", "RRTConnect", "lattice")


def _add_cluster(parser: argparse.ArgumentParser) -> None:
    """--cluster, as every command that can run on Ray takes it."""
    parser.add_argument("--cluster", default=None, metavar="ADDRESS",
                        help="run on the Ray cluster at HOST:PORT (or the RAY_ADDRESS variable); local: start one here")


def _add_plan(sub: argparse._SubParsersAction) -> None:
    """The `plan` command's arguments."""
    pl = sub.add_parser("plan", help="plan a scene; print a summary, write plan.json and cspace.png")
    pl.add_argument("scene", help="scene file (YAML), or the name of a shipped scene (see `scenes`)")
    pl.add_argument("--planner", default="RRTstar", help=f"OMPL planner ({', '.join(PLANNERS)}) or lattice")
    pl.add_argument("--objective", default=None, choices=OBJECTIVE_NAMES,
                    help="what the plan optimises (default: the scene's planning.objective, else cost): cost, "
                         "margin (the largest smallest friction margin along the path, then fewest "
                         "primitive changes, then the least length spent near that margin, then cost), balanced "
                         "(cost plus planning.margin_weight times a penalty growing as the margin shrinks) or "
                         "tolerance (as margin, with each state's tolerance of the paper errors, docs/model.md 4.6)")
    pl.add_argument("--time", type=_seconds, default=1.0, help="planning time in seconds (default 1)")
    pl.add_argument("--seed", type=int, default=None,
                    help="seed: the same seed gives the same plan (default: one drawn at random, printed and "
                         "stored in plan.json)")
    pl.add_argument("--iterations", type=int, default=None,
                    help="planner iterations (default with a seed: 6000 per second of --time; "
                         "1000 for PRM and PRMstar)")
    pl.add_argument("--out", default=None,
                    help="directory for plan.json and cspace.png (and certify.csv with --certify; default: none, "
                         "./plan with --certify)")
    pl.add_argument("--export", default=None, metavar="DIR",
                    help="also time the plan on the UR5e and its gripper and write the joint trajectory "
                         "(CSV, JSON, ROS 2 YAML, URScript) and plan.json to DIR. The files an earlier plan left in "
                         "--out or DIR (plan.json, cspace.png, the trajectory, the view, a simulation's or a "
                         "tiling's files) are removed first, so that a directory never mixes two plans' files; "
                         "other files stay")
    pl.add_argument("--cage", action="store_true",
                    help="also find the smallest escape energy (the energy-bounded cage, gravity only) along the "
                         "plan and where (takes seconds; in plan.json under cage)")
    pl.add_argument("--certify", type=int, default=None, metavar="N",
                    help="plan several candidates (--candidates), simulate N trials of each with the paper "
                         "perturbation, and keep the one with the highest Wilson 95 %% lower bound on success "
                         "(in plan.json under certification; every candidate in certify.csv, both in --out, "
                         "default ./plan)")
    pl.add_argument("--candidates", type=int, default=None, metavar="K",
                    help="candidate plans with --certify (default 4): objectives in turn (--objective first), "
                         "for each the planner with --seed then the lattice; then the planner with seed + 1, + 2, ...")
    pl.add_argument("--jobs", type=int, default=None,
                    help="parallel trials with --certify, and of the expected landing with --export "
                         "(robot.landing: expected) (default: all cores)")


def _add_bench(sub: argparse._SubParsersAction) -> None:
    """The `bench` command's arguments."""
    bn = sub.add_parser("bench", help="benchmark OMPL planners (and the exact lattice search) on scenes")
    bn.add_argument("scenes", nargs="+", help="scene files (YAML) or names of shipped scenes")
    bn.add_argument("--planners", default=",".join(BENCH_PLANNERS),
                    help=f"comma-separated planners (default {','.join(BENCH_PLANNERS)})")
    bn.add_argument("--runs", type=int, default=10, help="runs per scene and planner (default 10)")
    bn.add_argument("--time", type=_seconds, default=1.0, help="seconds per run (default 1)")
    bn.add_argument("--jobs", type=int, default=None, help="parallel worker processes (default: all cores)")
    bn.add_argument("--seed", type=int, default=1, help="seed of the first run; run k gets seed + k")
    bn.add_argument("--iterations", type=int, default=None,
                    help="planner iterations per run: runs become reproducible like plan --seed (30x --time as a "
                         "hard cap); default: stop on wall time, like OMPL's Benchmark")
    bn.add_argument("--out", default="benchmark", help="output directory (default ./benchmark)")
    _add_cluster(bn)
    bn.add_argument("--resume", action="store_true", help="keep the runs already in OUT/runs.csv, run the others")
    bn.add_argument("--objective", default="cost", choices=OBJECTIVE_NAMES,
                    help="what every planner (and the lattice yardstick) optimises, as for plan (default cost)")


def _add_sweep(sub: argparse._SubParsersAction) -> None:
    """The `sweep` command's arguments."""
    sw = sub.add_parser("sweep", help="success and cost against digit asymmetry alpha")
    sw.add_argument("scene", help="scene file (YAML) or the name of a shipped scene")
    sw.add_argument("--alpha", required=True, help="START:STOP:STEP over the object length, e.g. 0:0.6:0.05")
    sw.add_argument("--planner", default="RRTstar")
    sw.add_argument("--runs", type=int, default=5, help="runs per alpha (default 5)")
    sw.add_argument("--time", type=_seconds, default=1.0, help="seconds per run (default 1)")
    sw.add_argument("--jobs", type=int, default=None, help="parallel worker processes (default: all cores)")
    sw.add_argument("--seed", type=int, default=1, help="seed of the first run; run k gets seed + k")
    sw.add_argument("--iterations", type=int, default=None,
                    help="planner iterations per run (reproducible runs); default: stop on wall time")
    sw.add_argument("--out", default="sweep", help="output directory (default ./sweep)")
    _add_cluster(sw)
    sw.add_argument("--resume", action="store_true", help="keep the runs already in OUT/runs.csv, run the others")


def _add_map(sub: argparse._SubParsersAction) -> None:
    """The `map` command's arguments."""
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
    mp.add_argument("--jobs", type=int, default=None, help="cells at a time on this machine (default: all cores)")
    _add_cluster(mp)
    mp.add_argument("--resume", action="store_true", help="keep the cells already done in OUT/map.csv")
    mp.add_argument("--out", default="map", help="output directory (default ./map): map.csv and map.png")


def _add_design(sub: argparse._SubParsersAction) -> None:
    """The `design` command's arguments."""
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
    dn.add_argument("--jobs", type=int, default=None, help="designs at a time on this machine (default: all cores)")
    _add_cluster(dn)
    dn.add_argument("--out", default="design", help="output directory (default ./design): design.csv, design.png, "
                    "design_scene.yaml")


def _add_starts(sub: argparse._SubParsersAction) -> None:
    """The `starts` command's arguments."""
    sr = sub.add_parser("starts", help="where to hand the object over: plan from each start d in the goal's range, "
                        "choose the one from which B slides least along the thumb")
    sr.add_argument("scene", help="scene file (YAML) or the name of a shipped scene")
    sr.add_argument("--d", default=None, metavar="LOW:HIGH",
                    help="the candidates' d bounds over l, both included (default: the goal region's d range)")
    sr.add_argument("--step", type=float, default=0.01, help="spacing of the candidates' d over l (default 0.01)")
    sr.add_argument("--seed", type=int, default=1, help="seed of the lattice plans (default 1)")
    sr.add_argument("--both-tips", action="store_true",
                    help="count a start only where the other finger tip (flat for a rounded one, rounded for a "
                         "flat one) plans from it too, as the shipped object scenes' starts are chosen")
    sr.add_argument("--jobs", type=int, default=None, help="candidates at a time on this machine (default: all cores)")
    _add_cluster(sr)
    sr.add_argument("--out", default="starts", help="output directory (default ./starts): starts.csv, starts_scene.yaml")


def _add_stability(sub: argparse._SubParsersAction) -> None:
    """The `stability` command's arguments."""
    st = sub.add_parser("stability", help="print the 3D stability analysis of a scene with an object outline")
    st.add_argument("scene", help="scene file (YAML) with object.outline, or the name of a shipped scene")


def _add_cage(sub: argparse._SubParsersAction) -> None:
    """The `cage` command's arguments."""
    cg = sub.add_parser("cage", help="the energy-bounded cage (escape energy) and the friction margin along a plan")
    cg.add_argument("scene", help="scene file (YAML) of an object with a thickness, or the name of a shipped scene")
    cg.add_argument("--plan", default=None, help="plan.json to examine, or a directory holding one (plan --export "
                    "DIR); default: plan the scene, as plan does. A plan made for another scene is refused "
                    "(exit 2) unless --force")
    cg.add_argument("--force", action="store_true",
                    help="examine a --plan made for another scene (a warning names both)")
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
    cg.add_argument("--jobs", type=int, default=None,
                    help="parallel worker processes over the plan's states (default: all cores)")
    cg.add_argument("--out", default=None, help="directory for cage.png and cage.json")


def _add_tile(sub: argparse._SubParsersAction) -> None:
    """The `tile` command's arguments."""
    tl = sub.add_parser("tile", help="put every piece of a layout into its frame: order, planes, plans, one trajectory")
    tl.add_argument("layout", help="layout file (YAML): a frame and its pieces; or the name of a shipped layout")
    tl.add_argument("--planner", default="RRTstar", help="planner per piece (an OMPL planner, or lattice)")
    tl.add_argument("--time", type=_seconds, default=1.0, help="planning time per piece in seconds (default 1)")
    tl.add_argument("--seed", type=int, default=None,
                    help="seed: piece k is planned with seed + k (default: one drawn at random and printed)")
    tl.add_argument("--range", type=float, default=None,
                    help="the planner's longest motion per piece, state units (default: the layout's "
                         "planning.range, else 1.0)")
    tl.add_argument("--approaches", type=int, default=6, help="manipulation planes tried per piece (default 6)")
    tl.add_argument("--rank", default="first", choices=("first", "tolerance"),
                    help="once an order is found, each piece's approach: the first the search proved (default) or "
                         "the one whose lattice plan tolerates most of the paper errors")
    tl.add_argument("--out", default="tiling", help="output directory (default ./tiling): tiling.json, "
                    "layout.png, a C-space picture per piece and the exported trajectory (the files an earlier "
                    "plan, tiling or simulation left there are removed first; other files stay)")


def _add_simulate(sub: argparse._SubParsersAction) -> None:
    """The `simulate` command's arguments."""
    sm = sub.add_parser("simulate", help="execute a plan in MuJoCo (or Drake): success rate and placement errors "
                        "over perturbed trials")
    sm.add_argument("scene", help="scene file (YAML) with an object thickness, or a layout (every piece in "
                    "turn), or the name of a shipped one")
    sm.add_argument("--plan", default=None, help="plan.json (or a directory holding one) to execute instead of "
                    "planning (may be one the model rejects for this scene: a warning says why; one made for "
                    "another scene is refused, exit 2, unless --force)")
    sm.add_argument("--force", action="store_true",
                    help="execute a --plan made for another scene (a warning names both)")
    sm.add_argument("--planner", default="RRTstar", help="planner when no --plan is given (default RRTstar)")
    sm.add_argument("--time", type=_seconds, default=1.0, help="planning time in seconds (default 1)")
    sm.add_argument("--objective", default=None, choices=OBJECTIVE_NAMES,
                    help="what the plan optimises when no --plan is given, as for plan (default: the scene's "
                         "planning.objective, else cost)")
    sm.add_argument("--trials", type=int, default=10, help="trials (default 10)")
    sm.add_argument("--seed", type=int, default=1, help="seed of the plan and of the trials' perturbations (default 1)")
    sm.add_argument("--perturb", default="paper", help="perturbation preset: paper (default), none, grasp, "
                    "friction, mass, thickness, calibration")
    sm.add_argument("--jobs", type=int, default=None, help="parallel worker processes (default: all cores)")
    sm.add_argument("--out", default=None,
                    help="output directory (default: DIR/simulation beside --plan's plan.json, else ./simulation); "
                         "the files an earlier plan or simulation left there are removed first, other files stay")
    _add_cluster(sm)
    sm.add_argument("--finger-tip", choices=("rounded", "flat"), default=None,
                    help="the finger's tip instead of the scene's (rounded: point contact; flat: edge contact)")
    sm.add_argument("--start-psi-offset-deg", type=float, default=None,
                    help="start the plan with psi this much larger, outside force closure (caging experiment)")
    sm.add_argument("--world", action="append", default=None, metavar="KEY=VALUE",
                    help="run the trials in a world the plan and its aim never see (repeatable): friction, "
                         "friction_table, friction_digits, density, jaw_force (factors), stiffness (a factor in "
                         "(0, 1] on the contacts' stiffness), cone (elliptic or pyramidal)")
    sm.add_argument("--thickness", type=float, default=None,
                    help="simulate an object of this thickness (m) with the motion planned for the scene's")
    sm.add_argument("--equal-digits", action="store_true",
                    help="simulate a thumb as long as the finger (alpha 0), the motion unchanged (a control)")
    sm.add_argument("--engine", choices=("mujoco", "drake"), default="mujoco",
                    help="the physics engine the trials run in (default mujoco); drake needs the optional extra: "
                         "pip install 'ungrasp-ompl[drake]' (docs/model.md 11.19)")


def _add_view(sub: argparse._SubParsersAction) -> None:
    """The `view` command's arguments."""
    vw = sub.add_parser("view", help="an animated 3D view (one offline HTML page) of what plan --export, tile or "
                        "simulate wrote")
    vw.add_argument("dir", metavar="DIR", help="a directory holding trajectory.json (plan --export DIR, tile --out DIR, "
                    "simulate --out DIR)")
    vw.add_argument("--out", default=None, help="the HTML file to write (default DIR/view.html)")
    vw.add_argument("--frames", type=int, default=None, metavar="K",
                    help="also write a PNG strip of K key frames beside it (view_frames.png)")


def _add_regions(sub: argparse._SubParsersAction) -> None:
    """The `regions` command's arguments."""
    rg = sub.add_parser("regions", help="draw the C-space map (free, not force-closed, in collision)")
    rg.add_argument("scene", help="scene file (YAML) or the name of a shipped scene")
    rg.add_argument("--out", required=True, help="PNG file to write")
    rg.add_argument("--plan", default=None, help="plan.json (or a directory holding one) made for the scene: "
                    "its path, start and goal are drawn on every slice")
    rg.add_argument("--force", action="store_true", help="draw a --plan made for another scene (with a warning)")


def _add_scenes(sub: argparse._SubParsersAction) -> None:
    """The `scenes` command's arguments."""
    sub.add_parser("scenes", help="list the shipped scenes and layouts, which every command takes by name")


#: Each command's arguments, in the order --help lists them.
COMMANDS = (_add_plan, _add_bench, _add_sweep, _add_map, _add_design, _add_starts, _add_stability, _add_cage, _add_tile,
            _add_simulate, _add_view, _add_regions, _add_scenes)


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser: one sub-parser per command (COMMANDS)."""
    p = _Parser(prog="ungrasp-ompl", description="Plan dexterous ungrasping with OMPL.")
    p.add_argument("--version", action="version", version=f"ungrasp-ompl {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for add in COMMANDS:
        add(sub)
    return p
