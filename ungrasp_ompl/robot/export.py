"""Export a JointTrajectory for a controller: CSV, JSON, two ROS 2 FollowJointTrajectory goals
(YAML: the arm's six joints, and the gripper's opening apart) and a URScript servoj program for a
UR e-series arm.

Units everywhere: time in seconds; arm joints in rad, rad/s, rad/s^2; the gripper opening
in m, m/s, m/s^2 (a pincer's joint angle, ``gripper_angle``, in rad, rad/s, rad/s^2: the
trajectory's last joint says which). Every file is written atomically (ungrasp_ompl.io): after a failed write
the file at the path is still its previous self.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import re
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from ..errors import InputError
from ..io import parse_yaml, read_json_file, write_atomic, write_text_atomic
from .touch_off import TouchOff
from .trajectory import ARM_JOINTS, GRIPPER_JOINT, PINCER_JOINT, JointTrajectory

#: Version of the CSV/JSON/YAML/URScript layouts written here.
SCHEMA_VERSION = 1

# libyaml's C emitter when PyYAML has it (the pure-Python one is ~10x slower; io.parse_yaml reads)
_YAML_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
#: UR e-series control period (500 Hz), s: the servoj step of the URScript export.
CONTROL_PERIOD_S = 0.002

JSON_FORMAT = "ungrasp-ompl joint trajectory"
UNITS = {
    "time": "s",
    "arm_positions": "rad", "arm_velocities": "rad/s", "arm_accelerations": "rad/s^2",
    "gripper_positions": "m", "gripper_velocities": "m/s", "gripper_accelerations": "m/s^2",
}
#: A pincer's units (its last joint the joint angle, PINCER_JOINT).
PINCER_UNITS = {**UNITS, "gripper_positions": "rad", "gripper_velocities": "rad/s", "gripper_accelerations": "rad/s^2"}
_CSV_SUFFIXES = ("pos", "vel", "acc")
#: servoj limits from the URScript manual.
_LOOKAHEAD_RANGE_S = (0.03, 0.2)
_GAIN_RANGE = (100.0, 2000.0)
#: movej to the first pose: modest joint acceleration (rad/s^2) and speed (rad/s).
_MOVEJ_ACC, _MOVEJ_VEL = 1.0, 0.5
#: The URScript export commands the gripper again once its opening moved this far, m (a pincer's
#: angle: GRIPPER_RESEND_RAD, rad, 0.06 mm at a 60 mm joint radius).
GRIPPER_RESEND_M = 1e-4
GRIPPER_RESEND_RAD = 1e-3
_FILES = {"csv": "trajectory.csv", "json": "trajectory.json", "ros2_arm": "trajectory_ros2_arm.yaml",
          "ros2_gripper": "trajectory_ros2_gripper.yaml", "urscript": "trajectory.urscript"}

PathLike = str | os.PathLike[str]
Point = tuple[float, list[float], list[float], list[float]]


# --- shared helpers ----------------------------------------------------------------------

def is_pincer(traj: JointTrajectory) -> bool:
    """Whether the trajectory's gripper is a pincer: its last joint is PINCER_JOINT (rad)."""
    return bool(traj.joint_names) and traj.joint_names[-1] == PINCER_JOINT


def _num(x: float) -> str:
    """A float in full precision (round-trips exactly)."""
    return format(float(x), ".17g")


def _checked(traj: JointTrajectory, source: str | None = None) -> JointTrajectory:
    """traj itself after checking shapes, finiteness and strictly increasing times."""
    times = np.asarray(traj.times, dtype=float)
    n, m = len(times), len(traj.joint_names)
    if times.ndim != 1 or n == 0:
        raise InputError("times", "need a non-empty 1-D array", source)
    for name in ("positions", "velocities", "accelerations"):
        arr = np.asarray(getattr(traj, name), dtype=float)
        if arr.shape != (n, m):
            raise InputError(name, f"shape {arr.shape}, expected ({n}, {m}) (samples x joints)", source)
        if not np.all(np.isfinite(arr)):
            raise InputError(name, "contains NaN or infinity", source)
    if not np.all(np.isfinite(times)):
        raise InputError("times", "contains NaN or infinity", source)
    if np.any(np.diff(times) <= 0.0):
        raise InputError("times", "must be strictly increasing", source)
    return traj


