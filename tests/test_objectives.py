"""The robust objectives (docs/model.md, section 6.1): the lattice's margin search against brute
force over every path of a small lattice, the margin plan against the cost plan, reproducibility."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from conftest import SCENES
from ungrasp_ompl import Scene
from ungrasp_ompl.mechanics import primitive_sliding_signs
from ungrasp_ompl.mechanics.margin import friction_margin
from ungrasp_ompl.planning.atlas import FORWARD, LEG_PRIMITIVE, SecurityAtlas, reference_cost
from ungrasp_ompl.planning.lattice import lattice_search
from ungrasp_ompl.errors import InputError
from ungrasp_ompl.planning.margins import TIE_SCALE_DEG, LatticeMargins, Objective
from ungrasp_ompl.planning.result import Plan
from ungrasp_ompl.planning.setup import lattice_plan, plan

RES = np.array([math.radians(2), 0.02, math.radians(2)])
#: Forward lattice steps by leg kind (theta down, d down, psi up; X: d down and psi up).
STEPS = {"T": (-1, 0, 0), "P": (0, 0, 1), "D": (0, -1, 0), "X": (0, -1, 1)}


def small_problem(scene: Scene) -> tuple[SecurityAtlas, np.ndarray]:
    """A lattice of 7 x 4 x 7 states from the start (theta down 12 deg, d down 0.06, psi up 12
    deg) and a goal box in its far part."""
    s = scene.start
    box = np.array([s - [6 * RES[0], 3 * RES[1], 0], s + [0, 0, 6 * RES[2]]])
    goal = np.array([s - [6 * RES[0], 3 * RES[1], -3 * RES[2]], s + [-3 * RES[0], 0, 6 * RES[2]]])
    return SecurityAtlas(scene, box, RES), goal


def all_paths(atlas: SecurityAtlas, goal_box: np.ndarray) -> list[list[tuple[str, tuple, tuple]]]:
    """Every path of single forward lattice steps, each secure by the atlas (leg_secure), from the
    start to a releasable state in goal_box: lists of (leg kind, from, to)."""
    goal = atlas.releasable_in(goal_box)
    out = []

    def walk(idx, path):
        if goal[idx]:
            out.append(list(path))
        for kind, step in STEPS.items():
            nxt = tuple(int(i + s) for i, s in zip(idx, step))
            if all(0 <= nxt[a] < atlas.shape[a] for a in range(3)) and atlas.leg_secure(kind, idx, nxt):
                path.append((kind, idx, nxt))
                walk(nxt, path)
                path.pop()

    walk(atlas.index(atlas.scene.start), [])
    return out


def step_margin(atlas: SecurityAtlas, kind: str, a: tuple, b: tuple) -> float:
    """A lattice step's friction margin (rad), straight from the mechanics: the smaller of its
    ends' in the step's contact mode, the start included."""
    scene = atlas.scene
    qa, qb = atlas.state(a), atlas.state(b)
    dq = qb - qa
    out = math.inf
    for q in (qa, qb):
        sa, sb = primitive_sliding_signs(LEG_PRIMITIVE[kind], q[1], q[2], dq[1], dq[2])
        out = min(out, float(friction_margin(*q, sa, sb, scene.friction)[0]))
    return out


def slots(legs) -> list[tuple[str, bool]]:
    """The primitive and direction of each step (what a primitive change changes)."""
    return [(LEG_PRIMITIVE[kind], bool(np.any(np.subtract(b, a) * FORWARD > 0))) for kind, a, b in legs]


def path_figures(atlas: SecurityAtlas, legs, reference: float, known: dict) -> tuple[float, int, float, float]:
    """(smallest margin rad, primitive changes, tie-break, cost) of a path of lattice steps; the
    tie-break with the bottleneck reference (rad); known: the margin of every step (step_margin)."""
    opts = atlas.scene.options
    margins = [known[leg] for leg in legs]
    lengths = [reference_cost(np.subtract(b, a) * atlas.res, opts.d_weight) for _, a, b in legs]
    s = slots(legs)
    changes = sum(x != y for x, y in zip(s[:-1], s[1:]))
    tie = sum(length * math.exp(-(math.degrees(m) - math.degrees(reference)) / TIE_SCALE_DEG)
              for length, m in zip(lengths, margins))
    return min(margins), changes, tie, sum(lengths) + opts.mode_change_penalty * changes


@pytest.mark.parametrize("name", ["reference_asymmetric", "guitar_pick", "fabric_chalk"])
def test_margin_search_against_brute_force(name):
    """On a small lattice, every secure path enumerated: the search's path keeps the largest
    smallest margin (its bottleneck), has the fewest primitive changes among those, the least
    tie-break among those, and then the least cost. The pick's friction is taken as known exactly:
    at its +-30 % only theta 27.25-27.5 deg lets psi open from 0 at the start's d (docs/model.md 4.7),
    which the small lattice's 2 deg steps pass over (the chalk keeps its range)."""
    scene = Scene.from_file(SCENES / f"{name}.yaml")
    if name == "guitar_pick":
        scene = replace(scene, friction_uncertainty=0.0)
    atlas, goal_box = small_problem(scene)
    margins = LatticeMargins(atlas, "margin", goal_box)
    result = lattice_search(atlas, goal_box, "margin", margins)
    paths = all_paths(atlas, goal_box)
    assert len(paths) > 100 and result.reachable
    known = {leg: step_margin(atlas, *leg) for leg in {leg for p in paths for leg in p}}
    widest = max(min(known[leg] for leg in p) for p in paths)
    assert margins.bottleneck == pytest.approx(widest, abs=1e-12)
    figures = [path_figures(atlas, p, widest, known) for p in paths]
    kept = [f for f in figures if f[0] >= widest - 1e-12]
    assert len(kept) < len(figures)  # the bottleneck rules paths out
    fewest = min(f[1] for f in kept)
    tie = min(f[2] for f in kept if f[1] == fewest)
    cheapest = min(f[3] for f in kept if f[1] == fewest and f[2] <= tie * (1 + 1e-9))
    legs = [(leg.kind, leg.start, leg.end) for leg in result.legs]
    got = path_figures(atlas, legs, widest, known)
    assert got[0] == pytest.approx(widest, abs=1e-12) and result.min_margin == pytest.approx(widest, abs=1e-12)
    assert got[1] == fewest
    assert got[2] == pytest.approx(tie, rel=1e-9) and result.penalty == pytest.approx(tie, rel=1e-9)
    assert got[3] == pytest.approx(cheapest, abs=1e-9) and result.cost == pytest.approx(cheapest, abs=1e-9)
    assert len({f[1:3] for f in kept}) > 1  # the tie-breaks have something to decide


