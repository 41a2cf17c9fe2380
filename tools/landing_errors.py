"""Which of the set-up's errors move the mean landing, and by how much.

The release model (mechanics.release) predicts where a release lands the object when nothing but
the friction differs from the plan; the `paper` errors move the simulated mean landing further
(docs/model.md 11.17). This tool takes them one kind at a time. For each object scene as shipped
(its start, its own planning.objective, the RRT* plan of seed 1, the hand as planned: no aim) and
each world of tools/landing_check.py (nominal, friction x0.7 and x1.3, pyramidal cones), the
release is simulated with no error, then with --pairs antithetic pairs of `paper` draws (a draw
and its mirror through the box's middle, Perturbation.mirrored) of which only one kind of error is
kept: the grasp's shift along GB, its shift across GB, its turn, the palm's position, its
orientation, the table's height with the touch-off's probe, the friction, the mass, the thickness;
and the draws whole. A pair's mean cancels what is linear in the kind's errors, so a mean that
moves is the landing's curvature in them. Each row: the mean landing along GB (+ toward B, mm) less
the no-error landing, its standard error over the pairs' means, the smallest and largest of the
draws' landings less the no-error one, and how many placed the object. A world that sets the
friction draws no friction error (record 0100), so it has no friction row. Then the grasp's turn
alone at +-0.5, +-1 and +-2 deg (the box's bound): the mean of each pair's two landings less the
no-error one.

    python tools/landing_errors.py [--objects guitar_pick,puzzle_piece,fabric_chalk] [--pairs 4] [--jobs 2] [--results]

--results writes the study into docs/results/landing_errors.json (the markdown beside it rendered
from it). The draws come from --seed (default 1), apart from any campaign's trial seeds.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from dataclasses import fields, replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from landing_check import OBJECTS, WORLDS, in_plane, unaimed_scene  # noqa: E402
from ungrasp_ompl.planning import plan as make_plan  # noqa: E402
from ungrasp_ompl.scene.perturbation import PRESETS, TrialParams  # noqa: E402
from ungrasp_ompl.sim.campaign import run_each  # noqa: E402
from ungrasp_ompl.sim.landing import landing_offset  # noqa: E402
from ungrasp_ompl.sim.plan_trials import placement  # noqa: E402

#: Each kind of error: the fields of a `paper` draw it keeps (the others left at no error).
KINDS: dict[str, tuple[str, ...]] = {
    "grasp along GB": ("shift_along_mm",),
    "grasp across GB": ("shift_across_mm",),
    "grasp turn": ("yaw_deg",),
    "palm position": ("palm_shift_mm",),
    "palm orientation": ("palm_turn_deg",),
    "table height and probe": ("table_height_mm", "probe_noise_n", "probe_seed"),
    "friction": ("friction_scale",),
    "mass": ("mass_scale",),
    "thickness": ("thickness_scale",),
    "all (paper)": tuple(f.name for f in fields(TrialParams)),
}
#: The grasp turns (deg) at which the sweep runs, each with its mirror.
TURNS_DEG = (0.5, 1.0, 2.0)
RESULTS = ROOT / "docs" / "results" / "landing_errors.json"
FORMATS = {**{k: "{:+.2f}" for k in ("mean_shift_mm", "low_mm", "high_mm", "turn_0.5_mm", "turn_1_mm", "turn_2_mm")},
           "no_error_mm": "{:.2f}", "stderr_mm": "{:.2f}", "placed": "{}", "seconds": "{:.0f}", "minutes": "{:.0f}"}


def kept(params: TrialParams, kind: str) -> TrialParams:
    """The draw params with only the kind's errors kept."""
    return TrialParams(**{name: getattr(params, name) for name in KINDS[kind]})


def draws(kind: str, pairs: int, seed: int) -> list[TrialParams]:
    """pairs antithetic pairs of `paper` draws, only the kind's errors kept: draw, mirror, draw, ..."""
    box = PRESETS["paper"]
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(pairs):
        p = box.sample(rng)
        out += [kept(p, kind), kept(box.mirrored(p), kind)]
    return out


def object_setup(name: str):
    """The object scene's placement as the campaign plans it, the hand as planned (no aim)."""
    scene = unaimed_scene(name)
    result = make_plan(scene, planner="RRTstar", time=1.0, seed=1)
    if not result.solved:
        raise SystemExit(f"{name}: no plan ({result.reason})")
    return placement(scene, result)[1]


