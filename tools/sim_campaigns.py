"""The paper's experiments (sec. 6.2) as simulation campaigns, with the paper's figures beside ours.

    python tools/sim_campaigns.py [--trials N] [--jobs N] [--seed S] [--only base,edge,...]
                                  [--timestep S] [--previous-grip-rule] [--compounded-friction]
                                  [--engine mujoco|drake]
                                  [--table docs/results/campaigns.md] [--figure docs/figures/campaigns.png]

Campaigns (40 trials a row by default, the `paper` errors, RRT* plans with the seed):

* base: the three objects with a rounded (point-contact) finger tip, the table touched off first
  as the shipped scenes' robots do (robot.touch_off);
* open: the same open loop, without the touch-off, as the paper's set-up ran;
* handed: the same, the object handed over at the start (sim.handed_over: set into the gripper
  with its end on the table, not carried there);
* edge: the same with a flat (edge-contact) tip;
* smooth B: each object with the pair the plane chooser took before it knew the outlines' double
  normals (B on a rounded shoulder or corner, or G on the hypotenuse; docs/model.md 5.1 and 11.7),
  rounded tip;
* subset: the 1.5 mm pick run with the 0.96 mm pick's motion;
* caging: the pick's plan started steeper, by the smallest theta offset (whole degrees) that
  puts the start outside force closure in the model, rounded against flat tip; the row prints
  the deviation and the friction margin at the deviated start (negative);
* worlds: the three objects' base plans, their hands aimed as in base, run in worlds neither the
  plan nor the aim saw (sim.world, docs/model.md 11.16): every friction x0.7 and x1.3, pyramidal
  cones, densities x0.5 and x2, contacts a quarter as stiff (time constant x2), the gripper's
  force limit x0.5 and x2 (record 0139), the table's pairs and the digits' at opposite ends of the
  friction's range, both ways (record 0140), and friction x0.7 and x1.3 each under pyramidal cones
  (record 0135); with --tip flat
  the edge rows' plans (flat finger tip) in the same worlds, each label ending ', flat tip';
  with --start least-slide the base, worlds, unaimed and controls rows from each object's start
  from which B slides least along the thumb (record 0118, least_slide_start), the labels saying so;
  with --start previous from the object scenes' starts before record 0121 (PREVIOUS_STARTS);
  with --release least-moving the base, worlds, unaimed and controls rows planned to end where the
  model of the fall moves the object least (planning.release least_moving, record 0128);
* unaimed: the base rows with the hand as planned (robot.landing: planned), no aim at all;
* controls: equal digits as the paper means it (the scene planned with the thumb as long as
  the finger: the exact lattice search finds no secure path; then the asymmetric plan run with
  that thumb, and what stops it), and a fifth of the friction;
* tangram: the shipped layout tiled with lattice plans and simulated attempt by attempt, each
  piece's approach the search's first, then (two more rows) the one whose plan tolerates most,
  then with RRT* plans (the default planner), rounded tip, approaches the search's first, and
  the lattice plans aimed by their simulated releases with the landing's spread unbounded, as
  before decision 0102;
* designed: each object with the digits `ungrasp-ompl design OBJECT --simulate 10` chose (the
  shipped scenes OBJECT_designed.yaml) and the exact lattice plan it judged them by, run with the
  next seed, so that none of the row's trials is one the design was chosen on; beside them the
  scenes' own digits planned to the same free goal, to tell the digits' part from the goal's.
* curved (not among the default groups): the scenes whose object is a curved solid or whose
  gripper is a pincer, each as shipped (its own digits, landing rule and touch-off), its RRT* plan
  seeded with CURVED_PLAN_SEED; curved_worlds (nor this): the Go stone and the coin with the same
  plans in the worlds of CURVED_WORLDS.

`--previous-grip-rule` judges every trial by the lost-grip rule that let one contact of the pinch
part for any time (docs/model.md 11.4) instead of the bound of 11.4, to report rows under both.

`--timestep S` runs every row with MuJoCo's step set to S seconds in place of the scenes' own
(sim.timestep, and sim.pyramidal_timestep in a world with pyramidal cones), the rest of each scene
unchanged: to see whether the rows hold at a finer step than the scenes' own (records 0019, 0111).

`--worlds LABEL,...` runs only those worlds of the `worlds` rows (their labels in WORLDS, e.g.
"pyramidal cones"); with --merge the table's other worlds' rows are kept. `--scenes NAME,...` runs
only those scenes of the curved and curved_worlds rows; with --merge the others' rows are kept.

`--objects NAME,...` runs only those objects' rows of the row groups made per object (base, worlds,
unaimed, edge, open, smooth, handed, designed), with --merge into --table: each group's row of the
three objects then counts the other objects' rows as the table has them, and those rows stay the
table's, made by the runs that made them.

`--compounded-friction` draws the `paper` friction error on top of a world's friction factor, the
rule before a world fixed its pairs' friction (docs/decisions/0100-a-world-fixes-its-friction.md),
to report the worlds' rows under both.

Every row has a Wilson 95 % interval on its success rate; success is placed within the scene's
sim.max_error of the target by the strict verdict, and the paper's own criterion (no grip lost
before the termination, then flat: placed, any error, with its mean error) is given beside it
(docs/model.md 11.4), and the deepest any trial of the row sank into a digit or the table. Prints
one markdown table, writes it to --table, the same rows as numbers beside it (the table's name with
.json: tools/campaign_results.py, which the documentation's figures are read from) and draws ours
beside the paper's into the figure.

`--engine drake` runs the rows in Drake (sim.drake_trial; docs/model.md 11.19) instead of MuJoCo,
20 trials a row unless --trials says otherwise, and sets each row beside MuJoCo's row of the same
label in docs/results/campaigns.json (not rerun): both counts with their Wilson intervals and a
two-sided Fisher exact test of the two engines' strict successes, each over its own trials. The
rows are merged into the table (default docs/results/campaigns_drake.md) and its .json (the rows of
other row groups already there are kept, so that `--only base`, then `--only controls`, ... fill the
file group by group) and both engines are drawn into the figure (docs/figures/TABLE.png, TABLE the
table's name, unless --figure names another). The tangram rows run each piece's
trial in Drake, the pieces already down in it (sim.tiling.simulate_tiling's engine): the lattice's
rows alone, with the rounded and the flat tip, since an attempt costs minutes there.

`--engine drake --contacts guitar_pick:1,...` runs trial 1 (and so on) of an object's base row in
both engines (from the start --start chooses), logs the forces on the object at every control tick
(each engine's trial's contact_log), and writes what they show per
engine into docs/results/campaigns_drake_contacts.json (.md beside): while both digits and the
table hold the object, the table's friction use (its tangential over its normal force) against the
trial's mu at G, the mean size of each digit's force on the object and the table's normal force,
how far G moves along the table before the termination (and in which phase most) and after it
begins, and the finger's mean force on the object in the termination; and per object and engine
run on three trials or more, how many fail, how the placement error ranks (Spearman) with G's
slide from the termination on and with the table's grip over mu, and where the object lands along
GB and across it (each trial's landing is in its row), and in how many the object already lay out of
the plane when the drive began. With `--tip flat` the
trials are the edge rows' (the flat finger tip); with `--contacts-world KEY=VALUE` they run in
that world (`--contacts-world friction=0.2`: the control's); `--contacts-study NAME` keeps the
study beside the others in the file. `--drake-step S`, `--drake-table PA_PER_M` and `--drake-pad
PA_PER_M` run Drake's trials alone at another step, or with a table or pads of another stiffness
(record 0125).

`--pair FILE.json` sets the Drake rows a run wrote into FILE beside MuJoCo's rows of the same keys
as MuJoCo's file has them now, with the Fisher test again, and runs no trial: after a MuJoCo file
is written again, its Drake counterpart is compared with the new rows. `--mujoco FILE.json` names
the MuJoCo file to set them beside (a run of the same code and scenes); the default is
docs/results/campaigns.json.

The landings the hands are aimed by are kept for the run (UNGRASP_OMPL_CACHE, a temporary
directory unless it is set), so that a plan's rows in several worlds share one aim.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import os
import re
import sys
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ungrasp_ompl import Scene  # noqa: E402
from ungrasp_ompl.parallel import RunOptions  # noqa: E402
from ungrasp_ompl.planning import PlannerOptions, plan  # noqa: E402
from ungrasp_ompl.planning.deviate import plan_problems, steeper_start  # noqa: E402
from ungrasp_ompl.provenance import environment  # noqa: E402
from ungrasp_ompl.sim.campaign import simulate, wilson_interval  # noqa: E402
from ungrasp_ompl.scene.perturbation import PRESETS  # noqa: E402
from ungrasp_ompl.sim.plan_trials import placement  # noqa: E402
from ungrasp_ompl.scene.options import Landing, Release, SimOptions  # noqa: E402
from ungrasp_ompl.sim.landing import CACHE_VARIABLE  # noqa: E402
from ungrasp_ompl.sim.setup import Variant  # noqa: E402
from ungrasp_ompl.sim.trial import MAX_CONTACT_GAP, TOUCH_DISTANCE  # noqa: E402
from ungrasp_ompl.sim.world import World  # noqa: E402

SCENES = ROOT / "scenes"
OBJECTS = ("guitar_pick", "puzzle_piece", "fabric_chalk")
#: The objects whose rows run (--objects); the others' rows of a group's total are the table's.
SELECTED: tuple[str, ...] = OBJECTS
#: The row groups made per object, which --objects may choose from.
PER_OBJECT_GROUPS = ("base", "worlds", "unaimed", "edge", "open", "smooth", "handed", "designed")
#: The `curved` rows' scenes: the curved solids (docs/model.md 2.7) and the pincer (7).
CURVED = ("go_stone", "coin", "pincer_puzzle_piece", "pincer_guitar_pick")
#: The `curved_worlds` rows' scenes: the curved solids.
CURVED_WORLD_SCENES = ("go_stone", "coin")
#: The seed of the `curved` rows' RRT* plans, one with which RRT* solves all four scenes.
CURVED_PLAN_SEED = 3
#: The worlds the Go stone and the coin are run in besides their own (docs/model.md 11.16).
CURVED_WORLDS = (("friction x0.7", World(friction=0.7)), ("friction x1.3", World(friction=1.3)),
                 ("pyramidal cones", World(cone="pyramidal")))
#: MuJoCo's step (s) for every row, or None for the scenes' own (--timestep).
TIMESTEP: float | None = None
#: The physics engine every row runs in (sim.campaign.ENGINES; --engine).
ENGINE: str = "mujoco"
#: A campaign table's header (its rows: Row.line).
HEADER = ("| campaign | ours: success (95 % interval) | placed by the paper's criterion, any error | error mm (mean / max) "
          "| paper | the model on the plan | failures | deepest sinking mm |\n|---|---|---|---|---|---|---|---|")
#: MuJoCo's rows the Drake rows are set beside, and the order of the row groups in Drake's file.
MUJOCO_RESULTS = ROOT / "docs" / "results" / "campaigns.json"
#: MuJoCo's tangram rows, beside which a Drake file of tangram rows alone is set.
MUJOCO_TANGRAM = ROOT / "docs" / "results" / "campaigns_tangram.json"
#: MuJoCo's rows from the least-slide starts (record 0118), beside which Drake's from them are set.
MUJOCO_LEAST_SLIDE = ROOT / "docs" / "results" / "campaigns_least_slide.json"
#: The MuJoCo results file the Drake rows are set beside (--mujoco), or None for the one their rows
#: choose (paired_with_mujoco).
MUJOCO_SOURCE: Path | None = None
GROUP_ORDER = ("base", "edge", "control", "tangram")
#: The --only name of each row group.
GROUP_OPTION = {"base": "base", "edge": "edge", "control": "controls", "tangram": "tangram"}
#: The longest one contact may be absent before the termination (s): the verdict's own, or inf
#: for the rule of docs/model.md 11.4 (--previous-grip-rule).
MAX_GAP: float = MAX_CONTACT_GAP
#: The labels of the `worlds` rows to run (--worlds), or None for all of WORLDS.
WORLD_LABELS: tuple[str, ...] | None = None
#: The finger tip of the `worlds` rows (--tip): the base scenes' rounded one, or the edge rows' flat one.
WORLD_TIP = "rounded"
#: How far the `worlds` rows' targets are turned about the vertical (--turn-target, deg; record
#: 0137): the scene's object.target.yaw_deg plus this, the labels ending ", target turned D deg".
TARGET_TURN_DEG = 0.0
#: Where the base and worlds rows start (--start): the scenes' own start, or "least-slide" (record 0118).
START = "scene"
#: Where the base, worlds, unaimed and controls rows' plans end (--release): where the scenes'
#: planning.release says, or "least-moving" (record 0128: planning.release least_moving, the labels
#: ending RELEASE_WORDS).
RELEASE = "scene"
RELEASE_WORDS = ", least-moving release"
#: The curved rows' scenes (--scenes), or None for all of CURVED.
CURVED_SCENES: tuple[str, ...] | None = None
#: Whether a world's friction factor compounds with the trials' drawn friction error (--compounded-friction).
COMPOUNDED_FRICTION: bool = False
#: What the rows' RRT* plans optimise (--objective): None, each scene's planning.objective.
OBJECTIVE: str | None = None
#: The worlds of the `worlds` rows: label, world (docs/model.md 11.16).
WORLDS = (("friction x0.7", World(friction=0.7)), ("friction x1.3", World(friction=1.3)),
          ("pyramidal cones", World(cone="pyramidal")), ("density x0.5", World(density=0.5)),
          ("density x2", World(density=2.0)), ("stiffness x0.25 (time constant x2)", World(stiffness=0.25)),
          # the gripper's force, known to tens of per cent as the density is (record 0139)
          ("jaw force x0.5", World(jaw_force=0.5)), ("jaw force x2", World(jaw_force=2.0)),
          # the table's pairs and the digits' at opposite ends of the friction's range (record 0140)
          ("friction x0.7 at the table and x1.3 at the digits", World(friction_table=0.7, friction_digits=1.3)),
          ("friction x1.3 at the table and x0.7 at the digits", World(friction_table=1.3, friction_digits=0.7)),
          # both corners of the friction's range under the other cone model at once (record 0135)
          ("friction x0.7 under pyramidal cones", World(friction=0.7, cone="pyramidal")),
          ("friction x1.3 under pyramidal cones", World(friction=1.3, cone="pyramidal")))


@dataclass
class Row:
    """One campaign row: our count with its interval, and the paper's figure."""

    label: str
    successes: int
    trials: int
    placed: int  #: by the paper's criterion, any error
    placed_error: str  #: mean placement error of those (mm), or "-"
    errors: str  #: mean / max placement error of the successes (mm), or "-"
    paper: str
    paper_rate: tuple[int, int] | None  #: the paper's successes and trials, where it gives them
    model: str  #: what the model says of the plan that ran
    causes: str
    sinking: str = "-"  #: the deepest any trial sank into a digit or the table (mm), or "-"
    kept: bool = False  #: the table's row, not run again (--objects): counted in its group's total alone

    @classmethod
    def from_record(cls, r: dict) -> "Row":
        """The row of a results file's record (campaign_results.parse_row), for drawing: the
        paper's rate is the fraction its figure begins with, where it begins with one."""
        from campaign_results import row_line

        cells = [c.strip() for c in row_line(r).strip().strip("|").split(" | ")]
        placed_error = "-" if r["placed_error_mean_mm"] is None else f"mean {r['placed_error_mean_mm']:.2f} mm"
        rate = re.match(r"(\d+)/(\d+)", r["paper"])
        return cls(r["label"], r["successes"], r["trials"], r["placed"], placed_error, cells[3], r["paper"],
                   (int(rate.group(1)), int(rate.group(2))) if rate else None, r["model"], cells[6], cells[7])

    def line(self) -> str:
        low, high = wilson_interval(self.successes, self.trials)
        return (f"| {self.label} | {self.successes}/{self.trials} ({100 * low:.0f}-{100 * high:.0f} %) | "
                f"{self.placed}/{self.trials} ({self.placed_error}) | {self.errors} | {self.paper} | {self.model} | "
                f"{self.causes} | {self.sinking} |")


