"""Simulated execution in MuJoCo: positive trials beside negative controls that must fail.

Every trial here runs the real pipeline: the lattice plan of the scene, its robot trajectory
(IK, TOPPRA, Ruckig), forward kinematics of the exported joint samples, and a free object
between force-limited jaws. Nothing pins the object; the controls show the simulator can say no.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from conftest import SCENES, assert_picture, run_cli
from ungrasp_ompl import Scene
from ungrasp_ompl.planning import plan
from ungrasp_ompl.planning.result import Plan
from ungrasp_ompl.robot.pipeline import execute
from ungrasp_ompl.robot.placement import plane_points
from ungrasp_ompl.sim.campaign import deviated_plan, plan_problems, simulate
from ungrasp_ompl.sim.outcome import Outcome
from ungrasp_ompl.sim.perturb import PRESETS, TrialParams, trial_params
from ungrasp_ompl.sim.setup import Variant, trial_setup
from ungrasp_ompl.sim.trial import run_trial


@pytest.fixture(scope="module")
def pick():
    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    result = plan(scene, planner="lattice")
    assert result.solved
    return scene, result, execute(scene, result)


def _setup(pick, variant=Variant(), **sim):
    scene, result, ex = pick
    if sim:
        scene = replace(scene, sim=replace(scene.sim, **sim))
    return trial_setup(scene, result, ex.trajectory, ex.robot, variant)


def test_placement_puts_the_digits_on_the_faces_of_a_thick_object():
    """The finger touches the top face at A (its dome tangent there), the thumb's face passes
    through B on the bottom face, and the opening is the distance between the faces."""
    scene = Scene.from_file(SCENES / "puzzle_piece.yaml")
    rng = np.random.default_rng(0)
    q = np.column_stack([rng.uniform(0, 0.6, 50), rng.uniform(0.3, 1, 50), rng.uniform(0, 1.0, 50)])
    l, t = scene.object_length, scene.object_thickness
    for radius in (0.0, scene.digits.finger_tip_thickness / 2):
        s = replace(scene, digits=replace(scene.digits, finger_tip_radius=radius))
        p = plane_points(s, q)
        th, d, ps = q.T
        u = np.column_stack([np.cos(th), np.sin(th)])
        top = np.column_stack([-u[:, 1], u[:, 0]])
        # the thumb's face (through its tip, along e) passes through B
        assert np.allclose(np.sum((p["b"] - p["thumb"]) * p["n"], axis=1), 0, atol=1e-12)
        # A lies on the top face, (1 - d) l from G
        assert np.allclose(p["a"], (1 - d)[:, None] * l * u + t * top, atol=1e-12)
        # the finger's dome centre lies r from the top face, above A
        centre = p["finger"] + radius * l * (p["n"] - p["e"])
        assert np.allclose(centre, p["a"] + radius * l * top, atol=1e-12)
        if radius == 0:
            assert np.allclose(p["opening"], l * d * np.sin(ps) + t * np.cos(ps), atol=1e-12)
        # the finger's tip is alpha l beyond the thumb's along the digit axis
        assert np.allclose(np.sum((p["finger"] - p["thumb"]) * p["e"], axis=1), scene.digits.alpha * l, atol=1e-12)


def test_the_planned_pick_is_put_down_flat_near_its_target(pick):
    r = run_trial(_setup(pick), TrialParams())
    assert r.outcome is Outcome.SUCCESS, r.cause()
    assert r.position_error_mm < 3.0 and r.tilt_deg < 2.0 and r.roll_deg < 5.0


def test_a_fifth_of_the_friction_loses_the_grip_in_a_named_primitive(pick):
    r = run_trial(_setup(pick, Variant(friction_scale=0.2)), TrialParams())
    assert r.outcome in (Outcome.GRIP_LOST, Outcome.LEFT_PLANE, Outcome.B_PAST_THUMB_TIP), r.cause()
    assert r.phase.startswith("P_") and f"primitive {r.phase_index + 1} ({r.phase})" in r.cause()


def test_equal_digits_cannot_place_the_pick(pick):
    """The paper's negative result: with the thumb as long as the finger the same motion fails."""
    r = run_trial(_setup(pick, Variant(equal_digits=True)), TrialParams())
    assert not r.success


