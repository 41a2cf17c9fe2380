"""Drake's step by record 0126's rule, read off the contacts study's rows: the same base trials of
the pick and the puzzle piece, Drake alone on the builder's table, at each step of the study
(docs/results/campaigns_drake_contacts.json). Per object and step: the trials, how many failed,
the mean landing along GB (mm, + toward B) and its standard deviation (the study's own summaries),
and against the object's finest step (record 0127: the puzzle piece has an arm at 0.0125 ms, the
pick's finest is 0.025 ms) the two-sided p of Fisher's exact test of the failures, Welch's t-test
of the mean landing and the Brown-Forsythe test (Levene's about the median) of its spread; the
table's positive control at each step, each object scene's object dropped flat from 1 mm (how far
it moved in 0.3 s, against the 0.05 mm sim.drake_trial.FlatDrop allows); then the step the rule
gives: the coarsest step that agrees (every p >= 0.05 for every object with an arm there) and
passes the control, every finer one of which does both too, and the objects for which a finer
arm shows it converged. An arm whose study has not run is left out. No trial runs; the drops take
under a minute.

    python tools/drake_step.py [--results]

--results writes docs/results/drake_step.json (the markdown beside it rendered from it).
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

from campaign_results import CHANCE_P, OBJECTS, merge_study  # noqa: E402

CONTACTS = ROOT / "docs" / "results" / "campaigns_drake_contacts.json"
RESULTS = ROOT / "docs" / "results" / "drake_step.json"
#: the study's arms per step (ms): the contacts study's name holding each object's Drake trials
ARMS = {0.1: {"guitar_pick": "middle-aim-base", "puzzle_piece": "middle-aim-base"},
        0.05: {"guitar_pick": "step-0.05-pick", "puzzle_piece": "step-0.05-puzzle"},
        0.025: {"guitar_pick": "table-step-pick", "puzzle_piece": "table-step-puzzle"},
        0.0125: {"puzzle_piece": "step-0.0125-puzzle"}}  # record 0127: the puzzle piece alone
FORMATS = {"moved_mm": "{:.4f}", "step_ms": "{:g}", "trials": "{}", "failed": "{}", "landing_along_mean_mm": "{:+.2f}",
           "landing_along_sd_mm": "{:.2f}", "fisher_p": "{:.2g}", "welch_p": "{:.2g}",
           "brown_forsythe_p": "{:.2g}", "agrees": "{}", "chosen_step_ms": "{:g}", "against_ms": "{:g}",
           "converged_for": "{}"}


def arm(rows: list[dict], study: str, name: str) -> tuple[dict, np.ndarray]:
    """One object's Drake arm in one study: the study's own summary of its trials (how many, how many
    failed, the mean landing along GB and its standard deviation) and where each trial that ends
    with the object down landed along GB (mm), the trials the summary's landing figures take."""
    mine = [r for r in rows if r.get("study") == study and r.get("object") == name
            and r["engine"].startswith("drake")]
    summary = next((r for r in mine if "trials" in r), None)
    if summary is None:
        raise SystemExit(f"drake_step: {CONTACTS.name} has no Drake trials of {name} in study {study!r}")
    landed = [r["landing_along_mm"] for r in mine if "trial" in r and r["error_mm"] is not None]
    return summary, np.array(landed)


def compare(arm: tuple[dict, np.ndarray], finest: tuple[dict, np.ndarray]) -> dict[str, float]:
    """The three two-sided p of record 0126 for an arm (arm()) against the finest step's."""
    (s, a), (f, b) = arm, finest
    table = [[s["failed"], s["trials"] - s["failed"]], [f["failed"], f["trials"] - f["failed"]]]
    return {"fisher_p": float(stats.fisher_exact(table)[1]),
            "welch_p": float(stats.ttest_ind(a, b, equal_var=False).pvalue),
            "brown_forsythe_p": float(stats.levene(a, b, center="median").pvalue)}


