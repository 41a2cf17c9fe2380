"""One function per command: options from the parsed arguments, the library's workflow called,
its summary and the files it wrote printed. Returns the exit code; library errors propagate to
cli.run, which prints them."""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import secrets
from pathlib import Path

from ..errors import InputError
from ..parallel.options import RunOptions
from ..parallel.runner import default_jobs
from ..shipped import resolve, shipped_scenes
from ..sim.world import World
from .exits import EXIT_FAILURE, EXIT_NO_SOLUTION, EXIT_OK
from .progress import Progress, Steps, Ticker, map_status, tile_progress, trial_progress

# Each command imports its scene, workflow and pictures in its function: together they load OMPL, Pinocchio,
# FCL, SciPy, MuJoCo, matplotlib and meshcat (seconds), of which a command loads what it needs and
# `ungrasp-ompl --help` or `scenes` nothing.


def plan_command(args: argparse.Namespace) -> int:
    path = resolve(args.scene, "scene")  # before the imports: a wrong name is answered at once
    from ..planning.setup import PlannerOptions
    from ..scene import Scene
    from ..workflows.plan import PlanOptions, plan_scene

    scene = Scene.from_file(path)
    # --certify spends minutes: what it finds is kept, in ./plan when no --out is given
    out = Path(args.out) if args.out else Path("plan") if args.certify is not None else None
    export = Path(args.export) if args.export else None
    for flag, path in (("--out", out), ("--export", export)):
        if path is not None and path.exists() and not path.is_dir():
            raise InputError(flag, f"{path} exists and is not a directory")
    if args.certify is None and args.candidates is not None:
        raise InputError("--candidates", "applies only with --certify N")
    if args.certify is None and args.export is None and args.jobs is not None:
        raise InputError("--jobs", "applies only with --certify N or --export DIR")
    if args.jobs is not None and args.jobs < 1:
        raise InputError("--jobs", f"must be at least 1, got {args.jobs}")
    jobs = _all_cores() if args.jobs is None else args.jobs

    planner = PlannerOptions(planner=args.planner, time=args.time, iterations=args.iterations, objective=args.objective)
    certify = None
    if args.certify is not None:
        from ..sim.certify import CertifyOptions

        certify = CertifyOptions(trials=args.certify, candidates=4 if args.candidates is None else args.candidates,
                                 planner=planner, run=RunOptions(jobs=jobs))
    options = PlanOptions(planner=planner, cage=args.cage, certify=certify).validated(scene)
    seed = _seed(args.seed)  # drawn (and printed) only for options that can run
    planner = dataclasses.replace(planner, seed=seed)
    options = dataclasses.replace(options, planner=planner, certify=certify and dataclasses.replace(
        certify, planner=planner, run=dataclasses.replace(certify.run, seed=seed)))
    bars = {"planning": Progress("candidates", "planning"), "simulating": Progress("trials", "simulate")}
    with Ticker("planning", 0.0 if certify or args.planner == "lattice" else args.time):
        result = plan_scene(scene, options, lambda p: bars[p.stage].show(p.done, p.total))
    print(result.summary())
    steps = Steps("export", (("drawing the C-space picture",) if out is not None else ())
                  + ("executing on the arm", "writing the trajectory")) if export is not None else None
    cleared = _Cleared()
    if out is not None and result.certification is not None and not result.certification.certified:
        print(f"wrote {result.write_certification(cleared(out))}")
    elif out is not None:
        if steps is not None:
            steps.start("drawing the C-space picture")
        files = result.write(cleared(out))
        print("wrote " + _and([files["plan"], files["cspace"]] + ([files["certify"]] if "certify" in files else [])))
    if not result.solved:
        cleared.note()
        return EXIT_NO_SOLUTION
    if export is not None:
        if scene.planar_only:
            print(f"note: {scene.name} is planar-only: {scene.planar_only}")
        steps.start("executing on the arm")
        execution = result.execute(jobs)
        print(execution.summary())
        steps.start("writing the trajectory")
        paths = result.export(cleared(export), execution)
        steps.finish()
        print("wrote " + ", ".join(str(p) for p in paths.values()))
        print(f"view it: ungrasp-ompl view {export}  (writes {export / 'view.html'})")
    cleared.note()
    return EXIT_OK