@pytest.mark.slow
@pytest.mark.parametrize("name", ["reference_asymmetric", "guitar_pick", "puzzle_piece", "fabric_chalk"])
def test_lattice_margin_plan_never_narrower_than_the_cost_plan(name):
    """The exact margin plan keeps the lattice's bottleneck (forced), which no secure lattice path,
    the cheapest included, can beat."""
    scene = Scene.from_file(SCENES / f"{name}.yaml")
    cost_plan = lattice_plan(scene)
    margin_plan = lattice_plan(scene, objective="margin")
    assert cost_plan.solved and margin_plan.solved
    assert margin_plan.margin_forced is True and cost_plan.margin_forced is None
    assert margin_plan.min_margin_deg == pytest.approx(margin_plan.margin_bottleneck_deg, abs=1e-9)
    assert margin_plan.min_margin_deg >= cost_plan.min_margin_deg - 1e-9
    assert margin_plan.cost >= cost_plan.cost - 1e-9  # the cost plan is the cheapest
    # the profile: the smallest margin of each primitive, whose least is the path's
    assert len(margin_plan.margin_profile_deg) == len(margin_plan.primitives)
    assert min(margin_plan.margin_profile_deg) == margin_plan.min_margin_deg
    # the objective is a value, in the plan and back from its plan.json; a name it does not know is refused
    assert margin_plan.objective is Objective.MARGIN and cost_plan.objective is Objective.COST
    doc = margin_plan.to_dict()
    assert Plan.from_dict(doc).objective is Objective.MARGIN
    with pytest.raises(InputError, match="objective") as err:
        Plan.from_dict({**doc, "objective": "steepest"})
    assert err.value.field == "objective"


@pytest.mark.slow
@pytest.mark.parametrize("name,seed", [("reference_asymmetric", 2), ("guitar_pick", 2), ("fabric_chalk", 3)])
def test_rrtstar_margin_plan_not_narrower_than_its_cost_plan(name, seed):
    """Seeded RRT*: the margin objective's plan keeps at least the cost objective's smallest margin,
    and never more than the lattice's bottleneck."""
    scene = Scene.from_file(SCENES / f"{name}.yaml")
    cost_plan = plan(scene, seed=seed)
    margin_plan = plan(scene, seed=seed, objective="margin")
    assert margin_plan.min_margin_deg >= cost_plan.min_margin_deg - 1e-9
    assert margin_plan.min_margin_deg <= margin_plan.margin_bottleneck_deg + 1e-9


@pytest.mark.slow
def test_margin_plans_reproduce_with_a_seed():
    """The same seed gives the same margin plan (RRT*), in the same process."""
    scene = Scene.from_file(SCENES / "reference_asymmetric.yaml")
    a = plan(scene, seed=3, objective="margin")
    b = plan(scene, seed=3, objective="margin")
    assert a.solved and a.states == b.states and a.margin_profile_deg == b.margin_profile_deg


def test_a_scene_names_the_objective_its_plans_optimise_where_the_caller_names_none():
    """planning.objective: a plan with no objective named optimises the scene's (the same plan as
    naming it), one named overrides it, the roadmap planners (which optimise the cost only) take
    the cost, and a name that is no objective is refused naming the field."""
    import yaml

    from ungrasp_ompl.planning.setup import PlannerOptions, scene_objective

    doc = yaml.safe_load((SCENES / "reference_asymmetric.yaml").read_text())
    doc["planning"] = {**doc.get("planning", {}), "objective": "margin"}
    scene = Scene.from_dict(doc)
    assert scene.options.objective is Objective.MARGIN
    own = plan(scene, planner="lattice")
    named = plan(scene, planner="lattice", objective="margin")
    assert own.objective == Objective.MARGIN and own.states == named.states
    cost = plan(scene, planner="lattice", objective="cost")
    assert cost.objective == Objective.COST and cost.states != own.states
    assert scene_objective(None, scene, "PRM") is Objective.COST
    assert PlannerOptions().for_scene(scene).objective is Objective.MARGIN
    assert PlannerOptions().for_scene(Scene.from_file(SCENES / "reference_asymmetric.yaml")).objective is Objective.COST
    with pytest.raises(InputError) as err:
        Scene.from_dict({**doc, "planning": {"objective": "widest"}})
    assert err.value.field == "planning.objective"