def _stepped(scene: Scene) -> Scene:
    """The scene simulated with the campaign's timestep (TIMESTEP), if one is set, in every world
    (sim.timestep and sim.pyramidal_timestep)."""
    return scene if TIMESTEP is None else scene.with_sim(timestep=TIMESTEP, pyramidal_timestep=TIMESTEP)


def least_slide_start(scene: Scene) -> float:
    """Record 0118's rule: the start d (in hundredths, within the goal's d range, the scene's theta
    and psi) whose exact lattice plan (the scene's planning options, seed 1) is secure and slides B
    least along the thumb (ungrasp_ompl.benchmark.starts, as `ungrasp-ompl starts` chooses)."""
    from ungrasp_ompl.benchmark.starts import StartOptions, search_starts

    best = search_starts(scene, StartOptions(run=RunOptions(seed=1, jobs=1))).best
    if best is None:
        raise SystemExit(f"--start least-slide: {scene.name} has no secure lattice plan from any start in its goal's d range")
    return best.d


_LEAST_SLIDE: dict[tuple, float] = {}  # least_slide_start's answers by scene name and finger tip

#: The object scenes' starts (d) before record 0121 (--start previous).
PREVIOUS_STARTS = {"guitar_pick": 0.65, "puzzle_piece": 0.8, "fabric_chalk": 0.8}


def _started(scene: Scene) -> tuple[Scene, str]:
    """The scene from the start --start chooses, its plans ending where --release says, and the words
    its base row's label ends with."""
    scene, words = _from_start(scene)
    if RELEASE == "scene":
        return scene, words
    return scene.with_options(release=Release.LEAST_MOVING), words + RELEASE_WORDS


def _from_start(scene: Scene) -> tuple[Scene, str]:
    """The scene from the start --start chooses, and the words its base row's label ends with."""
    if START == "scene":
        return scene, ""
    if START == "previous":
        d = PREVIOUS_STARTS[scene.name]
        return scene.with_start_d(d), f", previous start d {d:.2f}"
    key = (scene.name, scene.digits.flat_finger_tip)
    if key not in _LEAST_SLIDE:
        _LEAST_SLIDE[key] = least_slide_start(scene)
    d = _LEAST_SLIDE[key]
    return scene.with_start_d(d), f", least-slide start d {d:.2f}"


def _scene(name: str, tip: str | None = None, contacts: dict | None = None, turn_deg: float = 0.0) -> Scene:
    """A shipped scene, its finger tip rounded or flat (or its own), its contacts fixed (or its own),
    its target turned by turn_deg about the vertical, with the campaign's timestep."""
    if contacts is None and not turn_deg:
        scene = _stepped(Scene.from_file(SCENES / f"{name}.yaml"))
    else:
        import yaml

        doc = yaml.safe_load((SCENES / f"{name}.yaml").read_text())
        source = f"{name}.yaml"
        if contacts is not None:
            doc, source = {**doc, "contacts": contacts}, f"{source}, contacts {contacts}"
        if turn_deg:
            target = doc["object"]["target"]
            doc["object"] = {**doc["object"], "target": {**target, "yaw_deg": target.get("yaw_deg", 0.0) + turn_deg}}
            source = f"{source}, target turned {turn_deg:g} deg"
        scene = _stepped(Scene.from_dict(doc, source=source))
    if tip is not None:
        dg = scene.digits
        scene = replace(scene, digits=replace(dg, flat_finger_tip=tip == "flat",
                                              finger_tip_radius=0.0 if tip == "flat" else dg.finger_tip_thickness / 2))
    return scene