def drops(steps: list[float]) -> dict[float, list[dict]]:
    """The table's positive control at each step (ms): each object scene's object (the world of
    its lattice plan's trials) dropped as sim.drake_trial.FlatDrop drops it, its row with how far it
    moved."""
    from ungrasp_ompl import Scene
    from ungrasp_ompl.planning import plan
    from ungrasp_ompl.sim.drake_trial import FlatDrop, settle_object
    from ungrasp_ompl.sim.plan_trials import placement

    drop = FlatDrop()
    out: dict[float, list[dict]] = {step: [] for step in steps}
    for name in OBJECTS:
        scene = Scene.from_file(ROOT / "scenes" / f"{name}.yaml")
        spec = placement(scene, plan(scene, planner="lattice"))[1].spec
        pose = drop.pose()
        for step in steps:
            final = settle_object(spec, pose, drop.duration, time_step=step / 1000)
            moved = float(np.linalg.norm(final[:2, 3] - pose[:2, 3]))
            out[step].append({"label": f"drop: {name} at {step:g} ms", "object": name, "step_ms": step,
                              "moved_mm": 1000 * moved, "agrees": "yes" if moved < drop.bound else "no"})
    return out


def arms_run(rows: list[dict]) -> dict[float, dict[str, str]]:
    """ARMS less the arms whose study the contacts study's rows do not hold yet, and the steps left
    with none."""
    have = {r["study"] for r in rows if "study" in r}
    arms = {step: {name: study for name, study in by.items() if study in have} for step, by in ARMS.items()}
    return {step: by for step, by in arms.items() if by}


def step_rows(rows: list[dict], dropped: dict[float, list[dict]]) -> list[dict]:
    """One row per object and step of the study's trial rows (the contacts study's) and the drops'
    rows of each step (drops()), then the row of the step the rule gives. Each object's arms are
    set against its own finest arm (record 0127)."""
    arms = arms_run(rows)
    steps = sorted(arms, reverse=True)
    finest = {name: min(step for step in steps if name in arms[step]) for step in steps for name in arms[step]}
    out, agrees = [], {}
    for step in steps:
        out += dropped[step]
        agrees[step] = all(r["agrees"] == "yes" for r in dropped[step])
        for name, study in arms[step].items():
            this = arm(rows, study, name)
            row = {"label": f"{name} at {step:g} ms", "object": name, "step_ms": step, "study_name": study,
                   **{k: this[0][k] for k in ("trials", "failed", "landing_along_mean_mm", "landing_along_sd_mm")}}
            if step != finest[name]:
                p = compare(this, arm(rows, arms[finest[name]][name], name))
                row |= {"against_ms": finest[name], **p}
                row["agrees"] = "yes" if min(p.values()) >= CHANCE_P else "no"
                agrees[step] &= row["agrees"] == "yes"
            out.append(row)
    chosen = next((step for step in steps if all(agrees[s] for s in steps if s <= step)), None)
    converged = sorted(name for name, f in finest.items() if chosen is not None and f < chosen)
    out.append({"label": "the step the rule gives", "chosen_step_ms": chosen or float("nan"),
                "agrees": ("no step passes the table's control" if chosen is None else
                           "no coarser step agrees and passes the control: convergence not shown"
                           if not converged else
                           f"agrees with {', '.join(f'{finest[n]:g} ms for {n}' for n in converged)}: converged "
                           f"for {'it' if len(converged) == 1 else 'them'} alone"),
                "converged_for": ", ".join(converged) or "none"})
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", action="store_true", help=f"write {RESULTS.relative_to(ROOT)}")
    args = ap.parse_args()
    started = time.perf_counter()
    contacts = json.loads(CONTACTS.read_text())["rows"]
    rows = step_rows(contacts, drops(sorted(arms_run(contacts), reverse=True)))
    for r in rows:
        print(", ".join(f"{k} {v}" for k, v in r.items()))
    if args.results:
        merge_study(RESULTS, "drake-step", shlex.join(["python", "tools/drake_step.py", *sys.argv[1:]]),
                    time.perf_counter() - started, rows, FORMATS,
                    "Drake's step by record 0126's rule (each object against its finest arm, record 0127): "
                    "the same base trials at each step")
        print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
