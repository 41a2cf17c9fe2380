"""The UR5e arm with a two-digit gripper as one Pinocchio model.

Frames (all poses are 4x4 homogeneous transforms, metres):

* world: the scene's frame. ``RobotModel.base`` places the arm's base frame in it.
* arm base (``base_link``): the UR5e DH base frame (the controller's ``base``), z up along the
  shoulder axis.
* ``tool0``: the UR flange, the DH product T_1 ... T_6 (``fk_dh``).
* palm (``ungrasp_palm``): ``tool0 · Tz(palm_depth)``, the same axes as the flange: z along the
  digits from the palm toward the tips, x the opening direction from the thumb toward the finger,
  y = z × x; its origin is the centre of the gripper's housing face. The gripper is parallel and
  symmetric (RH-P12-RN class): both jaws move, the thumb's contact face at x = -opening/2 (its
  body at smaller x), the finger's at x = +opening/2 (its body at larger x). The digit tips are
  the contact-face points at z = thumb_length and z = finger_length.

Trajectory configuration (7,): the six arm joints (rad) in ``ARM_JOINTS`` order, then the gripper
opening (m, the distance between the digit faces), as in ``trajectory.JOINT_NAMES``. The Pinocchio
model has one more coordinate: the two jaw slides (-opening/2, +opening/2); ``configuration``
expands a trajectory configuration into it.

A pincer (``load_ur5e(..., pincer=...)``, mechanics.pincer) has a hinge instead of the slides: the
palm frame's origin is then on the joint's axis (palm y), z bisects the digits toward their tips
and x points toward the finger; each digit turns about the axis by half the joint angle phi (rad,
0 closed), the thumb by -phi/2 and the finger by +phi/2 (a turn about +y takes z toward x), the
coordinates (-phi/2, +phi/2) of the two hinges. The trajectory's last column is phi
(``trajectory.PINCER_JOINT_NAMES``). The thumb's face lies joint_offset from the axis, the finger's
tip centre joint_radius from it; each digit's collision box runs from its tip to the joint's level.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

try:  # Pinocchio's collision library: coal since pin 3.4, hpp-fcl before
    import coal
except ImportError:  # pragma: no cover
    import hppfcl as coal

from ..errors import InputError
from ..robots import ur5e_urdf
from ..mechanics.pincer import PincerLinks
from .trajectory import ARM_JOINTS, GRIPPER_JOINT, PINCER_JOINT

#: UR5e published DH table (m, rad); standard DH, T_i = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i).
DH_A = np.array([0.0, -0.425, -0.3922, 0.0, 0.0, 0.0])
DH_D = np.array([0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996])
DH_ALPHA = np.array([np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0])
#: Published reach (m), for messages; see ``max_flange_distance_from_shoulder`` for the exact bound.
UR5E_REACH = 0.85

#: Arm joint acceleration limit (rad/s^2). Universal Robots publish no per-joint acceleration
#: limit; 4 rad/s^2 is a conservative choice for smooth motion with a payload.
ARM_ACCEL_LIMIT = 4.0
#: Gripper opening velocity (m/s) and acceleration (m/s^2) limits, RH-P12-RN class, conservative.
GRIPPER_VEL_LIMIT = 0.05
GRIPPER_ACCEL_LIMIT = 0.2
#: Nominal gripping force (N), the gripper joint's effort limit.
GRIPPER_FORCE_LIMIT = 170.0
#: Rough masses (kg) for the gripper's inertia: the body (on the flange) and the moving finger.
GRIPPER_BODY_MASS = 0.45
GRIPPER_FINGER_MASS = 0.05
#: Palm (gripper housing) box size (m) along palm x and y; along z it spans flange to palm.
PALM_WIDTH_X = 0.08
PALM_WIDTH_Y = 0.06

PALM_FRAME = "ungrasp_palm"
THUMB_SLIDE = "gripper_thumb_slide"
#: A pincer's thumb hinge (its finger's is trajectory.PINCER_JOINT) and its digits' frames: origin on
#: the digit's contact face at the joint's level, z along the face toward the tip, x across the gap
#: toward the finger (the thumb's body at smaller x, the finger's at larger x).
THUMB_HINGE = "gripper_thumb_hinge"
PINCER_THUMB_FRAME, PINCER_FINGER_FRAME = "gripper_thumb", "gripper_finger"
TOOL0_FRAME = "tool0"


@dataclass(frozen=True)
class GripperSpec:
    """Gripper geometry (m). Digit lengths run from the palm (palm frame z = 0) to the tip along
    the digit axis (palm z); width is across the digit (palm y), thickness behind the contact
    face (palm x)."""

    finger_length: float  #: the longer digit, palm to tip (m)
    thumb_length: float  #: the shorter digit, palm to tip (m)
    finger_width: float  #: both digits, along palm y (m)
    digit_thickness: float  #: both digits, behind the contact face along palm x (m)
    palm_depth: float = 0.11  #: UR flange (tool0) to palm along flange z (m); RH-P12-RN class
    max_opening: float = 0.106  #: largest distance between the digit faces (m); RH-P12-RN stroke
    palm_width: float = PALM_WIDTH_X  #: the housing across the gap, palm x, centred (m)
    palm_thickness: float = PALM_WIDTH_Y  #: the housing normal to the gap, palm y, centred (m)

    def __post_init__(self) -> None:
        for name in ("finger_length", "thumb_length", "finger_width", "digit_thickness", "palm_depth",
                     "max_opening", "palm_width", "palm_thickness"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise InputError(f"gripper.{name}", f"must be a positive length in metres, got {value!r}")


@dataclass
class RobotModel:
    """The arm and gripper as loaded by ``load_ur5e``.

    model: pin.Model with nq = nv = 8 (six revolute arm joints, then the prismatic thumb and
    finger slides, ``THUMB_SLIDE`` and ``gripper_opening``, at -opening/2 and +opening/2); data: its pin.Data (scratch space, not thread-safe); collision_model:
    collision geometry (arm cylinders, palm and digit boxes), placed on the joints.
    tcp_frame: frame id of the palm frame ``ungrasp_palm``. arm_joint_ids: Pinocchio joint ids of
    ARM_JOINTS, in order. q_lower, q_upper (7,): position limits (rad, m); v_max (7,): velocity
    limits (rad/s, m/s); a_max (7,): acceleration limits (rad/s^2, m/s^2). base: 4x4 pose of the
    arm's base frame in the world.
    """

    model: pin.Model
    data: pin.Data
    collision_model: pin.GeometryModel
    tcp_frame: int
    arm_joint_ids: tuple[int, ...]
    q_lower: NDArray[np.float64]
    q_upper: NDArray[np.float64]
    v_max: NDArray[np.float64]
    a_max: NDArray[np.float64]
    gripper: GripperSpec
    base: NDArray[np.float64]
    pincer: PincerLinks | None = None  #: a pincer's links (m, rad); None: the parallel jaws

    @property
    def tool0_frame(self) -> int:
        return self.model.getFrameId(TOOL0_FRAME)


def _dh_transform(theta: float, d: float, a: float, alpha: float) -> NDArray[np.float64]:
    """Standard DH link transform Rz(theta) Tz(d) Tx(a) Rx(alpha), 4x4."""
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct],
                     [st, ct * ca, -ct * sa, a * st],
                     [0.0, sa, ca, d],
                     [0.0, 0.0, 0.0, 1.0]])


def fk_dh(q6: ArrayLike) -> NDArray[np.float64]:
    """Flange (tool0) pose in the arm's base frame, 4x4, as the plain DH product T_1 ... T_6.

    q6: the six arm joint angles (rad). Independent of Pinocchio and the URDF, for checks.
    """
    q6 = np.asarray(q6, dtype=float).reshape(6)
    pose = np.eye(4)
    for theta, d, a, alpha in zip(q6, DH_D, DH_A, DH_ALPHA):
        pose = pose @ _dh_transform(theta, d, a, alpha)
    return pose


def max_flange_distance_from_shoulder() -> float:
    """Largest distance (m) from the shoulder point (joint 2's origin, d1 above the base) to the
    flange over all configurations, about 0.969 m (the published 0.85 m reach is a rating).

    Joints 2-4 are parallel. Relative to the shoulder, the flange is P + d5 z4 + d6 z5 with P =
    a2 x2 + a3 x3 + d4 z3 (in-plane part of length up to A = |a2| + |a3|, axial part B = d4), z4 any
    direction in the plane normal to the joint 2-4 axes and z5 any direction normal to z4. For z4 at
    angle t to P's in-plane part, the best z5 gives |.|^2 = (A cos t + d5)^2 + (sqrt(A^2 sin^2 t +
    B^2) + d6)^2, largest at cos t = 1 or at cos t = d5 sqrt(A^2 + B^2) / (A sqrt(d5^2 + d6^2)).
    """
    a, b, d5, d6 = abs(DH_A[1]) + abs(DH_A[2]), DH_D[3], DH_D[4], DH_D[5]
    stationary = d5 * np.hypot(a, b) / (a * np.hypot(d5, d6))
    candidates = [1.0] + ([stationary] if stationary <= 1.0 else [])
    return max(float(np.hypot(a * c + d5, np.sqrt(a * a * (1 - c * c) + b * b) + d6)) for c in candidates)


def shoulder_position(robot: RobotModel) -> NDArray[np.float64]:
    """World position (m) of the shoulder point: joint 2's origin, d1 along the base z."""
    return robot.base[:3, :3] @ np.array([0.0, 0.0, DH_D[0]]) + robot.base[:3, 3]


