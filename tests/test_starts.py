"""``starts``: the start's d planned exactly from each candidate, the one from which B slides least
chosen, its scene file written."""

from __future__ import annotations

import csv
from dataclasses import replace

import numpy as np
import pytest

from conftest import run_cli
from ungrasp_ompl.benchmark.starts import StartOptions, b_slide, choose_start, search_starts
from ungrasp_ompl.cli.exits import EXIT_NO_SOLUTION
from ungrasp_ompl.errors import InputError
from ungrasp_ompl.mechanics.kinematics import object_axis, s_b
from ungrasp_ompl.mechanics.pincer import pincer_pose
from ungrasp_ompl.parallel import RunOptions
from ungrasp_ompl.planning import plan
from ungrasp_ompl.planning.plan_tolerance import tolerance
from ungrasp_ompl.planning.predicted_landing import predict_landing
from ungrasp_ompl.scene import Scene
from ungrasp_ompl.shipped import resolve
from test_cli import assert_one_line_error

#: Four candidates about the pick's lowest secure start: two below the goal's d range, two in it.
NEAR = StartOptions(d_range=(0.58, 0.61), run=RunOptions(jobs=2))


@pytest.fixture(scope="module")
def chosen(tmp_path_factory):
    out = tmp_path_factory.mktemp("starts")
    result = choose_start("guitar_pick", NEAR)
    return result, result.write(out)


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_the_chosen_start_is_the_secure_one_that_slides_b_least(chosen):
    result, files = chosen
    rows = _rows(files["csv"])
    assert [float(r["d"]) for r in rows] == [0.58, 0.59, 0.6, 0.61]
    secure = [r for r in rows if r["outcome"] == "solved"]
    assert len(secure) == 2 and all(r["b_slide_mm"] == "" for r in rows if r not in secure)
    least = min(secure, key=lambda r: (float(r["b_slide_mm"]), -float(r["d"])))
    assert [r["chosen"] for r in rows].count("1") == 1 and least["chosen"] == "1"
    assert result.best.d == float(least["d"])


def test_a_candidates_row_is_its_scenes_own_lattice_plan(chosen):
    """The candidate at d is the scene moved to that start and planned exactly (planning.plan, the
    lattice); its slide, tolerance and landing spread are b_slide's, plan_tolerance's and
    predicted_landing's of that plan."""
    result, _ = chosen
    c = result.best
    scene = Scene.from_file("guitar_pick")
    moved = scene.with_start_d(c.d)
    found = plan(moved, planner="lattice", seed=1)
    assert found.cost == pytest.approx(c.cost, abs=1e-12)
    assert found.min_margin_deg == pytest.approx(c.min_margin_deg, abs=1e-12)
    assert b_slide(moved, found) == pytest.approx(c.b_slide_m, abs=1e-15)
    assert tolerance(moved, found).scale == c.tolerance
    assert predict_landing(moved, found).spread == pytest.approx(c.landing_spread_m, abs=1e-15)


def test_b_slides_only_while_psi_or_d_moves():
    """A P_theta keeps d and psi, so B keeps its place on the thumb (docs/model.md 3): the pick's
    plan (P_theta, P_psi, P_theta) slides B by the change of s_B over its P_psi alone; and at psi 0,
    with no thickness and a point tip, s_B is d - alpha (B lies d - alpha from the thumb's tip)."""
    scene = Scene.from_file("guitar_pick")
    found = plan(scene, planner="lattice", seed=1)
    dg, l = scene.digits, scene.object_length
    legs = [str(p.type) for p in found.primitives]
    assert legs == ["P_theta", "P_psi", "P_theta"]
    turn = found.primitives[1]
    ends = s_b(np.array([turn.start[1], turn.end[1]]), np.array([turn.start[2], turn.end[2]]), dg.alpha,
               dg.object_thickness, dg.finger_tip_radius)
    assert b_slide(scene, found) == pytest.approx(abs(ends[1] - ends[0]) * l, rel=1e-12)
    assert float(s_b(0.7, 0.0, 0.3)) == pytest.approx(0.4, abs=1e-15)


def test_the_search_gives_the_same_rows_on_one_worker_and_on_two(chosen):
    result, _ = chosen
    again = search_starts(Scene.from_file("guitar_pick"), replace(NEAR, run=RunOptions(jobs=1)))
    assert again.candidates == result.candidates and again.chosen == result.chosen


