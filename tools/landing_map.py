"""Where over its goal region the release moves each object scene's object least, by the model of
the fall (docs/model.md 11.17).

For every goal state of the scene at the goal's largest theta (the lattice's states there, inside
the goal's d and psi ranges, that the pinch holds and the gripper can let go from:
planning.predicted_landing.release_goals), the model's landing without the aim
(mechanics.release, the fall from the state itself): with the scene's friction and Coulomb's cone
(nominal) and over the worlds of the spread (friction 0.7-1.3 times the scene's, both cones: the
lowest and the highest landing), along GB, + toward B. A state's farthest landing is the larger of
the two ends' distances from the target: what an unaimed release can be off by in those worlds. A
plan's release is reachable from the start only at or below the start's d (the forward primitives
move d one way, down), and only at it where the scene allows no P_dpsi (planning.forbid_partial):
the states planning.release least_moving chooses among.

Per object: the release of the campaign's plan (RRT*, seed 1) had it ended anywhere in the goal
region (planning.release objective) from the same fall, the goal state reachable from the start
whose farthest landing is least (where the scenes' plans end: least_moving, record 0129), the same
over the whole goal region, and
how many goal states there are, how many the start reaches and how many of those land within 0.5
mm in every world. No trial runs: a minute or two.

    python tools/landing_map.py [--scenes guitar_pick,puzzle_piece,fabric_chalk] [--results]

--results writes docs/results/landing_map.json (the markdown beside it rendered from it) and
docs/figures/landing_map.png: each object's farthest landing over its goal states at that theta.
"""

from __future__ import annotations

import argparse
import math
import shlex
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from ungrasp_ompl import Scene  # noqa: E402
from ungrasp_ompl.planning import plan as make_plan  # noqa: E402
from ungrasp_ompl.planning.predicted_landing import farthest_landing as farthest  # noqa: E402
from ungrasp_ompl.planning.predicted_landing import landing_of_state as landing  # noqa: E402
from ungrasp_ompl.planning.predicted_landing import release_goals  # noqa: E402
from ungrasp_ompl.mechanics.release import ReleasePrediction  # noqa: E402
from ungrasp_ompl.scene.options import Release  # noqa: E402

SCENES = ("guitar_pick", "puzzle_piece", "fabric_chalk")
RESULTS = ROOT / "docs" / "results" / "landing_map.json"
FIGURE = ROOT / "docs" / "figures" / "landing_map.png"
#: A goal state "lands within" this (m) when its landing in every world of the spread does.
WITHIN = 5e-4
FORMATS = {**{k: "{:+.2f}" for k in ("nominal_mm", "low_mm", "high_mm")}, "farthest_mm": "{:.2f}",
           "spread_mm": "{:.2f}", "d": "{:.3f}", "psi_deg": "{:.1f}", "theta_deg": "{:.1f}",
           "goal_states": "{}", "reachable": "{}", "reachable_within": "{}", "start_d": "{:.3f}"}


def row(label: str, name: str, state, p: ReleasePrediction) -> dict:
    """One release's row: its state and its landing's figures (mm)."""
    return {"label": label, "object": name, "theta_deg": math.degrees(state[0]), "d": state[1],
            "psi_deg": math.degrees(state[2]), "nominal_mm": p.nominal * 1e3, "low_mm": p.low * 1e3,
            "high_mm": p.high * 1e3, "spread_mm": p.spread * 1e3, "farthest_mm": farthest(p) * 1e3}


def mapped(name: str) -> tuple[list[dict], dict]:
    """An object scene's rows, and what its figure draws (states, landings, start's d, plan's end)."""
    scene = Scene.from_file(ROOT / "scenes" / f"{name}.yaml")
    goals, reach = release_goals(scene, reachable=False), release_goals(scene)
    if not goals:
        raise SystemExit(f"{name}: no goal state at the goal's largest theta")
    anywhere = scene.with_options(release=Release.OBJECTIVE)
    result = make_plan(anywhere, planner="RRTstar", time=1.0, seed=1)
    if not result.solved:
        raise SystemExit(f"{name}: the campaign's plan (RRT*, seed 1) is not solved")
    end = tuple(float(x) for x in result.states[-1])
    rows = [row(f"{name}: the release anywhere in the goal region", name, end, landing(scene, end))]
    if reach:
        rows.append(row(f"{name}: the least-moving goal state the start reaches", name, *reach[0]))
    rows.append(row(f"{name}: the least-moving goal state", name, *goals[0]))
    start_d = float(scene.start[1])
    rows.append({"label": f"{name}: goal states", "object": name, "theta_deg": math.degrees(goals[0][0][0]),
                 "start_d": start_d, "goal_states": len(goals), "reachable": len(reach),
                 "reachable_within": sum(farthest(p) <= WITHIN for _, p in reach)})
    return rows, {"states": [s for s, _ in goals], "farthest": [farthest(p) for _, p in goals], "start_d": start_d,
                  "end": end, "least": reach[0][0] if reach else None}


def draw(maps: dict[str, dict], path: Path) -> None:
    """Each object's farthest landing (mm) over its goal states (d, psi), the start's d, the plan's
    release ending anywhere in the goal region and the least-moving state the start reaches marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ungrasp_ompl.plots.common import save_png

    fig, axes = plt.subplots(1, len(maps), figsize=(4.6 * len(maps), 4.6), squeeze=False)
    for ax, (name, m) in zip(axes[0], maps.items()):
        d = np.array([s[1] for s in m["states"]])
        psi = np.degrees([s[2] for s in m["states"]])
        dots = ax.scatter(d, psi, c=np.array(m["farthest"]) * 1e3, cmap="viridis", vmin=0.0, vmax=3.0, s=14,
                          marker="s")
        ax.axvline(m["start_d"], color="k", lw=1, ls="--", label="the start's d (reachable: left of it)")
        ax.plot(m["end"][1], math.degrees(m["end"][2]), "r*", ms=12,
                label="the plan's release, ending anywhere in the goal region")
        if m["least"] is not None:
            ax.plot(m["least"][1], math.degrees(m["least"][2]), "wo", mec="k", ms=9,
                    label="the least-moving state the start reaches (the scene's release)")
        ax.set_title(name)
        ax.set_xlabel("d at the release")
        ax.set_ylabel("psi at the release (deg)")
    fig.legend(*axes[0][0].get_legend_handles_labels(), loc="lower center", ncol=2, fontsize=8)
    fig.subplots_adjust(bottom=0.2)
    fig.colorbar(dots, ax=axes[0].tolist(), label="farthest unaimed landing over the worlds (mm)")
    save_png(fig, path)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--results", action="store_true", help="write docs/results/landing_map.json and its figure")
    args = ap.parse_args(argv)
    command = shlex.join(["python", "tools/landing_map.py", *(sys.argv[1:] if argv is None else argv)])
    wall = time.perf_counter()
    rows, maps = [], {}
    for name in args.scenes.split(","):
        mine, maps[name] = mapped(name)
        for r in mine:
            print(", ".join(f"{k} {FORMATS.get(k, '{}').format(v)}" for k, v in r.items() if k != "object"), flush=True)
        rows += mine
    if args.results:
        from campaign_results import merge_study

        print("wrote", merge_study(RESULTS, "landing-map", command, time.perf_counter() - wall, rows, FORMATS,
                                   "tools/landing_map.py: where over its goal region the release moves each "
                                   "object least (docs/model.md 11.17)"))
        draw(maps, FIGURE)
        print("wrote", FIGURE)
    return 0


if __name__ == "__main__":
    sys.exit(main())