class _Cleared:
    """The directories a command writes a plan's files into, each cleared of an earlier plan's
    files (workflows.plan_files) once, just before its first file is written; note() prints the
    files removed that were not written again."""

    def __init__(self) -> None:
        self.removed: dict[Path, tuple[Path, list[Path]]] = {}  # resolved: (as given, files removed)

    def __call__(self, directory: Path) -> Path:
        from ..workflows.plan_files import clear_plan_files

        key = directory.resolve()
        if key not in self.removed:
            self.removed[key] = directory, clear_plan_files(directory)
        return directory

    def note(self) -> None:
        for directory, removed in self.removed.values():
            gone = [p.name for p in removed if not p.exists()]
            if gone:
                print(f"note: removed an earlier plan's {_and(gone)} from {directory}")


def _and(items: list) -> str:
    """'a', 'a and b', 'a, b and c'."""
    words = [str(i) for i in items]
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def _all_cores() -> int:
    """What every --jobs defaults to: all cores (runner.default_jobs)."""
    return default_jobs()


def _seed(given: int | None) -> int:
    """The seed to plan with: the one given, else one drawn at random and printed, so that every run
    can be repeated."""
    if given is not None:
        return given
    seed = 1 + secrets.randbelow(9999)
    print(f"seed {seed} (pass --seed {seed} to repeat)")
    return seed


def stability_command(args: argparse.Namespace) -> int:
    from ..scene import Scene
    from ..scene.stability import describe

    print(describe(Scene.from_file(resolve(args.scene, "scene"))))
    return EXIT_OK


def cage_command(args: argparse.Namespace) -> int:
    from ..planning.setup import PlannerOptions
    from ..scene import Scene
    from ..workflows.cage import CageOptions, cage_report

    scene = Scene.from_file(resolve(args.scene, "scene"))
    out = Path(args.out) if args.out else None
    if out is not None and out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a directory")
    offset = None if args.start_psi_offset_deg is None else math.radians(args.start_psi_offset_deg)
    options = CageOptions(plan=args.plan, planner=PlannerOptions(planner=args.planner, time=args.time, seed=args.seed),
                          squeeze=args.squeeze, refine=args.refine, finger_tip=args.finger_tip, start_psi_offset=offset,
                          force=args.force, run=RunOptions(jobs=args.jobs))
    bar = Progress("states", "cage")
    with Ticker("planning", 0.0 if args.plan or args.planner == "lattice" else args.time) as ticker:
        def progress(p) -> None:
            ticker.stop()  # the plan is there: its cage's states are counted now
            bar.show(p.done, p.total)

        report = cage_report(scene, options, progress)
    _warn_of_another_scene(args, report.scene, report.plan)
    print(report.summary())
    if not report.plan.solved:
        return EXIT_NO_SOLUTION
    if out is not None:
        files = report.write(out)
        print(f"wrote {files[0]} and {files[1]}")
    return EXIT_OK


def bench_command(args: argparse.Namespace) -> int:
    from ..benchmark import BenchmarkOptions, run_benchmark
    from ..planning.setup import PlannerOptions

    planners = tuple(p.strip() for p in args.planners.split(",") if p.strip())
    scenes = [resolve(s, "scene") for s in args.scenes]
    planner = PlannerOptions(time=args.time, iterations=args.iterations, objective=args.objective)
    options = BenchmarkOptions(planners=planners, runs=args.runs, planner=planner, run=_run(args), out=args.out,
                               resume=args.resume)
    result = run_benchmark(scenes, options, progress=Progress("runs", "bench").show)
    print(result.table)
    print(f"wrote {', '.join(p.name for p in result.files.values())} to {result.out}")
    return EXIT_OK


def sweep_command(args: argparse.Namespace) -> int:
    from ..benchmark import SweepOptions, run_sweep
    from ..benchmark.ranges import parse_alpha_range
    from ..planning.setup import PlannerOptions

    options = SweepOptions(alphas=tuple(parse_alpha_range(args.alpha)),
                           planner=PlannerOptions(planner=args.planner, time=args.time, iterations=args.iterations),
                           runs=args.runs, run=_run(args), out=args.out, resume=args.resume)
    result = run_sweep(resolve(args.scene, "scene"), options, progress=Progress("runs", "sweep").show)
    print(result.summary())
    print(f"wrote {', '.join(p.name for p in result.files.values())} to {result.options.out}")
    return EXIT_OK


