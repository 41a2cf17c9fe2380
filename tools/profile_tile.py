"""Profile `ungrasp-ompl tile` and print where its seconds go, phase by phase; asserts nothing.

`python -m cProfile -m ungrasp_ompl tile ...` writes no profile, because the command leaves through
os._exit; this runs the same command line (cli.run) under cProfile in this process instead:

    python tools/profile_tile.py [scenes/tangram.yaml] [--out DIR] [--prof FILE] [--serial] [--sample S] [-- more tile arguments]

It prints the cumulative seconds of each phase (the search's screens and proofs, planning per
piece, execution, export, pictures) and the top functions by cumulative time. The pieces' plans
and the pictures are made in forked processes, which the profile does not see (it shows this
process waiting for them); --serial makes everything here, in turn, as one process would.

cProfile charges every Python call, so code making many small calls (the planners' callbacks,
the force-closure checks) looks dearer than it is beside numpy's large operations. --sample S
profiles instead by sampling this process's stack every S seconds (a thread; the profiler is
off): it prints each function's share of the samples, inclusive and its own, which is its share
of the wall time. With --serial that is the share of the whole command's work.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: phase -> (file suffix, function name) whose cumulative time is the phase's
PHASES = {
    "tile (search and planning)": ("layout/tiler.py", "tile"),
    "  screens": ("layout/tiler.py", "screen"),
    "  proofs (lattice builds and searches)": ("layout/tiler.py", "prove"),
    "  approaches (ranking)": ("layout/tiler.py", "approaches"),
    "  scenes of pieces": ("layout/model.py", "scene"),
    "  planning per piece": ("setup.py", "plan"),
    "    lattice friction margins (each state once)": ("margin_table.py", "margins"),
    "    legs re-validated": ("verify.py", "first_failing_leg"),
    "    landings predicted": ("predicted_landing.py", "predict_landing"),
    "  waiting for the pieces' plans": ("layout/tiler.py", "take_ahead"),
    "execution (IK, timing)": ("pipeline.py", "execute_sequence"),
    "export (trajectory files)": ("export.py", "export_all"),
    "3D view record": ("record.py", "write_view_record"),
    "layout picture": ("plots/layout.py", "draw_layout"),
    "C-space pictures": ("plots/cspace.py", "draw_plan"),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("layout", nargs="?", default=str(ROOT / "scenes" / "tangram.yaml"))
    parser.add_argument("--out", default=None, help="output directory (default: a temporary one)")
    parser.add_argument("--prof", default="/tmp/tile.prof", help="where to write the profile")
    parser.add_argument("--top", type=int, default=40, help="functions listed by cumulative time")
    parser.add_argument("--sample", type=float, default=None, metavar="S",
                        help="sample the stack every S seconds instead of cProfile (see above)")
    parser.add_argument("--serial", action="store_true",
                        help="plan the pieces and draw the pictures in this process (no forked processes)")
    argv = sys.argv[1:]
    cut = argv.index("--") if "--" in argv else len(argv)
    args = parser.parse_args(argv[:cut])
    rest = argv[cut + 1:]  # the tile arguments after --, which argparse would take for positionals
    from ungrasp_ompl.cli import run

    if args.serial:
        import ungrasp_ompl.layout.tiler as tiler
        import ungrasp_ompl.workflows.tile as workflow

        tiler.default_jobs = lambda: 1
        workflow.can_fork = lambda: False
    out = args.out or tempfile.mkdtemp(prefix="profile_tile_")
    if args.sample is not None:
        sampled(lambda: run(["tile", args.layout, "--out", out, *rest]), args.sample, args.top)
        return
    profiler = cProfile.Profile()
    t0 = time.perf_counter()
    code = profiler.runcall(run, ["tile", args.layout, "--out", out, *rest])
    wall = time.perf_counter() - t0
    profiler.dump_stats(args.prof)
    stats = pstats.Stats(args.prof, stream=sys.stderr)
    by_phase: dict[str, tuple[float, int]] = {}
    for (path, _, name), (_, calls, _, cumulative, _) in stats.stats.items():
        for phase, (suffix, function) in PHASES.items():
            if name == function and path.endswith(suffix):
                seconds, n = by_phase.get(phase, (0.0, 0))
                by_phase[phase] = (max(seconds, cumulative), n + calls)
    print(f"\nexit {code}; {wall:.2f} s in cli.run under the profiler (profile: {args.prof})", file=sys.stderr)
    for phase in PHASES:
        seconds, calls = by_phase.get(phase, (0.0, 0))
        print(f"{phase:<46} {seconds:7.2f} s  {calls:5d} calls", file=sys.stderr)
    stats.sort_stats("cumulative").print_stats(args.top)


def sampled(call, period: float, top: int) -> None:
    """Run call() while a thread samples the calling thread's stack every period seconds; print
    the top functions by their share of the samples (inclusive, and their own)."""
    stacks: Counter[tuple[str, ...]] = Counter()
    target, done = threading.get_ident(), threading.Event()

    def sample() -> None:
        while not done.wait(period):
            frame, stack = sys._current_frames().get(target), []
            while frame is not None:
                code = frame.f_code
                stack.append(f"{Path(code.co_filename).name}:{code.co_name}")
                frame = frame.f_back
            stacks[tuple(stack)] += 1

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    t0 = time.perf_counter()
    try:
        code = call()
    finally:
        done.set()
        sampler.join()
    total = max(sum(stacks.values()), 1)
    inclusive: Counter[str] = Counter()
    own: Counter[str] = Counter()
    for stack, n in stacks.items():
        for name in set(stack):
            inclusive[name] += n
        own[stack[0]] += n
    print(f"\nexit {code}; {time.perf_counter() - t0:.2f} s, {total} samples", file=sys.stderr)
    print(f"{'inclusive':>9} {'own':>6}  function", file=sys.stderr)
    for name, n in inclusive.most_common(top):
        print(f"{100 * n / total:8.1f}% {100 * own[name] / total:5.1f}%  {name}", file=sys.stderr)


if __name__ == "__main__":
    main()