def as_pose(value: ArrayLike, field: str) -> NDArray[np.float64]:
    """``value`` as a 4x4 float rigid transform; InputError naming ``field`` if it is not one."""
    pose = np.asarray(value, dtype=float)
    if pose.shape != (4, 4) or not np.all(np.isfinite(pose)):
        raise InputError(field, f"must be a finite 4x4 homogeneous transform, got shape {pose.shape}")
    rot = pose[:3, :3]
    if not np.allclose(rot.T @ rot, np.eye(3), atol=1e-6) or np.linalg.det(rot) < 0 \
            or not np.allclose(pose[3], [0.0, 0.0, 0.0, 1.0]):
        raise InputError(field, "must be a rigid transform (rotation part orthonormal, det +1, last row 0 0 0 1)")
    return pose


def _place_base(model: pin.Model, geometry: pin.GeometryModel, base: pin.SE3) -> None:
    """Move everything attached to the universe (the root joint, the base frames and geometry) by
    ``base``, so the arm's base frame sits at ``base`` in the world."""
    for joint_id in range(1, model.njoints):
        if model.parents[joint_id] == 0:
            model.jointPlacements[joint_id] = base * model.jointPlacements[joint_id]
    for frame in model.frames:
        if frame.parentJoint == 0 and frame.name != "universe":
            frame.placement = base * frame.placement
    for geom in geometry.geometryObjects:
        if geom.parentJoint == 0:
            geom.placement = base * geom.placement


