"""The pincer gripper (robot.gripper.kind pincer, mechanics.pincer): its map from a planar state to
its joint angle and palm, against forward kinematics; its scene fields; the reference planner's
example 5; its export; one simulated trial."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
import yaml

from conftest import SCENES, run_cli
from ungrasp_ompl import Scene
from ungrasp_ompl.errors import InputError, UnknownFieldError
from ungrasp_ompl.mechanics.kinematics import (DigitGeometry, contact_point, digit_axis, object_axis, s_b,
                                               thumb_normal)
from ungrasp_ompl.mechanics.pincer import PincerSpec, closed_angle, forward, pincer_pose

PUZZLE = "pincer_puzzle_piece"
REFERENCE = "pincer_reference"


def _states(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(0.0, math.radians(80), n), rng.uniform(0.3, 1.0, n),
                            rng.uniform(0.0, math.radians(80), n)])


@pytest.mark.parametrize("name", [PUZZLE, REFERENCE])
def test_placing_the_digits_by_the_joint_angle_puts_a_and_b_where_the_state_says(name):
    """Forward kinematics from the palm the map gives (the joint J and the palm's axes) and the joint
    angle: the thumb's face passes through B at theta + psi to the table, and the finger's tip
    (its dome, r above the object's top face) touches it at A where the state puts A (d_A from B,
    on the top face of the object's thickness), to 1e-9 of the object length."""
    scene = Scene.from_file(name)
    dg, spec = scene.digits, scene.robot.gripper
    radius, offset = spec.scaled(scene.object_length)
    q = _states(400, 1)
    th, d, ps = q.T
    pose = pincer_pose(th, d, ps, dg, radius, offset)
    assert np.isfinite(pose.angle).all()
    fk = forward(pose.joint, pose.palm_z, pose.palm_x, pose.angle, dg, radius, offset)
    b = object_axis(th)
    # B on the thumb's face, the face at theta + psi to the table (its direction e, its normal n_B)
    assert np.abs(np.sum((b - fk["thumb_foot"]) * fk["thumb_x"], axis=-1)).max() < 1e-9
    assert np.abs(fk["thumb_z"] - digit_axis(th, ps)).max() < 1e-9
    assert np.abs(fk["thumb_x"] - thumb_normal(th, ps)).max() < 1e-9
    # A: the dome's centre r above the contact along the top face's normal
    top = np.column_stack([-np.sin(th), np.cos(th)])
    a = fk["dome"] - dg.finger_tip_radius * top
    assert np.abs(a - contact_point(th, d, ps, dg.object_thickness, dg.finger_tip_radius)).max() < 1e-9
    # the joint is the joint radius from the dome and the joint offset from the thumb's face
    assert np.abs(np.linalg.norm(fk["dome"] - pose.joint, axis=-1) - radius).max() < 1e-9
    assert np.abs(np.sum((pose.joint - b) * fk["thumb_x"], axis=-1) - offset).max() < 1e-9
    # the digits the map places are the ones forward kinematics places
    for key in ("thumb_tip", "finger_corner", "dome"):
        assert np.abs(fk[key] - getattr(pose, key)).max() < 1e-9, key


def test_the_joint_angle_is_zero_closed_and_the_pincer_never_puts_b_nearer_the_thumbs_tip():
    """With the dome on the thumb's face the joint angle is 0; the finger parallel to the thumb
    (the dome's centre the joint offset from the thumb's face) gives the scene's alpha exactly, and
    every other state puts B further from the thumb's tip than the planner's s_B."""
    scene = Scene.from_file(PUZZLE)
    dg = scene.digits
    radius, offset = scene.robot.gripper.scaled(scene.object_length)
    q = _states(400, 2)
    th, d, ps = q.T
    pose = pincer_pose(th, d, ps, dg, radius, offset)
    b = object_axis(th)
    true_sb = np.sum((pose.thumb_tip - b) * digit_axis(th, ps), axis=-1)
    planned = s_b(d, ps, dg.alpha, dg.object_thickness, dg.finger_tip_radius)
    assert (true_sb >= planned - 1e-12).all()
    across = np.sum((pose.dome - b) * thumb_normal(th, ps), axis=-1) - offset
    assert np.allclose(true_sb - planned, radius - np.sqrt(radius ** 2 - across ** 2), atol=1e-12)
    # closed: a point finger on a segment (t = r = 0) at psi = 0 lies on the thumb's face
    point = DigitGeometry(alpha=0.4, thumb_length=0.6)
    assert pincer_pose(0.3, 0.7, 0.0, point, 1.0, 0.25).angle == pytest.approx(0.0, abs=1e-12)
    assert closed_angle(point, 1.0, 0.25) == pytest.approx(math.asin(-0.25))


def _doc(name: str) -> dict:
    return yaml.safe_load((SCENES / f"{name}.yaml").read_text())


@pytest.mark.parametrize("change, field", [
    ({"kind": "scissors"}, "robot.gripper.kind"),
    ({"kind": 3}, "robot.gripper.kind"),
    ({"joint_radius": -0.05}, "robot.gripper.joint_radius"),
    ({"joint_radius": "long"}, "robot.gripper.joint_radius"),
    ({"joint_radius": 0.05}, "robot.gripper.joint_radius"),  # shorter than the finger: the joint inside it
    ({"joint_offset": 0.08}, "robot.gripper.joint_offset"),
    ({"joint_offset": -0.076}, "robot.gripper.joint_offset"),
    ({"joint_torque": 0.0}, "robot.gripper.joint_torque"),
    ({"joint_torque": float("nan")}, "robot.gripper.joint_torque"),
    ({"max_angle_deg": 200}, "robot.gripper.max_angle_deg"),
])
def test_bad_pincer_fields_are_refused_naming_the_field(change, field):
    doc = _doc(PUZZLE)
    doc["robot"]["gripper"].update(change)
    with pytest.raises(InputError) as err:
        Scene.from_dict(doc)
    assert err.value.field == field
    assert "\n" not in str(err.value)


def test_missing_and_unknown_pincer_fields_and_what_a_pincer_cannot_do_are_refused():
    for missing in ("joint_radius", "joint_offset", "joint_torque"):
        doc = _doc(PUZZLE)
        del doc["robot"]["gripper"][missing]
        with pytest.raises(InputError) as err:
            Scene.from_dict(doc)
        assert err.value.field == f"robot.gripper.{missing}"
    doc = _doc(PUZZLE)
    doc["robot"]["gripper"] = {"kind": "parallel", "joint_radius": 0.076}  # the parallel jaws have no joint
    with pytest.raises(UnknownFieldError) as err:
        Scene.from_dict(doc)
    assert err.value.field == "robot.gripper.joint_radius"
    doc = _doc(PUZZLE)
    doc["robot"]["termination"] = "open_lift"
    with pytest.raises(InputError) as err:
        Scene.from_dict(doc)
    assert err.value.field == "robot.termination"
    with pytest.raises(InputError) as err:
        PincerSpec(joint_radius=0.05, joint_offset=0.06, joint_torque=0.25)
    assert err.value.field == "robot.gripper.joint_offset"


def test_the_parallel_gripper_is_the_default_and_kind_parallel_is_the_same_scene():
    scene = Scene.from_file("puzzle_piece")
    assert scene.robot.gripper is None and scene.robot.gripper_kind == "parallel"
    doc = _doc("puzzle_piece")
    doc["robot"]["gripper"] = {"kind": "parallel"}
    assert Scene.from_dict(doc).robot == scene.robot
    pincer = Scene.from_file(PUZZLE).robot
    assert pincer.gripper_kind == "pincer"
    assert pincer.gripper.pinch_force == pytest.approx(Scene.from_file(PUZZLE).sim.grip_force)  # 5 N at the radius


def test_reference_example_5_is_planned_with_its_primitives():
    """The reference planner's example 5 (start theta 30 deg, psi 5 deg, d 0.8; goal theta 0, psi
    44 deg, d 0.6; d_FT 0.4; the finger's tip one object length from the joint) ends as the
    reference's path does: one P_dpsi moving d and psi together, then a P_theta down to the table.
    The reference makes that P_dpsi at theta 30 deg; with the friction edge this project derives for
    A sliding toward B (docs/model.md 3.2) A cannot slide there from the start (the start is not
    force-closed with A sliding), so the exact optimum lowers the pinch first with a P_theta."""
    from ungrasp_ompl.planning.setup import plan

    scene = Scene.from_file(REFERENCE)
    result = plan(scene, "lattice", seed=1)
    assert result.solved
    types = [str(p.type) for p in result.primitives]
    assert types[-2:] == ["P_dpsi", "P_theta"] and types == ["P_theta", "P_dpsi", "P_theta"]
    dpsi = np.asarray(result.primitives[1].waypoints)
    steps = np.diff(dpsi, axis=0)
    assert (steps[:, 1] < 0).any() and (steps[:, 2] > 0).any()  # d down, psi up
    assert (np.abs(steps[:, 1]) > 0)[np.abs(steps[:, 2]) > 0].all()  # psi moves only with d: d and psi together
    assert scene.goal.contains(result.states[-1])[0]
    # the reference's sliding edge would hold A's slide at theta 30 deg; this project's does not
    start = np.array([[math.radians(30), 0.8, math.radians(5)]])
    assert not scene.force_closure(start, np.array([[0.0, -1.0, 1.0]]))[0]
    # every state of the path is one the pincer makes, clear of the table
    states = np.vstack([np.asarray(p.waypoints) for p in result.primitives])
    assert scene.is_valid(states).all()


def test_plan_export_writes_the_joint_angle(tmp_path):
    """plan pincer_puzzle_piece --export DIR: the trajectory's gripper joint is the pincer's angle
    (rad) in the CSV, the JSON and the ROS 2 gripper goal, at the plan's start the angle the map
    gives, and the digit tips follow the plan (forward kinematics of the exported samples)."""
    from ungrasp_ompl.mechanics.pincer import pincer_pose
    from ungrasp_ompl.robot.export import read_csv, read_json, read_ros2_yaml

    out = tmp_path / "out"
    proc = run_cli("plan", PUZZLE, "--planner", "lattice", "--seed", "1", "--export", str(out))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    doc = json.loads((out / "trajectory.json").read_text())
    assert doc["joint_names"][-1] == "gripper_angle"
    assert doc["units"]["gripper_positions"] == "rad"
    traj = read_json(out / "trajectory.json")
    csv = read_csv(out / "trajectory.csv")
    assert csv.joint_names[-1] == "gripper_angle" and np.array_equal(csv.positions, traj.positions)
    goal = read_ros2_yaml(out / "trajectory_ros2_gripper.yaml")
    assert goal.joint_names == ("gripper_angle",)
    assert np.allclose(goal.positions[:, 0], traj.positions[:, -1], atol=1e-15)
    scene = Scene.from_file(PUZZLE)
    plan_doc = json.loads((out / "plan.json").read_text())
    start = np.array(plan_doc["states"][0], dtype=float)
    angle = pincer_pose(*start, scene.digits, *scene.robot.gripper.scaled(scene.object_length)).angle
    first = next(a for name, a, _ in traj.segments if name.startswith("P_"))
    assert traj.positions[first, -1] == pytest.approx(float(angle), abs=1e-9)
    assert 0.0 < traj.positions[:, -1].min() and traj.positions[:, -1].max() < scene.robot.gripper.max_angle
    assert "ungrasp_gripper_set_angle(" in (out / "trajectory.urscript").read_text()


def test_the_simulated_pincer_places_the_piece():
    """One trial of the pincer's puzzle piece, no error drawn: the simulated digits start where the
    plan puts them (the hinge's MJCF against the plan, to a micrometre), and the piece is placed."""
    import mujoco

    from ungrasp_ompl.planning.setup import plan
    from ungrasp_ompl.robot.placement import scene_pincer, to_world
    from ungrasp_ompl.scene.perturbation import TrialParams
    from ungrasp_ompl.sim.model import build_mjcf, model_ids
    from ungrasp_ompl.sim.plan_trials import placement
    from ungrasp_ompl.sim.trial import run_trial

    scene = Scene.from_file(PUZZLE)
    result = plan(scene, "lattice", seed=1)
    execution, setup = placement(scene, result)
    # the hinge places the digits as the plan has them at the drive's first tick
    model = mujoco.MjModel.from_xml_string(build_mjcf(setup.spec))
    data, ids = mujoco.MjData(model), model_ids(model)
    palm, angle = setup.drive.palm[0], setup.drive.opening[0]
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(palm[:3, :3]).ravel())
    adr = model.jnt_qposadr[model.body_jntadr[ids.palm_body]]
    data.qpos[adr:adr + 3], data.qpos[adr + 3:adr + 7] = palm[:3, 3], quat
    for jaw, side in ((ids.thumb_jaw, -1.0), (ids.finger_jaw, 1.0)):
        data.qpos[model.jnt_qposadr[model.body_jntadr[jaw]]] = side * angle / 2
    mujoco.mj_kinematics(model, data)
    pose = scene_pincer(scene, result.states[0])
    frame = setup.aim.transform(scene.plane_frame()[:3, 3]) @ scene.plane_frame()
    down = np.array([0.0, 0.0, scene.robot.start_press])
    dome = to_world(frame, pose.dome * scene.object_length)[0] - down
    assert np.linalg.norm(data.geom_xpos[ids.finger_dome] - dome) < 1e-6
    thumb = to_world(frame, pose.thumb_tip * scene.object_length)[0] - down
    tip = data.xpos[ids.thumb_body] + data.xmat[ids.thumb_body].reshape(3, 3)[:, 2] * execution.robot.pincer.thumb_reach
    assert np.linalg.norm(tip - thumb) < 1e-6
    trial = run_trial(setup, TrialParams(), 0, 1)
    assert trial.success, trial.cause()
    assert trial.position_error_mm < scene.sim.max_error * 1000


def test_the_pincers_lattice_check_a_slice_at_a_time_is_the_state_by_state_check(monkeypatch):
    """CollisionChecker.in_collision_lattice, which takes a pincer's lattice a few theta at a time
    (its digits turn with every coordinate), answers as in_collision does state by state, the
    states the pincer cannot make (beyond its joint's range) included."""
    from ungrasp_ompl.geometry import collision
    from ungrasp_ompl.geometry.collision import CollisionChecker

    scene = Scene.from_file(PUZZLE)
    narrow = replace(scene.robot.gripper, max_angle=math.radians(12.0))
    model = replace(scene.collision_model(), pincer=narrow)
    axes = (np.radians(np.arange(0.0, 61.0, 4.0)), np.arange(0.3, 1.0001, 0.05), np.radians(np.arange(0.0, 61.0, 4.0)))
    monkeypatch.setattr(collision, "PINCER_LATTICE_CHUNK", 40)
    checker = CollisionChecker(model)
    lattice = checker.in_collision_lattice(axes)
    q = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    states = CollisionChecker(model).in_collision(q)
    assert np.array_equal(lattice.ravel(), states)
    beyond = CollisionChecker(model).out_of_reach(q)
    assert beyond.any() and (~beyond).any() and states[beyond].all()


# --- the release: the model of the fall against the export (docs/model.md 7, 11.17) --------------------

@pytest.mark.parametrize("termination", ["open", "open_symmetric"])
def test_a_pincer_may_aim_by_the_modelled_landing_with_an_opening_termination(termination):
    """robot.landing modelled loads with the pincer's opening terminations, and predict_landing
    models the pincer's own hand (its joint, its turns); with rotate the loader refuses modelled,
    for the pincer as for the parallel jaws."""
    from ungrasp_ompl.mechanics.pincer import release_turns
    from ungrasp_ompl.planning.predicted_landing import release_setup

    doc = _doc(PUZZLE)
    doc["robot"].update(landing="modelled", termination=termination)
    scene = Scene.from_dict(doc)
    assert scene.robot.landing == "modelled" and scene.robot.gripper is not None
    hand = release_setup(scene, (math.radians(8.0), 0.7, math.radians(40.0))).hand
    turns = release_turns(termination)
    assert hand.joint is not None and hand.turns == (turns["palm"], turns["thumb"], turns["finger"])
    doc["robot"]["termination"] = "rotate"
    with pytest.raises(InputError) as err:
        Scene.from_dict(doc)
    assert err.value.field == "robot.landing"


@pytest.mark.parametrize("depth_mm", [0.5, 1.0, -0.3])
def test_the_pincers_pressed_state_lowers_its_joint_and_keeps_its_palm_turned_the_same(depth_mm):
    """pincer_pressed_state: the state whose joint lies depth straight below the planned state's (to
    1e-12 l), the palm's axis turned the same (1e-12 rad), G where it was (the state keeps G at the
    origin by construction); pressed down, the object turns flatter about G and pushes the digits
    apart (a larger joint angle), lifted the other way; depth 0 is the state itself."""
    from ungrasp_ompl.mechanics.pincer import pincer_pressed_state

    scene = Scene.from_file(PUZZLE)
    dg, l = scene.digits, scene.object_length
    radius, offset = scene.robot.gripper.scaled(l)
    q = (math.radians(8.0), 0.675, math.radians(34.5))
    depth = depth_mm / 1000 / l
    th, d, ps, found = pincer_pressed_state(*q, depth, dg, radius, offset)
    assert found
    before, after = pincer_pose(*q, dg, radius, offset), pincer_pose(th, d, ps, dg, radius, offset)
    assert np.abs(after.joint - (before.joint - (0.0, depth))).max() < 1e-12
    assert abs(math.atan2(after.palm_z[1], after.palm_z[0]) - math.atan2(before.palm_z[1], before.palm_z[0])) < 1e-12
    assert (th < q[0]) == (depth > 0) and (after.angle > before.angle) == (depth > 0)
    assert pincer_pressed_state(*q, 0.0, dg, radius, offset) == pytest.approx((*q, True), abs=1e-15)


@pytest.fixture(scope="module")
def exported_release():
    """The pincer's puzzle piece, as planned (no aim), its RRT* plan of seed 1 (with a P_dpsi)
    executed for the robot, and the model's hand for that plan (release_setup)."""
    from ungrasp_ompl.planning.setup import plan
    from ungrasp_ompl.planning.predicted_landing import release_setup
    from ungrasp_ompl.robot.pipeline import execute
    from ungrasp_ompl.scene.options import Landing

    scene = Scene.from_file(PUZZLE)
    scene = replace(scene, robot=replace(scene.robot, landing=Landing.PLANNED))
    result = plan(scene, "RRTstar", time=1.0, seed=1)
    assert result.solved
    return scene, result, execute(scene, result), release_setup(scene, tuple(result.states[-1])).hand


def _exported_digits(scene, execution, segment):
    """Per sample of the trajectory's segment: t (s from the segment's start), and in the plane's
    frame (m) the palm's origin J, the palm's axis, and by forward kinematics of the exported joint
    angle the thumb's tip and the finger's dome centre."""
    from ungrasp_ompl.mechanics.pincer import forward
    from ungrasp_ompl.robot.model import tcp_pose

    traj, robot = execution.trajectory, execution.robot
    l = scene.object_length
    radius, offset = scene.robot.gripper.scaled(l)
    inv = np.linalg.inv(scene.plane_frame())
    _, i0, i1 = next(s for s in traj.segments if s[0] == segment)
    _, t0, _ = next(s for s in traj.segments if s[0] == "termination")
    rows = []
    for k in range(i0, i1 + 1):
        pose = inv @ tcp_pose(robot, traj.positions[k, :6])
        joint, z, x = pose[[0, 2], 3], pose[[0, 2], 2], pose[[0, 2], 0]
        fk = forward(joint / l, z, x, traj.positions[k, 6], scene.digits, radius, offset)
        rows.append((traj.times[k] - traj.times[t0], joint, z, fk["thumb_tip"] * l, fk["dome"] * l))
    return rows


def test_the_modelled_release_moves_the_digits_as_the_export_commands(exported_release):
    """The model's hand (mechanics.release.pincer_hand, the command alone: no squeeze taken up) against
    the exported trajectory's termination and retreat (forward kinematics of the palm pose and the
    joint angle, in the plane's frame): the termination starts with J where the export's end press
    puts it and the palm turned the same (the pincer's own pressed state, 1e-6 m and 1e-6 rad); over
    the termination J and the thumb's tip stay where they are and the finger's dome turns about J
    as the model has them at the same time (1e-6 m for J and the thumb: the IK's residual; 0.05 mm
    for the finger: TOPPRA's timing against the model's trapezoid, whose duration lies within 2 ms
    of the export's), the dome moving by the termination's 4 mm; over the retreat every one of them
    within 0.2 mm (the retreat's timing)."""
    scene, _, execution, hand = exported_release
    command = replace(hand, held=0.0)
    term = _exported_digits(scene, execution, "termination")
    retreat = _exported_digits(scene, execution, "retreat")
    _, joint0, z0, thumb0, dome0 = term[0]
    assert np.linalg.norm(joint0 - hand.joint) < 1e-6
    # the palm's axis bisects the model's thumb's face (e) and its finger's link (J to the dome)
    link = np.array(hand.finger) - hand.joint
    bisector = np.array(hand.axis) + link / np.linalg.norm(link)
    assert abs(math.atan2(*z0[::-1]) - math.atan2(*bisector[::-1])) < 1e-6
    duration = term[-1][0]
    assert abs(duration - command.duration) < 0.002
    for t, joint, _, thumb, dome in term:
        model_joint = np.array(command.palm_at(t)[:2]) + hand.joint
        assert np.linalg.norm(joint - model_joint) < 1e-6, t
        moved = np.array(command.thumb_at(t)[:2]) - command.thumb_at(0.0)[:2]
        assert np.linalg.norm((thumb - thumb0) - moved) < 1e-6, t
        turned = np.array(command.finger_at(t)[:2]) - command.finger_at(0.0)[:2]
        assert np.linalg.norm((dome - dome0) - turned) < 5e-5, t
    assert np.linalg.norm(term[-1][4] - dome0) == pytest.approx(scene.robot.termination_opening, abs=1e-6)
    for t, joint, _, thumb, dome in retreat:
        lifted = np.array(command.palm_at(t)[:2])
        assert np.linalg.norm(joint - (hand.joint + lifted)) < 2e-4, t
        assert np.linalg.norm((thumb - thumb0) - (np.array(command.thumb_at(t)[:2]) - command.thumb_at(0.0)[:2])) < 2e-4
        assert np.linalg.norm((dome - dome0) - (np.array(command.finger_at(t)[:2]) - command.finger_at(0.0)[:2])) < 2e-4
