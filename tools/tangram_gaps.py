"""How much of the tangram's gaps its landings use: the shipped layout tiled with lattice plans and
run attempt by attempt under an error preset (`paper` unless --errors names another), as the
campaign's lattice row is (seed 1, 10 attempts), and from each piece's trial the clearance its
resting footprint leaves to the walls and to the pieces already down where they then lie.

Per piece (in the tiling's order): its trials (the attempts that reached it) and how many of them
placed it (a trial not placed stops where its failure is found, so it has no landing); over those,
how far it came to rest from its target (the outline centroid's offset, in the piece's own
manipulation plane: along GB, + toward B, and across it, + to GB's left seen from above; the means
and standard deviations, mm, and the root mean square of the two standard deviations); where it
lands along GB with no error drawn, alone on the table, and that trial's verdict (mm: what the aim
leaves; the trial runs to its end whatever its verdict, so that a failed one still lands); the
clearance the layout gives it at the targets (mm) and the narrowest clearance its landings left (mm;
negative where the footprints overlap: the piece rests on a wall or a neighbour's edge), each
clearance measured as the layout's spread measures its gaps (geometry.spread.separation: along the
separating edge normal). Per attempt that failed: the piece, its cause, the clearance it left, how
far its trial pushed a piece already down (mm) and which, and the longest its thumb's contact was
absent (ms); an attempt whose every piece was placed but which ends with one not flat inside the
frame names that piece, its clearance at the end from the walls and every other piece where they
then lie, how far the later pieces' trials moved it (mm) and whose trial moved it furthest. The
footprints are the outlines seen from above (a tilted piece's drawn flat), so a clearance is that of
the shapes on the table. It asserts nothing.

The presets split the `paper` errors (scene.perturbation.PRESETS): `grasp` draws the object's
place and turn in the grasp alone, `calibration` the arm's calibration (the palm's position and
turn, one draw per attempt as one per set-up, and the table's height found by the touch-off) alone.

    python tools/tangram_gaps.py [--errors paper] [--attempts 10] [--seed 1] [--jobs 2] [--results]
                                 [--study NAME]

--results writes the study into docs/results/tangram_gaps.json (the markdown beside it rendered
from it): "gaps" under `paper`, "gaps, NAME errors" under another preset, whose rows' labels begin
with its name; --study names it "gaps, NAME" instead, its rows' labels beginning with NAME (a run
under a later set-up kept beside the earlier one).
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from ungrasp_ompl.geometry.spread import separation  # noqa: E402
from ungrasp_ompl.layout.model import Layout  # noqa: E402
from ungrasp_ompl.layout.tiler import TilingOptions  # noqa: E402
from ungrasp_ompl.parallel import RunOptions  # noqa: E402
from ungrasp_ompl.planning.setup import PlannerOptions  # noqa: E402
from ungrasp_ompl.scene.perturbation import PRESETS, TrialParams  # noqa: E402
from ungrasp_ompl.shipped import resolve  # noqa: E402
from ungrasp_ompl.sim.tiling import simulate_tiling, tile_aimed  # noqa: E402
from ungrasp_ompl.sim.trial import placement_offset, run_trial  # noqa: E402

RESULTS = ROOT / "docs" / "results" / "tangram_gaps.json"
FORMATS = {"attempts": "{}", "trials": "{}", "placed": "{}", "along_mean_mm": "{:.2f}", "along_sd_mm": "{:.2f}",
           "across_mean_mm": "{:.2f}", "across_sd_mm": "{:.2f}", "offset_sd_mm": "{:.2f}",
           "no_error_along_mm": "{:.2f}", "designed_mm": "{:.2f}", "narrowest_mm": "{:.2f}", "clearance_mm": "{:.2f}",
           "narrowest_success_mm": "{:.2f}", "thumb_gap_ms": "{:.0f}", "pushed_mm": "{:.2f}", "moved_mm": "{:.2f}"}


#: A piece down that moved less than this (mm) in another piece's trial is not named as pushed.
PUSHED_MM = 0.01


def _footprint(outline: NDArray, pose: NDArray) -> NDArray:
    """The outline (N, 2, body frame) at pose (4 x 4) seen from above: world (x, y)."""
    pose = np.asarray(pose, dtype=float)
    return outline @ pose[:2, :2].T + pose[:2, 3]


def _narrowest(own: NDArray, others: list[NDArray]) -> float:
    """The smallest clearance (m) between outline own and any of others, as the layout's spread
    measures it (geometry.spread.separation)."""
    return min(separation(own, o)[0] for o in others)


def _pushed(attempt, k: int, names: list[str]) -> tuple[float, str | None]:
    """How far (mm) piece k's trial moved the pieces already down, and which it moved furthest: the
    largest shift of one (its centroid, in 3D), from where the trial before left it to where this
    one does (None: none moved PUSHED_MM or more)."""
    pieces = attempt.pieces
    if k == 0:
        return 0.0, None
    shifts = [_shift(pieces[k - 1], pieces[k], j) for j in range(len(pieces[k].placed_poses))]
    j = int(np.argmax(shifts))
    return shifts[j], names[j] if shifts[j] >= PUSHED_MM else None


def _plane_axes(placement) -> NDArray:
    """The piece's manipulation plane seen from above: rows along GB (toward B) and across it (GB
    turned a quarter left), world (x, y)."""
    u = np.asarray(placement.approach.b, dtype=float) - np.asarray(placement.approach.g, dtype=float)
    u /= np.linalg.norm(u)
    return np.array([u, [-u[1], u[0]]])


def _not_flat_at_end(attempt, names: list[str], outlines: dict, walls: list[NDArray]) -> list[dict]:
    """The rows of an attempt whose every piece was placed but which ends with a piece not flat
    inside the frame: per such piece, its clearance at the end from the walls and every other piece
    where they then lie, how far the later pieces' trials moved it, and whose moved it furthest."""
    last = attempt.pieces[-1]
    poses = [*last.placed_poses, last.final_pose]  # every piece where the attempt leaves it, in order
    rows = []
    for j, name in enumerate(names):
        if attempt.flat_inside[j]:
            continue
        others = walls + [_footprint(outlines[n], pose) for i, (n, pose) in enumerate(zip(names, poses)) if i != j]
        low = _narrowest(_footprint(outlines[name], poses[j]), others) * 1000
        moves = [(_shift(attempt.pieces[k - 1], attempt.pieces[k], j), names[k]) for k in range(j + 1, len(names))]
        moved, by = max(moves, default=(0.0, None))
        rows.append({"label": f"attempt {attempt.attempt}", "piece": name, "cause": attempt.cause(),
                     "clearance_mm": round(low, 3), "moved_mm": round(moved, 3),
                     "moved_by": by if moved >= PUSHED_MM else None})
    return rows


