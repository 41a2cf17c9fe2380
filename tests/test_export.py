"""Export of joint trajectories: CSV, JSON, ROS 2 YAML (built and serialised as real ROS 2 messages)
and URScript round trips, atomic writes."""

from __future__ import annotations

import csv
import json
import math
import re

import numpy as np
import pytest
import yaml

from ungrasp_ompl.errors import InputError
from ungrasp_ompl.robot import export
from ungrasp_ompl.robot.trajectory import ARM_JOINTS, GRIPPER_JOINT, JOINT_NAMES, JointTrajectory

DURATION = 3.7


def make_trajectory(n: int = 200, duration: float = DURATION, phase: float = 0.0) -> JointTrajectory:
    """Smooth sinusoids with analytic derivatives at non-uniform times: arm within +-2 rad,
    gripper opening within 0..0.1 m."""
    u = np.linspace(0.0, 1.0, n)
    t = duration * (u + 0.05 * np.sin(2 * np.pi * u))  # non-uniform, t[0] = 0, t[-1] = duration
    amp = np.array([1.9, 1.2, 1.5, 0.8, 1.1, 1.7, 0.045])
    omega = np.array([0.9, 1.3, 0.7, 2.1, 1.7, 0.5, 1.9])
    offset = np.array([0, 0, 0, 0, 0, 0, 0.05])
    arg = omega * t[:, None] + np.arange(7) * 0.4 + phase
    pos = offset + amp * np.sin(arg)
    vel = amp * omega * np.cos(arg)
    acc = -amp * omega**2 * np.sin(arg)
    return JointTrajectory(times=t, positions=pos, velocities=vel, accelerations=acc,
                           segments=[("approach", 0, 50), ("P_theta", 50, 200)])


@pytest.fixture
def traj() -> JointTrajectory:
    return make_trajectory()


def assert_same(a: JointTrajectory, b: JointTrajectory, time_tol: float = 1e-12, tol: float = 1e-12) -> None:
    assert a.joint_names == b.joint_names
    np.testing.assert_allclose(a.times, b.times, rtol=0, atol=time_tol)
    for name in ("positions", "velocities", "accelerations"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=0, atol=tol)


def test_sanity_of_fixture(traj):
    assert traj.positions.shape == (200, 7) and traj.duration == pytest.approx(DURATION)
    assert np.all(np.diff(traj.times) > 0) and np.ptp(np.diff(traj.times)) > 1e-3
    assert np.all(np.abs(traj.positions[:, :6]) <= 2.0)
    assert 0.0 <= traj.positions[:, 6].min() and traj.positions[:, 6].max() <= 0.1


def test_csv_json_yaml_round_trip(traj, tmp_path):
    export.write_csv(traj, tmp_path / "t.csv")
    back = export.read_csv(tmp_path / "t.csv")
    assert_same(traj, back)

    export.write_json(traj, tmp_path / "t.json")
    back = export.read_json(tmp_path / "t.json")
    assert_same(traj, back)
    assert back.segments == traj.segments
    doc = json.loads((tmp_path / "t.json").read_text())
    assert doc["schema_version"] == export.SCHEMA_VERSION == 1
    assert doc["units"]["time"] == "s" and doc["segments"][1] == {"name": "P_theta", "start": 50, "end": 200}

    for part, cols in (("arm", slice(0, 6)), ("gripper", slice(6, 7))):
        export.write_ros2_yaml(traj, tmp_path / "t.yaml", part)
        assert_same(columns(traj, cols), export.read_ros2_yaml(tmp_path / "t.yaml"), time_tol=1e-9)


def columns(traj: JointTrajectory, cols: slice) -> JointTrajectory:
    """The trajectory of some of traj's joints."""
    return JointTrajectory(traj.times, traj.positions[:, cols], traj.velocities[:, cols],
                           traj.accelerations[:, cols], traj.joint_names[cols], traj.segments)


def test_csv_header_and_yaml_message_layout(traj, tmp_path):
    export.write_csv(traj, tmp_path / "t.csv")
    with open(tmp_path / "t.csv", newline="") as f:
        rows = list(csv.reader(f))
    expected = ["time_s"] + [f"{j}_{s}" for j in JOINT_NAMES for s in ("pos", "vel", "acc")]
    assert rows[0] == expected
    assert len(rows) == 1 + len(traj.times)
    assert float(rows[5][1 + 3 * 2 + 1]) == traj.velocities[4, 2]  # elbow velocity, exact

    export.write_ros2_yaml(traj, tmp_path / "t.yaml", "arm")
    text = (tmp_path / "t.yaml").read_text()
    assert text.startswith("#") and "FollowJointTrajectory" in text.splitlines()[0]
    assert "scaled_joint_trajectory_controller" in text.split("trajectory:")[0]
    msg = yaml.safe_load(text)["trajectory"]
    assert msg["header"] == {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""}
    assert msg["joint_names"] == list(ARM_JOINTS)
    for p in msg["points"]:
        assert set(p) == {"positions", "velocities", "accelerations", "effort", "time_from_start"}
        d = p["time_from_start"]
        assert isinstance(d["sec"], int) and isinstance(d["nanosec"], int)
        assert 0 <= d["nanosec"] < 1_000_000_000
    assert msg["points"][-1]["time_from_start"]["sec"] == 3


