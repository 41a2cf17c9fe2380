"""The UR5e model against its DH table, the gripper's frames, joint limits, and IK."""

from __future__ import annotations

import importlib.util
import pickle
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from ungrasp_ompl.cli.exits import EXIT_NO_SOLUTION, exit_code
from ungrasp_ompl.errors import InputError, UngraspError
from ungrasp_ompl.robot.ik import MAX_PATH_STEP, ReachabilityError, Unreachable, ik_seed_for, solve_ik, solve_path
from ungrasp_ompl.robot.model import (GripperSpec, fk_dh, finger_tip, frame_pose, load_ur5e,
                                      max_flange_distance_from_shoulder, shoulder_position, tcp_pose, thumb_tip)
from ungrasp_ompl.robots import ur5e_urdf
from ungrasp_ompl.robot.trajectory import ARM_JOINTS, GRIPPER_JOINT

GRIPPER = GripperSpec(finger_length=0.09, thumb_length=0.07, finger_width=0.02, digit_thickness=0.012)
#: The arm's base in the world: turned 30 deg about z, tilted 10 deg about x, and moved.
BASE = pin.SE3(pin.rpy.rpyToMatrix(np.radians(10.0), 0.0, np.radians(30.0)),
               np.array([0.4, -0.2, 0.75])).homogeneous


@pytest.fixture(scope="module")
def robot():
    return load_ur5e(GRIPPER)


@pytest.fixture(scope="module")
def robot_on_base():
    return load_ur5e(GRIPPER, BASE)


def _random_q7(robot, rng, n):
    """n trajectory configurations (6 arm joints, opening) uniform within the limits."""
    return rng.uniform(robot.q_lower, robot.q_upper, size=(n, 7))


def _pose_error(a, b):
    """Position (m) and rotation (rad) distance between two 4x4 poses."""
    return np.linalg.norm(a[:3, 3] - b[:3, 3]), np.linalg.norm(pin.log3(a[:3, :3].T @ b[:3, :3]))


def _tz(z):
    pose = np.eye(4)
    pose[2, 3] = z
    return pose


