"""How a digit's contact with the object goes missing while the digit stays on it: tangram pieces
(the shipped layout tiled with lattice plans, seed 1, aimed as the campaign aims them) each run
alone on the table with no error drawn, tick by tick to the termination, MuJoCo's distance between
the thumb's geometry and the piece's read at every control tick (mj_geomDistance).

Per piece: the longest stretch before the termination in which MuJoCo reports no contact between
the thumb and the piece (ms), the largest distance between them over it (um), how far the piece's
outline centroid moved over it (um), and at the tick before it the thumb's normal force (N) and how
deep it reached into the piece (um). It asserts nothing.

    python tools/contact_gap.py [--pieces large_triangle_1,large_triangle_2] [--results]

--results writes the study into docs/results/contact_gap.json (the markdown beside it rendered
from it).
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from ungrasp_ompl.layout.model import Layout  # noqa: E402
from ungrasp_ompl.layout.tiler import TilingOptions  # noqa: E402
from ungrasp_ompl.planning.setup import PlannerOptions  # noqa: E402
from ungrasp_ompl.scene.perturbation import TrialParams  # noqa: E402
from ungrasp_ompl.shipped import resolve  # noqa: E402
from ungrasp_ompl.sim.tiling import tile_aimed  # noqa: E402
from ungrasp_ompl.sim.trial import _move_palm, _palm_quats, _start, touch_down  # noqa: E402

RESULTS = ROOT / "docs" / "results" / "contact_gap.json"
FORMATS = {"gap_ms": "{:.0f}", "widest_um": "{:.3f}", "moved_um": "{:.2f}", "force_before_n": "{:.2f}",
           "depth_before_um": "{:.2f}"}


def _thumb_contact(model, data, thumb: set[int], obj: int) -> tuple[float, float] | None:
    """The thumb's contacts with the object now: (their normal force N, the deepest m), or None."""
    import mujoco

    f6, force, depth, found = np.zeros(6), 0.0, 0.0, False
    for i in range(data.ncon):
        g = data.contact.geom[i]
        if obj in g and (g[0] in thumb or g[1] in thumb):
            mujoco.mj_contactForce(model, data, i, f6)
            force, depth, found = force + f6[0], max(depth, -float(data.contact.dist[i])), True
    return (force, depth) if found else None


def piece_gap(setup) -> dict:
    """The piece's trial with no error, stepped as sim.trial.run_trial steps it up to the
    termination, and its thumb's longest stretch without a contact (see the module docstring)."""
    import mujoco

    spec, model, data, ids, palm, offset = _start(setup, TrialParams())
    drive = setup.drive
    quats = _palm_quats(palm)
    substeps = max(1, round(float(drive.times[1] - drive.times[0]) / spec.timestep))
    touch_down(model, data, ids, palm[0], offset, setup.sim.settle_time)
    centre = np.append(np.asarray(setup.spec.obj.outline, dtype=float).mean(axis=0), [0.0, 1.0])
    end = drive.phase_start("termination")
    ticks = []  # (time s, the thumb's contact or None, distance m, the centroid (3,) m)
    for k in range(1, len(drive.times)):
        t = float(drive.times[k])
        if t >= end:
            break
        data.ctrl[ids.actuator] = max(drive.opening[k] - setup.servo_squeeze, 0.0)
        _move_palm(model, data, ids, (palm[k - 1][:3, 3], quats[k - 1]), (palm[k][:3, 3], quats[k]), substeps)
        pose = np.eye(4)
        pose[:3, :3], pose[:3, 3] = data.xmat[ids.object_body].reshape(3, 3), data.xpos[ids.object_body]
        distance = min(mujoco.mj_geomDistance(model, data, g, ids.object_geom, 1e-3, None) for g in ids.thumb_geoms)
        ticks.append((t, _thumb_contact(model, data, ids.thumb_geoms, ids.object_geom), distance, (pose @ centre)[:3]))
    runs, run = [], []
    for k, tick in enumerate(ticks):
        if tick[1] is None:
            run.append(k)
        elif run:
            runs.append(run)
            run = []
    runs += [run] if run else []
    if not runs:
        return {"gap_ms": 0.0}
    longest = max(runs, key=len)
    first = longest[0]
    before = ticks[first - 1] if first else None
    period = ticks[1][0] - ticks[0][0]
    return {"gap_ms": round(len(longest) * period * 1000, 1), "from_s": round(ticks[first][0], 3),
            "widest_um": round(max(ticks[k][2] for k in longest) * 1e6, 4),
            "moved_um": round(max(float(np.linalg.norm(ticks[k][3] - (before or ticks[first])[3])) for k in longest) * 1e6, 3),
            "force_before_n": None if before is None else round(float(before[1][0]), 3),
            "depth_before_um": None if before is None else round(before[1][1] * 1e6, 3)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pieces", default="large_triangle_1", help="comma-separated piece names")
    ap.add_argument("--results", action="store_true", help="write docs/results/contact_gap.json")
    args = ap.parse_args()
    t0 = time.perf_counter()
    layout = Layout.from_file(resolve("tangram", "layout"))
    _, aimed = tile_aimed(layout, TilingOptions(planner=PlannerOptions(planner="lattice", seed=1)))
    if aimed is None:
        raise SystemExit("the tangram found no tiling")
    setups = dict(aimed.setups)
    names = args.pieces.split(",")
    unknown = [n for n in names if n not in setups]
    if unknown:
        raise SystemExit(f"--pieces: no piece {', '.join(unknown)} in the tangram")
    rows = [{"label": name, **piece_gap(setups[name])} for name in names]
    for r in rows:
        print(r)
    if args.results:
        from campaign_results import merge_study

        command = "python tools/contact_gap.py " + shlex.join(sys.argv[1:])
        merge_study(RESULTS, "thumb gaps", command, time.perf_counter() - t0, rows, FORMATS,
                    "How a digit's contact goes missing while the digit stays on the object", prefixed=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