def _shift(before, after, j: int) -> float:
    """How far (mm) piece j, already down, moved in the trial after (its centroid, in 3D) from where
    the trial before left it."""
    was = [*before.placed_poses, before.final_pose][j]
    return float(np.linalg.norm(np.asarray(after.placed_poses[j])[:3, 3] - np.asarray(was)[:3, 3])) * 1000


def study(errors: str, attempts: int, seed: int, jobs: int, prefix: str | None) -> list[dict]:
    """The study's rows: the layout tiled and run as the campaign's lattice row is, under the error
    preset named, then measured; row labels begin with prefix when given."""
    layout = Layout.from_file(resolve("tangram", "layout"))
    tiling, aimed = tile_aimed(layout, TilingOptions(planner=PlannerOptions(planner="lattice", seed=seed)))
    if aimed is None:
        raise SystemExit("the tangram found no tiling")
    results = simulate_tiling(layout, aimed.setups, PRESETS[errors], attempts, RunOptions(seed=seed, jobs=jobs))
    alone = {name: run_trial(setup, TrialParams(), stop_at_failure=False)  # no error, no piece down
             for name, setup in aimed.setups}
    rows = measured(layout, tiling, aimed, results, alone)
    return rows if prefix is None else [{**r, "label": f"{prefix}: {r['label']}"} for r in rows]


