"""Whole-process wall and CPU time of the commands a user types; prints best and median, asserts nothing.

Each command runs REPEAT times in a fresh process, output to a temporary directory, as a user runs
it (the installed console script next to this interpreter, else ``python -m ungrasp_ompl``), after
one untimed run: Python keeps the bytecode it compiles, as on a user's machine (the commands run
without PYTHONDONTWRITEBYTECODE, which would make every process compile every module it imports
again, a few seconds each), and the first run writes it. It prints what it measures:

    python tools/bench_cli.py [--repeat 5] [--only plan,import,...] [--results]

Names: import (``python -c "import ungrasp_ompl.cli"``), help (``ungrasp-ompl --help``),
bad_input (a scene that does not exist: exit 2), plan (reference_asymmetric, 1 s of RRT*,
pictures), plan_pick (guitar_pick planned, seed 1, its picture), export (the same, timed and
exported), tile (the tangram, RRT*). With plan_pick, export and tile it prints what the project
aims at: export's time over plan_pick's (s, at most 2) and tile's as a multiple of plan_pick's (at
most 3), and tile's CPU time over plan_pick's: tile's time can come no nearer plan_pick's than
its CPU time shared over every core (tile_floor_over_plan); --results writes those rows to
docs/results/bench_cli.json (.md beside), for the pages.
Two rows follow from inside a fresh process each: setup (UngraspSetup.setup_time on
reference_asymmetric: the secure lattice and the planner) and cost (RRT*'s cost after its seeded
budget for seeds 1-5, median, against the exact lattice optimum): what the speed work must keep.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
SCENES = ROOT / "scenes"


def _cli() -> list[str]:
    script = Path(sys.executable).with_name("ungrasp-ompl")
    return [str(script)] if script.exists() else [sys.executable, "-m", "ungrasp_ompl"]


#: The commands' environment: this one's, with Python keeping the bytecode it compiles.
ENVIRONMENT = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


#: name -> (argument list with {out} for the output directory, expected exit codes, aim in s)
COMMANDS: dict[str, tuple[list[str], tuple[int, ...], float]] = {
    "import": ([sys.executable, "-c", "import ungrasp_ompl.cli"], (0,), 0.3),
    "help": (_cli() + ["--help"], (0,), 0.3),
    "bad_input": (_cli() + ["plan", "no_such_scene.yaml"], (2,), 0.3),
    "plan": (_cli() + ["plan", str(SCENES / "reference_asymmetric.yaml"), "--seed", "1", "--time", "1",
                       "--out", "{out}"], (0,), 1.5),
    "plan_pick": (_cli() + ["plan", str(SCENES / "guitar_pick.yaml"), "--seed", "1", "--out", "{out}"], (0,), 2.0),
    "export": (_cli() + ["plan", str(SCENES / "guitar_pick.yaml"), "--seed", "1", "--export", "{out}"], (0,), 2.0),
    "tile": (_cli() + ["tile", str(SCENES / "tangram.yaml"), "--out", "{out}"], (0, 3), 15.0),
}


#: In-process figures, each printed by a fresh interpreter as one JSON number (or list).
_SETUP = ("from ungrasp_ompl import Scene; from ungrasp_ompl.planning.setup import UngraspSetup, PlannerOptions; "
          f"s = Scene.from_file({str(SCENES / 'reference_asymmetric.yaml')!r}); "
          "print(UngraspSetup(s, PlannerOptions(seed=1)).setup_time)")
_COSTS = ("import json; from ungrasp_ompl import Scene, plan; "
          f"s = Scene.from_file({str(SCENES / 'reference_asymmetric.yaml')!r}); "
          "print(json.dumps([plan(s, seed=k, time=1.0).cost for k in range(1, 6)] + "
          "[plan(s, planner='lattice').cost]))")


def _shown(argv: list[str]) -> str:
    """A command line as a user types it: the console script by name, the scenes' paths from the
    checkout's root, OUT for the output directory."""
    cli = _cli()
    words = ["ungrasp-ompl", *argv[len(cli):]] if argv[:len(cli)] == cli else argv
    return " ".join(w.replace(str(ROOT) + "/", "").replace("{out}", "OUT") for w in words)