#: The pairs the plane chooser took before it knew the outlines' double normals (m, object frame):
#: the thumb on a rounded shoulder (pick) or corner (chalk, puzzle piece), G across from it
#: (docs/model.md 11.7).
OLD_PAIRS = {"guitar_pick": ("G near the tip, B on a shoulder", {"G": [0.000718, 0.032210], "B": [-0.007146, 0.000281]}),
             "puzzle_piece": ("G on the hypotenuse, B at the right angle", {"G": [0.025, 0.025], "B": [0.0, 0.0]}),
             "fabric_chalk": ("G on a side, B on a rounded corner", {"G": [0.033752, 0.019497], "B": [0.003374, 0.002159]})}


def _plan(scene: Scene, seed: int):
    result = plan(scene, planner="RRTstar", time=1.0, seed=seed, objective=OBJECTIVE)
    if not result.solved:
        raise SystemExit(f"{scene.name}: {result.reason}")
    return result


def run(label: str, scene: Scene, result, trials: int, jobs: int, seed: int, paper: str,
        paper_rate: tuple[int, int] | None = None, variant: Variant = Variant(), model: str | None = None,
        world: World = World()) -> Row:
    """Execute and simulate one plan, in world; the row of the table."""
    problems = plan_problems(scene, result)
    setup = replace(placement(scene, result, variant)[1], max_contact_gap=MAX_GAP,
                    friction_draw_in_world=COMPOUNDED_FRICTION)
    report = simulate(setup, PRESETS["paper"], trials, RunOptions(seed=seed, jobs=jobs), scene=scene.name,
                      variant=variant, world=world, engine=ENGINE)
    s = report.to_dict()
    err, placed = s["position_error_mm"], s["placed_position_error_mm"]
    errs = f"{err['mean']:.2f} / {err['max']:.2f}" if err["mean"] is not None else "-"
    placed_err = f"mean {placed['mean']:.2f} mm" if placed["mean"] is not None else "-"
    causes = "; ".join(f"{n} {c}" for c, n in report.causes().items()) or "-"
    verdict = model or ("secure" if not problems else "rejected: " + str(problems[0].failure).split(" at (")[0])
    sinking = f"{s['max_penetration_mm']:.3f}" if s["max_penetration_mm"] is not None else "-"
    return Row(label, report.successes, trials, report.placed, placed_err, errs, paper, paper_rate, verdict, causes,
               sinking)


def caging_deviation(scene: Scene, result) -> tuple[float, float]:
    """The smallest theta offset (rad, whole degrees) that puts the plan's start outside force
    closure in the scene's model while kinematics and collision still hold, and the friction
    margin there (rad, negative)."""
    from ungrasp_ompl.scene import StateClass

    theta, d, psi = result.states[0]
    for deg in range(1, 60):
        q = [theta + math.radians(deg), d, psi]
        if StateClass(int(scene.classify([q])[0])) is StateClass.NOT_FORCE_CLOSED:
            return math.radians(deg), float(scene.margin([q]).friction[0])
    raise SystemExit(f"{scene.name}: no steeper start within 60 deg leaves force closure")


def tangram(attempts: int, jobs: int, seed: int, tip: str, rank: str = "first", planner: str = "lattice",
            simulated_aim: bool = False) -> Row:
    """The shipped tangram tiled (each piece planned by planner, the exact lattice by default, and
    its approach chosen by rank), then simulated attempt by attempt. simulated_aim: each piece aimed
    by its own release simulated with no error drawn (robot.landing simulated, decision 0013) and
    its landing's spread left unbounded, the layout's set-up before decision 0102, for comparison."""
    import yaml

    from ungrasp_ompl.layout.model import Layout
    from ungrasp_ompl.sim.tiling import simulate_tiling, tile_aimed
    from ungrasp_ompl.layout.tiler import TilingOptions

    doc = yaml.safe_load((SCENES / "tangram.yaml").read_text())
    doc["digits"]["finger_tip"] = tip
    if simulated_aim:  # the simulated release measures the whole landing: no offset beyond the model's
        doc["robot"]["landing"] = "simulated"
        del doc["planning"]["max_landing_spread"]
        for piece in doc["pieces"]:
            piece.pop("landing_offset", None)
    if TIMESTEP is not None:
        doc.setdefault("sim", {})["timestep"] = TIMESTEP
    layout = Layout.from_dict(doc, source="tangram.yaml")
    tiling, aimed = tile_aimed(layout, TilingOptions(planner=PlannerOptions(planner=planner, seed=seed), rank=rank))
    ranked = ("" if rank == "first" else ", approaches ranked by tolerance") + (
        ", aimed by the simulated release, spread unbounded" if simulated_aim else "")
    name = f"tangram, {tip} tip ({planner.replace('star', '*')} plans{ranked})"
    if aimed is None:
        return Row(name, 0, attempts, 0, "-", "-", "9/10", (9, 10), "no tiling",
                   f"no tiling: {tiling.failed_piece} cannot be placed ({tiling.reasons[0].kind.value if tiling.reasons else '?'})")
    results = simulate_tiling(layout, aimed.setups, PRESETS["paper"], attempts, RunOptions(seed=seed, jobs=jobs),
                              engine=ENGINE)
    # each cause without its time (" at 4.65 s"); "not flat inside the frame at the end: ..." keeps its pieces
    causes = collections.Counter(re.sub(r" at [0-9.]+ s$", "", a.cause()) for a in results if not a.success)
    ok, placed = sum(a.success for a in results), sum(a.placed for a in results)
    return Row(name, ok, attempts, placed, "-", "-", "9/10", (9, 10), "secure",
               "; ".join(f"{n} {c}" for c, n in causes.most_common()) or "-")