def map_command(args: argparse.Namespace) -> int:
    from ..benchmark.map import MapOptions, run_map
    from ..benchmark.ranges import parse_range
    from ..planning.setup import PlannerOptions

    options = MapOptions(alphas=tuple(parse_range(args.alpha, "--alpha")),
                         friction_scales=tuple(parse_range(args.friction_scale, "--friction-scale")),
                         start_theta_deg=args.start_theta,
                         planner=PlannerOptions(planner=args.planner, time=args.time, seed=args.seed),
                         simulate=args.simulate, perturb=args.perturb, run=_run(args), resume=args.resume, out=args.out)
    bar = Progress("cells", "map")
    result = run_map(resolve(args.scene, "scene"), options,
                     progress=lambda p: bar.show(p.done, p.total, map_status(p)))
    print(result.summary())
    print(f"wrote {result.files['csv']} and {result.files['plot']}")
    return EXIT_FAILURE if result.failed else EXIT_OK


def design_command(args: argparse.Namespace) -> int:
    from ..benchmark.design import DesignOptions, run_design
    from ..benchmark.ranges import parse_range

    radii = tuple(r / 1000 for r in parse_range(args.tip_radius, "--tip-radius")) if args.tip_radius else ()
    options = DesignOptions(alphas=tuple(parse_range(args.alpha, "--alpha")) if args.alpha else (), tip_radii=radii,
                            finger_tip=args.finger_tip, goal=args.goal, simulate=args.simulate, perturb=args.perturb,
                            run=_run(args), out=args.out)
    bar = Progress("designs", "design")
    result = run_design(args.scene, options, progress=lambda p: bar.show(p.done, p.total))
    files = result.write(result.options.out)
    print(result.summary())
    print(f"wrote {', '.join(str(p) for p in files.values())}")
    return EXIT_OK if result.best is not None else EXIT_NO_SOLUTION


def starts_command(args: argparse.Namespace) -> int:
    from ..benchmark.starts import StartOptions, choose_start

    bounds = None
    if args.d is not None:
        try:  # a word that is no number, or other than two parts
            low, high = (float(x) for x in args.d.split(":"))
        except ValueError:
            raise InputError("--d", f"must be LOW:HIGH, two numbers over l, got {args.d!r}") from None
        bounds = (low, high)
    options = StartOptions(d_range=bounds, d_step=args.step, run=_run(args), out=args.out, both_tips=args.both_tips)
    bar = Progress("starts", "starts")
    result = choose_start(args.scene, options, progress=bar.show)
    files = result.write(options.out)
    print(result.summary())
    print(f"wrote {', '.join(str(p) for p in files.values())}")
    return EXIT_OK if result.best is not None else EXIT_NO_SOLUTION


def _cluster(args: argparse.Namespace) -> str | None:
    """The Ray cluster to run on: --cluster, else the RAY_ADDRESS variable, else None (this machine)."""
    return args.cluster or os.environ.get("RAY_ADDRESS") or None


def _run(args: argparse.Namespace) -> RunOptions:
    """How a campaign runs: --seed, --jobs and the cluster (_cluster)."""
    return RunOptions(seed=args.seed, jobs=args.jobs, cluster=_cluster(args))


def tile_command(args: argparse.Namespace) -> int:
    from ..layout.model import Layout
    from ..layout.tiler import TilingOptions
    from ..planning.setup import PlannerOptions
    from ..workflows.tile import check_tiling_options, tile_layout

    layout = Layout.from_file(resolve(args.layout, "layout"))
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a directory")
    planner = PlannerOptions(planner=args.planner, time=args.time, seed=args.seed, range=args.range)
    options = check_tiling_options(TilingOptions(planner=planner, approaches=args.approaches, rank=args.rank))
    seed = _seed(args.seed)
    options = dataclasses.replace(options, planner=dataclasses.replace(planner, seed=seed))
    result = tile_layout(layout, options, tile_progress(Progress("pieces")))
    print(result.summary())
    cleared = _Cleared()
    doc, picture, cspaces = result.write(cleared(out))
    print(f"wrote {doc}, {picture} and {len(cspaces)} C-space pictures")
    if result.execution is None:
        cleared.note()
        return EXIT_NO_SOLUTION
    print("wrote " + ", ".join(str(p) for p in result.export(out).values()))
    print(f"view it: ungrasp-ompl view {out}  (writes {out / 'view.html'})")
    cleared.note()
    return EXIT_OK


