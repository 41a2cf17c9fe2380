"""Robot execution of shipped plans: IK accuracy, contacts on the plan, limits, termination, export."""

from __future__ import annotations

import csv
import dataclasses
import math
import re

import numpy as np
import pytest
import yaml

from conftest import SCENES, run_cli
from ungrasp_ompl import Scene, plan
from ungrasp_ompl.robot.export import read_csv, read_json, write_json
from ungrasp_ompl.robot.model import finger_tip, load_ur5e, tcp_pose, thumb_tip
from ungrasp_ompl.robot.pipeline import check_limits, execute, gripper_spec
from ungrasp_ompl.robot.placement import contact_points_world, densify
from ungrasp_ompl.robot.trajectory import JOINT_NAMES


@pytest.fixture(scope="module")
def pick():
    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    result = plan(scene, seed=2, time=1.0)  # RRT* finds the path over the friction's +-30 % within 3,000 iterations
    assert result.solved
    return scene, result


def pressed_frame(scene):
    """The plane frame moved straight down by the start press: where a hand that lets none of it
    out runs the plan."""
    frame = scene.plane_frame().copy()
    frame[2, 3] -= scene.robot.start_press
    return frame


@pytest.fixture(scope="module", params=["open", "open_symmetric", "open_lift", "rotate"])
def executed(request, pick):
    """The pick's plan with each termination, the start press held to the end."""
    scene, result = pick
    robot = dataclasses.replace(scene.robot, termination=request.param, end_press=None)
    scene = dataclasses.replace(scene, robot=robot)
    return scene, result, execute(scene, result)


def test_ik_and_contacts_follow_the_plan(executed):
    scene, result, ex = executed
    assert ex.ik_residual_m < 1e-4 and ex.ik_residual_rad < 1e-4  # 0.1 mm, 0.1 mrad
    assert ex.contact_error_m < 1e-4  # at the IK samples and halfway between them


def test_timed_thumb_tip_stays_on_its_planned_path(executed):
    """Along each primitive the timed trajectory's thumb tip (forward kinematics) stays within
    0.1 mm of the planned contact path."""
    scene, result, ex = executed
    states, _ = densify(result, angle_step=math.radians(0.05), d_step=0.0005)
    planned = contact_points_world(scene, states, pressed_frame(scene))["thumb"]
    traj = ex.trajectory
    for name, a, b in traj.segments:
        if not name.startswith("P_"):
            continue
        for q in traj.positions[a:b + 1:5]:
            tip = thumb_tip(ex.robot, q)
            assert np.min(np.linalg.norm(planned - tip, axis=1)) < 1e-4, name


def test_the_rounded_tip_rolls_on_the_object_along_the_exported_trajectory(executed, tmp_path):
    """The exported trajectory, written and read back: at every sample of a primitive, forward
    kinematics puts the finger's dome centre (r behind the finger's face and r back from its tip
    corner) r above the object's top face, the object posed by G (the plane's origin) and B, which
    lies on the thumb's face l from G. Where A sticks (P_psi, P_theta) the contact, the foot of the
    dome's centre on the top face, moves over the object between samples by r times the finger's
    turn against the object (psi), toward G: the dome rolls (docs/model.md, section 2.6)."""
    scene, result, ex = executed
    write_json(ex.trajectory, tmp_path / "trajectory.json")
    traj = read_json(tmp_path / "trajectory.json")
    l, t = scene.object_length, scene.object_thickness
    r = scene.digits.finger_tip_radius * l
    assert r > 0 and not scene.digits.flat_finger_tip
    frame = pressed_frame(scene)

    def plane(p):  # world point -> (x along GB, z up), G at the origin
        return np.array([(p - frame[:3, 3]) @ frame[:3, 0], (p - frame[:3, 3]) @ frame[:3, 2]])

    rolled = 0.0
    for name, a, b in traj.segments:
        if not name.startswith("P_"):
            continue
        along, psi = [], []
        for q in traj.positions[a:b + 1]:
            palm = tcp_pose(ex.robot, q)
            centre = plane(finger_tip(ex.robot, q) + r * palm[:3, 0] - r * palm[:3, 2])
            e = palm[:3, 2] @ frame[:3, [0, 2]]  # the digit axis in the plane
            tip = plane(thumb_tip(ex.robot, q))
            k = tip @ e  # B = tip - s e with |B| = l, s >= 0 (toward the palm)
            bx, bz = tip - (k + math.sqrt(k * k - tip @ tip + l * l)) * e
            theta = math.atan2(bz, bx)
            u, top = np.array([math.cos(theta), math.sin(theta)]), np.array([-math.sin(theta), math.cos(theta)])
            assert centre @ top - t == pytest.approx(r, abs=1e-7), name  # 0.1 um
            along.append((centre - r * top) @ u)
            psi.append(math.atan2(-e[1], -e[0]) - theta)
        if name in ("P_psi", "P_theta"):
            np.testing.assert_allclose(np.diff(along), -r * np.diff(psi), atol=1e-8, err_msg=name)
            rolled += abs(along[-1] - along[0])
    assert rolled > 1e-4  # the plan's P_psi turns the finger: A rolled more than 0.1 mm