def draw(rows: list[Row], path: Path) -> None:
    """Ours (bars with Wilson 95 % intervals) beside the paper's (diamonds with theirs)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(12, 0.34 * len(rows) + 1.6))
    y = np.arange(len(rows))[::-1]
    rate = np.array([r.successes / r.trials for r in rows])
    ci = np.array([wilson_interval(r.successes, r.trials) for r in rows])
    ax.barh(y, rate * 100, color="#4c72b0", height=0.6, label="simulated here (placed within max_error)")
    ax.errorbar(rate * 100, y, xerr=[(rate - ci[:, 0]) * 100, (ci[:, 1] - rate) * 100], fmt="none", ecolor="black",
                capsize=3, label="Wilson 95 % interval")
    ax.plot([100 * r.placed / r.trials for r in rows], y, "o", mfc="none", mec="#4c72b0", ms=6,
            label="simulated here, placed by the paper's criterion (any error)")
    marked = False
    for yy, r in zip(y, rows):
        if r.paper_rate is None:
            continue
        k, n = r.paper_rate
        lo, hi = wilson_interval(k, n)
        ax.errorbar([100 * k / n], [yy], xerr=[[100 * (k / n - lo)], [100 * (hi - k / n)]], fmt="D", color="#dd8452",
                    capsize=3, label=None if marked else "the paper (physical), with its interval")
        marked = True
    ax.set_yticks(y, [r.label for r in rows], fontsize=8)
    ax.set_xlim(0, 102)  # room for the markers at 100 %
    ax.set_ylim(-0.7, len(rows) - 0.3)
    ax.set_xlabel("success rate (%)")
    fig.suptitle("The paper's experiments: simulated here beside the paper's physical results", fontsize=10)
    fig.legend(*ax.get_legend_handles_labels(), loc="lower center", ncol=4, fontsize=7, frameon=False)
    fig.tight_layout(rect=(0, 0.6 / fig.get_figheight(), 1, 1))  # the legend's band at the bottom
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=None, help="trials per row (default 40; 20 with --engine drake)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--only", default="base,worlds,unaimed,open,smooth,handed,edge,subset,caging,controls,tangram,designed")
    ap.add_argument("--previous-grip-rule", action="store_true",
                    help="judge lost grips by the rule that let one contact part for any time (docs/model.md 11.4)")
    ap.add_argument("--compounded-friction", action="store_true",
                    help="draw the `paper` friction error on top of a world's friction factor "
                         "(docs/decisions/0100-a-world-fixes-its-friction.md)")
    ap.add_argument("--table", type=Path, default=None, help="also write the table (markdown) to this file")
    ap.add_argument("--objective", choices=("cost", "margin", "balanced", "tolerance"), default=None,
                    help="what the rows' RRT* plans optimise (default: each scene's planning.objective)")
    ap.add_argument("--merge", action="store_true",
                    help="with --table: replace only the rows this run makes, keeping the table's others and "
                         "recording this run's command beside the table's (the figure draws the merged rows)")
    ap.add_argument("--attempts", type=int, default=10, help="tangram attempts per row (default 10)")
    ap.add_argument("--timestep", type=float, default=None,
                    help="MuJoCo's step for every row, in every world (s; default: the scenes' own, sim.timestep "
                         "and sim.pyramidal_timestep)")
    ap.add_argument("--no-figure", action="store_true", help="write the table alone, no figure")
    ap.add_argument("--objects", default=None, metavar="NAME,...",
                    help="only these objects' rows of the groups made per object, the others' rows kept from "
                         "the table (with --merge; --only worlds alone needs none)")
    ap.add_argument("--scenes", default=None,
                    help="only these scenes in the curved and curved_worlds rows, comma-separated (e.g. go_stone)")
    ap.add_argument("--worlds", default=None,
                    help="only these worlds of the `worlds` rows, by label, comma-separated (e.g. 'pyramidal cones')")
    ap.add_argument("--figure", type=Path, default=None,
                    help="default docs/figures/TABLE.png, TABLE the --table's name (campaigns.png without one)")
    ap.add_argument("--contacts", default=None, help="with --engine drake: OBJECT:TRIAL,... of the base rows, "
                                                     "their contact forces logged in both engines")
    ap.add_argument("--contacts-study", default=None, metavar="NAME",
                    help="with --contacts: the study's name in the results file (default contacts, "
                         "contacts_thumb_point, ..._flat_tip); a name given starts its rows' labels")
    ap.add_argument("--contacts-summaries", action="store_true",
                    help="make every contacts study's summaries per object and engine again from its trials' rows "
                         "(no trial runs), after the summaries learn a field")
    ap.add_argument("--contacts-world", action="append", default=[], metavar="KEY=VALUE",
                    help="with --contacts: run the trials in this world (simulate --world's keys, repeatable; "
                         "e.g. friction=0.2, the control's), each row's label saying so")
    ap.add_argument("--tip", choices=("rounded", "flat"), default="rounded",
                    help="the finger tip of the `worlds` rows (flat: each label ends ', flat tip'), and with "
                         "--contacts of the rows whose trials are run (flat: the edge rows')")
    ap.add_argument("--turn-target", type=float, default=0.0, metavar="DEG",
                    help="turn the `worlds` rows' targets by DEG about the vertical (the scene's target yaw plus "
                         "DEG; each label ends ', target turned DEG deg'; record 0137)")
    ap.add_argument("--start", choices=("scene", "least-slide", "previous"), default="scene",
                    help="where the base and worlds rows (and --contacts' trials) start: the scenes' own start, each "
                         "object's start from which B slides least along the thumb (record 0118; labels end "
                         "', least-slide start'), or the object scenes' starts before record 0121")
    ap.add_argument("--release", choices=("scene", "least-moving"), default="scene",
                    help="where the base, worlds, unaimed and controls rows' plans end: where the scenes' "
                         "planning.release says, or where the model of the fall moves the object least "
                         "(planning.release least_moving, "
                         f"record 0128; labels end '{RELEASE_WORDS}')")
    ap.add_argument("--thumb", choices=("pad", "point"), default="pad",
                    help="with --contacts: how the thumb touches the object in Drake (docs/model.md 11.19); "
                         "point: its mesh's point contact, the builder before the thumb's pad")
    ap.add_argument("--drake-step", type=float, default=None, metavar="S",
                    help="with --contacts: Drake's time step (s) instead of sim.drake_trial.DRAKE_TIME_STEP; only "
                         "Drake's rows are made, their labels saying so (record 0125)")
    ap.add_argument("--drake-table", type=float, default=None, metavar="PA_PER_M",
                    help="with --contacts: how fast the table's pressure rises with depth in Drake (Pa/m) instead of "
                         "sim.drake_world's TABLE_MODULUS / TABLE_SLAB; only Drake's rows are made (record 0125)")
    ap.add_argument("--drake-pad", type=float, default=None, metavar="PA_PER_M",
                    help="with --contacts: the same for the digits' pads (sim.drake_world.PAD_GRADIENT; record 0125)")
    ap.add_argument("--drake-hull", choices=("large-fanned", "convex", "fanned"), default="large-fanned",
                    help="with --engine drake: how the object's and the pieces' hulls reach Drake "
                         "(sim.drake_world.HULLS): Drake's division with large faces fanned from their "
                         "centroids (record 0116, the builder's), Drake's Convex, or record 0115's (refused)")
    ap.add_argument("--engine", choices=("mujoco", "drake"), default="mujoco",
                    help="the physics engine of every row; drake: beside MuJoCo's rows of docs/results/campaigns.json")
    ap.add_argument("--mujoco", type=Path, default=None, metavar="FILE",
                    help="with --engine drake or --pair: the MuJoCo results file (docs/results/*.json) whose rows "
                         "of the same keys the Drake rows are set beside; default: docs/results/campaigns.json "
                         "(the tangram's and the least-slide starts' their own)")
    ap.add_argument("--pair", type=Path, default=None, metavar="FILE",
                    help="set the Drake rows of FILE (a results file --engine drake wrote) beside MuJoCo's rows as "
                         "its MuJoCo file has them now, with the Fisher test again; no trial runs")
    args = ap.parse_args()
    global TIMESTEP, MAX_GAP, COMPOUNDED_FRICTION, ENGINE, OBJECTIVE, WORLD_LABELS, WORLD_TIP, START, CURVED_SCENES, SELECTED
    global RELEASE, TARGET_TURN_DEG
    global MUJOCO_SOURCE
    if args.mujoco is not None:
        MUJOCO_SOURCE = args.mujoco.resolve()
        if not MUJOCO_SOURCE.is_file() or not MUJOCO_SOURCE.is_relative_to(ROOT):
            ap.error(f"--mujoco: {args.mujoco} is not a results file of this repository")
    if args.pair is not None:
        pair_again(args.pair)
        return
    if args.contacts_summaries:
        contact_summaries()
        return
    ENGINE = args.engine
    WORLD_TIP, START, RELEASE, TARGET_TURN_DEG = args.tip, args.start, args.release, args.turn_target
    drake = ENGINE == "drake"
    if drake:
        from ungrasp_ompl.sim import drake_world

        drake_world.HULLS = args.drake_hull
    if args.trials is None:
        args.trials = 20 if drake else 40
    if drake and args.table is None:
        args.table = ROOT / "docs" / "results" / "campaigns_drake.md"
    if args.figure is None:  # named as the table is, so that a campaign's figure never takes another's name
        args.figure = ROOT / "docs" / "figures" / (f"{args.table.stem}.png" if args.table else "campaigns.png")
    if drake and args.contacts:
        contact_forces(args.contacts, args.seed, args.thumb, args.tip, args.contacts_study,
                       World.parse(args.contacts_world), args.drake_step, args.drake_table,
                       args.drake_pad)
        return
    TIMESTEP = args.timestep
    if args.worlds is not None:
        WORLD_LABELS = tuple(w.strip() for w in args.worlds.split(","))
        unknown = set(WORLD_LABELS) - {label for label, _ in WORLDS}
        if unknown:
            ap.error(f"--worlds: no world labelled {', '.join(sorted(unknown))} (worlds: "
                     f"{', '.join(label for label, _ in WORLDS)})")
    CURVED_SCENES = None if args.scenes is None else tuple(x.strip() for x in args.scenes.split(","))
    curved = CURVED if CURVED_SCENES is None else CURVED_SCENES
    if set(curved) - set(CURVED):
        ap.error(f"--scenes: no curved row of {', '.join(sorted(set(curved) - set(CURVED)))} (scenes: {', '.join(CURVED)})")
    COMPOUNDED_FRICTION = args.compounded_friction
    OBJECTIVE = args.objective
    MAX_GAP = math.inf if args.previous_grip_rule else MAX_CONTACT_GAP
    os.environ.setdefault(CACHE_VARIABLE, tempfile.mkdtemp(prefix="landings-"))
    only = set(args.only.split(","))
    KEPT = {}
    if args.objects is not None:
        SELECTED = tuple(x.strip() for x in args.objects.split(","))
        if set(SELECTED) - set(OBJECTS):
            ap.error(f"--objects: no object {', '.join(sorted(set(SELECTED) - set(OBJECTS)))} "
                     f"(objects: {', '.join(OBJECTS)})")
        if only - set(PER_OBJECT_GROUPS):
            ap.error(f"--objects: the groups {', '.join(sorted(only - set(PER_OBJECT_GROUPS)))} are not made per "
                     f"object (those that are: {', '.join(PER_OBJECT_GROUPS)})")
        if only != {"worlds"}:  # the worlds rows count no objects together: no other rows are needed
            if not (args.merge and args.table is not None and args.table.with_suffix(".json").is_file()):
                ap.error("--objects: needs --merge into a --table whose results file holds the other objects' rows")
            KEPT = {r["label"]: r for r in json.loads(args.table.with_suffix(".json").read_text())["rows"]}
    n, j, s = args.trials, args.jobs, args.seed
    started = time.perf_counter()
    rows: list[Row] = []

    def show(row: Row) -> None:
        rows.append(row)
        print(row.line(), flush=True)

    def attempt(label: str, make) -> None:
        """show(make()); in Drake, a row whose trials Drake cannot step (a RuntimeError) is left
        out with the error named, and the others run."""
        try:
            show(make())
        except RuntimeError as exc:
            if not drake:
                raise
            print(f"  {label}: left out, Drake could not run it: {str(exc).splitlines()[0]}", file=sys.stderr,
                  flush=True)

    print(HEADER)
    base_paper = "109/120 over the objects, mean < 2.6 mm"

    def per_object(total: str | None, row_of) -> None:
        """A row per object of SELECTED (row_of(name): its label, and what runs it), the others'
        rows as the table has them (--objects), then with a total label the three objects' row."""
        for name in OBJECTS:
            label, make = row_of(name)
            if name in SELECTED:
                show(make())
            elif label not in KEPT:
                raise SystemExit(f"--objects: {args.table} has no row '{label}' to count in '{total}'")
            else:
                rows.append(replace(Row.from_record(KEPT[label]), kept=True))
        if total is not None:
            show(Row(total, sum(r.successes for r in rows[-3:]), sum(r.trials for r in rows[-3:]),
                     sum(r.placed for r in rows[-3:]), "-", "-", "109/120", (109, 120), "secure", "-"))

    def objects(total: str | None, scene_of, paper: str = base_paper) -> None:
        """A row per object (scene_of(name): its label and scene, planned with the seed), then with
        a total label the three objects' row (per_object)."""
        def row_of(name: str):
            label, scene = scene_of(name)
            return label, lambda: run(label, scene, _plan(scene, s), n, j, s, paper)
        per_object(total, row_of)

    if "base" in only:
        def based(name: str):
            scene, start = _started(_scene(name, "rounded"))
            return f"base: {name}, rounded tip{start}", scene
        objects("base: the three objects", based)
    if "worlds" in only:  # worlds the plan and its aim never saw (docs/model.md 11.16)
        tip = "" if WORLD_TIP == "rounded" else f", {WORLD_TIP} tip"
        tip += ("" if START == "scene" else f", {START} start") + ("" if RELEASE == "scene" else RELEASE_WORDS)
        tip += f", target turned {TARGET_TURN_DEG:+g} deg" if TARGET_TURN_DEG else ""
        for name in SELECTED:
            scene, _ = _started(_scene(name, WORLD_TIP, turn_deg=TARGET_TURN_DEG))
            result = _plan(scene, s)
            for label, world in WORLDS:
                if WORLD_LABELS is not None and label not in WORLD_LABELS:
                    continue
                show(run(f"world: {name}, {label}{tip}", scene, result, n, j, s, "-", world=world))
    if "unaimed" in only:  # the hand as planned: no aim fitted in any world
        def unaimed(name: str):
            scene, start = _started(_scene(name, "rounded"))
            return (f"unaimed (landing: planned): {name}, rounded tip{start}",
                    replace(scene, robot=replace(scene.robot, landing=Landing.PLANNED)))
        objects("unaimed: the three objects", unaimed)
    if "edge" in only:
        objects(None, lambda name: (f"edge: {name}, flat tip", _scene(name, "flat")), "better than point contact")
    if "open" in only:  # without the touch-off (docs/model.md 11.14): the arm's calibration alone
        def open_loop(name: str):
            scene = _scene(name, "rounded")
            return f"base, open loop (no touch-off): {name}, rounded tip", replace(
                scene, robot=replace(scene.robot, touch_off=False))
        objects("base, open loop: the three objects", open_loop)
    if "smooth" in only:  # the pairs chosen before the double normals (docs/model.md 11.7)
        objects("previous pairs: the three objects", lambda name: (
            f"previous pair: {name}, {OLD_PAIRS[name][0]}, rounded tip", _scene(name, "rounded", OLD_PAIRS[name][1])))
    if "handed" in only:  # the other start (docs/model.md 11.3): the object set into the gripper on the table
        def handed(name: str):
            return (f"base, handed over at the start: {name}, rounded tip",
                    _scene(name, "rounded").with_sim(handed_over=True))
        objects("base, handed over: the three objects", handed)
    if "subset" in only:
        scene = _scene("guitar_pick")
        thick = Scene.from_file(SCENES / "guitar_pick_1_5mm.yaml").object_thickness
        show(run("subset: 1.5 mm pick, 0.96 mm pick's motion", scene, _plan(scene, s), n, j, s, "placed",
                 variant=Variant(thickness=thick)))
    if "caging" in only:
        for tip, paper, rate in (("rounded", "4/40", (4, 40)), ("flat", "34/40", (34, 40))):
            scene = _scene("guitar_pick", tip)
            result = _plan(scene, s)
            offset, margin = caging_deviation(scene, result)
            print(f"  caging, {tip} tip: start theta +{math.degrees(offset):.0f} deg, friction margin there "
                  f"{math.degrees(margin):.2f} deg (outside force closure)", file=sys.stderr, flush=True)
            show(run(f"caging: pick, start theta +{math.degrees(offset):.0f} deg "
                     f"(margin {math.degrees(margin):.1f} deg), {tip} tip", scene, steeper_start(result, offset),
                     n, j, s, paper, rate))
    if "controls" in only:
        scene, start = _started(_scene("guitar_pick"))
        dg = scene.digits  # equal digits: the thumb as long as the finger, the finger unchanged
        equal = plan(replace(scene, digits=replace(dg, alpha=0.0, thumb_length=dg.thumb_length + dg.alpha)),
                     planner="lattice")
        verdict = f"planned with equal digits: {equal.reason}" if not equal.solved else "equal digits: solved"
        print(f"  control, equal digits planned: {verdict}", file=sys.stderr)
        attempt(f"control: pick, the asymmetric plan run with equal digits{start}", lambda: run(
            f"control: pick, the asymmetric plan run with equal digits{start}", scene, _plan(scene, s), n, j, s,
            "not placeable", variant=Variant(equal_digits=True), model=verdict))
        show(run(f"control: pick, a fifth of the friction{start}", scene, _plan(scene, s), n, j, s, "(must fail)",
                 world=World(friction=0.2)))
    if "tangram" in only:
        # in Drake the lattice's rows alone, unranked: an attempt costs minutes there
        for rank in ("first",) if drake else ("first", "tolerance"):
            for tip in ("rounded", "flat"):
                show(tangram(args.attempts, j, s, tip, rank))
        if not drake:
            show(tangram(args.attempts, j, s, "rounded", planner="RRTstar"))  # the default planner
            show(tangram(args.attempts, j, s, "rounded", simulated_aim=True))  # decision 0102's comparison
    if "designed" in only:
        def designed(name: str):
            scene = _stepped(Scene.from_file(SCENES / f"{name}_designed.yaml"))
            dg = scene.digits
            label = (f"designed: {name} (alpha {dg.alpha:g}, tip radius {dg.finger_tip_radius * scene.object_length * 1000:g} "
                     f"mm; lattice plan), seed {s + 1}")
            # the plan the design judged the digits by
            return label, lambda: run(label, scene, plan(scene, planner="lattice", objective="cost"), n, j, s + 1,
                                      base_paper)
        per_object("designed: the three objects", designed)

        def free_goal(name: str):  # what the goal alone does: the scenes' own digits, the designs' free goal
            scene = _scene(name).with_free_goal()
            label = f"own digits, the designs' free goal: {name} (lattice plan), seed {s + 1}"
            # the designs' objective: the digits compared alike
            return label, lambda: run(label, scene, plan(scene, planner="lattice", objective="cost"), n, j, s + 1,
                                      base_paper)
        per_object("own digits, free goal: the three objects", free_goal)
    if "curved" in only:  # curved solids and the pincer, as shipped (docs/model.md 2.7, 7)
        for name in curved:
            scene = _stepped(Scene.from_file(SCENES / f"{name}.yaml"))
            show(run(f"curved: {name}, plan seed {CURVED_PLAN_SEED}", scene, _plan(scene, CURVED_PLAN_SEED), n, j, s,
                     "-"))
    if "curved_worlds" in only:  # the same plans in worlds they never saw (docs/model.md 11.16)
        for name in (x for x in CURVED_WORLD_SCENES if x in curved):
            scene = _stepped(Scene.from_file(SCENES / f"{name}.yaml"))
            result = _plan(scene, CURVED_PLAN_SEED)
            for label, world in CURVED_WORLDS:
                show(run(f"curved world: {name}, {label}", scene, result, n, j, s, "-", world=world))
    sim = SimOptions()
    step = (f"the scenes' own steps ({sim.timestep * 1000:g} ms; pyramidal cones {sim.pyramidal_timestep * 1000:g} ms)"
            if TIMESTEP is None else f"timestep {TIMESTEP * 1000:g} ms")
    if drake:
        from ungrasp_ompl.sim.drake_trial import DRAKE_TIME_STEP

        step = f"Drake (SAP) at timestep {DRAKE_TIME_STEP * 1000:g} ms"
    rule = ("the previous lost-grip rule (11.4)" if args.previous_grip_rule else
            f"the lost-grip bound (11.4) with a digit within {TOUCH_DISTANCE * 1e6:g} um touching")
    friction = ("a world's friction compounded with the drawn friction error" if COMPOUNDED_FRICTION
                else "a world's friction fixes its pairs (decision 0100)")
    footer = (f"{time.perf_counter() - started:.0f} s in all; {n} trials per row, seed {s}, {j} jobs, {step}, {rule}, "
              f"{friction}")
    print(f"\n{footer}")
    if drake:
        if rows:
            engines_compared(rows, footer, args, only)
        return
    if args.table is not None and args.merge:
        doc = merged_table(args.table, rows, footer, only)
        print(f"wrote {args.table}\nwrote {args.table.with_suffix('.json')}")
        if not args.no_figure:
            draw([Row.from_record(r) for r in doc["rows"]], args.figure)
            print(f"wrote {args.figure}")
        return
    if args.table is not None:
        from ungrasp_ompl.io import write_text_atomic

        write_text_atomic(args.table, "\n".join([HEADER, *(r.line() for r in rows), "", footer, ""]))
        print(f"wrote {args.table}")
        import shlex

        from campaign_results import write_json

        print(f"wrote {write_json(args.table, shlex.join(['python', 'tools/sim_campaigns.py', *sys.argv[1:]]))}")
    if rows:
        if not args.no_figure:
            draw(rows, args.figure)
            print(f"wrote {args.figure}")


