"""ROS 2 messages built from the exported goal files with a real message library (rosbags' type
store, ROS 2 Humble), the way `ros2 action send_goal` fills a goal from YAML: every field given
is set (an unknown one, a wrong type or an integer out of range is an error), the others keep
their defaults. Then CDR serialisation, as the goal travels to the controller.

control_msgs is not in rosbags' Humble store: its FollowJointTrajectory goal and the two
tolerance messages are registered here from their Humble definitions (control_msgs 4.x)."""

from __future__ import annotations

from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_typestore, get_types_from_msg
from rosbags.typesys.base import Nodetype

GOAL = "control_msgs/action/FollowJointTrajectory_Goal"

_DEFINITIONS = {
    "control_msgs/msg/JointTolerance": "string name\nfloat64 position\nfloat64 velocity\nfloat64 acceleration\n",
    "control_msgs/msg/JointComponentTolerance": (
        "uint16 X_AXIS=1\nuint16 Y_AXIS=2\nuint16 Z_AXIS=3\nuint16 TRANSLATION=4\nuint16 ROTATION=5\n"
        "string joint_name\nuint16 component\nfloat64 position\nfloat64 velocity\nfloat64 acceleration\n"),
    GOAL: ("trajectory_msgs/JointTrajectory trajectory\n"
           "trajectory_msgs/MultiDOFJointTrajectory multi_dof_trajectory\n"
           "control_msgs/JointTolerance[] path_tolerance\n"
           "control_msgs/JointComponentTolerance[] component_path_tolerance\n"
           "control_msgs/JointTolerance[] goal_tolerance\n"
           "control_msgs/JointComponentTolerance[] component_goal_tolerance\n"
           "builtin_interfaces/Duration goal_time_tolerance\n"),
}
_INTS = {f"{u}int{b}": ((0, 2**b - 1) if u else (-(2 ** (b - 1)), 2 ** (b - 1) - 1))
         for b in (8, 16, 32, 64) for u in ("", "u")}
_INTS.update(byte=(0, 255), char=(0, 255), octet=(0, 255))
_FLOATS = {"float32": np.float32, "float64": np.float64}


def typestore():
    """The ROS 2 Humble type store with the FollowJointTrajectory goal registered."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    types: dict = {}
    for name, text in _DEFINITIONS.items():
        types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


def build(store, typename: str, doc: Any, where: str = ""):
    """The message typename with the fields of doc (a dict from YAML) set and the rest default;
    AssertionError naming the field for what `ros2 action send_goal` would refuse."""
    doc = {} if doc is None else doc
    assert isinstance(doc, dict), f"{where.rstrip('.') or typename}: a message must be a mapping, got {type(doc).__name__}"
    _, fields = store.fielddefs[typename]
    names = [name for name, _ in fields]
    unknown = sorted(set(doc) - set(names))
    assert not unknown, f"{where.rstrip('.') or typename}: {typename} has no field {', '.join(unknown)}"
    values = {name: _value(store, kind, detail, doc.get(name), name in doc, f"{where}{name}")
              for name, (kind, detail) in fields}
    return store.types[typename](**values)


def _value(store, kind, detail, value, given: bool, where: str):
    if kind is Nodetype.NAME:
        return build(store, detail, value if given else None, where + ".")
    if kind is Nodetype.BASE:
        return _base(detail[0], value, given, where)
    (sub_kind, sub_detail), size = detail
    items = value if given else []
    assert isinstance(items, list), f"{where}: a sequence must be a list, got {type(items).__name__}"
    if kind is Nodetype.ARRAY:
        assert len(items) == size, f"{where}: needs {size} items, got {len(items)}"
    if sub_kind is Nodetype.BASE and sub_detail[0] in _FLOATS:
        return np.array([_base(sub_detail[0], v, True, where) for v in items], dtype=_FLOATS[sub_detail[0]])
    if sub_kind is Nodetype.BASE and sub_detail[0] in _INTS:
        dtype = "uint8" if sub_detail[0] in ("byte", "char", "octet") else sub_detail[0]
        return np.array([_base(sub_detail[0], v, True, where) for v in items], dtype=dtype)
    return [_value(store, sub_kind, sub_detail, v, True, f"{where}[{k}]") for k, v in enumerate(items)]


def _base(typ: str, value, given: bool, where: str):
    if typ in _INTS:
        if not given:
            return 0
        assert isinstance(value, int) and not isinstance(value, bool), f"{where}: {typ} needs an integer, got {value!r}"
        lo, hi = _INTS[typ]
        assert lo <= value <= hi, f"{where}: {value} is outside {typ}'s range"
        return value
    if typ in _FLOATS:
        if not given:
            return 0.0
        assert isinstance(value, (int, float)) and not isinstance(value, bool), f"{where}: {typ} needs a number"
        return float(value)
    if typ == "bool":
        assert not given or isinstance(value, bool), f"{where}: bool needs true or false"
        return bool(value) if given else False
    assert typ == "string", typ
    assert not given or isinstance(value, str), f"{where}: string needs text, got {value!r}"
    return value if given else ""


def round_trip(store, doc: dict):
    """The goal doc as a FollowJointTrajectory goal, serialised to CDR and read back."""
    goal = build(store, GOAL, doc)
    raw = store.serialize_cdr(goal, GOAL)
    assert len(raw) > 0
    return store.deserialize_cdr(raw, GOAL)


def controller_refusals(goal, controller_joints: tuple[str, ...]) -> list[str]:
    """Why a joint_trajectory_controller owning controller_joints (the UR driver's
    scaled_joint_trajectory_controller is one) refuses the goal: the checks of its
    validate_trajectory_msg (ros2_controllers, joint_trajectory_controller.cpp) with its default
    parameters (no partial goals, no integration, a position interface, the last point at rest).
    Empty: accepted."""
    traj = goal.trajectory
    names = list(traj.joint_names)
    why = [] if len(names) == len(controller_joints) else [f"{len(names)} joints, the controller has "
                                                             f"{len(controller_joints)}"]
    why += [f"joint {j} is not the controller's" for j in names if j not in controller_joints]
    if not names or not traj.points:
        return why + ["no joint names or no points"]
    why += [f"the last point's velocity of {j} is not zero" for j, v in zip(names, traj.points[-1].velocities)
            if abs(v) > np.finfo(np.float32).eps]
    previous = None
    for k, p in enumerate(traj.points):
        t = p.time_from_start.sec * 1_000_000_000 + p.time_from_start.nanosec
        if previous is not None and t <= previous:
            why.append(f"point {k}: time_from_start does not increase")
        previous = t
        if len(p.positions) != len(names):
            why.append(f"point {k}: {len(p.positions)} positions for {len(names)} joints")
        for field in ("velocities", "accelerations"):
            if len(getattr(p, field)) not in (0, len(names)):
                why.append(f"point {k}: {len(getattr(p, field))} {field} for {len(names)} joints")
        if len(p.effort):
            why.append(f"point {k}: efforts need the effort command interface")
    return why