def test_urdf_is_generated_from_the_dh_table():
    """The shipped ungrasp_ompl/robots/ur5e.urdf is what robots/make_ur5e_urdf.py writes today."""
    script = Path(__file__).resolve().parents[1] / "robots" / "make_ur5e_urdf.py"
    spec = importlib.util.spec_from_file_location("make_ur5e_urdf", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.URDF_PATH == ur5e_urdf().resolve()
    assert ur5e_urdf().read_text() == module.urdf_text()


@pytest.mark.parametrize("on_base", [False, True], ids=["identity base", "moved base"])
def test_pinocchio_fk_equals_dh_product(robot, robot_on_base, on_base):
    arm = robot_on_base if on_base else robot
    base = BASE if on_base else np.eye(4)
    rng = np.random.default_rng(0)
    for q in _random_q7(arm, rng, 200):
        dist, angle = _pose_error(frame_pose(arm, q, arm.tool0_frame), base @ fk_dh(q[:6]))
        assert dist < 1e-9 and angle < 1e-9


def test_palm_frame_and_digit_tips(robot_on_base):
    arm, g = robot_on_base, GRIPPER
    rng = np.random.default_rng(1)
    for q in _random_q7(arm, rng, 50):
        palm = tcp_pose(arm, q)
        dist, angle = _pose_error(palm, frame_pose(arm, q, arm.tool0_frame) @ _tz(g.palm_depth))
        assert dist < 1e-12 and angle < 1e-12
        thumb, finger = thumb_tip(arm, q), finger_tip(arm, q)
        # symmetric jaws: the thumb's face half the opening behind the palm axis
        assert np.allclose(thumb, palm[:3, 3] - q[6] / 2 * palm[:3, 0] + g.thumb_length * palm[:3, 2], atol=1e-12)
        # Finger minus thumb, in palm axes: the opening along x, the length difference along z.
        assert np.allclose(palm[:3, :3].T @ (finger - thumb), [q[6], 0.0, g.finger_length - g.thumb_length],
                           atol=1e-12)


def test_digit_bodies_lie_behind_their_contact_faces(robot):
    """Thumb box behind its face at palm x = -opening/2, finger box beyond its face at +opening/2,
    both from palm z = 0 to their tips."""
    from ungrasp_ompl.robot.model import configuration

    arm, g = robot, GRIPPER
    q = np.array([0.3, -1.2, 1.5, -1.9, -1.6, 0.4, 0.05])
    geometry = arm.collision_model
    data = pin.GeometryData(geometry)
    pin.framesForwardKinematics(arm.model, arm.data, configuration(arm, q))
    pin.updateGeometryPlacements(arm.model, arm.data, geometry, data)
    palm_inv = np.linalg.inv(tcp_pose(arm, q))
    expected = {  # centre (palm frame) and size of each box
        "gripper_thumb": ([-q[6] / 2 - g.digit_thickness / 2, 0, g.thumb_length / 2],
                          [g.digit_thickness, g.finger_width, g.thumb_length]),
        "gripper_finger": ([q[6] / 2 + g.digit_thickness / 2, 0, g.finger_length / 2],
                           [g.digit_thickness, g.finger_width, g.finger_length]),
    }
    for name, (centre, size) in expected.items():
        gid = geometry.getGeometryId(name)
        in_palm = palm_inv @ data.oMg[gid].homogeneous
        assert np.allclose(in_palm[:3, 3], centre, atol=1e-12)
        assert np.allclose(in_palm[:3, :3], np.eye(3), atol=1e-12)
        assert np.allclose(2 * geometry.geometryObjects[gid].geometry.halfSide, size)
    palm_box = palm_inv @ data.oMg[geometry.getGeometryId("gripper_palm")].homogeneous
    assert palm_box[2, 3] < 0


def test_joint_limits(robot):
    model = robot.model
    assert model.nq == model.nv == 8  # 6 arm joints and the two jaw slides
    assert [model.names[j] for j in robot.arm_joint_ids] == list(ARM_JOINTS)
    assert model.names[model.njoints - 1] == GRIPPER_JOINT
    assert np.allclose(robot.q_lower[:6], -2 * np.pi) and np.allclose(robot.q_upper[:6], 2 * np.pi)
    assert np.allclose(robot.v_max[:6], np.pi)
    assert robot.q_lower[6] == 0.0 and robot.q_upper[6] == pytest.approx(GRIPPER.max_opening)
    assert robot.v_max[6] == pytest.approx(0.05) and robot.a_max[6] == pytest.approx(0.2)
    assert np.all(robot.a_max[:6] == 4.0)
    assert np.allclose(model.effortLimit[:6], [150, 150, 150, 28, 28, 28])


def test_reach_bound_is_tight():
    """No configuration puts the flange farther from the shoulder than the bound; some come close."""
    rng = np.random.default_rng(2)
    shoulder = np.array([0.0, 0.0, 0.1625])
    distances = [np.linalg.norm(fk_dh(q)[:3, 3] - shoulder) for q in rng.uniform(-np.pi, np.pi, (20000, 6))]
    bound = max_flange_distance_from_shoulder()
    assert max(distances) <= bound
    assert max(distances) > bound - 0.01


def test_solve_ik_reaches_random_targets(robot_on_base):
    arm = robot_on_base
    rng = np.random.default_rng(3)
    for k in range(50):
        q_true = rng.uniform(-np.pi, np.pi, 6)
        target = tcp_pose(arm, q_true)
        q = solve_ik(arm, target, q_true + rng.normal(0.0, 0.2, 6), index=k)
        dist, angle = _pose_error(tcp_pose(arm, q), target)
        assert dist < 1e-7 and angle < 1e-6, k
        assert np.all(q >= arm.q_lower[:6]) and np.all(q <= arm.q_upper[:6])


def test_ik_seed_for_needs_no_start(robot_on_base):
    arm = robot_on_base
    rng = np.random.default_rng(4)
    for _ in range(20):
        target = tcp_pose(arm, rng.uniform(-np.pi, np.pi, 6))
        dist, angle = _pose_error(tcp_pose(arm, ik_seed_for(arm, target)), target)
        assert dist < 1e-7 and angle < 1e-6


def _line(start: np.ndarray, direction: np.ndarray, length: float, n: int) -> list[np.ndarray]:
    """n poses with start's orientation, evenly from start to start + length * direction (world)."""
    poses = []
    for s in np.linspace(0.0, length, n):
        pose = start.copy()
        pose[:3, 3] += s * direction / np.linalg.norm(direction)
        poses.append(pose)
    return poses


def test_out_of_reach_names_the_sample(robot):
    home = tcp_pose(robot, [0.3, -1.2, 1.5, -1.9, -1.6, 0.4])
    far = home.copy()
    far[:3, 3] = [1.2, 0.0, 0.3]  # about 1.2 m from the base
    targets = _line(home, np.array([0.0, 0.0, 1.0]), 0.003, 3) + [far]
    with pytest.raises(ReachabilityError) as info:
        solve_path(robot, targets, ik_seed_for(robot, home))
    error = info.value
    assert isinstance(error, UngraspError) and exit_code(error) == EXIT_NO_SOLUTION == 3
    assert error.index == 3 and np.array_equal(error.target, far)
    assert error.kind is Unreachable.OUT_OF_REACH
    assert error.evidence["distance_m"] > error.evidence["limit_m"] == max_flange_distance_from_shoulder()
    flange = far[:3, 3] - robot.gripper.palm_depth * far[:3, 2]  # where the flange would be, from the shoulder
    assert error.evidence["distance_m"] == pytest.approx(np.linalg.norm(flange - shoulder_position(robot)))
    assert str(error).startswith("sample 3: palm at (1200.0, 0.0, 300.0) mm unreachable: out of reach")
    # it reaches a parent process whole, its evidence with it
    back = pickle.loads(pickle.dumps(error))
    assert type(back) is ReachabilityError and str(back) == str(error)
    assert (back.index, back.kind, back.evidence) == (3, Unreachable.OUT_OF_REACH, error.evidence)


def test_unreachable_inside_the_workspace_says_why(robot):
    """The flange on the base axis: the shoulder offset keeps the wrist off it, though within reach."""
    target = np.diag([1.0, -1.0, -1.0, 1.0])
    target[:3, 3] = [0.0, 0.0, 0.6]
    with pytest.raises(ReachabilityError) as info:
        solve_ik(robot, target, [0.0, -1.57, 1.57, -1.57, -1.57, 0.0], index=7)
    error = info.value
    assert error.index == 7 and error.kind is Unreachable.NOT_CONVERGED
    assert error.evidence["residual_m"] > 1e-5  # above the tolerance it was asked for
    assert 1 <= error.evidence["iterations"] <= 200 and "distance_m" not in error.evidence  # within the rated reach


def test_solve_path_along_a_line_is_continuous(robot_on_base):
    arm = robot_on_base
    start = tcp_pose(arm, [0.3, -1.2, 1.5, -1.9, -1.6, 0.4])
    targets = _line(start, np.array([1.0, -0.5, 0.3]), 0.10, 200)
    path = solve_path(arm, targets, ik_seed_for(arm, targets[0]))
    assert path.q.shape == (200, 6)
    assert np.max(np.abs(np.diff(path.q, axis=0))) < 0.01  # 0.5 mm per sample, far from singular
    assert np.max(path.pos_residual) < 1e-7 and np.max(path.rot_residual) < 1e-6
    for q, target in zip(path.q[::20], targets[::20]):  # the residuals are what they claim
        dist, angle = _pose_error(tcp_pose(arm, q), target)
        assert dist < 1e-7 and angle < 1e-6


def test_solve_path_reports_a_branch_flip(robot):
    start = tcp_pose(robot, [0.3, -1.2, 1.5, -1.9, -1.6, 0.4])
    targets = [start, _line(start, np.array([0.0, 1.0, 0.0]), 0.3, 2)[1]]
    with pytest.raises(ReachabilityError) as info:
        solve_path(robot, targets, ik_seed_for(robot, start))
    error = info.value
    assert error.index == 1 and error.kind is Unreachable.BRANCH_FLIP
    assert error.evidence["jump_rad"] > error.evidence["max_step_rad"] == MAX_PATH_STEP
    assert error.evidence["joint"] in ARM_JOINTS


def test_bad_inputs_are_input_errors():
    with pytest.raises(InputError, match="gripper.finger_width"):
        GripperSpec(finger_length=0.09, thumb_length=0.07, finger_width=-0.02, digit_thickness=0.012)
    with pytest.raises(InputError, match="robot.base"):
        load_ur5e(GRIPPER, np.diag([1.0, 1.0, 2.0, 1.0]))


def test_robot_collision_broad_phase_drops_no_pair(robot):
    """The robot checker sends FCL only the link/target pairs whose bounding ball and box meet;
    FCL over every pair is the oracle: the same pairs collide for configurations spread over
    the joint limits, near the tangram's frame and pieces, and some do collide."""
    import fcl

    from ungrasp_ompl.layout.model import Layout
    from ungrasp_ompl.robot.collision import RobotCollisionChecker
    from ungrasp_ompl.robot.model import configuration
    from ungrasp_ompl.shipped import resolve
    from ungrasp_ompl.layout.tiler import approaches

    layout = Layout.from_file(resolve("tangram", "layout"))
    a = approaches(layout, 0, [1, 2, 3, 4], 1)[0]
    scene = layout.scene(0, (a.g, a.b), [1, 2, 3, 4])
    checker = RobotCollisionChecker(robot, scene, scene.plane_frame())
    request = fcl.CollisionRequest()
    rng = np.random.default_rng(2)
    found = 0
    for q in _random_q7(robot, rng, 400):
        got = set(checker.collisions(q))
        pin.forwardKinematics(robot.model, robot.data, configuration(robot, q))
        pin.updateGeometryPlacements(robot.model, robot.data, checker.geom, checker.gdata)
        expected = set()
        for (name, obj, _), placement in zip(checker.links, checker.gdata.oMg):
            obj.setTransform(fcl.Transform(placement.rotation, placement.translation))
            for target_name, target, _ in checker.targets:
                if target_name == "table" and name.startswith("shoulder_link"):
                    continue
                if fcl.collide(obj, target, request, fcl.CollisionResult()):
                    expected.add(f"{name}/{target_name}")
        assert got == expected
        found += bool(expected)
    assert 0 < found < 400