# --- the engines side by side (--engine drake) ---------------------------------------------------

def _group(record: dict) -> str:
    return next((g for g in GROUP_ORDER if record["campaign"].startswith(g)), record["campaign"])


#: Each row's --only name by the start of its label, the longer starts first.
ROW_OPTIONS = (("base, open loop", "open"), ("base, handed over", "handed"), ("base", "base"), ("world", "worlds"),
               ("unaimed", "unaimed"), ("edge", "edge"), ("previous pair", "smooth"), ("subset", "subset"),
               ("caging", "caging"), ("control", "controls"), ("tangram", "tangram"), ("designed", "designed"),
               ("own digits", "designed"), ("curved world", "curved_worlds"), ("curved", "curved"))


def _world_place(record: dict) -> tuple[int, int]:
    """A world row's place in its group: its object's in OBJECTS, then its world's in WORLDS (the
    longest label its subject's world starts with; unknown ones last); (0, 0) for other rows."""
    if _group(record) != "world":
        return 0, 0
    name, _, world = record["subject"].partition(", ")
    worlds = [label for label, _ in WORLDS]
    own = max((label for label in worlds if world.startswith(label)), key=len, default=None)
    return (OBJECTS.index(name) if name in OBJECTS else len(OBJECTS),
            worlds.index(own) if own is not None else len(worlds))