def _python(code: str) -> object:
    proc = subprocess.run([sys.executable, "-c", code + "; import sys, os; sys.stdout.flush(); os._exit(0)"],
                          capture_output=True, text=True, env=ENVIRONMENT)
    if proc.returncode != 0 or not proc.stdout.strip():
        raise SystemExit(f"bench_cli: {code[:60]}... failed: {(proc.stderr.strip().splitlines() or ['?'])[-1]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _time_once(argv: list[str], ok: tuple[int, ...]) -> tuple[float, float]:
    """One run's wall time and CPU time (s): the CPU the command and the processes it forked and
    waited for spent, user and system (getrusage of the children this process waited for)."""
    out = tempfile.mkdtemp(prefix="bench_cli_")
    try:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        proc = subprocess.run([a.replace("{out}", out) for a in argv], capture_output=True, text=True, env=ENVIRONMENT)
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    finally:
        shutil.rmtree(out, ignore_errors=True)
    if proc.returncode not in ok:
        tail = (proc.stderr.strip().splitlines() or ["(no output)"])[-1]
        raise SystemExit(f"bench_cli: {' '.join(argv)} exited {proc.returncode}: {tail}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--repeat", type=int, default=5, help="runs per command (default 5)")
    p.add_argument("--only", default=",".join(COMMANDS), help="comma-separated names (default: all)")
    p.add_argument("--no-inside", action="store_true", help="leave out the setup and cost rows")
    p.add_argument("--results", action="store_true",
                   help="write the commands' rows and the targets' ratios to docs/results/bench_cli.json")
    args = p.parse_args()
    started = time.perf_counter()
    names = [n.strip() for n in args.only.split(",") if n.strip()]
    unknown = [n for n in names if n not in COMMANDS]
    if unknown:
        raise SystemExit(f"bench_cli: --only: unknown command(s) {', '.join(unknown)}; known: {', '.join(COMMANDS)}")
    print(f"{'command':<10} {'best':>7} {'median':>7} {'aim':>6} {'CPU':>7}   (whole process, s, {args.repeat} runs; "
          "CPU: the median user and system time, forked processes included)")
    rows = {}
    for name in names:
        argv, ok, aim = COMMANDS[name]
        _time_once(argv, ok)  # untimed: it writes the bytecode the timed runs read
        walls, cpus = zip(*[_time_once(argv, ok) for _ in range(args.repeat)])
        row = rows[name] = {"label": name, "command": _shown(argv), "runs": len(walls), "best_s": min(walls),
                            "median_s": statistics.median(walls), "cpu_median_s": statistics.median(cpus)}
        print(f"{name:<10} {row['best_s']:7.2f} {row['median_s']:7.2f} {aim:6.1f} {row['cpu_median_s']:7.2f}", flush=True)
    if {"plan_pick", "export", "tile"} <= rows.keys():
        plan, export, tile = rows["plan_pick"], rows["export"], rows["tile"]
        cores = os.cpu_count() or 1
        rows["targets"] = {"label": "targets", "export_over_plan_s": export["median_s"] - plan["median_s"],
                           "tile_over_plan": tile["median_s"] / plan["median_s"],
                           "tile_cpu_over_plan_cpu": tile["cpu_median_s"] / plan["cpu_median_s"], "cores": cores,
                           "tile_floor_over_plan": tile["cpu_median_s"] / cores / plan["median_s"]}
        t = rows["targets"]
        print(f"export takes {t['export_over_plan_s']:.2f} s more than plan_pick (aim: at most 2 s); tile takes "
              f"{t['tile_over_plan']:.2f} times plan_pick's time (aim: at most 3); its CPU time is "
              f"{t['tile_cpu_over_plan_cpu']:.2f} times plan_pick's, so that on {cores} cores, all busy throughout, "
              f"it would take {t['tile_floor_over_plan']:.2f} times plan_pick's time")
    if args.results:
        from campaign_results import merge_study

        here = [r for name, r in rows.items() if name in ("plan_pick", "export", "tile", "targets")]
        formats = {"best_s": "{:.2f}", "median_s": "{:.2f}", "cpu_median_s": "{:.2f}", "export_over_plan_s": "{:.2f}",
                   "tile_over_plan": "{:.2f}", "tile_cpu_over_plan_cpu": "{:.2f}", "tile_floor_over_plan": "{:.2f}"}
        path = merge_study(ROOT / "docs" / "results" / "bench_cli.json", "commands",
                           " ".join(["python", "tools/bench_cli.py", *sys.argv[1:]]), time.perf_counter() - started,
                           here, formats, "What the commands a user types cost, whole process (tools/bench_cli.py)")
        print(f"wrote {path}")
    if not args.no_inside:
        setups = [float(_python(_SETUP)) for _ in range(args.repeat)]
        print(f"{'setup':<10} {min(setups):7.3f} {statistics.median(setups):7.3f} {0.1:6.1f}   "
              "(reference_asymmetric's lattice and planner, inside the process)", flush=True)
        *costs, optimum = _python(_COSTS)
        print(f"RRT* cost on reference_asymmetric after its seeded budget, seeds 1-5: median "
              f"{statistics.median(costs):.1f} (each: {', '.join(f'{c:.1f}' for c in costs)}); lattice optimum {optimum:.1f}")


if __name__ == "__main__":
    main()