def test_the_recommended_scene_file_has_the_chosen_start_and_plans(chosen):
    result, files = chosen
    scene = Scene.from_file(files["scene"])
    shipped = Scene.from_file("guitar_pick")
    assert scene.start[1] == result.best.d
    assert scene.start[0] == shipped.start[0] and scene.start[2] == shipped.start[2]
    assert scene.digits == shipped.digits and scene.goal == shipped.goal
    assert plan(scene, planner="lattice", seed=1).cost == pytest.approx(result.best.cost, abs=1e-12)
    own = resolve("guitar_pick", "scene").read_text().splitlines()
    written = files["scene"].read_text().splitlines()
    body = [s for s in written if s not in own]  # the head's two lines and the start's: every other line kept
    assert len(written) == len(own) + 2 and len(body) == 3 and body[2].startswith("start:")


@pytest.mark.parametrize("options, field", [
    (StartOptions(d_step=0.0), "d_step"),
    (StartOptions(d_step=float("nan")), "d_step"),
    (StartOptions(d_range=(0.7, 0.6)), "d_range"),
    (StartOptions(d_range=(0.601, 0.609)), "d_range"),
    (StartOptions(d_step=1e-6), "d_step"),
    (StartOptions(run=RunOptions(jobs=0)), "jobs"),
])
def test_bad_options_name_their_field(options, field):
    with pytest.raises(InputError) as err:
        options.candidates(Scene.from_file("guitar_pick"))
    assert err.value.field == field


def test_the_command_names_its_flag_and_exits_3_without_a_secure_start(tmp_path):
    assert_one_line_error(run_cli("starts", "guitar_pick", "--d", "0.7:0.6", "--out", str(tmp_path / "a")), "--d")
    assert_one_line_error(run_cli("starts", "guitar_pick", "--d", "x", "--out", str(tmp_path / "a")), "--d")
    assert_one_line_error(run_cli("starts", "guitar_pick", "--step", "0", "--out", str(tmp_path / "a")), "--step")
    out = tmp_path / "none"
    r = run_cli("starts", "guitar_pick", "--d", "0.66:0.67", "--jobs", "2", "--out", str(out))
    assert r.returncode == EXIT_NO_SOLUTION, r.stderr
    rows = _rows(out / "starts.csv")
    assert [r["outcome"] for r in rows] == ["no_secure_path", "no_secure_path"]
    assert not (out / "starts_scene.yaml").exists()


def test_a_pincers_slide_is_how_far_b_moves_from_its_thumbs_tip():
    """On a pincer B's slide is the change of B's distance from the thumb's tip, both on the thumb's
    face (mechanics.pincer.pincer_pose), summed over the plan's waypoints."""
    scene = Scene.from_file("pincer_puzzle_piece")
    found = plan(scene, planner="lattice", seed=1)
    assert found.solved
    q = np.array([w for p in found.primitives for w in p.waypoints], dtype=float)
    pose = pincer_pose(q[:, 0], q[:, 1], q[:, 2], scene.digits, *scene.robot.gripper.scaled(scene.object_length))
    apart = np.linalg.norm(pose.thumb_tip - object_axis(q[:, 0]), axis=-1)
    assert b_slide(scene, found) == pytest.approx(np.sum(np.abs(np.diff(apart))) * scene.object_length, rel=1e-9)
    assert b_slide(scene, found) > 0.0


def test_both_tips_counts_a_start_only_where_the_flat_tip_plans_from_it_too():
    """The chalk from d 0.66 and 0.67: the rounded tip plans from both and B slides less from 0.66;
    the flat tip reaches no goal state from 0.66 (its own lattice plan, planned here: the goal cut by
    the start along d) and plans from 0.67, so with both_tips the choice is 0.67 (docs/decisions/0121)."""
    from ungrasp_ompl.planning.result import PlanOutcome

    options = StartOptions(d_range=(0.66, 0.67), run=RunOptions(jobs=1))
    scene = Scene.from_file("fabric_chalk")
    one = search_starts(scene, options)
    both = search_starts(scene, replace(options, both_tips=True))
    assert [c.outcome for c in one.candidates] == [PlanOutcome.SOLVED] * 2 and one.best.d == 0.66
    assert one.candidates[0].b_slide_m < one.candidates[1].b_slide_m
    flat = scene.with_digits(finger_tip="flat")
    at = [plan(flat.with_start_d(d), planner="lattice", seed=1) for d in (0.66, 0.67)]
    assert at[0].outcome is PlanOutcome.GOAL_EMPTY and at[0].evidence["cut_by_start"] == ["d"] and at[1].solved
    assert [c.other_tip_outcome for c in both.candidates] == [PlanOutcome.GOAL_EMPTY, PlanOutcome.SOLVED]
    assert both.candidates[0].b_slide_m is None and both.best.d == 0.67
    assert both.candidates[1] == replace(one.candidates[1], other_tip_outcome=PlanOutcome.SOLVED)