def _placed(rows: list[dict], new: list[dict]) -> list[dict]:
    """rows with each of new inserted after the last row of its group whose place (_world_place)
    is not after its own (before the group where none is), or at the end when its group has none:
    a merge moves no row already in the table."""
    rows = list(rows)
    for row in new:
        group = [k for k, r in enumerate(rows) if _group(r) == _group(row)]
        before = [k for k in group if _world_place(rows[k]) <= _world_place(row)]
        rows.insert(before[-1] + 1 if before else group[0] if group else len(rows), row)
    return rows


def _option(record: dict) -> str | None:
    """The --only name of the row group that makes record's row (None: no group's)."""
    return next((o for start, o in ROW_OPTIONS if record["label"].startswith(start)), None)


def merge_rows(table: Path, rows: list[Row], footer: str, only: set[str]) -> tuple[list[dict], dict, str, dict | None]:
    """The records of table's results file (TABLE.json) with this run's rows in place of those of
    the groups it ran (the rows of other groups kept, in GROUP_ORDER), the runs that made them (each: its command,
    seconds and the keys of the rows it still holds; a run none of whose rows is left dropped), the
    merged table's footer (its seconds the runs' sum), and the file as it was (None: no file)."""
    import shlex

    from campaign_results import parse_footer, parse_row, row_line

    path = table.with_suffix(".json")
    new = [parse_row(r.line()) for r in rows if not r.kept]
    first = json.loads(path.read_text()) if path.exists() else None
    old = first if first is not None else {"rows": [], "runs": {}}
    keys = {r["key"] for r in new}  # and the rows of the groups run again, whatever their labels now
    regrouped = only - {"worlds"} if WORLD_LABELS is not None else only  # --worlds: only its worlds' rows
    if CURVED_SCENES is not None:  # --scenes: only its scenes' rows
        regrouped = regrouped - {"curved", "curved_worlds"}
    keys |= {r["key"] for r in old["rows"] if _option(r) in regrouped and _selected(r["label"])}
    fresh = {r["key"]: r for r in new}  # a row run again keeps its place
    merged = _placed([fresh.pop(r["key"]) if r["key"] in fresh else parse_row(row_line(r)) for r in old["rows"]
                      if r["key"] not in keys or r["key"] in fresh], list(fresh.values()))
    merged.sort(key=lambda r: GROUP_ORDER.index(_group(r)) if _group(r) in GROUP_ORDER else len(GROUP_ORDER))
    runs = old.get("runs", {})
    if not runs and old["rows"]:  # a table one run wrote whole: that run, named by its groups
        words = shlex.split(old["command"])
        groups = words[words.index("--only") + 1] if "--only" in words else "default"
        runs = {",".join(sorted(groups.split(","))): {"command": old["command"], "seconds": old["seconds"],
                                                      "rows": [r["key"] for r in old["rows"]]}}
    runs = {name: {**run, "rows": [k for k in run["rows"] if k not in keys]} for name, run in runs.items()}
    runs = {name: run for name, run in runs.items() if run["rows"]}
    runs[_run_name(only)] = {"command": shlex.join(["python", "tools/sim_campaigns.py", *sys.argv[1:]]),
                             "seconds": parse_footer(footer)["seconds"], "rows": [r["key"] for r in new],
                             "environment": environment()}
    _, tail = footer.split(" s in all; ", 1)
    footer = f"{sum(r['seconds'] for r in runs.values())} s in all; {tail}"
    return merged, runs, footer, first


def _selected(label: str) -> bool:
    """Whether a row of that label is run again under --objects: a row of one of SELECTED, or a
    row of the three objects; every row when all are selected."""
    return SELECTED == OBJECTS or "the three objects" in label or any(name in label for name in SELECTED)


def _run_name(only: set[str]) -> str:
    """A run's name in a merged file's `runs`: its groups, and the worlds, scenes and objects it ran
    where --worlds, --scenes and --objects chose them, the `worlds` rows' tip where --tip chose the
    flat one and their targets' turn where --turn-target gave one (runs that differ in either make
    rows of their own, so each keeps its own entry)."""
    name = ",".join(sorted(only))
    chosen = [*(WORLD_LABELS or ()), *(CURVED_SCENES or ()), *(SELECTED if SELECTED != OBJECTS else ())]
    if "worlds" in only and WORLD_TIP != "rounded":
        chosen.append(f"{WORLD_TIP} tip")
    if "worlds" in only and TARGET_TURN_DEG:
        chosen.append(f"target turned {TARGET_TURN_DEG:+g} deg")
    return f"{name}: {', '.join(chosen)}" if chosen else name


def _write_merged(table: Path, merged: list[dict], footer: str) -> None:
    """The merged table's markdown."""
    from campaign_results import row_line

    from ungrasp_ompl.io import write_text_atomic

    write_text_atomic(table, "\n".join([HEADER, *(row_line(r) for r in merged), "", footer, ""]))


def merged_table(table: Path, rows: list[Row], footer: str, only: set[str]) -> dict:
    """Merge this run's rows into table (.md and .json, merge_rows): the file keeps the command and
    day of its first run, its seconds the runs' sum, and lists every run under `runs`. Returns the
    file's content."""
    from datetime import date

    from campaign_results import table_json

    from ungrasp_ompl.io import write_text_atomic

    path = table.with_suffix(".json")
    merged, runs, footer, first = merge_rows(table, rows, footer, only)
    _write_merged(table, merged, footer)
    latest = runs[_run_name(only)]
    doc = table_json(table, latest["command"] if first is None else first["command"], date.today().isoformat())
    if first is not None:
        doc.update(produced=first["produced"])
    doc["runs"] = runs
    write_text_atomic(path, json.dumps(doc, indent=1, ensure_ascii=False) + "\n")
    return doc


def paired_with_mujoco(doc: dict, source: Path | None = None) -> dict:
    """A Drake results file's rows, each with MuJoCo's row of the same key and the two-sided Fisher
    test's p of the two counts, from source when given, else from MUJOCO_SOURCE when --mujoco names
    it, else from MUJOCO_TANGRAM when every row is the tangram's, from MUJOCO_LEAST_SLIDE with
    --start least-slide, else from MUJOCO_RESULTS (a row MuJoCo's file lacks gets None for both);
    the file names its MuJoCo file."""
    from campaign_results import fisher_p

    source = source or MUJOCO_SOURCE or (MUJOCO_TANGRAM if all(_group(r) == "tangram" for r in doc["rows"]) else (
        MUJOCO_LEAST_SLIDE if START == "least-slide" else MUJOCO_RESULTS))
    mujoco = json.loads(source.read_text())
    theirs = {r["key"]: r for r in mujoco["rows"]}
    for r in doc["rows"]:
        m = theirs.get(r["key"])
        r["mujoco"] = None if m is None else {k: m[k] for k in (
            "successes", "trials", "interval_percent", "placed", "error_mean_mm", "error_max_mm", "sinking_max_mm",
            "failures")}
        r["fisher_p"] = None if m is None else fisher_p(r, m)
    return {**doc, "mujoco_source": str(source.relative_to(ROOT)), "mujoco_command": mujoco["command"],
            "mujoco_produced": mujoco["produced"]}


def pair_again(path: Path) -> None:
    """Set the Drake rows of the results file at path beside MuJoCo's rows of the same keys as
    MuJoCo's file has them now, with the Fisher test again (paired_with_mujoco, from the MuJoCo file
    --mujoco names, else the one the file was set beside, else the one the rows' start and group
    choose), the file's other fields kept; no trial runs. The command is recorded in the file
    (`paired`)."""
    import shlex
    from datetime import date

    from ungrasp_ompl.io import write_text_atomic

    global START
    doc = json.loads(path.read_text())
    START = "least-slide" if "--start least-slide" in doc["command"] else "scene"
    beside = ROOT / doc["mujoco_source"] if "mujoco_source" in doc else None
    fresh = paired_with_mujoco({k: v for k, v in doc.items() if not k.startswith("mujoco_")}, MUJOCO_SOURCE or beside)
    fresh["paired"] = {"command": shlex.join(["python", "tools/sim_campaigns.py", *sys.argv[1:]]),
                       "produced": date.today().isoformat()}
    write_text_atomic(path, json.dumps(fresh, indent=1, ensure_ascii=False) + "\n")
    print(f"wrote {path}")


def engines_compared(rows: list[Row], footer: str, args, only: set[str]) -> None:
    """Merge the Drake rows into args.table (.md and .json, the rows of other groups kept), each
    with MuJoCo's row of the same key and the Fisher test's p, and draw both engines."""
    from datetime import date

    from campaign_results import table_json

    from ungrasp_ompl.io import write_text_atomic

    table: Path = args.table
    path = table.with_suffix(".json")
    merged, runs, footer, _ = merge_rows(table, rows, footer, only)
    _write_merged(table, merged, footer)
    groups = ",".join(GROUP_OPTION[g] for g in GROUP_ORDER if any(_group(r) == g for r in merged))
    rel = table.resolve().relative_to(ROOT) if table.resolve().is_relative_to(ROOT) else table
    command = (f"python tools/sim_campaigns.py --engine drake --drake-hull {args.drake_hull} --trials {args.trials} "
               f"--jobs {args.jobs} --seed {args.seed} --table {rel} --only {groups}"
               + ("" if START == "scene" else f" --start {START}")
               + ("" if MUJOCO_SOURCE is None else f" --mujoco {MUJOCO_SOURCE.relative_to(ROOT)}"))
    doc = paired_with_mujoco({**table_json(table, command, date.today().isoformat()), "runs": runs})
    write_text_atomic(path, json.dumps(doc, indent=1, ensure_ascii=False) + "\n")
    print(f"wrote {table}\nwrote {path}")
    if not args.no_figure:
        draw_engines(doc["rows"], args.figure)
        print(f"wrote {args.figure}")


#: The ticks (2 ms each) over which the table's friction use sums its forces: SAP's force on a
#: face varies from step to step (docs/model.md 11.19).
WINDOW = 5