def _make(times: Any, positions: Any, velocities: Any, accelerations: Any, joint_names: Sequence[str],
          segments: Iterable[tuple[str, int, int]] = (), source: str | None = None) -> JointTrajectory:
    """Build and check a JointTrajectory from what a reader parsed."""
    try:
        traj = JointTrajectory(times=np.asarray(times, dtype=float),
                               positions=np.asarray(positions, dtype=float).reshape(len(times), -1),
                               velocities=np.asarray(velocities, dtype=float).reshape(len(times), -1),
                               accelerations=np.asarray(accelerations, dtype=float).reshape(len(times), -1),
                               joint_names=tuple(str(j) for j in joint_names),
                               segments=[(str(s), int(a), int(b)) for s, a, b in segments])
    except (TypeError, ValueError):
        raise InputError("points", f"must be a table of numbers, one row of {len(joint_names)} per sample "
                         "(positions, velocities, accelerations), and segments names with sample indices",
                         source) from None
    return _checked(traj, source)


def _points(traj: JointTrajectory) -> list[Point]:
    """(time, positions, velocities, accelerations) per sample, as plain Python floats."""
    _checked(traj)
    return list(zip(np.asarray(traj.times, dtype=float).tolist(),
                    np.asarray(traj.positions, dtype=float).tolist(),
                    np.asarray(traj.velocities, dtype=float).tolist(),
                    np.asarray(traj.accelerations, dtype=float).tolist()))


def _field(doc: Any, key: str, kind: type | tuple[type, ...], source: str, where: str = "") -> Any:
    """doc[key], checked to be a kind (bool is not a number); InputError naming the field otherwise."""
    name = f"{where}{key}"
    if not isinstance(doc, dict) or key not in doc:
        raise InputError(name, "missing", source)
    value = doc[key]
    if not isinstance(value, kind) or isinstance(value, bool):
        kinds = kind if isinstance(kind, tuple) else (kind,)
        raise InputError(name, f"expected {' or '.join(k.__name__ for k in kinds)}, got {type(value).__name__}",
                         source)
    return value


# --- CSV -----------------------------------------------------------------------------------

def csv_header(joint_names: Sequence[str]) -> list[str]:
    """`time_s`, then `<joint>_pos`, `<joint>_vel`, `<joint>_acc` for each joint in order."""
    return ["time_s"] + [f"{j}_{s}" for j in joint_names for s in _CSV_SUFFIXES]