def test_urscript_servo_targets(traj, tmp_path):
    path = tmp_path / "t.urscript"
    export.write_urscript(traj, path)
    text = path.read_text()
    targets = export.read_urscript_servo_targets(path)

    n = math.floor(traj.duration / 0.002) + 1
    assert targets.shape == (n, 6)
    times = traj.times[0] + 0.002 * np.arange(n)
    expected = np.column_stack([np.interp(times, traj.times, traj.positions[:, j]) for j in range(6)])
    np.testing.assert_allclose(targets, expected, rtol=0, atol=1e-6)

    servo_lines = [ln for ln in text.splitlines() if "servoj(" in ln]
    assert len(servo_lines) == n
    assert all(re.search(r"\],\s*0,\s*0,\s*0\.002,\s*0\.1,\s*300\)\s*$", ln) for ln in servo_lines)

    assert re.search(r"^\s*def ungrasp_gripper_set_opening\(opening_m\):", text, re.M)
    calls = re.findall(r"^\s*ungrasp_gripper_set_opening\(([-0-9.]+)\)", text, re.M)
    assert len(calls) >= 2
    assert float(calls[0]) == pytest.approx(traj.positions[0, 6], abs=1e-6)
    assert np.all(np.abs(np.diff([float(c) for c in calls])) > 1e-4 - 2e-6)  # 6-decimal rounding

    lines = [ln.strip() for ln in text.splitlines()]
    assert lines.index("def ungrasp_program():") < lines.index(next(ln for ln in lines if ln.startswith("movej(")))
    assert lines[-1] == "ungrasp_program()" and "stopj(2.0)" in lines
    first_servo = lines.index(servo_lines[0].strip())
    assert lines[first_servo - 1].startswith("#") or lines[first_servo - 1].startswith("movej")
    header = text.split("def ")[0]
    assert "ungrasp-ompl" in header and f"{n} servoj steps" in header and all(j in header for j in ARM_JOINTS)


def test_urscript_still_gripper_is_commanded_once(traj, tmp_path):
    traj.positions[:, 6] = 0.03
    export.write_urscript(traj, tmp_path / "t.urscript")
    assert len(re.findall(r"^\s*ungrasp_gripper_set_opening\(", (tmp_path / "t.urscript").read_text(), re.M)) == 1


def test_urscript_rejects_out_of_range_servo_parameters(traj, tmp_path):
    with pytest.raises(InputError) as e:
        export.write_urscript(traj, tmp_path / "t.urscript", lookahead_time=0.5)
    assert e.value.field == "lookahead_time"
    assert not (tmp_path / "t.urscript").exists()


def _no_temp_files(directory) -> bool:
    return not [p for p in directory.iterdir() if p.name.startswith(".")]


def test_export_all_writes_replaces_and_is_atomic(traj, tmp_path, monkeypatch):
    out = tmp_path / "new" / "dir"
    paths = export.export_all(traj, out)
    assert set(paths) == {"csv", "json", "ros2_arm", "ros2_gripper", "urscript"}
    assert {p.name for p in paths.values()} == {"trajectory.csv", "trajectory.json", "trajectory_ros2_arm.yaml",
                                               "trajectory_ros2_gripper.yaml", "trajectory.urscript"}
    assert all(p.parent == out and p.is_file() for p in paths.values())

    # A second, different (shorter) trajectory replaces every file whole.
    other = make_trajectory(n=80, duration=1.3, phase=0.7)
    assert export.export_all(other, out) == paths
    assert_same(other, export.read_csv(paths["csv"]))
    assert_same(other, export.read_json(paths["json"]))
    assert_same(columns(other, slice(0, 6)), export.read_ros2_yaml(paths["ros2_arm"]), time_tol=1e-9)
    assert_same(columns(other, slice(6, 7)), export.read_ros2_yaml(paths["ros2_gripper"]), time_tol=1e-9)
    assert len(export.read_urscript_servo_targets(paths["urscript"])) == math.floor(1.3 / 0.002) + 1
    assert _no_temp_files(out)

    # A failure while writing (after the temporary file exists) leaves the old file untouched.
    before = paths["ros2_arm"].read_bytes()

    def broken_dump(data, stream=None, **kwargs):
        stream.write("trajectory:\n  points: [")  # half-written
        raise OSError("disk full")

    monkeypatch.setattr(yaml, "dump", broken_dump)
    with pytest.raises(OSError, match="disk full"):
        export.export_all(traj, out)
    assert paths["ros2_arm"].read_bytes() == before
    assert_same(columns(other, slice(0, 6)), export.read_ros2_yaml(paths["ros2_arm"]), time_tol=1e-9)
    assert _no_temp_files(out)