def _summary(log: list, mu_g: float, result, poses: list, drive, gb: NDArray) -> dict:
    """What a trial's log of contact forces shows: while both digits press the object and the table
    holds it up, the table's friction use (its tangential over its normal force, each summed over
    WINDOW ticks) against mu_G, the mean size of the force each digit exerts and the table's mean
    normal force; and from its poses ((time s, the object's pose 4x4) per tick, G at the body's
    origin), how far G moves along the table before the termination and in which phase of the
    drive (sim.drive.GripperDrive) it moves furthest, and what the termination does (_release; gb:
    the plane's GB in the world (2,), a unit vector toward B)."""
    log = [(t, {**f, "finger": f.get("finger", 0) + f.get("finger_tip", 0)} if "finger_tip" in f else f)
           for t, f in log]  # each engine names the finger's dome apart
    held = [(t, f) for t, f in log if "finger" in f and "thumb" in f and "table" in f and f["table"][2] > 0.01]
    times, g_track = _g_track(poses)
    g = np.array([f["table"] for _, f in held]) if held else np.zeros((1, 3))
    kernel = np.ones(min(WINDOW, len(g)))
    use = (np.convolve(np.hypot(g[:, 0], g[:, 1]), kernel, "valid")
           / np.maximum(np.convolve(g[:, 2], kernel, "valid"), 1e-12))
    return {"outcome": result.outcome.value.replace("_", " "), "error_mm": result.position_error_mm,
            "mu_g": mu_g, "g_use_max": float(use.max()), "g_use_p95": float(np.percentile(use, 95)),
            "g_use_over_mu": float(use.max() / mu_g), "ticks_at_mu": int(np.sum(use >= 0.98 * mu_g)),
            "ticks_above_mu": int(np.sum(use > 1.02 * mu_g)), "held_ticks": len(held),
            "held_until_s": float(held[-1][0]) if held else None,
            "a_force_mean_n": float(np.mean([np.linalg.norm(f["finger"]) for _, f in held])) if held else None,
            "b_force_mean_n": float(np.mean([np.linalg.norm(f["thumb"]) for _, f in held])) if held else None,
            "g_normal_mean_n": float(np.mean(g[:, 2])) if held else None, "roll_max_deg": result.roll_deg,
            **_g_travel(times, g_track, drive, gb), **_release(log, times, g_track, drive, gb)}


def _g_track(poses: list) -> tuple[NDArray, NDArray]:
    """From a trial's poses ((time s, the object's pose 4x4) per tick): their times (K,) and G's
    place on the table (K, 2, m), G the object's body origin."""
    return np.array([t for t, _ in poses]), np.array([np.asarray(pose)[:2, 3] for _, pose in poses])


def _release(log: list, times: NDArray, g: NDArray, drive, gb: NDArray) -> dict:
    """What the termination does to the object: how far (mm) G (at times, _g_track) moves along the
    table from the termination's start to the trial's end, and how far of it along GB (gb, a unit
    vector toward B; + toward B), the finger's mean force (N) on the object over the termination's
    ticks (log: _summary's, the finger's dome counted with it), and the impulse (mN s) of the
    thumb's, the finger's and the table's forces over the logged ticks from the termination on,
    along G's travel and along GB (+ toward B: the same way in either engine)."""
    start = drive.phase_start("termination")
    end = next((b for name, _, b in drive.phases if name == "termination"), start)
    g = g[times >= start]
    finger = [np.linalg.norm(f.get("finger", np.zeros(3))) for t, f in log if start <= t <= end]
    out = {"g_moved_release_mm": float(np.linalg.norm(g[-1] - g[0]) * 1000) if len(g) else None,
           "g_release_along_mm": float((g[-1] - g[0]) @ gb * 1000) if len(g) else None,
           "finger_release_n": float(np.mean(finger)) if finger else None}
    ticks = [(t, f) for t, f in log if t >= start]
    dt = float(drive.times[1] - drive.times[0])

    def impulses(direction: NDArray, field: str) -> dict:  # each kind's impulse along direction, mN s
        return {f"{kind}_{field}_release_mns": 1000 * dt * sum(float(f.get(kind, np.zeros(3))[:2] @ direction)
                                                               for _, f in ticks)
                for kind in ("thumb", "finger", "table")}

    out.update(impulses(gb, "gb"))
    if len(g) > 1 and np.linalg.norm(g[-1] - g[0]) > 0:  # along G's travel, from the termination on
        out.update(impulses((g[-1] - g[0]) / np.linalg.norm(g[-1] - g[0]), "push"))
    return out


def _g_travel(times: NDArray, g: NDArray, drive, gb: NDArray) -> dict:
    """How far (mm) G (at times, _g_track) moves along the table from the drive's start to its
    termination's, and how far of it along GB (gb, a unit vector toward B; + toward B), and the
    phase of the drive in which it moves furthest (its name and mm)."""
    end = drive.phase_start("termination")
    held = times <= end
    steps = np.linalg.norm(np.diff(g, axis=0), axis=1) * 1000
    per_phase: dict[str, float] = {}
    for t, step in zip(times[1:], steps):
        if t <= end:
            name = drive.phase_at(float(t))[1]
            per_phase[name] = per_phase.get(name, 0.0) + float(step)
    phase = max(per_phase, key=per_phase.get) if per_phase else None
    last = int(np.flatnonzero(held)[-1]) if held.any() else 0
    return {"g_moved_mm": float(np.linalg.norm(g[last] - g[0]) * 1000),
            "g_held_along_mm": float((g[last] - g[0]) @ gb * 1000), "g_moved_most_in": phase,
            "g_moved_most_mm": per_phase.get(phase) if phase else None}


#: How the contacts study's fields are shown (docs/results/campaigns_drake_contacts.md).
CONTACT_FORMATS = {"error_mm": "{:.2f}", "mu_g": "{:.3f}", "g_use_max": "{:.3f}", "g_use_p95": "{:.3f}",
                   "g_use_over_mu": "{:.2f}", "held_until_s": "{:.3f}", "a_force_mean_n": "{:.2f}",
                   "b_force_mean_n": "{:.2f}", "g_normal_mean_n": "{:.2f}", "roll_max_deg": "{:.2f}",
                   "roll_start_deg": "{:.2f}", "g_moved_mm": "{:.2f}", "g_moved_most_mm": "{:.2f}",
                   "g_moved_release_mm": "{:.2f}", "finger_release_n": "{:.2f}", "thumb_push_release_mns": "{:.2f}",
                   "finger_push_release_mns": "{:.2f}", "table_push_release_mns": "{:.2f}",
                   "rho_error_g_release": "{:.2f}", "rho_error_grip": "{:.2f}", "g_release_failed_mm": "{:.2f}",
                   "g_release_success_mm": "{:.2f}", "grip_failed": "{:.2f}", "grip_success": "{:.2f}",
                   "landing_along_mm": "{:+.2f}", "landing_across_mm": "{:+.2f}", "landing_along_mean_mm": "{:+.2f}",
                   "landing_along_sd_mm": "{:.2f}", "landing_across_mean_mm": "{:+.2f}",
                   "landing_across_sd_mm": "{:.2f}",
                   "g_release_mean_mm": "{:.2f}", "thumb_push_mean_mns": "{:+.1f}", "table_push_mean_mns": "{:+.1f}",
                   "rho_along_thumb_push": "{:.2f}", "rho_along_table_push": "{:.2f}", "grip_mean": "{:.2f}",
                   "landing_along_se_mm": "{:.2f}", "g_release_along_mm": "{:+.2f}", "g_held_along_mm": "{:+.2f}",
                   "g_held_along_mean_mm": "{:+.2f}", "g_release_along_mean_mm": "{:+.2f}", "thumb_gb_release_mns": "{:+.1f}",
                   "finger_gb_release_mns": "{:+.1f}", "table_gb_release_mns": "{:+.1f}",
                   "thumb_gb_mean_mns": "{:+.1f}", "finger_gb_mean_mns": "{:+.1f}", "table_gb_mean_mns": "{:+.1f}",
                   "out_at_start": "{}"}