def study(name: str, pairs: int, seed: int, jobs: int) -> list[dict]:
    """The object's rows: per world the no-error landing, each kind's shift, the turn sweep."""
    base = object_setup(name)
    frame = np.asarray(base.target_pose)
    work, index = [], []
    for label, world in WORLDS.items():
        setup = replace(base, world=world)
        table_fixed, digits_fixed = world.fixed_friction
        kinds = [k for k in KINDS if not (k == "friction" and table_fixed and digits_fixed)]
        batches = [("no error", [TrialParams()])] + [(k, draws(k, pairs, seed)) for k in kinds]
        batches += [(f"turn {t:g}", [TrialParams(yaw_deg=t), TrialParams(yaw_deg=-t)]) for t in TURNS_DEG]
        for kind, params in batches:
            for p in params:
                work.append((setup, p, len(work), None))
                index.append((label, kind))
    results = run_each(work, jobs)
    along: dict[tuple[str, str], list[float | None]] = {}
    for (label, kind), (setup, *_), r in zip(index, work, results):
        value = in_plane(frame, landing_offset(setup, np.array(r.final_pose)))[0] * 1e3 if r.placed else None
        along.setdefault((label, kind), []).append(value)
    return rows_of(name, along)


def rows_of(name: str, along: dict[tuple[str, str], list[float | None]]) -> list[dict]:
    """The results file's rows from the landings along GB (mm; None where not placed)."""
    rows = []
    for label in WORLDS:
        zero = along[(label, "no error")][0]
        if zero is None:
            rows.append({"label": f"{name}, {label}", "object": name, "world": label, "no_error_mm": None})
            continue
        turns = {f"turn_{t:g}_mm": _pair_mean(along[(label, f"turn {t:g}")], zero) for t in TURNS_DEG}
        rows.append({"label": f"{name}, {label}", "object": name, "world": label, "no_error_mm": zero, **turns})
        for kind in KINDS:
            values = along.get((label, kind))
            if values is None:
                continue
            pairs = [(a, b) for a, b in zip(values[::2], values[1::2]) if a is not None and b is not None]
            means = [(a + b) / 2 - zero for a, b in pairs]
            landed = [v - zero for v in values if v is not None]
            rows.append({"label": f"{name}, {label}, {kind}", "object": name, "world": label, "kind": kind,
                         "placed": len(landed), "draws": len(values),
                         "mean_shift_mm": float(np.mean(means)) if means else None,
                         "stderr_mm": float(np.std(means, ddof=1) / np.sqrt(len(means))) if len(means) > 1 else None,
                         "low_mm": min(landed) if landed else None, "high_mm": max(landed) if landed else None})
    return rows


def _pair_mean(values: list[float | None], zero: float) -> float | None:
    """The mean of a mirrored pair's landings less the no-error one (mm), or None if either fell."""
    return None if None in values else float(np.mean(values)) - zero


def table(rows: list[dict]) -> str:
    """The study as text: per object and world, each kind's mean shift with its standard error."""
    lines = [f"{'object, world':<34} {'kind':<24} {'shift':>7} {'+-':>5} {'low':>7} {'high':>7} {'placed':>7}"]
    for r in rows:
        if "kind" not in r:
            turns = "  ".join(f"{t:g} deg {_mm(r.get(f'turn_{t:g}_mm'))}" for t in TURNS_DEG)
            lines.append(f"{r['label']:<34} no error {_mm(r['no_error_mm'])} mm; grasp turn: {turns}")
            continue
        lines.append(f"{'':<34} {r['kind']:<24} {_mm(r['mean_shift_mm']):>7} {_mm(r['stderr_mm']):>5} "
                     f"{_mm(r['low_mm']):>7} {_mm(r['high_mm']):>7} {r['placed']:>3}/{r['draws']:<3}")
    return "\n".join(lines)


def _mm(value: float | None) -> str:
    return "-" if value is None else f"{value:+.2f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--objects", default=",".join(OBJECTS))
    ap.add_argument("--pairs", type=int, default=4, help="antithetic pairs of draws per kind and world (default 4)")
    ap.add_argument("--seed", type=int, default=1, help="the draws' seed")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--results", action="store_true", help="write docs/results/landing_errors.json and .md")
    args = ap.parse_args(argv)
    command = shlex.join(["python", "tools/landing_errors.py", *(sys.argv[1:] if argv is None else argv)])
    wall = time.perf_counter()
    rows = [row for name in args.objects.split(",") for row in study(name, args.pairs, args.seed, args.jobs)]
    print(table(rows))
    if args.results:
        from campaign_results import merge_study

        print("wrote", merge_study(RESULTS, "landing-errors", command, time.perf_counter() - wall, rows, FORMATS,
                                   "tools/landing_errors.py: which of the set-up's errors move the mean landing "
                                   "(docs/model.md 11.17)"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