def simulate_command(args: argparse.Namespace) -> int:
    from ..layout.model import Layout
    from ..planning.setup import PlannerOptions
    from ..scene import Scene
    from ..scene.loader import read_yaml
    from ..workflows.simulate import SimulateOptions, simulate_layout, simulate_scene

    if args.out is not None:
        out = Path(args.out)
    elif args.plan is not None:  # beside the plan executed: DIR/simulation for --plan DIR or DIR/plan.json
        given = Path(args.plan)
        out = (given if given.is_dir() else given.parent) / "simulation"
    else:
        out = Path("simulation")
    if out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a directory")
    shipped = next((s for s in shipped_scenes() if s.name == args.scene), None)
    path = resolve(args.scene, shipped.kind if shipped and not Path(args.scene).exists() else "scene")
    offset = None if args.start_psi_offset_deg is None else math.radians(args.start_psi_offset_deg)
    # one --seed: the plan's (planner.seed) and the trials' errors' (run.seed)
    options = SimulateOptions(trials=args.trials, perturb=args.perturb, run=_run(args), plan=args.plan,
                              planner=PlannerOptions(planner=args.planner, time=args.time, seed=args.seed,
                                                     objective=args.objective),
                              finger_tip=args.finger_tip, start_psi_offset=offset,
                              world=World.parse(args.world or ()), thickness=args.thickness, equal_digits=args.equal_digits,
                              force=args.force, engine=args.engine)
    doc = read_yaml(path, "scene")
    if isinstance(doc, dict) and "frame" in doc and "pieces" in doc:
        layout = Layout.from_file(path)
        run = simulate_layout(layout, options, trial_progress(args.trials))
        print(run.summary())
        if run.execution is None:
            return EXIT_NO_SOLUTION
        cleared = _Cleared()
        files = run.write(cleared(out))
        print(f"wrote {files['summary']} and the trajectory")
        cleared.note()
        return EXIT_OK
    scene = Scene.from_dict(doc, source=str(path), default_name=path.stem)
    step = trial_progress(args.trials)
    with Ticker("planning", 0.0 if args.plan or args.planner == "lattice" else args.time) as ticker:
        def progress(trial) -> None:
            ticker.stop()  # planned and executed: the trials are counted now
            step(trial)

        run = simulate_scene(scene, options, progress)
    _warn_of_another_scene(args, run.scene, run.plan)
    print(run.summary())
    if run.report is None:
        return EXIT_NO_SOLUTION
    cleared = _Cleared()
    files = run.write(cleared(out))
    if "model" in files:
        print(f"wrote {files['trials']}, {files['summary']}, {files['picture']}, plan.json, the trajectory, "
              f"view_scene.json, trial_poses.json (trial 0's object poses) and model.xml (trial 0's world, keyframe "
              f"'start': python -m mujoco.viewer --mjcf={files['model']})")
    else:  # trials in Drake: MuJoCo's replay of trial 0 and its world are not theirs
        print(f"wrote {files['trials']}, {files['summary']}, {files['picture']}, plan.json, the trajectory and "
              "view_scene.json")
    print(f"view it: ungrasp-ompl view {out}  ({'trial 0 beside ' if 'poses' in files else ''}the plan)")
    cleared.note()
    return EXIT_OK


def _warn_of_another_scene(args: argparse.Namespace, scene, plan) -> None:
    """The warning of --force: the --plan run was made for another scene (one line)."""
    from ..workflows.plan_files import plan_made_for

    other = plan_made_for(scene, plan) if args.plan is not None else None
    if other is not None:
        print(f"warning: --plan {args.plan} was made for scene {other!r}, not {scene.name!r} (run anyway: --force)")


def view_command(args: argparse.Namespace) -> int:
    from ..view import make_view

    files = make_view(args.dir, args.out, args.frames)
    for note in files.notes:
        print(f"note: {note}")
    print(f"wrote {files.page} (open it in a browser; it works offline)")
    if files.frames is not None:
        times = ", ".join(f"{t:.2f}" for t in files.key_times)
        print(f"wrote {files.frames}: {len(files.key_times)} key frames at {times} s")
    return EXIT_OK


def regions_command(args: argparse.Namespace) -> int:
    from ..plots.cspace import draw_regions
    from ..scene import Scene
    from ..workflows.plan_files import read_plan_for

    scene = Scene.from_file(resolve(args.scene, "scene"))
    if not args.out.lower().endswith(".png"):
        raise InputError("--out", "must name a .png file")
    plan = None if args.plan is None else read_plan_for(scene, args.plan, force=args.force)
    if plan is not None:
        _warn_of_another_scene(args, scene, plan)
    draw_regions(scene, args.out, plan=plan)
    print(f"wrote {args.out}")
    return EXIT_OK


def scenes_command(args: argparse.Namespace) -> int:
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


#: The function of each command, by its name on the command line.
COMMANDS = {"plan": plan_command, "regions": regions_command, "stability": stability_command, "cage": cage_command, "bench": bench_command, "sweep": sweep_command, "map": map_command, "design": design_command, "starts": starts_command, "tile": tile_command, "simulate": simulate_command, "scenes": scenes_command, "view": view_command}