@pytest.mark.parametrize("version", [2, 0, "1", None, "missing"])
def test_read_json_checks_schema_version(traj, tmp_path, version):
    path = tmp_path / "t.json"
    export.write_json(traj, path)
    doc = json.loads(path.read_text())
    if version == "missing":
        del doc["schema_version"]
    else:
        doc["schema_version"] = version
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError) as e:
        export.read_json(path)
    assert e.value.field == "schema_version"
    assert "schema_version" in str(e.value)


def test_ros2_points_are_written_as_pyyaml_writes_them():
    """write_ros2_yaml formats its points itself (speed); PyYAML is the oracle: for values of
    every kind (tiny, huge, negative, whole, 1e-05 that YAML 1.1 needs written 1.0e-05) the text
    equals yaml.dump's, and reads back to the same floats."""
    import yaml

    from ungrasp_ompl.robot.export import _YAML_DUMPER, _duration_msg, _yaml_points

    rng = np.random.default_rng(5)
    specials = [0.0, -0.0, 1.0, -2.0, 1e-05, -3e-300, 1.5e300, 123456789.0, 0.1, 2.0 ** -40]
    points = []
    for k in range(40):
        cols = [(rng.normal(size=7) * 10.0 ** rng.integers(-12, 12, size=7)).tolist() for _ in range(3)]
        cols[k % 3][k % 7] = specials[k % len(specials)]
        points.append((float(k) * 0.0173 + 1e-10 * k, *cols))
    doc = {"points": [{"positions": q, "velocities": dq, "accelerations": ddq, "effort": [],
                       "time_from_start": _duration_msg(t)} for t, q, dq, ddq in points]}
    oracle = yaml.dump(doc, Dumper=_YAML_DUMPER, sort_keys=False, default_flow_style=None, width=2**16)
    ours = _yaml_points(points)
    assert ours == "".join("  " + line + "\n" for line in oracle.splitlines())
    parsed = yaml.safe_load("trajectory:\n" + ours)["trajectory"]["points"]
    assert [p["positions"] for p in parsed] == [p[1] for p in points]
    assert _yaml_points([]) == "  points: []\n"


def test_ros2_goals_are_real_messages_each_controller_accepts(traj, tmp_path):
    """Each goal file, as `ros2 action send_goal` would fill it, builds a
    control_msgs/action/FollowJointTrajectory goal (rosbags' ROS 2 Humble type store), serialises
    to CDR and reads back with the joint names, sizes, times (1 ns) and values written; the arm's
    names exactly the UR driver's six joints, which its controller accepts, the gripper's its
    one joint, which the arm's controller refuses (as it refused the mixed goal)."""
    from ros2_goal import controller_refusals, round_trip, typestore

    store = typestore()
    traj.velocities[-1] = 0.0  # at rest at the end, as a planned trajectory is (else refused, below)
    paths = export.export_all(traj, tmp_path)
    goals = {}
    for part, cols in (("ros2_arm", slice(0, 6)), ("ros2_gripper", slice(6, 7))):
        goal = round_trip(store, yaml.safe_load(paths[part].read_text()))
        goals[part] = goal
        want = columns(traj, cols)
        assert list(goal.trajectory.joint_names) == list(want.joint_names)
        assert len(goal.trajectory.points) == len(traj.times)
        stamps = np.array([p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in goal.trajectory.points])
        np.testing.assert_allclose(stamps, traj.times, rtol=0, atol=1e-9)
        for field in ("positions", "velocities", "accelerations"):
            got = np.array([getattr(p, field) for p in goal.trajectory.points])
            assert got.shape == (len(traj.times), len(want.joint_names))
            np.testing.assert_array_equal(got, getattr(want, field))
        assert all(len(p.effort) == 0 for p in goal.trajectory.points)
        assert goal.trajectory.header.stamp.sec == 0 and goal.trajectory.header.stamp.nanosec == 0
    assert list(goals["ros2_arm"].trajectory.joint_names) == list(ARM_JOINTS)
    assert controller_refusals(goals["ros2_arm"], ARM_JOINTS) == []
    assert controller_refusals(goals["ros2_gripper"], (GRIPPER_JOINT,)) == []
    assert f"joint {GRIPPER_JOINT} is not the controller's" in controller_refusals(goals["ros2_gripper"], ARM_JOINTS)
    moving = make_trajectory()
    export.write_ros2_yaml(moving, tmp_path / "moving.yaml", "arm")
    refusals = controller_refusals(round_trip(store, yaml.safe_load((tmp_path / "moving.yaml").read_text())), ARM_JOINTS)
    assert refusals == [f"the last point's velocity of {j} is not zero" for j in ARM_JOINTS]


def test_ros2_goal_needs_its_joints(traj, tmp_path):
    arm_only = columns(traj, slice(0, 6))
    with pytest.raises(InputError) as e:
        export.write_ros2_yaml(arm_only, tmp_path / "g.yaml", "gripper")
    assert e.value.field == "joint_names" and GRIPPER_JOINT in e.value.reason
    assert not (tmp_path / "g.yaml").exists()