def test_the_same_seed_gives_the_same_trials(pick):
    setup = _setup(pick)
    params = trial_params(PRESETS["paper"], seed=3, trials=2)
    assert params == trial_params(PRESETS["paper"], seed=3, trials=2)
    assert params[0] != params[1]
    first = [run_trial(setup, p) for p in params]
    again = [run_trial(setup, p) for p in params]
    for a, b in zip(first, again):
        assert a.outcome is b.outcome and a.final_pose == b.final_pose


def test_halving_the_timestep_keeps_the_outcomes(pick):
    for variant in (Variant(), Variant(friction_scale=0.2)):
        coarse = run_trial(_setup(pick, variant), TrialParams())
        fine = run_trial(_setup(pick, variant, timestep=pick[0].sim.timestep / 2), TrialParams())
        assert coarse.outcome is fine.outcome
        if coarse.success:
            assert abs(coarse.position_error_mm - fine.position_error_mm) < 1.0


def test_simulate_runs_seeded_trials_on_workers_like_inline(pick):
    setup = _setup(pick)
    inline = simulate(setup, PRESETS["grasp"], trials=2, seed=5, jobs=1)
    pooled = simulate(setup, PRESETS["grasp"], trials=2, seed=5, jobs=2)
    assert [t.final_pose for t in inline.trials] == [t.final_pose for t in pooled.trials]
    assert [t.params for t in inline.trials] == [t.params for t in pooled.trials]


def test_a_deviated_start_is_executed_and_flagged_when_the_model_rejects_it(pick):
    scene, result, _ = pick
    assert plan_problems(scene, result) == []
    deviated = deviated_plan(result, math.radians(10))
    assert deviated.states[0][2] == pytest.approx(result.states[0][2] + math.radians(10))
    assert all(w[2] >= deviated.states[0][2] - 1e-12 for p in deviated.primitives for w in p.waypoints)
    assert deviated.primitives[-1].end == result.primitives[-1].end
    # 60 deg more: B lies beyond the thumb's tip at the start, which the model refuses
    problems = plan_problems(scene, deviated_plan(result, math.radians(60)))
    assert problems and "primitive 1" in problems[0] and "s_B >= 0" in problems[0]


def test_plan_json_round_trips(pick):
    doc = json.loads(pick[1].to_json())
    assert Plan.from_dict(doc).to_dict() == doc


@pytest.mark.parametrize("args, field", [
    (["--friction-scale", "2"], "--friction-scale"),
    (["--perturb", "storm"], "--perturb"),
    (["--trials", "0"], "--trials"),
    (["--thickness", "-1"], "--thickness"),
    (["--plan", "no_such_plan.json"], "--plan"),
])
def test_bad_simulate_options_exit_2_with_one_line(tmp_path, args, field):
    out = tmp_path / "sim"
    r = run_cli("simulate", str(SCENES / "guitar_pick.yaml"), "--out", str(out), *args)
    assert r.returncode == 2, r.stderr
    assert field in r.stderr and len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr
    assert not out.exists()


def test_simulate_refuses_a_scene_without_thickness_and_a_bad_sim_section(tmp_path):
    r = run_cli("simulate", str(SCENES / "reference_asymmetric.yaml"), "--out", str(tmp_path / "a"))
    assert r.returncode == 2 and "object.thickness" in r.stderr
    text = (SCENES / "guitar_pick.yaml").read_text() + "sim: {timestep: 0.5}\n"
    (tmp_path / "bad.yaml").write_text(text)
    r = run_cli("simulate", str(tmp_path / "bad.yaml"), "--out", str(tmp_path / "b"))
    assert r.returncode == 2 and "sim.timestep" in r.stderr and not (tmp_path / "b").exists()


@pytest.mark.slow
def test_simulate_command_writes_its_files(tmp_path):
    out = tmp_path / "sim"
    r = run_cli("simulate", str(SCENES / "guitar_pick.yaml"), "--planner", "lattice", "--trials", "2",
                "--perturb", "none", "--jobs", "1", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "success 2/2" in r.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["successes"] == 2 and summary["trials"] == 2
    rows = (out / "trials.csv").read_text().splitlines()
    assert len(rows) == 3 and rows[0].startswith("outcome,")
    assert_picture(out / "trials.png", colours=((0.173, 0.627, 0.173),))  # the placed outlines' green
    assert (out / "trajectory.json").exists() and (out / "plan.json").exists()