def write_csv(traj: JointTrajectory, path: PathLike) -> None:
    """One row per sample: time (s), then position, velocity, acceleration of each joint
    (rad, rad/s, rad/s^2; the gripper in m, m/s, m/s^2), full float precision."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(csv_header(traj.joint_names))
    for t, q, dq, ddq in _points(traj):
        w.writerow([_num(t)] + [_num(v) for triple in zip(q, dq, ddq) for v in triple])
    write_text_atomic(path, buf.getvalue())


def read_csv(path: PathLike) -> JointTrajectory:
    """Read a file written by write_csv (segments are not stored in CSV: empty)."""
    source = str(path)
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f) if r]
    if not rows:
        raise InputError("header", "empty file", source)
    header = rows[0]
    if header[0] != "time_s" or (len(header) - 1) % 3 or len(header) < 4:
        raise InputError("header", "expected time_s then <joint>_pos,_vel,_acc columns", source)
    joints = [c[: -len("_pos")] for c in header[1::3]]
    if header != csv_header(joints):
        raise InputError("header", "expected time_s then <joint>_pos,_vel,_acc columns", source)
    try:
        table = np.array([[float(v) for v in r] for r in rows[1:]], dtype=float)
    except ValueError as e:
        raise InputError("rows", str(e), source) from None
    if table.ndim != 2 or table.shape[1] != len(header):
        raise InputError("rows", f"each row needs {len(header)} values", source)
    return _make(table[:, 0], table[:, 1::3], table[:, 2::3], table[:, 3::3], joints, (), source)


# --- JSON ----------------------------------------------------------------------------------

def write_json(traj: JointTrajectory, path: PathLike) -> None:
    """A self-describing JSON document (schema_version, units, joint names, segments, points);
    times in s, arm joints in rad, rad/s, rad/s^2, the gripper in m, m/s, m/s^2."""
    head = {
        "schema_version": SCHEMA_VERSION,
        "format": JSON_FORMAT,
        "units": PINCER_UNITS if is_pincer(traj) else UNITS,
        "joint_names": list(traj.joint_names),
        "segments": [{"name": s, "start": int(a), "end": int(b)} for s, a, b in traj.segments],
    }
    # one point a line: json's compiled encoder writes each (an indented document goes through its
    # pure-Python encoder, most of the export's time)
    points = ",\n".join("    " + json.dumps({"time_s": t, "positions": q, "velocities": dq, "accelerations": ddq},
                                           allow_nan=False) for t, q, dq, ddq in _points(traj))
    text = json.dumps(head, indent=2, allow_nan=False)
    write_text_atomic(path, text[:-2] + f',\n  "points": [\n{points}\n  ]\n}}\n')


def read_json(path: PathLike) -> JointTrajectory:
    """Read a file written by write_json; InputError("schema_version", ...) unless it is
    SCHEMA_VERSION, InputError naming the field for other malformed content."""
    source = str(path)
    doc = read_json_file(path, "trajectory.json")
    if not isinstance(doc, dict) or "schema_version" not in doc:
        raise InputError("schema_version", f"missing; expected {SCHEMA_VERSION}", source)
    version = doc["schema_version"]
    if type(version) is not int or version != SCHEMA_VERSION:
        raise InputError("schema_version", f"is {version!r}; this reader understands {SCHEMA_VERSION}", source)
    joints = _field(doc, "joint_names", list, source)
    segments = [(_field(s, "name", str, source, "segments."), _field(s, "start", int, source, "segments."),
                 _field(s, "end", int, source, "segments."))
                for s in _field(doc, "segments", list, source)]
    points = _field(doc, "points", list, source)
    cols = {k: [_field(p, k, list, source, "points.") for p in points]
            for k in ("positions", "velocities", "accelerations")}
    times = [_field(p, "time_s", (int, float), source, "points.") for p in points]
    return _make(times, cols["positions"], cols["velocities"], cols["accelerations"], joints, segments, source)


# --- ROS 2 ---------------------------------------------------------------------------------

def _duration_msg(t: float) -> dict[str, int]:
    """builtin_interfaces/Duration of t seconds: sec (int, floor) and nanosec in [0, 1e9)."""
    sec = math.floor(t)
    nanosec = round((t - sec) * 1e9)
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    return {"sec": int(sec), "nanosec": int(nanosec)}


#: What each ROS 2 goal file is for: its joints and the lines that say which controller takes it.
ROS2_GOALS = {
    "arm": (ARM_JOINTS, (
        "# The UR arm's six joints only (rad, rad/s, rad/s^2), as the UR ROS 2 driver's\n"
        "# scaled_joint_trajectory_controller (or joint_trajectory_controller) owns them, for its\n"
        "# action /scaled_joint_trajectory_controller/follow_joint_trajectory. The first point is the\n"
        "# arm's home pose (robot.home_deg): move the arm there first.\n")),
    "gripper": ((GRIPPER_JOINT,), (
        f"# The gripper alone: '{GRIPPER_JOINT}', the distance between the digit faces (m, m/s, m/s^2),\n"
        "# for a joint_trajectory_controller/JointTrajectoryController that commands the gripper's\n"
        f"# position interface (joints: [{GRIPPER_JOINT}]; a gripper whose joint is named or scaled\n"
        "# otherwise needs its name and units here). It follows the opening over time, which a\n"
        "# GripperCommand action (one target) cannot.\n")),
}
#: A pincer's gripper goal: its joint angle.
_PINCER_GOAL = ((PINCER_JOINT,), (
    f"# The pincer alone: '{PINCER_JOINT}', the angle its digits are turned apart from closed (rad,\n"
    "# rad/s, rad/s^2), for a joint_trajectory_controller/JointTrajectoryController that commands\n"
    f"# the joint's position interface (joints: [{PINCER_JOINT}]; a joint named or zeroed otherwise\n"
    "# needs its name and offset here). It follows the angle over time, which a GripperCommand\n"
    "# action (one target) cannot.\n"))
_SEND_NOTE = (
    "# Send it as `ros2 action send_goal` does (rosidl_runtime_py.set_message_fields on a\n"
    "# FollowJointTrajectory.Goal from this YAML, then an rclpy ActionClient); a long goal exceeds\n"
    "# what one shell argument may hold. Arm and gripper goals share their sample times: to start\n"
    "# them together give both the same future trajectory.header.stamp (0: each starts on arrival).\n")


def write_ros2_yaml(traj: JointTrajectory, path: PathLike, part: str) -> None:
    """The goal of a ROS 2 control_msgs/action/FollowJointTrajectory for one controller as YAML:
    part "arm" (ARM_JOINTS, rad, rad/s, rad/s^2) or "gripper" (GRIPPER_JOINT, m, m/s, m/s^2; a
    pincer's PINCER_JOINT, rad, rad/s, rad/s^2), a trajectory_msgs/JointTrajectory with every
    sample, time_from_start the sample time (s)."""
    if part not in ROS2_GOALS:
        raise InputError("part", f"must be one of {', '.join(ROS2_GOALS)}, got {part!r}")
    joints, note = _PINCER_GOAL if part == "gripper" and is_pincer(traj) else ROS2_GOALS[part]
    missing = [j for j in joints if j not in traj.joint_names]
    if missing:
        raise InputError("joint_names", f"lack {', '.join(missing)} for the {part}'s ROS 2 goal")
    cols = [traj.joint_names.index(j) for j in joints]
    head = {"trajectory": {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""},
                           "joint_names": list(joints)}}
    points = [(t, [q[c] for c in cols], [dq[c] for c in cols], [ddq[c] for c in cols])
              for t, q, dq, ddq in _points(traj)]
    comment = (
        f"# control_msgs/action/FollowJointTrajectory goal, generated by ungrasp-ompl"
        f" (export schema version {SCHEMA_VERSION}).\n" + note + _SEND_NOTE
        + "# Segments (name: start..end sample index): "
        + (", ".join(f"{s}: {a}..{b}" for s, a, b in traj.segments) or "none") + "\n")

    def write(tmp: str) -> None:
        with open(tmp, "w") as f:
            f.write(comment)
            yaml.dump(head, f, Dumper=_YAML_DUMPER, sort_keys=False, default_flow_style=None, width=2**16)
            f.write(_yaml_points(points))

    write_atomic(path, write)


def _yaml_float(x: float) -> str:
    """A float as PyYAML's representer writes it (YAML 1.1 wants a '.' in 1.0e-05)."""
    if x != x:
        return ".nan"
    if math.isinf(x):
        return ".inf" if x > 0 else "-.inf"
    text = repr(x).lower()
    return text.replace("e", ".0e", 1) if "." not in text and "e" in text else text


def _yaml_points(points: list[Point]) -> str:
    """The points of write_ros2_yaml's message, indented under its trajectory, in the text PyYAML
    would write (a test holds them equal); written directly, as PyYAML's representer takes a
    quarter of a second for a thousand samples."""
    if not points:
        return "  points: []\n"

    def row(values: list[float]) -> str:
        return "[" + ", ".join(map(_yaml_float, values)) + "]"

    lines = ["  points:"]
    for t, q, dq, ddq in points:
        stamp = _duration_msg(t)
        lines += [f"  - positions: {row(q)}", f"    velocities: {row(dq)}", f"    accelerations: {row(ddq)}",
                  "    effort: []", f"    time_from_start: {{sec: {stamp['sec']}, nanosec: {stamp['nanosec']}}}"]
    return "\n".join(lines) + "\n"


def read_ros2_yaml(path: PathLike) -> JointTrajectory:
    """Read a goal written by write_ros2_yaml (its joints only): times (s) from time_from_start
    sec + nanosec*1e-9."""
    source = str(path)
    try:
        doc = parse_yaml(Path(path).read_text())
    except yaml.YAMLError as e:
        raise InputError("yaml", str(e), source) from None
    msg = _field(doc, "trajectory", dict, source)
    joints = _field(msg, "joint_names", list, source, "trajectory.")
    points = _field(msg, "points", list, source, "trajectory.")
    where = "trajectory.points."
    cols = {k: [_field(p, k, list, source, where) for p in points]
            for k in ("positions", "velocities", "accelerations")}
    stamps = [_field(p, "time_from_start", dict, source, where) for p in points]
    times = [_field(d, "sec", int, source, where + "time_from_start.")
             + _field(d, "nanosec", int, source, where + "time_from_start.") * 1e-9 for d in stamps]
    return _make(times, cols["positions"], cols["velocities"], cols["accelerations"], joints, (), source)


# --- URScript ------------------------------------------------------------------------------

def servo_times(traj: JointTrajectory, period: float = CONTROL_PERIOD_S) -> NDArray[np.float64]:
    """Times (s) of the servo steps: t0 + k*period for k = 0 .. floor(duration/period),
    the last clipped to the trajectory's end (a 1e-9 tolerance absorbs float rounding
    of durations that are a whole number of periods)."""
    n = math.floor(traj.duration / period + 1e-9) + 1
    t0 = float(traj.times[0])
    return np.minimum(t0 + period * np.arange(n), float(traj.times[-1]))


def _resample(traj: JointTrajectory, times: NDArray[np.float64]) -> NDArray[np.float64]:
    """Positions of all joints at the given times by linear interpolation, (len(times), joints)."""
    return np.column_stack([np.interp(times, traj.times, traj.positions[:, j])
                            for j in range(traj.positions.shape[1])])


def _joint_list(q: Iterable[float]) -> str:
    return "[" + ", ".join(f"{v:.6f}" for v in q) + "]"


_PINCER_FUNCTION = """\
  # Gripper hook: command the pincer's joint angle, angle_rad in radians from closed.
  # PLACEHOLDER: integrators replace the body with their gripper's call, e.g. a message over
  # a socket to its joint's position controller (convert radians to the joint's own units and
  # zero there). It is called between servoj steps, so it must not block: return within the
  # 2 ms control period (send the command, or hand it to a thread), never wait for the motion.
  def ungrasp_gripper_set_angle(angle_rad):
    textmsg("gripper angle ", angle_rad)
  end
"""

_GRIPPER_FUNCTION = """\
  # Gripper hook: command the distance between the digit faces, opening_m in metres.
  # PLACEHOLDER: integrators replace the body with their gripper's call, e.g. the
  # RH-P12-RN URCap's command or a message over a socket to its Dynamixel controller
  # (convert metres to the gripper's own units there). It is called between servoj
  # steps, so it must not block: return within the 2 ms control period (send the
  # command, or hand it to a thread), never wait for the motion to finish.
  def ungrasp_gripper_set_opening(opening_m):
    textmsg("gripper opening ", opening_m)
  end
"""


def write_urscript(traj: JointTrajectory, path: PathLike, lookahead_time: float = 0.1,
                   gain: float = 300) -> None:
    """A URScript program that streams the arm's positions (rad), linearly resampled every
    CONTROL_PERIOD_S (s), with servoj, and calls ungrasp_gripper_set_opening(m) whenever the
    commanded opening has moved more than GRIPPER_RESEND_M (and once at the start); a pincer's
    ungrasp_gripper_set_angle(rad), whenever its angle has moved more than GRIPPER_RESEND_RAD.
    lookahead_time in s (0.03..0.2), gain 100..2000 (servoj's ranges). The trajectory's
    joints must be ARM_JOINTS then GRIPPER_JOINT (or PINCER_JOINT)."""
    _checked(traj)
    pincer = is_pincer(traj)
    if not pincer and tuple(traj.joint_names) != ARM_JOINTS + (GRIPPER_JOINT,):
        raise InputError("joint_names", f"URScript export needs {ARM_JOINTS + (GRIPPER_JOINT,)}")
    if pincer and tuple(traj.joint_names) != ARM_JOINTS + (PINCER_JOINT,):
        raise InputError("joint_names", f"URScript export needs {ARM_JOINTS + (PINCER_JOINT,)}")
    if not _LOOKAHEAD_RANGE_S[0] <= lookahead_time <= _LOOKAHEAD_RANGE_S[1]:
        raise InputError("lookahead_time", f"{lookahead_time} s is outside servoj's {_LOOKAHEAD_RANGE_S}")
    if not _GAIN_RANGE[0] <= gain <= _GAIN_RANGE[1]:
        raise InputError("gain", f"{gain} is outside servoj's {_GAIN_RANGE}")
    times = servo_times(traj)
    samples = _resample(traj, times)
    arm, opening = samples[:, : len(ARM_JOINTS)], samples[:, len(ARM_JOINTS)]
    servo = f"0, 0, {CONTROL_PERIOD_S:g}, {lookahead_time:g}, {gain:g})"

    setter, resend = ("ungrasp_gripper_set_angle", GRIPPER_RESEND_RAD) if pincer else \
        ("ungrasp_gripper_set_opening", GRIPPER_RESEND_M)
    lines = [
        f"# Generated by ungrasp-ompl (export schema version {SCHEMA_VERSION}).",
        f"# Duration {traj.duration:.6f} s: {len(times)} servoj steps of {CONTROL_PERIOD_S:g} s"
        f" ({1 / CONTROL_PERIOD_S:g} Hz), lookahead {lookahead_time:g} s, gain {gain:g}.",
        f"# Arm joints (rad): {', '.join(ARM_JOINTS)}; gripper: "
        + (f"{PINCER_JOINT} (rad)." if pincer else f"{GRIPPER_JOINT} (m)."),
        "def ungrasp_program():",
        (_PINCER_FUNCTION if pincer else _GRIPPER_FUNCTION).rstrip("\n"),
        "",
        "  # Set the gripper to the plan's first " + ("angle" if pincer else "opening")
        + ", then move (joint space) to the first pose.",
        f"  {setter}({opening[0]:.6f})",
        f"  movej({_joint_list(arm[0])}, a={_MOVEJ_ACC:g}, v={_MOVEJ_VEL:g})",
        "  # Stream the trajectory, one servoj per control period.",
    ]
    sent = opening[0]
    for q, x in zip(arm, opening):
        if abs(x - sent) > resend:
            lines.append(f"  {setter}({x:.6f})")
            sent = x
        lines.append(f"  servoj({_joint_list(q)}, {servo}")
    lines += ["  stopj(2.0)", "end", "", "ungrasp_program()", ""]
    write_text_atomic(path, "\n".join(lines))


_SERVOJ = re.compile(r"^\s*servoj\(\[([^\]]*)\]")


def read_urscript_servo_targets(path: PathLike) -> NDArray[np.float64]:
    """The arm targets (rad) of the servoj lines of a write_urscript program, (M, 6)."""
    rows = [[float(v) for v in m.group(1).split(",")]
            for m in map(_SERVOJ.match, Path(path).read_text().splitlines()) if m]
    return np.array(rows, dtype=float).reshape(-1, len(ARM_JOINTS))


def write_touch_off_urscript(probe: TouchOff, path: PathLike) -> None:
    """A URScript program for the touch-off before the plan (robot.touch_off), with the options the
    simulator's probe uses (probe.options: TouchOffOptions): with the hand empty, it sets the start
    pinch's opening (a pincer's joint angle), moves to probe.options.lift above the start pinch, zeroes the force sensor,
    lowers the hand straight down at probe.options.speed, one control period at a time, until the
    vertical force reading reaches probe.options.threshold in magnitude (or halts once it has gone
    probe.options.overtravel past the expected touch), takes the commanded pose there less the
    hand's give at the threshold (probe.deflection, the cell's calibration), goes back up and
    reports how much higher than the scene has it the table stands (m) and the robot.base height
    (m) that corrects it."""
    o = probe.options
    q0 = _joint_list(probe.start_joints)
    lines = [
        f"# Generated by ungrasp-ompl (export schema version {SCHEMA_VERSION}): the touch-off before the plan.",
        "# Run it with the hand EMPTY. It reports how much higher than the scene has it the table stands,",
        "# and the robot.base z that corrects it: set that in the scene and export the plan again.",
        f"# A table where the scene has it is met {probe.expected_descent:.6f} m below the probe's start",
        f"# ({o.lift:g} m above the start pinch, where the digits' lowest point is {probe.clearance:.6f} m above the table).",
        f"# The descent stops at the first {o.period:g} s period whose vertical force reading reaches {o.threshold:g} N;",
        "# the hand has then gone on past the first touch by the give of the digits at that force: deflection",
        "# below, the cell's calibration, measured once by running this program over a surface of known height",
        "# with deflection = 0 (the offset it then reports is minus the give). 0: not calibrated.",
        "def ungrasp_touch_off():",
        (_PINCER_FUNCTION if probe.pincer else _GRIPPER_FUNCTION).rstrip("\n"),
        "",
        f"  deflection = {probe.deflection:.6f}",
        f"  ungrasp_gripper_set_{'angle' if probe.pincer else 'opening'}({probe.opening:.6f})",
        f"  q_pinch = {q0}",
        f"  p_top = pose_trans(p[0, 0, {o.lift:g}, 0, 0, 0], get_forward_kin(q_pinch))",
        f"  movej(get_inverse_kin(p_top, qnear=q_pinch), a={_MOVEJ_ACC:g}, v={_MOVEJ_VEL:g})",
        "  sleep(0.5)",
        "  zero_ftsensor()",
        "  p_top = get_target_tcp_pose()",
        "  reading = 0",
        f"  while norm(reading) < {o.threshold:g}:",
        f"    if p_top[2] - get_target_tcp_pose()[2] > {probe.expected_descent + o.overtravel:.6f}:",
        "      stopl(3)",
        "      popup(\"ungrasp touch-off: no table within reach\", \"ungrasp touch-off\", error=True, blocking=True)",
        "      halt",
        "    end",
        f"    speedl([0, 0, {-o.speed:g}, 0, 0, 0], a=0.5, t={o.period:g})",
        "    reading = get_tcp_force()[2]",
        "  end",
        "  p_stop = get_target_tcp_pose()",
        "  stopl(3)",
        "  movel(p_top, a=0.5, v=0.01)",
        f"  offset = {probe.expected_descent:.6f} - (p_top[2] - p_stop[2] - deflection)",
        "  textmsg(\"ungrasp touch-off: the table is higher than the scene has it by (m) \", offset)",
        f"  textmsg(\"ungrasp touch-off: set robot.base.position z (m) to \", {probe.base_z:.6f} - offset)",
        "end",
        "",
        "ungrasp_touch_off()",
        "",
    ]
    write_text_atomic(path, "\n".join(lines))


# --- all -----------------------------------------------------------------------------------

def export_all(traj: JointTrajectory, directory: PathLike, probe: TouchOff | None = None) -> dict[str, Path]:
    """Write trajectory.csv, trajectory.json, trajectory_ros2_arm.yaml, trajectory_ros2_gripper.yaml
    and trajectory.urscript into directory (created if needed), and with a probe (robot.touch_off)
    touch_off.urscript; returns their paths by kind ("csv", "json", "ros2_arm", "ros2_gripper",
    "urscript", "touch_off"). Each file is replaced atomically."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    writers = {"csv": write_csv, "json": write_json,
               "ros2_arm": lambda t, p: write_ros2_yaml(t, p, "arm"),
               "ros2_gripper": lambda t, p: write_ros2_yaml(t, p, "gripper"), "urscript": write_urscript}
    paths = {kind: directory / name for kind, name in _FILES.items()}
    for kind, write in writers.items():
        write(traj, paths[kind])
    if probe is not None:
        paths["touch_off"] = directory / "touch_off.urscript"
        write_touch_off_urscript(probe, paths["touch_off"])
    return paths