def measured(layout: Layout, tiling, aimed, results: list, alone: dict) -> list[dict]:
    """Per piece, per failed attempt and over the attempts: the landings' offsets and clearances;
    alone holds each piece's trial with no error drawn, on the table by itself, run to its end (by
    name)."""
    walls = [np.asarray(w.vertices, dtype=float)[:, :2] for w in layout.frame.walls()]  # separation takes hulls
    names = [p.name for p in tiling.placements]
    index = {p.name: k for k, p in enumerate(layout.pieces)}
    setups = dict(aimed.setups)
    outlines = {n: np.asarray(setups[n].spec.obj.outline, dtype=float) for n in names}
    per: dict[str, dict[str, list]] = {n: {"trials": 0, "offsets": [], "narrowest": []} for n in names}
    failures, success_narrowest = [], []
    for a in results:
        lows = []
        for k, (name, t) in enumerate(zip(names, a.pieces)):
            s = setups[name]
            per[name]["trials"] += 1
            if t.placed:
                per[name]["offsets"].append(placement_offset(np.array(t.final_pose), s.target_pose, outlines[name]) * 1000)
            others = walls + [_footprint(outlines[n], pose) for n, pose in zip(names[:k], t.placed_poses)]
            low = _narrowest(_footprint(outlines[name], t.final_pose), others) * 1000
            if t.placed:
                per[name]["narrowest"].append(low)
            lows.append(low)
            if not t.success:
                pushed, moved = _pushed(a, k, names)
                failures.append({"label": f"attempt {a.attempt}", "piece": name, "cause": t.cause(),
                                 "clearance_mm": round(low, 3), "pushed_mm": round(pushed, 3), "pushed_piece": moved,
                                 "thumb_gap_ms": round(t.b_gap_s * 1000, 1)})
        if a.success:
            success_narrowest.append(min(lows))
        elif len(a.pieces) == len(names) and all(t.success for t in a.pieces):
            failures.extend(_not_flat_at_end(a, names, outlines, walls))
    rows = []
    for k, (name, placement) in enumerate(zip(names, tiling.placements)):
        own = layout.footprint(index[name])
        designed = _narrowest(own, walls + [layout.footprint(index[n]) for n in names[:k]]) * 1000
        axes = _plane_axes(placement)
        o = np.array(per[name]["offsets"]).reshape(-1, 2) @ axes.T  # (along, across) per placed trial
        sd = o.std(axis=0, ddof=1) if len(o) > 1 else None
        clean = alone[name]
        no_error = axes[0] @ placement_offset(np.array(clean.final_pose), setups[name].target_pose,
                                              outlines[name]) * 1000
        rows.append({"label": name, "trials": per[name]["trials"], "placed": len(o),
                     "along_mean_mm": round(float(o[:, 0].mean()), 3) if len(o) else None,
                     "along_sd_mm": None if sd is None else round(float(sd[0]), 3),
                     "across_mean_mm": round(float(o[:, 1].mean()), 3) if len(o) else None,
                     "across_sd_mm": None if sd is None else round(float(sd[1]), 3),
                     "offset_sd_mm": None if sd is None else round(float(np.sqrt(np.mean(sd ** 2))), 3),
                     "no_error_along_mm": round(float(no_error), 3), "no_error_outcome": clean.cause(),
                     "designed_mm": round(designed, 3), "narrowest_mm": round(min(per[name]["narrowest"]), 3) if len(o) else None})
    rows.append({"label": "attempts", "attempts": len(results), "successes": sum(a.success for a in results),
                 "narrowest_success_mm": round(min(success_narrowest), 3) if success_narrowest else None})
    return rows + failures


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--errors", choices=[n for n in PRESETS if n != "none"], default="paper",
                    help="the error preset the attempts draw from (default: paper)")
    ap.add_argument("--attempts", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--results", action="store_true", help="write docs/results/tangram_gaps.json")
    ap.add_argument("--study", help="the study's name after 'gaps, ' and its rows' prefix (default: the preset's)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    if args.study:
        name, prefix = f"gaps, {args.study}", args.study
    elif args.errors == "paper":
        name, prefix = "gaps", None
    else:
        name, prefix = f"gaps, {args.errors} errors", args.errors
    rows = study(args.errors, args.attempts, args.seed, args.jobs, prefix)
    for r in rows:
        print(r)
    if args.results:
        from campaign_results import merge_study

        command = "python tools/tangram_gaps.py " + shlex.join(sys.argv[1:])
        merge_study(RESULTS, name, command, time.perf_counter() - t0, rows, FORMATS,
                    "How much of the tangram's gaps its landings use")
    return 0


if __name__ == "__main__":
    sys.exit(main())