def contact_forces(which: str, seed: int, thumb: str = "pad", tip: str = "rounded", study: str | None = None,
                   world: World = World(), drake_step: float | None = None, table_gradient: float | None = None,
                   pad_gradient: float | None = None) -> None:
    """Trials of the base rows (OBJECT:TRIAL,...; with tip "flat" the edge rows') in both engines
    with their contact forces logged; their summaries into
    docs/results/campaigns_drake_contacts.json. thumb: how the thumb touches the object in Drake
    (sim.drake_world.THUMB_PAD); with "point" only Drake's rows are made. study: the study's name
    in the file, its rows' labels then starting with it (None: named by thumb and tip); world: the
    world the trials run in (the nominal one: the base rows' own); drake_step (s), table_gradient and
    pad_gradient (Pa/m): Drake's time step and its table's and pads' stiffness instead of the
    builder's, only Drake's rows then made (record 0125)."""
    import shlex

    from campaign_results import merge_study

    from ungrasp_ompl.scene.perturbation import trial_params
    from ungrasp_ompl.sim import trial as mj_trial
    from ungrasp_ompl.sim import drake_trial, drake_world
    from ungrasp_ompl.sim.drake_trial import run_drake_trial

    drake_world.THUMB_PAD = thumb == "pad"
    changed = []  # what differs from the builder's Drake, in the rows' labels
    if drake_step is not None:
        drake_trial.DRAKE_TIME_STEP = drake_step
        changed.append(f"step {drake_step * 1000:g} ms")
    if table_gradient is not None:
        drake_world.TABLE_MODULUS = table_gradient * drake_world.TABLE_SLAB
        changed.append(f"table {table_gradient:g} Pa/m")
    if pad_gradient is not None:
        drake_world.PAD_GRADIENT = pad_gradient
        changed.append(f"pads {pad_gradient:g} Pa/m")
    variant = ", ".join(([] if thumb == "pad" else ["thumb point"]) + changed)
    engines = ("drake",) if variant else ("mujoco", "drake")
    started = time.perf_counter()
    rows = []
    for item in which.split(","):
        name, k = item.split(":")
        scene, _ = _started(_scene(name, tip))
        setup = replace(placement(scene, _plan(scene, seed))[1], max_contact_gap=MAX_GAP, world=world)
        params = trial_params(PRESETS["paper"], seed, int(k) + 1)[int(k)]
        mu_g = mj_trial.trial_spec(setup, params).friction.table
        logs: dict[str, list] = {"mujoco": [], "drake": []}
        poses: dict[str, list] = {"mujoco": [], "drake": []}
        results = {}
        if "mujoco" in engines:
            results["mujoco"] = mj_trial.run_trial(setup, params, int(k), seed, record=poses["mujoco"],
                                                   contact_log=logs["mujoco"])
        results["drake"] = run_drake_trial(setup, params, int(k), seed, record=poses["drake"],
                                           contact_log=logs["drake"])
        for engine in engines:
            row = _summary(logs[engine], mu_g, results[engine], poses[engine], setup.drive, setup.target_pose[:2, 0])
            # where it landed, in the plane's frame: along GB (+ toward B) and across it (mm)
            row.update(landing_along_mm=results[engine].offset_along_mm, landing_across_mm=results[engine].offset_across_mm)
            # how far the object lies out of the manipulation plane when the drive starts, the settling done
            row["roll_start_deg"] = mj_trial._roll(poses[engine][0][1], setup.target_pose[:3, 1])
            label = (f"{name} trial {k}, {engine}" + (", thumb in point contact" if thumb == "point" else "")
                     + "".join(f", {c}" for c in changed)
                     + (", flat tip" if tip == "flat" else "") + ("" if world.nominal else f", {world.describe()}"))
            rows.append({"label": label, "object": name, "trial": int(k),
                         "engine": f"{engine} ({variant})" if variant else engine, **row})
            print(f"  {name} trial {k} in {engine}: {row}", file=sys.stderr, flush=True)
    rows += _over_trials(rows)
    name = study or (("contacts" if thumb == "pad" else "contacts_thumb_point") + ("_flat_tip" if tip == "flat" else ""))
    path = merge_study(ROOT / "docs" / "results" / "campaigns_drake_contacts.json", name,
                       shlex.join(["python", "tools/sim_campaigns.py", *sys.argv[1:]]), time.perf_counter() - started,
                       rows, CONTACT_FORMATS, "The object's contact forces in MuJoCo and in Drake, the same trials",
                       prefixed=study is not None)
    print(f"wrote {path}")


def contact_summaries() -> None:
    """The summaries per object and engine in docs/results/campaigns_drake_contacts.json made again
    from their studies' trial rows by _over_trials as it is now, nothing else changed and no trial
    run: after _over_trials learns a field, the studies already run show it too. A study written
    before the summaries were is left as it is."""
    from campaign_results import study_row, write_study_file

    path = ROOT / "docs" / "results" / "campaigns_drake_contacts.json"
    doc = json.loads(path.read_text())
    rows = []
    for study in dict.fromkeys(r["study"] for r in doc["rows"]):
        if not any("trials" in r for r in doc["rows"] if r["study"] == study):
            rows += [r for r in doc["rows"] if r["study"] == study]
            continue
        kept = [r for r in doc["rows"] if r["study"] == study and "trials" not in r]  # its own row, its trials
        prefix = f"{study}: " if any(r["label"].startswith(f"{study}: ") for r in kept if "trial" in r) else ""
        summaries = [{**r, "label": prefix + r["label"]} for r in _over_trials([r for r in kept if "trial" in r])]
        rows += kept + [study_row(study, r) for r in summaries]
    write_study_file(path, {**doc, "formats": {**doc["formats"], **CONTACT_FORMATS}, "rows": rows})
    print(f"wrote {path}")


def _over_trials(rows: list[dict]) -> list[dict]:
    """Per object and engine run on more than two trials (contact_forces' rows): how many trials
    fail, and whether the table's part tells which: the rank correlation (Spearman) of the
    placement error with G's slide along the table from the termination on (rho_error_g_release)
    and with the table's grip as a multiple of mu_G (rho_error_grip), and each one's mean over the
    trials that fail and over those that succeed (None where there are none); and where the object
    lands in the plane's frame, along GB and across it, its mean and standard deviation, and the
    standard error of the mean along GB; the mean grip over mu of every trial; the mean slide of G
    and the thumb's and the table's mean impulses along it from the termination on, and how each
    impulse ranks with the landing along GB; and G's mean slide along GB while held and from the
    termination on, and each contact's mean impulse along GB from the termination on (+ toward B);
    and how many trials already lay out of the plane (beyond the verdict's sim.trial.LEFT_PLANE_DEG)
    when the drive began, the settling done (None where no row logs it). These take the trials that
    end with the object down (an error to rank, a landing), but for the grip and the start."""
    from scipy.stats import spearmanr

    from ungrasp_ompl.sim.trial import LEFT_PLANE_DEG

    out = []
    for name in dict.fromkeys(r["object"] for r in rows):
        for engine in dict.fromkeys(r["engine"] for r in rows if r["object"] == name):
            trials = [r for r in rows if r["object"] == name and r["engine"] == engine]
            if len(trials) < 3:
                continue
            landed = [r for r in trials if r["error_mm"] is not None]  # a trial that ends held has no error
            failed = [r for r in trials if r["outcome"] != "success"]
            success = [r for r in trials if r["outcome"] == "success"]
            started = [r for r in trials if r.get("roll_start_deg") is not None]

            def mean(group: list[dict], field: str) -> float | None:  # over the rows that have the field
                values = [r[field] for r in group if r.get(field) is not None]
                return float(np.mean(values)) if values else None

            def rho(field: str, against: str = "error_mm") -> float | None:  # None where either side does not vary
                both = [r for r in landed if r.get(field) is not None]
                x, y = [r[against] for r in both], [r[field] for r in both]
                if len(both) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
                    return None
                return float(spearmanr(x, y)[0])

            out.append({"label": f"{name}, {engine}: the trials", "object": name, "engine": engine,
                        "trials": len(trials), "failed": len(failed),
                        "rho_error_g_release": rho("g_moved_release_mm"), "rho_error_grip": rho("g_use_over_mu"),
                        "g_release_failed_mm": mean(failed, "g_moved_release_mm"),
                        "g_release_success_mm": mean(success, "g_moved_release_mm"),
                        "grip_failed": mean(failed, "g_use_over_mu"), "grip_success": mean(success, "g_use_over_mu"),
                        "grip_mean": mean(trials, "g_use_over_mu"),
                        "landing_along_mean_mm": mean(landed, "landing_along_mm"),
                        "landing_along_sd_mm": float(np.std([r["landing_along_mm"] for r in landed])),
                        "landing_along_se_mm": float(np.std([r["landing_along_mm"] for r in landed])
                                                     / math.sqrt(len(landed))) if landed else None,
                        "landing_across_mean_mm": mean(landed, "landing_across_mm"),
                        "landing_across_sd_mm": float(np.std([r["landing_across_mm"] for r in landed])),
                        "g_release_mean_mm": mean(landed, "g_moved_release_mm"),
                        "thumb_push_mean_mns": mean(landed, "thumb_push_release_mns"),
                        "table_push_mean_mns": mean(landed, "table_push_release_mns"),
                        "rho_along_thumb_push": rho("thumb_push_release_mns", "landing_along_mm"),
                        "rho_along_table_push": rho("table_push_release_mns", "landing_along_mm"),
                        "g_held_along_mean_mm": mean(landed, "g_held_along_mm"),
                        "g_release_along_mean_mm": mean(landed, "g_release_along_mm"),
                        **{f"{kind}_gb_mean_mns": mean(landed, f"{kind}_gb_release_mns")
                           for kind in ("thumb", "finger", "table")},
                        "out_at_start": sum(r["roll_start_deg"] > LEFT_PLANE_DEG for r in started) if started else None})
    return out


def draw_engines(records: list[dict], path: Path) -> None:
    """Each row's strict success rate in MuJoCo and in Drake, with their Wilson 95 % intervals and
    the Fisher test's p."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(11, 0.5 * len(records) + 1.6))
    y = np.arange(len(records))[::-1].astype(float)
    for shift, name, colour, get in ((0.18, "MuJoCo", "#4c72b0", lambda r: r["mujoco"]),
                                     (-0.18, "Drake", "#dd8452", lambda r: r)):
        counts = [(get(r)["successes"], get(r)["trials"]) if get(r) else (0, 0) for r in records]
        rate = np.array([k / n if n else np.nan for k, n in counts])
        ci = np.array([wilson_interval(k, n) if n else (np.nan, np.nan) for k, n in counts])
        ax.barh(y + shift, rate * 100, height=0.34, color=colour, label=f"{name} (strict: placed within max_error)")
        ax.errorbar(rate * 100, y + shift, xerr=[(rate - ci[:, 0]) * 100, (ci[:, 1] - rate) * 100], fmt="none",
                    ecolor="black", capsize=2)
    for yy, r in zip(y, records):
        if r["fisher_p"] is not None:
            ax.text(101, yy, f"p = {r['fisher_p']:.2g}", va="center", fontsize=7,
                    color="#c44e52" if r["fisher_p"] < 0.05 else "black")
    ax.set_yticks(y, [r["label"] for r in records], fontsize=7)
    ax.set_xlim(0, 112)
    ax.set_xlabel("success rate (%), with Wilson 95 % intervals; p: two-sided Fisher exact test")
    fig.suptitle("The same trials in MuJoCo and in Drake", fontsize=10)
    fig.legend(*ax.get_legend_handles_labels(), loc="lower center", ncol=2, fontsize=7, frameon=False)
    fig.tight_layout(rect=(0, 0.5 / fig.get_figheight(), 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