def test_every_sample_within_limits_and_continuous(executed):
    scene, result, ex = executed
    traj = ex.trajectory
    assert check_limits(traj, ex.robot) == []
    assert np.all(np.diff(traj.times) > 0)
    assert np.allclose(traj.velocities[[0, -1]], 0.0, atol=1e-9)
    names = [s[0] for s in traj.segments]
    assert names[0] == "approach" and names[-2:] == ["termination", "retreat"]
    assert [n for n in names if n.startswith("P_")] == [p.type for p in result.primitives]
    # positions follow from velocities (no jumps between phases)
    dt = np.diff(traj.times)[:, None]
    predicted = traj.positions[:-1] + traj.velocities[:-1] * dt + 0.5 * traj.accelerations[:-1] * dt ** 2
    assert np.max(np.abs(predicted - traj.positions[1:])) < 2e-3


def test_limits_left_are_found_where_furthest_beyond(executed):
    """A trajectory twice as fast as the robot's limits allow, and one joint moved out of its range:
    each joint beyond a limit is reported once, at the sample furthest beyond it, with its value."""
    _, _, ex = executed
    traj, robot = ex.trajectory, ex.robot
    peak = np.max(np.abs(traj.velocities) / robot.v_max)  # the fastest joint's share of its limit
    fast = dataclasses.replace(traj, velocities=traj.velocities * 2 / peak)
    found = check_limits(fast, robot)
    assert found and all(v.quantity == "velocity" for v in found)
    over = np.abs(fast.velocities) > robot.v_max * (1 + 1e-6) + 1e-12
    assert [v.joint for v in found] == [JOINT_NAMES[j] for j in np.flatnonzero(over.any(axis=0))]
    for v in found:
        j = JOINT_NAMES.index(v.joint)
        k = int(np.argmax(np.abs(fast.velocities[:, j])))
        assert v.value == fast.velocities[k, j] and v.time_s == traj.times[k]
        assert (v.low, v.high) == (-robot.v_max[j], robot.v_max[j]) and abs(v.value) > v.high
    moved = traj.positions.copy()
    moved[5, 0] = robot.q_upper[0] + 0.1
    (out,) = check_limits(dataclasses.replace(traj, positions=moved), robot)
    assert (out.joint, out.quantity, out.value, out.time_s) == (JOINT_NAMES[0], "position", moved[5, 0], traj.times[5])


def test_termination_maneuver(executed):
    scene, result, ex = executed
    traj = ex.trajectory
    name, a, b = next(s for s in traj.segments if s[0] == "termination")
    qs = traj.positions[a:b + 1]
    tips = np.array([thumb_tip(ex.robot, q) for q in qs])
    opening = qs[:, 6]
    if scene.robot.termination == "rotate":
        assert np.ptp(opening) < 1e-9
    else:
        assert opening[-1] - opening[0] == pytest.approx(scene.robot.termination_opening, abs=1e-6)
    if scene.robot.termination in ("open", "rotate"):
        assert np.max(np.linalg.norm(tips - tips[0], axis=1)) < 1e-4  # the thumb stays on B
        return
    palm = np.array([tcp_pose(ex.robot, q) for q in qs])
    fingers = np.array([finger_tip(ex.robot, q) for q in qs])
    across = palm[0][:3, 0]  # palm x: from the thumb toward the finger
    half = (opening - opening[0])[:, None] / 2 * across
    if scene.robot.termination == "open_symmetric":
        # the gripper's own opening: the palm stays, each tip moves by half the opening across the gap
        assert np.max(np.abs(palm - palm[0])) < 1e-6
        assert np.max(np.linalg.norm(tips - (tips[0] - half), axis=1)) < 1e-6
        assert np.max(np.linalg.norm(fingers - (fingers[0] + half), axis=1)) < 1e-6
        return
    # open_lift: the finger leaves the object's top face along its normal (in the plane, theta
    # from the plan's last state), the thumb goes down as far as the gripper's own opening takes it
    # and the palm turns not at all
    frame, theta = scene.plane_frame(), result.states[-1][0]
    normal = frame[:3, :3] @ np.array([-math.sin(theta), 0.0, math.cos(theta)])
    rise = fingers - fingers[0]
    assert np.max(np.linalg.norm(rise - (rise @ normal)[:, None] * normal, axis=1)) < 1e-6
    assert rise[-1] @ normal > 1e-3
    np.testing.assert_allclose(tips[:, 2] - tips[0, 2], -half[:, 2], atol=1e-6)
    assert np.max(np.abs(palm[:, :3, :3] - palm[0][:3, :3])) < 1e-6


