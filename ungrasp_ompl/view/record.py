"""What the 3D view needs besides the joint trajectory: ``view_scene.json``.

``plan --export DIR``, ``tile --out DIR`` and ``simulate --out DIR`` write it beside the trajectory.
It holds the arm's base pose and the gripper (to rebuild the robot model; a pincer's links too,
``robot.pincer``: mechanics.pincer.PincerLinks in m and rad, absent for the parallel jaws), the
fixed bodies on the table (a layout's frame walls; obstacles), and for each object put down its
outline's prism and its planned pose over the trajectory's time:

* hidden until ``appear_s`` (the start of its approach: it is handed over at the home pose);
* carried rigidly in the pinch until ``carry_end_s``: body pose = palm pose (forward kinematics of
  the trajectory) @ ``grip``;
* afterwards tilted about G by theta(t) (``tilt_times_s``, ``tilt_rad``, linear in between, held
  after the last): body pose = target @ Ry(-theta) (``sim.setup.tilted``). theta follows the plan's
  states along the primitives (each trajectory sample is matched to the planned palm path), falls
  to 0 during the termination (the released object settles flat) and stays 0 afterwards.

Frames and units: world frame (x, y on the table, z up, the table's top at z = 0), metres, radians,
seconds of trajectory time. An object's body frame is the manipulation plane's frame at its target
(origin at G on the table, x toward B, z up); its prism spans z in [0, thickness].
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..io import read_versioned_json, write_text_atomic
from ..mechanics.pincer import PincerLinks
from ..robot.model import GripperSpec, load_ur5e, tcp_pose
from ..robot.pipeline import aimed_frame, hand_offsets
from ..robot.placement import densify, palm_poses
from ..robot.trajectory import JointTrajectory

RECORD_FILE = "view_scene.json"
FORMAT = "ungrasp-ompl view scene"
SCHEMA_VERSION = 1
KINDS = ("plan", "tiling", "simulation")
#: Obstacles are planar boxes extruded through the manipulation plane; the view draws them this
#: deep across the plane (m).
OBSTACLE_DEPTH = 0.1
#: The digits' profile the view draws (scene.digits fields, over l; the record holds them in m).
DIGIT_KEYS = ("thumb_tip_thickness", "thumb_base_thickness", "finger_tip_thickness", "finger_base_thickness",
              "finger_tip_radius")
#: Phases of a placement that are not primitives (robot.pipeline's segment names).
NON_PRIMITIVES = ("return", "approach", "press", "termination", "retreat")
#: A pincer's links in the record (robot.pincer): mechanics.pincer.PincerLinks' fields, m and rad.
PINCER_KEYS = ("radius", "offset", "thumb_reach", "tip_radius", "closed_angle", "max_angle", "joint_torque")

PathLike = str | os.PathLike[str]


@dataclass
class PieceRecord:
    """One object put down (see the module docstring for the pose rule)."""

    name: str
    prefix: str  #: its segments' prefix in the trajectory ('' for one plan, 'square/' in a tiling)
    outline: NDArray[np.float64]  #: (N, 2) m, body frame
    thickness: float  #: m
    target: NDArray[np.float64]  #: 4x4 world pose of the body frame at the target
    appear_s: float
    carry_end_s: float
    grip: NDArray[np.float64]  #: 4x4 body pose in the palm frame while carried
    tilt_times_s: NDArray[np.float64]
    tilt_rad: NDArray[np.float64]

    def poses(self, times: NDArray, palm: NDArray) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """World body poses (T, 4, 4) and visibility (T,) at times (T,) s, given the palm poses
        (T, 4, 4) at those times."""
        from ..sim.setup import tilted  # the simulator's modules (scipy.special): loaded when poses are asked for

        times = np.asarray(times, dtype=float)
        out = np.empty((len(times), 4, 4))
        theta = np.interp(times, self.tilt_times_s, self.tilt_rad)
        for i, t in enumerate(times):
            out[i] = palm[i] @ self.grip if t <= self.carry_end_s else tilted(self.target, float(theta[i]))
        return out, times >= self.appear_s - 1e-9


@dataclass
class SolidRecord:
    """A fixed convex body: its vertices (N, 3) in the world, m. kind: 'solid' (a frame's wall, a
    body of the scene) or 'obstacle' (a planar obstacle, drawn OBSTACLE_DEPTH deep)."""

    name: str
    vertices: NDArray[np.float64]
    kind: str = "solid"


@dataclass
class ViewRecord:
    """The contents of view_scene.json."""

    kind: str  #: plan, tiling or simulation
    base: NDArray[np.float64]  #: 4x4 world pose of the arm's base frame
    gripper: GripperSpec
    solids: list[SolidRecord] = field(default_factory=list)
    pieces: list[PieceRecord] = field(default_factory=list)
    title: str = ""
    #: the digits' profile (m): thumb_tip_thickness, thumb_base_thickness, finger_tip_thickness,
    #: finger_base_thickness, finger_tip_radius; None draws the robot model's digit boxes
    digits: dict[str, float] | None = None
    #: a pincer's links (m, rad): its digits turn on one joint; None: the parallel jaws
    pincer: PincerLinks | None = None

    def to_dict(self) -> dict:
        def r(a: Any) -> Any:
            return np.round(np.asarray(a, dtype=float), 9).tolist()

        robot = {"base": r(self.base), "gripper": {k: float(v) for k, v in self.gripper.__dict__.items()},
                 "digits": self.digits}
        if self.pincer is not None:
            robot["pincer"] = {k: float(getattr(self.pincer, k)) for k in PINCER_KEYS}
        return {
            "format": FORMAT, "schema_version": SCHEMA_VERSION, "kind": self.kind, "title": self.title,
            "units": {"length": "m", "angle": "rad", "time": "s (trajectory time)"},
            "robot": robot,
            "solids": [{"name": s.name, "kind": s.kind, "vertices": r(s.vertices)} for s in self.solids],
            "pieces": [{"name": p.name, "prefix": p.prefix, "outline": r(p.outline), "thickness": float(p.thickness),
                        "target": r(p.target), "appear_s": float(p.appear_s), "carry_end_s": float(p.carry_end_s),
                        "grip": r(p.grip), "tilt_times_s": r(p.tilt_times_s), "tilt_rad": r(p.tilt_rad)}
                       for p in self.pieces],
        }


# --- building -------------------------------------------------------------------------------

def build_record(jobs: list, execution: Any, labels: list[str] | None = None, kind: str = "plan") -> ViewRecord:
    """The view record of an executed plan or sequence of plans.

    jobs: [(Scene, Plan)] as given to robot.pipeline.execute_sequence; execution: its Execution;
    labels: the segment labels it was given (a tiling's piece names), None for one plan.
    """
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    traj, robot = execution.trajectory, execution.robot
    first = jobs[0][0]
    solids = [SolidRecord(s.name, np.asarray(s.vertices, dtype=float)) for s in first.solids]
    seen = set()
    for scene, _ in jobs:
        for box in scene.obstacles:
            if box.name not in seen:
                seen.add(box.name)
                solids.append(SolidRecord(box.name, _obstacle_corners(box, scene.plane_frame()), "obstacle"))
    aims = execution.aims or [(0.0, 0.0)] * len(jobs)
    pieces = [_piece(scene, plan, traj, robot, f"{labels[k]}/" if labels else "", aims[k])
              for k, (scene, plan) in enumerate(jobs)]
    title = f"{len(jobs)} pieces" if labels else first.name
    l, dg = first.object_length, first.digits
    digits = {k: float(getattr(dg, k) * l) for k in DIGIT_KEYS}
    return ViewRecord(kind, robot.base.copy(), robot.gripper, solids, pieces, title, digits, robot.pincer)


def write_view_record(directory: PathLike, jobs: list, execution: Any, labels: list[str] | None = None,
                      kind: str = "plan") -> Path:
    """Build the record (build_record) and write it atomically to directory/view_scene.json."""
    path = Path(directory) / RECORD_FILE
    write_text_atomic(path, json.dumps(build_record(jobs, execution, labels, kind).to_dict()) + "\n")
    return path


def _obstacle_corners(box: Any, frame: NDArray) -> NDArray[np.float64]:
    """World corners (8, 3) of a planar obstacle box (x, z in the plane), OBSTACLE_DEPTH across it."""
    half = OBSTACLE_DEPTH / 2
    local = np.array([[x, y, z] for x in (box.lo[0], box.hi[0]) for y in (-half, half) for z in (box.lo[1], box.hi[1])])
    return local @ frame[:3, :3].T + frame[:3, 3]


def _segments(traj: JointTrajectory, prefix: str) -> list[tuple[str, int, int]]:
    return [(n[len(prefix):], a, b) for n, a, b in traj.segments if n.startswith(prefix)
            and (prefix or "/" not in n)]


def _piece(scene: Any, plan: Any, traj: JointTrajectory, robot: Any, prefix: str,
           aim: tuple[float, float] = (0.0, 0.0)) -> PieceRecord:
    """The record of one object: its prism, target, and planned pose along traj (module docstring),
    in the plane's frame shifted by aim as the hand ran it (robot.pipeline.aimed_frame)."""
    from ..sim.setup import object_outline, tilted  # the simulator's modules (scipy.special), as in poses

    segs = _segments(traj, prefix)
    approach = next(s for s in segs if s[0] == "approach")
    prims = [s for s in segs if s[0] not in NON_PRIMITIVES]
    term = next((s for s in segs if s[0] == "termination"), None)
    frame = aimed_frame(scene, aim)
    states, dense = densify(plan)
    if len(prims) != len(dense):
        raise ValueError(f"the trajectory has {len(prims)} primitives for {scene.name}, the plan {len(dense)}")
    # the hand runs the plan as much lower as a start press took it; the object stays as planned
    palms, _ = palm_poses(scene, states, frame, robot.gripper.thumb_length)
    palms[:, :3, 3] += hand_offsets(scene, dense, len(states))
    grip = np.linalg.inv(palm_poses(scene, states[:1], frame, robot.gripper.thumb_length)[0][0]) @ tilted(
        frame, float(states[0, 0]))
    times, thetas = [float(traj.times[approach[2]])], [float(states[0, 0])]
    for (_, a, b), (_, first, last) in zip(prims, dense):
        path = _features(palms[first:last + 1])
        here = _features(np.array([tcp_pose(robot, traj.positions[i, :6]) for i in range(a + 1, b + 1)]))
        param = _project(here, path)
        times += traj.times[a + 1:b + 1].tolist()
        thetas += np.interp(param, np.arange(last - first + 1), states[first:last + 1, 0]).tolist()
    if term is not None:  # released, the object settles flat by the end of the termination
        times.append(float(traj.times[term[2]]))
        thetas.append(0.0)
    return PieceRecord(scene.name, prefix, object_outline(scene), float(scene.object_thickness), frame.copy(),
                       float(traj.times[approach[1]]), float(traj.times[approach[2]]), grip,
                       np.array(times), np.array(thetas))


def _features(poses: NDArray) -> NDArray[np.float64]:
    """(N, 9) points that pin down palm poses (N, 4, 4): the origin and points 5 cm along x and z (m)."""
    o = poses[:, :3, 3]
    return np.hstack([o, o + 0.05 * poses[:, :3, 0], o + 0.05 * poses[:, :3, 2]])


def _project(points: NDArray, polyline: NDArray) -> NDArray[np.float64]:
    """For each point (N, D) the fractional vertex index (N,) of its nearest point on polyline (M, D)."""
    if len(polyline) < 2:
        return np.zeros(len(points))
    a, ab = polyline[:-1], np.diff(polyline, axis=0)
    diff = points[:, None, :] - a[None]
    t = np.clip(np.einsum("nmd,md->nm", diff, ab) / np.maximum(np.einsum("md,md->m", ab, ab), 1e-30), 0.0, 1.0)
    dist = np.linalg.norm(diff - t[..., None] * ab[None], axis=2)
    k = np.argmin(dist, axis=1)
    return k + t[np.arange(len(points)), k]


# --- reading --------------------------------------------------------------------------------

def read_view_record(path: PathLike) -> ViewRecord:
    """Read a view_scene.json; InputError naming the field for malformed content."""
    source = str(path)
    doc = read_versioned_json(path, "view_scene.json", FORMAT, SCHEMA_VERSION)
    kind = _get(doc, "kind", str, source)
    if kind not in KINDS:
        raise InputError("kind", f"must be one of {', '.join(KINDS)}, got {kind!r}", source)
    robot = _get(doc, "robot", dict, source)
    gripper = _get(robot, "gripper", dict, source, "robot.")
    try:
        spec = GripperSpec(**{k: float(v) for k, v in gripper.items()})
    except InputError as e:
        raise InputError(f"robot.{e.field}", e.reason, source) from None
    except (TypeError, ValueError):
        raise InputError("robot.gripper", "needs the lengths of robot.model.GripperSpec in metres", source) from None
    if max(spec.__dict__.values()) > 10.0:
        raise InputError("robot.gripper", "has a length over 10 m", source)
    solids = [SolidRecord(_get(s, "name", str, source, "solids."),
                          _array(_get(s, "vertices", list, source, "solids."), (-1, 3), "solids.vertices", source),
                          s.get("kind", "solid"))
              for s in _get(doc, "solids", list, source)]
    pieces = []
    for p in _get(doc, "pieces", list, source):
        w = "pieces."
        times = _array(_get(p, "tilt_times_s", list, source, w), (-1,), w + "tilt_times_s", source)
        tilt = _array(_get(p, "tilt_rad", list, source, w), (-1,), w + "tilt_rad", source)
        if len(times) != len(tilt) or len(times) == 0:
            raise InputError(w + "tilt_rad", "needs one angle per time, at least one", source)
        pieces.append(PieceRecord(
            _get(p, "name", str, source, w), _get(p, "prefix", str, source, w),
            _array(_get(p, "outline", list, source, w), (-1, 2), w + "outline", source),
            float(_array(_get(p, "thickness", (int, float), source, w), (), w + "thickness", source)),
            _pose(_get(p, "target", list, source, w), w + "target", source),
            float(_array(_get(p, "appear_s", (int, float), source, w), (), w + "appear_s", source)),
            float(_array(_get(p, "carry_end_s", (int, float), source, w), (), w + "carry_end_s", source)),
            _pose(_get(p, "grip", list, source, w), w + "grip", source), times, tilt))
    base = _pose(_get(robot, "base", list, source, "robot."), "robot.base", source)
    digits = robot.get("digits")
    if digits is not None:
        if not isinstance(digits, dict) or any(not isinstance(digits.get(k), (int, float)) or isinstance(digits.get(k), bool)
                                               or not 0.0 <= digits[k] < 1.0 for k in DIGIT_KEYS):
            raise InputError("robot.digits", f"needs {', '.join(DIGIT_KEYS)} in metres", source)
        digits = {k: float(digits[k]) for k in DIGIT_KEYS}
    pincer = robot.get("pincer")
    if pincer is not None:
        pincer = _pincer(pincer, source)
    return ViewRecord(kind, base, spec, solids, pieces, str(doc.get("title", "")), digits, pincer)


def _pincer(value: Any, source: str) -> PincerLinks:
    """robot.pincer as PincerLinks (m, rad), InputError naming the field unless it is a pincer the
    robot model can build: positive lengths up to 10 m (the offset within the radius either way),
    a closed angle within +-pi/2 and a joint range in (0, 2 pi]."""
    if not isinstance(value, dict):
        raise InputError("robot.pincer", f"needs {', '.join(PINCER_KEYS)} (m, rad)", source)
    links = {}
    for k in PINCER_KEYS:
        v = value.get(k)
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not np.isfinite(v) or abs(v) > 10.0:
            raise InputError(f"robot.pincer.{k}", f"must be a finite number (m or rad), got {v!r}", source)
        links[k] = float(v)
    for k, ok, what in (("radius", links["radius"] > 0, "positive"),
                        ("offset", abs(links["offset"]) < links["radius"], "within the radius either way"),
                        ("thumb_reach", links["thumb_reach"] > 0, "positive"),
                        ("tip_radius", 0 <= links["tip_radius"] < links["radius"], "in [0, radius)"),
                        ("closed_angle", abs(links["closed_angle"]) < np.pi / 2, "within +-pi/2"),
                        ("max_angle", 0 < links["max_angle"] <= 2 * np.pi, "in (0, 2 pi]"),
                        ("joint_torque", links["joint_torque"] > 0, "positive")):
        if not ok:
            raise InputError(f"robot.pincer.{k}", f"must be {what}, got {links[k]:g}", source)
    return PincerLinks(**links)


def _get(doc: Any, key: str, kind: type | tuple[type, ...], source: str, where: str = "") -> Any:
    if not isinstance(doc, dict) or key not in doc:
        raise InputError(where + key, "missing", source)
    value = doc[key]
    if not isinstance(value, kind) or isinstance(value, bool):
        raise InputError(where + key, f"has the wrong type ({type(value).__name__})", source)
    return value


#: The largest magnitude a number of the record may have (m, rad or s): a bound far beyond any
#: scene's, which keeps a hand-edited absurd value from overflowing the drawing.
_LARGEST = 1e4


def _array(value: Any, shape: tuple[int, ...], name: str, source: str) -> NDArray[np.float64]:
    """value as a float array of shape (-1: any length), InputError naming the field otherwise."""
    wanted = tuple("N" if s == -1 else s for s in shape)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.ndim != len(shape) or any(s not in (-1, n) for s, n in zip(shape, arr.shape)) \
            or not np.all(np.isfinite(arr)):
        raise InputError(name, f"must be finite numbers of shape {wanted}", source)
    if np.any(np.abs(arr) > _LARGEST):
        raise InputError(name, f"must lie within +-{_LARGEST:g} (m, rad or s)", source)
    return arr


def _pose(value: Any, name: str, source: str) -> NDArray[np.float64]:
    """value as a 4x4 rigid transform (a rotation and a translation in m), InputError naming the field otherwise."""
    pose = _array(value, (4, 4), name, source)
    rot = pose[:3, :3]
    if not (np.allclose(rot @ rot.T, np.eye(3), atol=1e-6) and np.linalg.det(rot) > 0
            and np.allclose(pose[3], [0, 0, 0, 1])):
        raise InputError(name, "must be a rigid transform: a rotation, a translation and the row 0 0 0 1", source)
    return pose


def robot_model(record: ViewRecord) -> Any:
    """The robot model (robot.model.RobotModel) the record's trajectory was made for."""
    return load_ur5e(record.gripper, record.base, pincer=record.pincer)


#: The pincer a record-less pincer trajectory is drawn with: pincer_puzzle_piece's (76 mm joint
#: radius, 23 mm offset, a 1 mm dome, a 60.4 mm thumb), m and rad.
DEFAULT_PINCER = PincerLinks(radius=0.076, offset=0.023, thumb_reach=0.0604, tip_radius=0.001,
                             closed_angle=float(np.arcsin((0.001 - 0.023) / 0.076)), max_angle=float(np.pi / 2),
                             joint_torque=0.38)


def default_record(pincer: bool = False) -> ViewRecord:
    """A record for a trajectory written without one (an older export): the robot at the origin with
    a generic gripper (60 mm thumb, 75 mm finger; pincer: DEFAULT_PINCER's digits), nothing on the table."""
    if pincer:
        links = DEFAULT_PINCER
        spec = GripperSpec(finger_length=links.finger_length, thumb_length=links.thumb_reach, finger_width=0.02,
                           digit_thickness=0.002)
        return ViewRecord("plan", np.eye(4), spec, [], [], "trajectory", pincer=links)
    spec = GripperSpec(finger_length=0.075, thumb_length=0.06, finger_width=0.02, digit_thickness=0.002)
    return ViewRecord("plan", np.eye(4), spec, [], [], "trajectory")
