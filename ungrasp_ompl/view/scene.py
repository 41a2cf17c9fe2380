"""The animated 3D scene: bodies (triangle meshes with colours) and their world poses at the view's
frame times, built from a trajectory and its view record. The meshcat page (view.html) and the
key-frame strip (frames) both draw this.

Frames and units: world frame (x, y on the table, z up; the table's top at z = 0), metres,
seconds of trajectory time. Each body's mesh is in its own frame; ``poses[b, f]`` maps body b's
frame to the world at frame f.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from ..robot.model import PINCER_FINGER_FRAME, PINCER_THUMB_FRAME, THUMB_SLIDE, configuration
from ..robot.trajectory import GRIPPER_JOINT, JointTrajectory
from ..sim.poses import TrialPoses
from . import geometry as geo
from .record import PieceRecord, ViewRecord, robot_model

#: Frames per second of the animation (key frames; the browser interpolates between them).
FPS = 30.0
RGBA = tuple[float, float, float, float]

LINK_RGBA: RGBA = (0.80, 0.82, 0.85, 1.0)
HOUSING_RGBA: RGBA = (0.33, 0.52, 0.72, 1.0)
PALM_RGBA: RGBA = (0.28, 0.28, 0.30, 1.0)
THUMB_RGBA: RGBA = (0.85, 0.30, 0.20, 1.0)
FINGER_RGBA: RGBA = (0.20, 0.35, 0.85, 1.0)
OBJECT_RGBA: RGBA = (0.98, 0.76, 0.05, 1.0)
GHOST_RGBA: RGBA = (0.60, 0.35, 0.90, 0.45)
TARGET_RGBA: RGBA = (0.20, 0.60, 0.30, 0.30)
TABLE_RGBA: RGBA = (0.86, 0.83, 0.77, 1.0)
WALL_RGBA: RGBA = (0.55, 0.45, 0.35, 1.0)
OBSTACLE_RGBA: RGBA = (0.60, 0.30, 0.60, 0.6)

#: Joint housings drawn on the arm's cylinders (the URDF has collision cylinders only): joint
#: name -> (radius, length) in m, a cylinder along the joint's axis.
HOUSINGS = {"shoulder_lift_joint": (0.065, 0.14), "elbow_joint": (0.058, 0.12),
            "wrist_1_joint": (0.047, 0.10), "wrist_2_joint": (0.047, 0.10)}
#: The base's mounting flange: radius, height (m), standing on the table.
BASE_FLANGE = (0.075, 0.03)
#: A pincer's joint pin, drawn on the joint's axis (the palm's y): its radius and how far it stands
#: out of the housing's sides (m).
PINCER_PIN = (0.005, 0.008)
#: Table thickness below z = 0 and margin around what stands on it (m).
TABLE_THICKNESS, TABLE_MARGIN = 0.03, 0.25
#: The target footprint is drawn this thin (m), just above the table.
FOOTPRINT = (0.0001, 0.0003)

PRIMITIVE_TEXT = {"P_theta": "theta down: pivot about G, all contacts stick",
                  "P_psi": "psi up: the thumb turns, B slides",
                  "P_dpsi": "d down, psi up: A and B slide",
                  "approach": "approach: carry the object from home to the start pinch",
                  "press": "press: come straight down, the object's end held by the table",
                  "termination": "termination: let go", "retreat": "retreat: lift the palm",
                  "return": "return home for the next piece"}


@dataclass
class Body:
    """One drawn body: path (meshcat path under the scene root, e.g. 'robot/upper_arm'), its mesh
    (body frame, m), colour and opacity (rgba in [0, 1]) and its legend group."""

    path: str
    mesh: geo.Mesh
    rgba: RGBA
    group: str


@dataclass
class Camera:
    """A viewpoint: the point looked at, the camera's position, and the half-size of the region
    around the target it is to show (world, m)."""

    target: NDArray[np.float64]
    position: NDArray[np.float64]
    half: float


@dataclass
class ViewScene:
    """Bodies and their poses (B, F, 4, 4) and visibility (B, F) at frame times (F,) s; the
    trajectory's phases (name, label for a person, start s, end s); viewpoints; legend entries."""

    title: str
    times: NDArray[np.float64]
    bodies: list[Body]
    poses: NDArray[np.float64]
    visible: NDArray[np.bool_]
    phases: list[tuple[str, str, float, float]]
    cameras: dict[str, Camera]
    legend: list[tuple[str, RGBA]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def frame_at(self, t: float) -> int:
        """The index of the frame nearest time t (s)."""
        return int(np.argmin(np.abs(self.times - t)))

    def phase_at(self, t: float) -> tuple[str, str, float, float]:
        """The phase running at time t (s); the last after the end."""
        return next((p for p in self.phases if t <= p[3] + 1e-9), self.phases[-1])


def frame_times(duration: float, fps: float = FPS) -> NDArray[np.float64]:
    """0, 1/fps, ... and the end (s); [0] for a trajectory of one sample."""
    times = np.arange(0.0, duration, 1.0 / fps) if duration > 0 else np.zeros(1)
    return np.append(times, duration) if duration - times[-1] > 1e-6 else times


def build_scene(traj: JointTrajectory, record: ViewRecord, trial: TrialPoses | None = None) -> ViewScene:
    """The animated scene of a trajectory and its record; trial: a simulated trial of the record's
    (first) object, drawn beside the planned one (the planned one then a translucent ghost)."""
    robot = robot_model(record)
    t0 = float(traj.times[0])
    times = frame_times(float(traj.times[-1]) - t0)
    q = np.column_stack([np.interp(times + t0, traj.times, traj.positions[:, j])
                         for j in range(traj.positions.shape[1])])
    bodies, tracks = _robot_bodies(robot, q, record.digits)
    palm = tracks.pop("_palm")
    poses = [tracks[b.path] for b in bodies]
    visible = [np.ones(len(times), dtype=bool) for _ in bodies]

    static = np.repeat(np.eye(4)[None], len(times), axis=0)
    for s in record.solids:
        bodies.append(Body(f"frame/{_slug(s.name)}", geo.convex_hull(s.vertices),
                           OBSTACLE_RGBA if s.kind == "obstacle" else WALL_RGBA, s.kind))
        poses.append(static)
        visible.append(np.ones(len(times), dtype=bool))
    simulated = trial is not None and len(record.pieces) == 1
    for k, piece in enumerate(record.pieces):
        name = _slug(piece.name) or f"piece{k}"
        prism = geo.prism(piece.outline, 0.0, piece.thickness)
        footprint = geo.prism(piece.outline, *FOOTPRINT)
        bodies.append(Body(f"targets/{name}", footprint, TARGET_RGBA, "target"))
        poses.append(np.repeat(piece.target[None], len(times), axis=0))
        visible.append(np.ones(len(times), dtype=bool))
        planned, shown = piece.poses(times + t0, palm)
        bodies.append(Body(f"planned/{name}", prism, GHOST_RGBA if simulated else OBJECT_RGBA, "planned"))
        poses.append(planned)
        visible.append(shown)
        if simulated:
            bodies.append(Body(f"simulated/{name}", geo.prism(trial.outline, 0.0, trial.thickness), OBJECT_RGBA,
                               "simulated"))
            poses.append(_simulated_poses(times + t0, trial, planned))
            visible.append(shown)

    table = _table(robot.base, record.pieces, record.solids)
    bodies.insert(0, Body("table", table, TABLE_RGBA, "table"))
    poses.insert(0, static)
    visible.insert(0, np.ones(len(times), dtype=bool))

    legend = [("arm (UR5e)", HOUSING_RGBA), ("thumb", THUMB_RGBA), ("finger", FINGER_RGBA)]
    notes = []
    if simulated:
        legend += [("simulated object", OBJECT_RGBA), ("planned object", GHOST_RGBA)]
        err = "" if math.isnan(trial.position_error_mm) else f", placement error {trial.position_error_mm:.2f} mm"
        notes.append(f"simulated trial {trial.trial}: {trial.outcome}{err}")
    elif record.pieces:
        legend.append(("object" if len(record.pieces) == 1 else "pieces", OBJECT_RGBA))
    if record.pieces:
        legend.append(("target", TARGET_RGBA))
    if any(s.kind == "solid" for s in record.solids):
        legend.append(("frame" if record.kind == "tiling" else "solids", WALL_RGBA))
    if any(s.kind == "obstacle" for s in record.solids):
        legend.append(("obstacles", OBSTACLE_RGBA))
    return ViewScene(record.title or "trajectory", times, bodies, np.array(poses), np.array(visible),
                     _phases(traj), _cameras(robot.base, record.pieces, tracks), legend, notes)


def _robot_bodies(robot, q: NDArray, digits: dict[str, float] | None = None
                  ) -> tuple[list[Body], dict[str, NDArray]]:
    """The arm and gripper bodies and their poses (F, 4, 4) at configurations q (F, 7); '_palm'
    holds the palm frame's poses. digits: the digits' tapered profile (m, record.DIGIT_KEYS), drawn
    on the jaws instead of the robot model's digit boxes. A pincer's (robot.pincer) digits are drawn
    in their hinged frames (robot.model.PINCER_THUMB_FRAME, PINCER_FINGER_FRAME: each turned about
    the joint by half the joint angle and half the closed angle), from the joint's level to their
    tips, and its joint's pin (PINCER_PIN) on the palm's y axis."""
    model, data, geom = robot.model, robot.data, robot.collision_model
    links = robot.pincer
    gdata = pin.GeometryData(geom)
    bodies: list[Body] = []
    for g in geom.geometryObjects:
        shape = g.geometry
        if type(shape).__name__ == "Box":
            mesh = geo.box(2 * np.asarray(shape.halfSide))
        else:
            mesh = geo.cylinder(float(shape.radius), 2 * float(shape.halfLength))
        name = g.name.removesuffix("_0")
        rgba = {"gripper_palm": PALM_RGBA, "gripper_thumb": THUMB_RGBA, "gripper_finger": FINGER_RGBA}.get(name, LINK_RGBA)
        bodies.append(Body(f"robot/{name}", mesh, rgba, "robot"))
    jaws = {}  # digit body index -> its jaw joint, when drawn tapered in the jaw's frame
    hinged = {}  # a pincer's digit body index -> its digit frame, when drawn tapered in that frame
    if digits is not None and links is not None:
        w = robot.gripper.finger_width
        for i, b in enumerate(bodies):
            if b.path == "robot/gripper_thumb":
                b.mesh = geo.digit(links.thumb_reach, digits["thumb_tip_thickness"], digits["thumb_base_thickness"],
                                   w, -1.0)
                hinged[i] = model.getFrameId(PINCER_THUMB_FRAME)
            elif b.path == "robot/gripper_finger":
                b.mesh = geo.digit(links.finger_length, digits["finger_tip_thickness"],
                                   digits["finger_base_thickness"], w, 1.0, links.tip_radius)
                hinged[i] = model.getFrameId(PINCER_FINGER_FRAME)
    elif digits is not None:
        g = robot.gripper
        for i, b in enumerate(bodies):
            if b.path == "robot/gripper_thumb":
                b.mesh = geo.digit(g.thumb_length, digits["thumb_tip_thickness"], digits["thumb_base_thickness"],
                                   g.finger_width, -1.0)
                jaws[i] = model.getJointId(THUMB_SLIDE)
            elif b.path == "robot/gripper_finger":
                b.mesh = geo.digit(g.finger_length, digits["finger_tip_thickness"], digits["finger_base_thickness"],
                                   g.finger_width, 1.0, digits["finger_tip_radius"])
                jaws[i] = model.getJointId(GRIPPER_JOINT)
    joints = {name: model.getJointId(name) for name in HOUSINGS}
    for name, (radius, length) in HOUSINGS.items():
        bodies.append(Body(f"robot/{name}_housing", geo.cylinder(radius, length), HOUSING_RGBA, "robot"))
    r, h = BASE_FLANGE
    flange = geo.cylinder(r, h).moved(_translation(0.0, 0.0, h / 2))
    bodies.append(Body("robot/base_flange", flange, HOUSING_RGBA, "robot"))
    if links is not None:  # the joint's pin: a cylinder along the palm's y, on the joint's axis
        radius, out = PINCER_PIN
        across = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
        length = max(robot.gripper.palm_thickness, robot.gripper.finger_width) + 2 * out
        pin_mesh = geo.cylinder(radius, length).moved(across)
        bodies.append(Body("robot/gripper_pin", pin_mesh, HOUSING_RGBA, "robot"))

    n = len(q)
    tracks = {b.path: np.empty((n, 4, 4)) for b in bodies}
    tracks["_palm"] = np.empty((n, 4, 4))
    names = [b.path for b in bodies]
    for f in range(n):
        pin.forwardKinematics(model, data, configuration(robot, q[f]))
        pin.updateGeometryPlacements(model, data, geom, gdata)
        for i in range(len(geom.geometryObjects)):
            if i in hinged:
                tracks[names[i]][f] = pin.updateFramePlacement(model, data, hinged[i]).homogeneous
            else:
                tracks[names[i]][f] = data.oMi[jaws[i]].homogeneous if i in jaws else gdata.oMg[i].homogeneous
        for name, jid in joints.items():
            tracks[f"robot/{name}_housing"][f] = data.oMi[jid].homogeneous
        tracks["robot/base_flange"][f] = robot.base
        tracks["_palm"][f] = pin.updateFramePlacement(model, data, robot.tcp_frame).homogeneous
        if links is not None:
            tracks["robot/gripper_pin"][f] = tracks["_palm"][f]
    return bodies, tracks


def _simulated_poses(times: NDArray, trial: TrialPoses, planned: NDArray) -> NDArray[np.float64]:
    """The simulated object's poses at times: the planned ones before the trial's first recorded
    time, interpolated (position linearly, rotation by slerp) in between, the last after."""
    from scipy.spatial.transform import Rotation, Slerp  # scipy.spatial: 0.4 s, loaded to animate

    out = planned.copy()
    inside = (times >= trial.times[0]) & (times <= trial.times[-1])
    if len(trial.times) == 1:
        out[times >= trial.times[0]] = trial.poses[0]
        return out
    slerp = Slerp(trial.times, Rotation.from_matrix(trial.poses[:, :3, :3]))
    out[inside, :3, :3] = slerp(times[inside]).as_matrix()
    for j in range(3):
        out[inside, j, 3] = np.interp(times[inside], trial.times, trial.poses[:, j, 3])
    out[times > trial.times[-1]] = trial.poses[-1]
    return out


def _table(base: NDArray, pieces: list[PieceRecord], solids: list) -> geo.Mesh:
    """The table: a slab under z = 0 covering the arm's base and every target and solid, with margin."""
    pts = [base[:2, 3]] + [(p.target[:3, :3] @ np.append(xy, 0.0) + p.target[:3, 3])[:2]
                           for p in pieces for xy in p.outline]
    pts += [v[:2] for s in solids for v in s.vertices]
    pts = np.array(pts)
    lo, hi = pts.min(axis=0) - TABLE_MARGIN, pts.max(axis=0) + TABLE_MARGIN
    size = np.append(hi - lo, TABLE_THICKNESS)
    return geo.box(size, np.append((hi + lo) / 2, -TABLE_THICKNESS / 2))


#: Camera distance over the half-size of the region shown (meshcat's 75 deg field of view).
OVERVIEW_DISTANCE, CLOSE_DISTANCE = 2.2, 2.4
#: Half-size (m) of the close-up region about the first object's target.
CLOSE_HALF = 0.045


def _cameras(base: NDArray, pieces: list[PieceRecord], robot_tracks: dict[str, NDArray]) -> dict[str, Camera]:
    """'overview': everything the arm sweeps and the targets, from the right of the base-to-target
    line, a little from the front and above; 'close': one object's target, looking across its
    manipulation plane (the plane's x to the right), a little from the front and above; for several
    objects (a layout) all their targets, from the overview's side and steeply above."""
    b = base[:3, 3]
    if pieces:
        centres = np.array([p.target[:3, :3] @ np.append(p.outline.mean(axis=0), 0.0) + p.target[:3, 3]
                            for p in pieces])
        c = centres.mean(axis=0)
        normal = pieces[0].target[:3, 1]
    else:
        c, normal = b + np.array([0.45, 0.1, 0.0]), np.array([0.0, 1.0, 0.0])
        centres = c[None]
    pts = np.vstack([b[None], centres] + [t[:, :3, 3] for t in robot_tracks.values()])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    lo[2] = 0.0
    look = (lo + hi) / 2
    half = float(np.max(hi - lo)) / 2 + 0.08
    reach = np.append((c - b)[:2], 0.0)
    u = reach / np.linalg.norm(reach) if np.linalg.norm(reach) > 1e-9 else np.array([1.0, 0.0, 0.0])
    side = np.array([u[1], -u[0], 0.0])  # to the right of the base-to-target line, seen from above
    view = 0.85 * side + 0.3 * u + np.array([0.0, 0.0, 0.45])
    overview = look + OVERVIEW_DISTANCE * half * view / np.linalg.norm(view)
    if len(centres) > 1:  # a layout: the frame and its pieces, from the overview's side and steeply above
        close_target = centres.mean(axis=0) + np.array([0.0, 0.0, 0.01])
        close_half = float(np.max(np.ptp(centres, axis=0))) / 2 + 0.06
        across = 0.85 * side + 0.3 * u + np.array([0.0, 0.0, 1.2])
    else:
        close_target, close_half = centres[0] + np.array([0.0, 0.0, 0.015]), CLOSE_HALF
        across = -normal + 0.35 * np.cross(np.array([0.0, 0.0, 1.0]), -normal) + np.array([0.0, 0.0, 0.35])
    close = close_target + CLOSE_DISTANCE * close_half * across / np.linalg.norm(across)
    return {"overview": Camera(look, overview, half), "close": Camera(close_target, close, close_half)}


def _phases(traj: JointTrajectory) -> list[tuple[str, str, float, float]]:
    """The trajectory's segments as (name, label, start s, end s), primitives numbered per piece."""
    out = []
    counts: dict[str, int] = {}
    totals: dict[str, int] = {}
    for name, _, _ in traj.segments:
        prefix, _, phase = name.rpartition("/")
        if phase.startswith("P_"):
            totals[prefix] = totals.get(prefix, 0) + 1
    t0 = float(traj.times[0])
    for name, a, b in traj.segments:
        prefix, _, phase = name.rpartition("/")
        text = PRIMITIVE_TEXT.get(phase, phase)
        if phase.startswith("P_"):
            counts[prefix] = counts.get(prefix, 0) + 1
            text = f"{phase} (primitive {counts[prefix]} of {totals[prefix]}): {text}"
        label = f"{prefix}: {text}" if prefix else text
        out.append((name, label, float(traj.times[a]) - t0, float(traj.times[b]) - t0))
    if not out:
        out.append(("trajectory", "trajectory", 0.0, float(traj.times[-1]) - t0))
    return out


def _translation(x: float, y: float, z: float) -> NDArray[np.float64]:
    pose = np.eye(4)
    pose[:3, 3] = (x, y, z)
    return pose


def _slug(name: str) -> str:
    """A meshcat path element from a name: letters, digits, '_' and '-'."""
    return "".join(ch if ch.isalnum() or ch in "_-" else "_" for ch in name)