def test_a_start_press_comes_straight_down_and_runs_the_plan_that_much_lower(pick):
    """robot.start_press p: the trajectory's 'press' goes from the planned start pinch (where the
    approach ends) straight down by p, and every primitive and the termination start and end p
    below where they do without it (forward kinematics of the palm); the termination's check meets
    the table p higher (CollisionModel.lowered). With robot.end_press e the last P_theta ends e
    below, and the termination runs there; the primitives before it are as p had them."""
    shipped, result = pick  # the shipped pick presses 1 mm and lets half of it out
    p, e = shipped.robot.start_press, shipped.robot.end_press
    assert (p, e) == (pytest.approx(0.001), pytest.approx(0.0005)) and result.primitives[-1].type == "P_theta"
    pressed = dataclasses.replace(shipped, robot=dataclasses.replace(shipped.robot, end_press=None))
    scene = dataclasses.replace(shipped, robot=dataclasses.replace(shipped.robot, start_press=0.0, end_press=None))
    ends, press = {}, {}
    for key, sc in (("plain", scene), ("low", pressed), ("let out", shipped)):
        ex = execute(sc, result)
        tr = ex.trajectory
        poses = [(name, tcp_pose(ex.robot, tr.positions[a, :6]), tcp_pose(ex.robot, tr.positions[b, :6]))
                 for name, a, b in tr.segments]
        press[key] = [pose for pose in poses if pose[0] == "press"]
        ends[key] = [pose for pose in poses if pose[0].startswith("P_") or pose[0] == "termination"]
        if key == "plain":
            approach_end = poses[0][2]
    assert press["plain"] == [] and len(press["low"]) == 1
    down = np.array([0.0, 0.0, -p])
    _, first, last = press["low"][0]
    assert np.allclose(first[:3, 3], approach_end[:3, 3], atol=2e-5)
    assert np.allclose(last[:3, 3] - first[:3, 3], down, atol=2e-5)
    assert np.allclose(last[:3, :3], first[:3, :3], atol=1e-5)
    assert [n for n, _, _ in ends["low"]] == [n for n, _, _ in ends["plain"]] and len(ends["plain"]) >= 3
    for i, ((name, *plain), (_, *low), (_, *out)) in enumerate(zip(ends["plain"], ends["low"], ends["let out"])):
        for k in (0, 1):
            assert np.allclose(low[k][:3, 3] - plain[k][:3, 3], down, atol=2e-5), name
            let_out = i == len(ends["plain"]) - 1 or (i == len(ends["plain"]) - 2 and k == 1)
            want = np.array([0.0, 0.0, -e]) if let_out else down
            assert np.allclose(out[k][:3, 3] - plain[k][:3, 3], want, atol=2e-5), name
    assert pressed.collision_model().lowered == p and scene.collision_model().lowered == 0.0