def _box(name: str, joint_id: int, frame_id: int, placement: pin.SE3, size: tuple[float, float, float]
         ) -> pin.GeometryObject:
    """A box collision object of ``size`` (m) centred at ``placement`` in joint ``joint_id``'s frame."""
    return pin.GeometryObject(name, joint_id, frame_id, placement, coal.Box(*size))


def _add_gripper(model: pin.Model, geometry: pin.GeometryModel, spec: GripperSpec) -> int:
    """Append the palm frame, the prismatic ``gripper_opening`` joint, the finger, and the palm,
    thumb and finger collision boxes. Returns the palm frame id."""
    tool0 = model.getFrameId(TOOL0_FRAME)
    wrist = model.frames[tool0].parentJoint
    palm_in_wrist = model.frames[tool0].placement * pin.SE3(np.eye(3), np.array([0.0, 0.0, spec.palm_depth]))
    palm = model.addFrame(pin.Frame(PALM_FRAME, wrist, tool0, palm_in_wrist, pin.FrameType.OP_FRAME))

    # The housing (flange to palm) moves with wrist 3, centred on the palm axis.
    palm_size = (spec.palm_width, spec.palm_thickness, spec.palm_depth)
    palm_center = pin.SE3(np.eye(3), np.array([0.0, 0.0, -spec.palm_depth / 2]))
    model.appendBodyToJoint(wrist, pin.Inertia.FromBox(GRIPPER_BODY_MASS, *palm_size),
                            palm_in_wrist * palm_center)
    geometry.addGeometryObject(_box("gripper_palm", wrist, palm, palm_in_wrist * palm_center, palm_size))
    half = spec.max_opening / 2
    # Each jaw slides along palm x; its frame's origin lies on its contact face at the palm.
    for name, sign, length, limits in ((THUMB_SLIDE, -1.0, spec.thumb_length, (-half, 0.0)),
                                       (GRIPPER_JOINT, 1.0, spec.finger_length, (0.0, half))):
        jaw = model.addJoint(wrist, pin.JointModelPX(), palm_in_wrist, name, np.array([GRIPPER_FORCE_LIMIT]),
                             np.array([GRIPPER_VEL_LIMIT / 2]), np.array([limits[0]]), np.array([limits[1]]))
        jaw_frame = model.addJointFrame(jaw, palm)
        centre = pin.SE3(np.eye(3), np.array([sign * spec.digit_thickness / 2, 0.0, length / 2]))
        size = (spec.digit_thickness, spec.finger_width, length)
        model.appendBodyToJoint(jaw, pin.Inertia.FromBox(GRIPPER_FINGER_MASS, *size), centre)
        digit = "gripper_thumb" if sign < 0 else "gripper_finger"
        geometry.addGeometryObject(_box(digit, jaw, jaw_frame, centre, size))
    return palm


