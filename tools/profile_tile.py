"""Profile `ungrasp-ompl tile` and print where its seconds go, phase by phase; asserts nothing.

`python -m cProfile -m ungrasp_ompl tile ...` writes no profile, because the command leaves through
os._exit; this runs the same command line (cli.run) under cProfile in this process instead:

    python tools/profile_tile.py [scenes/tangram.yaml] [--out DIR] [--prof FILE] [--serial] [-- more tile arguments]

It prints the cumulative seconds of each phase (the search's screens and proofs, planning per
piece, execution, export, pictures) and the top functions by cumulative time. The pieces' plans
and the pictures are made in forked processes, which the profile does not see (it shows this
process waiting for them); --serial makes everything here, in turn, as one process would.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import tempfile
import time
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
        print(f"{phase:<42} {seconds:7.2f} s  {calls:5d} calls", file=sys.stderr)
    stats.sort_stats("cumulative").print_stats(args.top)


if __name__ == "__main__":
    main()