@pytest.mark.slow
def test_export_command_writes_the_trajectory_files_within_limits(tmp_path):
    out = tmp_path / "t"
    proc = run_cli("plan", str(SCENES / "guitar_pick.yaml"), "--seed", "1", "--export", str(out))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert re.search(r"\d+\.\d\d s, \d+ samples; the joints reach at most \d+ % .* and \d+ % ", proc.stdout), proc.stdout
    assert sorted(p.name for p in out.iterdir()) == ["plan.json", "touch_off.urscript", "trajectory.csv",
                                                     "trajectory.json", "trajectory.urscript", "trajectory_ros2_arm.yaml",
                                                     "trajectory_ros2_gripper.yaml", "view_scene.json"]
    with open(out / "trajectory.csv") as f:
        header = next(csv.reader(f))
    assert header == ["time_s"] + [f"{j}_{k}" for j in JOINT_NAMES for k in ("pos", "vel", "acc")]
    traj = read_csv(out / "trajectory.csv")
    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    robot = load_ur5e(gripper_spec(scene), np.array(scene.robot.base))
    assert check_limits(traj, robot) == []
    # robot.landing simulated: the export is the trajectory the trials run, aimed by the release's landing
    from ungrasp_ompl.planning.result import read_plan
    from ungrasp_ompl.sim.plan_trials import placement

    execution = placement(scene, read_plan(out / "plan.json"))[0]
    np.testing.assert_allclose(traj.positions, execution.trajectory.positions, rtol=0, atol=1e-6)
    assert f"moved {1000 * execution.aims[0].shift:.2f} mm" in proc.stdout, proc.stdout  # how far the hand is aimed
    from ros2_goal import controller_refusals, round_trip, typestore

    store = typestore()
    for part, joints in (("arm", JOINT_NAMES[:6]), ("gripper", JOINT_NAMES[6:])):
        goal = round_trip(store, yaml.safe_load((out / f"trajectory_ros2_{part}.yaml").read_text()))
        assert list(goal.trajectory.joint_names) == list(joints)
        assert controller_refusals(goal, joints) == []  # the UR driver's controller, the gripper's
        stamps = [p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in goal.trajectory.points]
        np.testing.assert_allclose(stamps, traj.times, rtol=0, atol=1e-9)


def test_unreachable_scene_exits_3(tmp_path):
    data = yaml.safe_load((SCENES / "guitar_pick.yaml").read_text())
    data["robot"] = {"base": {"position": [2.0, 0.0, 0.0]}}
    path = tmp_path / "far.yaml"
    path.write_text(yaml.safe_dump(data))
    proc = run_cli("plan", str(path), "--seed", "1", "--time", "1", "--export", str(tmp_path / "x"))
    assert proc.returncode == 3
    assert "unreachable" in proc.stderr and "out of reach" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr
    assert not (tmp_path / "x").exists()


def test_a_plan_the_arm_cannot_reach_has_no_trials_and_says_why_as_a_value(tmp_path):
    from ungrasp_ompl.robot.ik import ReachabilityError, Unreachable
    from ungrasp_ompl.sim.plan_trials import plan_trials

    data = yaml.safe_load((SCENES / "guitar_pick.yaml").read_text())
    data["robot"] = {"base": {"position": [2.0, 0.0, 0.0]}}
    path = tmp_path / "far.yaml"
    path.write_text(yaml.safe_dump(data))
    scene = Scene.from_file(path)
    run = plan_trials(scene, plan(scene, planner="lattice"), trials=3)
    assert not run.executable and run.results == () and run.successes == 0
    error = run.unexecutable
    assert isinstance(error, ReachabilityError) and error.kind is Unreachable.OUT_OF_REACH
    assert error.evidence["distance_m"] > error.evidence["limit_m"]


def test_a_path_a_fraction_of_a_millimetre_long_is_timed_within_the_limits():
    """A 0.15 mm P_psi of the chalk (arm joints rad, opening m; the contacts' travel m), on which
    TOPPRA's fine grid finds no parameterisation: it is timed all the same, from rest to rest,
    through the path's end points, within the velocity and acceleration limits and the contact speed."""
    from ungrasp_ompl.robot.timing import toppra_path

    q = np.array([[-0.093156786, -2.057806228, -1.939542788, 2.815694915, -2.261361941, 0.571970093, 0.016793886],
                  [-0.091768769, -2.057015489, -1.939044758, 2.813423708, -2.25839036, 0.572336851, 0.016850017],
                  [-0.090377637, -2.056230527, -1.93854341, 2.811155157, -2.255419447, 0.572711041, 0.016906012],
                  [-0.088983414, -2.055451377, -1.938038736, 2.808889208, -2.25244923, 0.573092605, 0.01696187]])
    travel = np.array([0.0, 5.0276775e-05, 1.00690178e-04, 1.51240342e-04])
    v_max, a_max, speed = np.array([math.pi] * 6 + [0.05]), np.array([4.0] * 6 + [0.2]), 0.01
    timed = toppra_path(q, travel, v_max, a_max, speed, 0.008)
    assert np.allclose(timed.q[[0, -1]], q[[0, -1]], atol=1e-9)
    assert np.allclose(timed.qd[[0, -1]], 0.0, atol=1e-9)
    assert np.all(np.abs(timed.qd) <= v_max * 1.001) and np.all(np.abs(timed.qdd) <= a_max * 1.001)
    # the contacts' speed: their travel per unit of joint motion, along the timed path
    rate = travel[-1] / np.linalg.norm(q[-1] - q[0])
    assert np.max(np.linalg.norm(timed.qd, axis=1)) * rate <= speed * 1.01