def _rot_y(angle: float) -> NDArray[np.float64]:
    """The rotation by angle (rad) about y, taking z toward x."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _add_pincer(model: pin.Model, geometry: pin.GeometryModel, spec: GripperSpec, links: PincerLinks) -> int:
    """Append the palm frame on the pincer's joint, its two hinges (THUMB_HINGE and PINCER_JOINT,
    about palm y), the digits' frames, and the palm, thumb and finger collision boxes. Returns the
    palm frame id."""
    tool0 = model.getFrameId(TOOL0_FRAME)
    wrist = model.frames[tool0].parentJoint
    palm_in_wrist = model.frames[tool0].placement * pin.SE3(np.eye(3), np.array([0.0, 0.0, spec.palm_depth]))
    palm = model.addFrame(pin.Frame(PALM_FRAME, wrist, tool0, palm_in_wrist, pin.FrameType.OP_FRAME))
    palm_size = (spec.palm_width, spec.palm_thickness, spec.palm_depth)
    palm_center = pin.SE3(np.eye(3), np.array([0.0, 0.0, -spec.palm_depth / 2]))
    model.appendBodyToJoint(wrist, pin.Inertia.FromBox(GRIPPER_BODY_MASS, *palm_size), palm_in_wrist * palm_center)
    geometry.addGeometryObject(_box("gripper_palm", wrist, palm, palm_in_wrist * palm_center, palm_size))
    half = links.max_angle / 2
    torque = np.array([links.joint_torque])
    speed = np.array([GRIPPER_VEL_LIMIT / links.radius / 2])
    # each digit's frame in its hinge's, closed: turned half the closed angle, its face's foot
    # offset from the axis (the thumb's by the joint offset, the finger's by its tip's rounding)
    for name, frame, sign, across, length, limits in (
            (THUMB_HINGE, PINCER_THUMB_FRAME, -1.0, links.offset, links.thumb_reach, (-half, 0.0)),
            (PINCER_JOINT, PINCER_FINGER_FRAME, 1.0, links.tip_radius, links.finger_length, (0.0, half))):
        hinge = model.addJoint(wrist, pin.JointModelRY(), palm_in_wrist, name, torque, speed,
                               np.array([limits[0]]), np.array([limits[1]]))
        model.addJointFrame(hinge, palm)
        turn = _rot_y(sign * links.closed_angle / 2)
        digit = pin.SE3(turn, turn @ np.array([-across, 0.0, 0.0]))
        digit_frame = model.addFrame(pin.Frame(frame, hinge, palm, digit, pin.FrameType.OP_FRAME))
        centre = digit * pin.SE3(np.eye(3), np.array([sign * spec.digit_thickness / 2, 0.0, length / 2]))
        size = (spec.digit_thickness, spec.finger_width, length)
        model.appendBodyToJoint(hinge, pin.Inertia.FromBox(GRIPPER_FINGER_MASS, *size), centre)
        geometry.addGeometryObject(_box(frame, hinge, digit_frame, centre, size))
    return palm


def load_ur5e(gripper: GripperSpec, base: ArrayLike | None = None, urdf: Path | str | None = None,
              pincer: PincerLinks | None = None) -> RobotModel:
    """Load the UR5e (the shipped ``ungrasp_ompl/robots/ur5e.urdf``) with ``gripper`` on its flange.

    base: 4x4 pose of the arm's base frame in the world (default identity). urdf: another URDF
    with the same link and joint names (default ``ungrasp_ompl.robots.ur5e_urdf()``, the shipped
    one, found with importlib.resources). pincer: the gripper's digits hinge on one joint with these
    links (its housing and digit sizes from gripper), rather than slide apart.
    """
    path = Path(urdf) if urdf is not None else ur5e_urdf()
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no UR5e URDF; regenerate the shipped one with robots/make_ur5e_urdf.py")
    base_pose = np.eye(4) if base is None else as_pose(base, "robot.base")

    model = pin.buildModelFromUrdf(str(path))
    geometry = pin.buildGeomFromUrdf(model, str(path), pin.GeometryType.COLLISION)
    missing = [name for name in ARM_JOINTS if not model.existJointName(name)]
    if missing or not model.existFrame(TOOL0_FRAME):
        raise InputError("robot.urdf", f"{path}: missing {', '.join(missing) or TOOL0_FRAME}")
    _place_base(model, geometry, pin.SE3(base_pose))
    palm = _add_gripper(model, geometry, gripper) if pincer is None else _add_pincer(model, geometry, gripper, pincer)

    arm_ids = tuple(model.getJointId(name) for name in ARM_JOINTS)
    arm_q = [model.joints[j].idx_q for j in arm_ids]
    n_arm = len(arm_ids)
    # limits in trajectory coordinates: the arm joints, then the opening (a pincer's joint angle:
    # the finger tip's speed and acceleration limits at the joint radius)
    if pincer is None:
        stroke, speed, accel = gripper.max_opening, GRIPPER_VEL_LIMIT, GRIPPER_ACCEL_LIMIT
    else:
        stroke, speed, accel = (pincer.max_angle, GRIPPER_VEL_LIMIT / pincer.radius,
                                GRIPPER_ACCEL_LIMIT / pincer.radius)
    q_lower = np.append(model.lowerPositionLimit[arm_q], 0.0)
    q_upper = np.append(model.upperPositionLimit[arm_q], stroke)
    v_max = np.append(np.asarray(model.velocityLimit)[arm_q], speed)
    a_max = np.array([ARM_ACCEL_LIMIT] * n_arm + [accel])
    return RobotModel(model=model, data=model.createData(), collision_model=geometry, tcp_frame=palm,
                      arm_joint_ids=arm_ids, q_lower=q_lower, q_upper=q_upper, v_max=v_max,
                      a_max=a_max, gripper=gripper, base=base_pose.copy(), pincer=pincer)


def configuration(robot: RobotModel, q: ArrayLike, opening: float = 0.0) -> NDArray[np.float64]:
    """The Pinocchio configuration (8,) of a trajectory configuration: the arm's (6,) with
    ``opening`` (m), or the arm and the opening (7,); the jaws at -opening/2 and +opening/2 (a
    pincer's opening is its joint angle, rad: its hinges at -angle/2 and +angle/2)."""
    q = np.asarray(q, dtype=float).ravel()
    n_arm = len(robot.arm_joint_ids)
    if q.size == n_arm + 1:
        q, opening = q[:n_arm], float(q[n_arm])
    elif q.size != n_arm:
        raise ValueError(f"q must have {n_arm} or {n_arm + 1} entries, got {q.size}")
    return np.concatenate([q, [-opening / 2, opening / 2]])


def frame_pose(robot: RobotModel, q: ArrayLike, frame: int) -> NDArray[np.float64]:
    """World pose (4x4) of the frame with id ``frame`` at q ((6,) or (7,), see ``configuration``)."""
    pin.framesForwardKinematics(robot.model, robot.data, configuration(robot, q))
    return robot.data.oMf[frame].homogeneous.copy()


def tcp_pose(robot: RobotModel, q: ArrayLike) -> NDArray[np.float64]:
    """World pose (4x4) of the palm frame at q ((6,) or (7,); the opening does not move the palm)."""
    return frame_pose(robot, q, robot.tcp_frame)


def thumb_tip(robot: RobotModel, q: ArrayLike) -> NDArray[np.float64]:
    """World position (3,) of the thumb's contact-face tip: palm origin - opening/2 along palm x +
    thumb_length along palm z (a pincer's: thumb_reach along its face from the joint's foot). q (7,)
    includes the opening (m; a pincer's joint angle, rad)."""
    if np.size(q) != len(robot.arm_joint_ids) + 1:
        raise ValueError(f"thumb_tip needs q with the opening ({len(robot.arm_joint_ids) + 1} entries)")
    if robot.pincer is not None:
        return _point_on(robot, q, robot.model.getFrameId(PINCER_THUMB_FRAME), (0.0, 0.0, robot.pincer.thumb_reach))
    return _point_on(robot, q, robot.model.getFrameId(THUMB_SLIDE), (0.0, 0.0, robot.gripper.thumb_length))


def finger_tip(robot: RobotModel, q: ArrayLike) -> NDArray[np.float64]:
    """World position (3,) of the finger's contact-face tip: palm origin + opening/2 along palm x +
    finger_length along palm z (a pincer's: its face's end, the joint radius and the tip's rounding
    along it from the joint's level). q (7,) includes the opening (m; a pincer's joint angle, rad)."""
    if np.size(q) != len(robot.arm_joint_ids) + 1:
        raise ValueError(f"finger_tip needs q with the opening ({len(robot.arm_joint_ids) + 1} entries)")
    if robot.pincer is not None:
        return _point_on(robot, q, robot.model.getFrameId(PINCER_FINGER_FRAME),
                         (0.0, 0.0, robot.pincer.finger_length))
    finger_frame = robot.model.getFrameId(GRIPPER_JOINT)
    return _point_on(robot, q, finger_frame, (0.0, 0.0, robot.gripper.finger_length))


def _point_on(robot: RobotModel, q: ArrayLike, frame: int, point: tuple[float, float, float]
              ) -> NDArray[np.float64]:
    """World position (3,) of ``point`` (m, in frame ``frame``) at q."""
    pose = frame_pose(robot, q, frame)
    return pose[:3, :3] @ np.asarray(point, dtype=float) + pose[:3, 3]
