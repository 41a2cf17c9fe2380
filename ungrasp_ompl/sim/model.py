"""The MuJoCo model of one trial: table, object, gripper, the scene's solids (MJCF text).

World frame: the scene's (x, y on the table, z up, metres; the table's top is z = 0).

What is dynamic and what is kinematic:

* the object is a free body (six degrees of freedom, gravity, no constraint of any kind
  holding it to the manipulation plane or to a digit);
* the gripper's two jaws are dynamic: each slides along the palm's x axis, the two are
  coupled symmetrically (as the RH-P12-RN's linkage couples them) and driven by one position
  servo on the opening with a force limit, so the object is squeezed with at most the grip
  force and the opening follows the object rather than the other way round; a pincer's two
  jaws (GripperGeometry.hinge, mechanics.pincer) turn instead about one hinge on the palm's y axis
  at the palm's origin, coupled symmetrically the same way, and one position servo on the
  joint angle with a torque limit (the grip force at the joint radius) drives them;
* the palm (the gripper's housing, carrying the jaws' slides) follows the pose forward
  kinematics gives for the exported joint samples: a free body welded stiffly to a mocap
  target that the trial moves there, interpolated between the control periods. A
  position-controlled UR5e moves its flange where it is told, whatever the few newtons of the
  pinch, so the weld holds it within nanometres; simulating the arm's joints would add
  nothing the contacts feel. The palm is not itself the mocap body because MuJoCo gives a
  mocap body, and every body it carries, no velocity: a digit moved that way slides over the
  object without dragging it, its friction only braking the object's own motion (docs/model.md
  section 11.13);

Friction: each contact pair has the scene's physical coefficient (table-object mu_G,
finger-object mu_A, thumb-object mu_B; walls and pieces already down mu_G), never more. The
object's own geom has friction 0, so MuJoCo's rule (the larger of the two geoms' values)
gives each pair the value of the other geom. Contacts use elliptic (Coulomb) cones with
sliding friction only (condim 3).

Contact stiffness, the timestep and the fingertip's shape are chosen from the materials
(PLA digits, celluloid, wood, chalk, a laminate table); docs/model.md section 11.2 gives
the reasons and the figures they come from.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..mechanics.pincer import PincerLinks

#: Contact softness: MuJoCo's reference time constant (s) and damping ratio. 0.2 ms is the
#: contact's own time scale between stiff solids (a gram-heavy object on a PLA dome of Hertz
#: stiffness ~2.5e5 N/m at 5 N rings at ~0.1-0.4 ms), twice the 0.1 ms step as MuJoCo asks;
#: critically damped (no bounce between stiff plastics). Steady sinking scales with its square.
SOLREF = (0.0002, 1.0)
#: Impedance: 0.95 at first touch rising to 0.995 over 0.02 mm, the Hertz deformation of a 1 mm
#: PLA dome on celluloid at 5 N (docs/model.md 11.2), with MuJoCo's default sigmoid shape.
SOLIMP = (0.95, 0.995, 0.00002, 0.5, 2.0)
#: Ratio of frictional to normal constraint impedance: > 1 makes sticking contacts stiffer
#: (less creep), as MuJoCo advises with elliptic cones. It does not change the friction coefficient.
IMPRATIO = 10.0
#: How far a rounded finger's face leans back from its dome toward the palm (rad).
FACE_DRAFT = math.radians(3.0)
#: Mass of each jaw (kg): the gripper's moving finger carriage the digit is fixed to.
JAW_MASS = 0.05
#: Mass of the palm (kg): the gripper's housing (the RH-P12-RN weighs about half a kilogram); the
#: arm carries its weight (gravity compensated), so it only sets how hard the weld pulls.
PALM_MASS = 0.5
#: The weld that makes the palm follow its target: reference time constant (s) and damping ratio
#: as stiff as the contacts' (SOLREF, the least MuJoCo's 0.1 ms step allows), critically damped;
#: an impedance of 0.99 and more lets 10 N of pinch move a 0.5 kg palm by about 1e-8 m.
PALM_SOLREF = (0.0002, 1.0)
PALM_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)
#: The 3D-printed digits' material, PLA as printed (docs/model.md 11.2): Young's modulus (Pa),
#: density (kg/m^3) and damping ratio (half the loss factor of about 0.1 of printed PLA).
PLA_MODULUS = 3.0e9
PLA_DENSITY = 1240.0
PLA_DAMPING_RATIO = 0.05


def digit_bending(length: float, t_tip: float, t_base: float, width: float,
                  modulus: float = PLA_MODULUS, density: float = PLA_DENSITY) -> tuple[float, float]:
    """A tapered digit as a rigid link on a torsion spring at its base: (stiffness N m/rad, damping
    N m s/rad) that give its tip the deflection of the cantilever (Euler-Bernoulli, second moment
    w h(z)^3 / 12 with the thickness h tapering from t_base at the palm to t_tip) and the
    vibration's damping ratio PLA_DAMPING_RATIO. Tip deflection under a tip force F:
    F * integral (L - z)^2 / (E I(z)) dz, so the spring is L^2 / that integral."""
    z = np.linspace(0.0, length, 401)
    h = t_base + (t_tip - t_base) * z / length
    compliance = np.trapezoid((length - z) ** 2 / (modulus * width * h ** 3 / 12), z)
    stiffness = length ** 2 / compliance
    inertia = np.trapezoid(density * width * h * z ** 2, z)  # about the base, kg m^2
    return float(stiffness), float(2 * PLA_DAMPING_RATIO * math.sqrt(stiffness * inertia))


@dataclass(frozen=True)
class GripperGeometry:
    """The gripper as the simulator builds it (m). Digit lengths run from the palm (palm z = 0)
    to the tip along palm z; thicknesses are behind each contact face (palm x), at the tip and
    the base; width along palm y. finger_tip_radius 0 is a flat tip (an edge across the width);
    otherwise a dome of that radius ends the finger, touching the object at one point."""

    thumb_length: float  #: palm to thumb tip (m)
    finger_length: float  #: palm to finger tip (m)
    thumb_tip_thickness: float  #: behind the thumb's face at its tip (m)
    thumb_base_thickness: float  #: behind the thumb's face at the palm (m)
    finger_tip_thickness: float  #: behind the finger's face at its tip (m)
    finger_base_thickness: float  #: behind the finger's face at the palm (m)
    width: float  #: both digits along palm y (m)
    finger_tip_radius: float  #: the finger's rounded tip (m); 0 for a flat tip
    max_opening: float  #: the gripper's stroke between the digit faces (m)
    palm_width: float  #: housing across the gap, palm x (m)
    palm_thickness: float  #: housing along palm y (m)
    palm_depth: float  #: housing along palm z, behind the palm (m)
    hinge: PincerLinks | None = None  #: a pincer's links (m, rad): the jaws turn on one hinge; None: they slide


@dataclass(frozen=True)
class SimObject:
    """The object as the simulator builds it: its outline's convex prism.

    outline: (N, 2) vertices (m) in the body frame's xy plane; the body frame is the
    manipulation plane's frame when the object lies at its target (origin at G on the
    table, x toward B, z up), so the prism spans z in [0, thickness].
    """

    outline: NDArray[np.float64]
    thickness: float  #: m
    density: float  #: kg/m^3


@dataclass(frozen=True)
class Friction:
    """Coulomb coefficients per contact pair, as the simulator uses them."""

    table: float  #: object on the table (the scene's mu_G)
    finger: float  #: object on the finger (mu_A)
    thumb: float  #: object on the thumb (mu_B)
    solids: float  #: object on walls and pieces already down (mu_G)


@dataclass(frozen=True)
class SimModelSpec:
    """Everything the MJCF needs; plain data, so that it crosses to worker processes."""

    obj: SimObject
    gripper: GripperGeometry
    friction: Friction
    solids: tuple[tuple[str, NDArray[np.float64]], ...] = ()  #: (name, world vertices (N, 3)) convex bodies
    placed: tuple[tuple[str, SimObject, NDArray[np.float64]], ...] = ()  #: free objects already down: name, object, 4x4 pose
    timestep: float = 0.0001  #: s
    table_height: float = 0.0  #: m, where the table's top really is (a calibration error moves it)
    grip_force: float = 5.0  #: N, the jaws' force limit (squeeze on the object; a pincer's at its joint radius)
    servo_stiffness: float = 1.0e4  #: N/m of opening error, below the force limit (a pincer's: at its joint radius)
    contact_time: float = SOLREF[0]  #: s, the contacts' reference time constant (MuJoCo's solref)
    cone: str = "elliptic"  #: the contacts' friction cone: elliptic or pyramidal (MuJoCo's option)


@dataclass
class ModelIds:
    """Ids of what a trial reads back from the compiled model."""

    object_body: int
    palm_mocap: int  #: the palm's target (a mocap body), moved by the trial
    palm_body: int  #: the palm itself, welded to its target
    finger_geoms: set[int]
    finger_dome: int  #: the rounded tip's dome geom; -1 for a flat tip
    thumb_geoms: set[int]
    table_geom: int
    solid_geoms: set[int]
    palm_geom: int
    object_geom: int
    actuator: int
    thumb_body: int  #: the thumb itself (it bends on its jaw)
    finger_body: int  #: the finger itself
    thumb_jaw: int  #: the thumb's carriage, sliding on the palm
    finger_jaw: int
    placed_bodies: list[int] = field(default_factory=list)


def _quat(rot: NDArray) -> NDArray[np.float64]:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    import mujoco

    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rot, dtype=float).ravel())
    return q


def _floats(values, digits: int = 9) -> str:
    return " ".join(f"{float(v):.{digits}g}" for v in np.ravel(values))


def _prism(outline: NDArray, bottom: float, top: float) -> NDArray[np.float64]:
    lo = np.column_stack([outline, np.full(len(outline), bottom)])
    hi = np.column_stack([outline, np.full(len(outline), top)])
    return np.vstack([lo, hi])


def _digit(length: float, t_tip: float, t_base: float, side: float, tip_cut: float = 0.0,
           relief: float = 0.0, draft: float = 0.0) -> NDArray[np.float64]:
    """A tapered digit's outline (x, z) in its jaw frame, on the side of x given by side (extruded
    along y by _extrude_y), the thickness measured from x = 0. The contact face runs from z = 0
    to length - tip_cut; relief > 0 stands it back behind x = 0 (where a rounded tip's dome
    touches) at its tip end, and draft (rad) tilts it further back toward the palm."""
    end = length - tip_cut
    t_end = t_base + (t_tip - t_base) * end / length
    return np.array([[side * (relief + end * math.tan(draft)), 0.0], [side * relief, end], [side * t_end, end],
                     [side * t_base, 0.0]])


def _extrude_y(xz: NDArray, width: float) -> NDArray[np.float64]:
    return np.vstack([np.column_stack([xz[:, 0], np.full(len(xz), s * width / 2), xz[:, 1]]) for s in (-1, 1)])


@dataclass(frozen=True)
class Keyframe:
    """A state of the compiled model, as MuJoCo's <key> holds it (the model's own orders)."""

    name: str
    qpos: NDArray[np.float64]
    ctrl: NDArray[np.float64]
    mocap_pos: NDArray[np.float64]  #: (nmocap, 3) m
    mocap_quat: NDArray[np.float64]  #: (nmocap, 4) w, x, y, z


def _pincer_jaws(spec: SimModelSpec, thumb_bend: str, finger_bend: str, tip: str) -> tuple[str, str, str]:
    """A pincer's jaws (GripperGeometry.hinge), MJCF: their bodies, their coupling and their
    servo. Each jaw turns on a hinge about the palm's y axis at the palm's origin (the joint),
    the thumb's by -phi/2 and the finger's by +phi/2 (phi the joint angle, rad), its digit turned
    half the closed angle within it and its face's foot off the axis (mechanics.pincer). A jaw is a
    rod of the parallel carriage's mass over the joint radius; the servo's stiffness and force
    limit are the parallel's (N/m, N) moved to the joint radius (N m/rad, N m), so that the
    fingertip feels the same servo; ctrl is the joint angle (rad)."""
    g, f = spec.gripper, spec.friction
    links = g.hinge
    half = links.max_angle / 2
    rod = JAW_MASS * links.radius ** 2 / 3  # kg m^2 about the joint
    stiffness = spec.servo_stiffness * links.radius ** 2
    bodies = []
    for name, sign, across, (lo, hi), bend, extra, mu, rgba in (
            ("thumb", -1.0, links.offset, (-half, 0.0), thumb_bend, "", f.thumb, ".8 .3 .2 1"),
            ("finger", 1.0, links.tip_radius, (0.0, half), finger_bend, tip, f.finger, ".2 .3 .8 1")):
        a = sign * links.closed_angle / 2
        bodies.append(
            f'<body name="{name}_jaw">\n'
            f'        <joint name="{name}_hinge" type="hinge" axis="0 1 0" range="{lo:.9g} {hi:.9g}" damping="0"/>\n'
            f'        <inertial pos="0 0 0" mass="{JAW_MASS}" diaginertia="{_floats([rod, rod, rod])}"/>\n'
            f'        <body name="{name}" pos="{_floats([-across * math.cos(a), 0.0, across * math.sin(a)])}" '
            f'quat="{_floats([math.cos(a / 2), 0.0, math.sin(a / 2), 0.0])}">\n'
            f'          {bend}\n'
            f'          <geom name="{name}" type="mesh" mesh="{name}" density="{PLA_DENSITY:g}" friction="{mu} 0 0" '
            f'rgba="{rgba}"/>\n'
            f'          {extra}\n'
            f'        </body>\n'
            f'      </body>')
    coupling = '<joint joint1="thumb_hinge" joint2="finger_hinge" polycoef="0 -1 0 0 0" solref="0.002 1"/>'
    force = spec.grip_force * links.radius
    actuator = (f'<position name="opening" joint="finger_hinge" gear="2" kp="{stiffness:.9g}"\n'
                f'              kv="{2 * math.sqrt(stiffness * rod):.9g}" forcelimited="true"\n'
                f'              forcerange="{-force:.9g} {force:.9g}" ctrllimited="true" '
                f'ctrlrange="0 {links.max_angle:.9g}"/>')
    return "\n      ".join(bodies), coupling, actuator


def build_mjcf(spec: SimModelSpec, key: Keyframe | None = None) -> str:
    """The MJCF text of the trial's world (see the module docstring for what moves how), with
    key as a <keyframe> when given."""
    g, f, obj = spec.gripper, spec.friction, spec.obj
    solref, solimp = _floats((spec.contact_time, SOLREF[1])), _floats(SOLIMP)
    half = g.max_opening / 2
    flat = g.finger_tip_radius <= 0.0
    thumb = _extrude_y(_digit(g.thumb_length, g.thumb_tip_thickness, g.thumb_base_thickness, -1.0), g.width)
    # a rounded finger is a ball-nosed digit: its body ends at the dome's centre and its face
    # stands back by the dome's radius there, and further toward the palm (FACE_DRAFT), so that
    # nothing but the dome reaches the object, even where it turns a little in the grasp (psi < 0)
    r = 0.0 if flat else g.finger_tip_radius
    finger = _extrude_y(_digit(g.finger_length, g.finger_tip_thickness, g.finger_base_thickness, 1.0, r, r,
                               0.0 if flat else FACE_DRAFT), g.width)
    thumb_k, thumb_c = digit_bending(g.thumb_length, g.thumb_tip_thickness, g.thumb_base_thickness, g.width)
    finger_k, finger_c = digit_bending(g.finger_length, g.finger_tip_thickness, g.finger_base_thickness, g.width)
    assets = [f'<mesh name="object" vertex="{_floats(_prism(obj.outline, 0.0, obj.thickness))}"/>',
              f'<mesh name="thumb" vertex="{_floats(thumb)}"/>',
              f'<mesh name="finger" vertex="{_floats(finger)}"/>']
    solids = []
    for k, (name, verts) in enumerate(spec.solids):
        centre = np.asarray(verts).mean(axis=0)
        assets.append(f'<mesh name="solid{k}" vertex="{_floats(np.asarray(verts) - centre)}"/>')
        solids.append(f'<geom name="solid{k}" type="mesh" mesh="solid{k}" pos="{_floats(centre)}" '
                      f'friction="{f.solids} 0 0" rgba=".55 .45 .35 1"/>')
    placed = []
    for k, (name, other, pose) in enumerate(spec.placed):
        assets.append(f'<mesh name="placed{k}" vertex="{_floats(_prism(other.outline, 0.0, other.thickness))}"/>')
        quat = _quat(np.asarray(pose)[:3, :3])
        placed.append(f'<body name="placed{k}" pos="{_floats(np.asarray(pose)[:3, 3])}" quat="{_floats(quat)}">'
                      f'<freejoint/><geom name="placed{k}" type="mesh" mesh="placed{k}" density="{other.density:.9g}" '
                      f'friction="{f.solids} 0 0" rgba=".6 .6 .2 1"/></body>')
    tip = "" if flat else (
        f'<geom name="finger_tip" type="sphere" size="{g.finger_tip_radius:.9g}" '
        f'pos="{g.finger_tip_radius:.9g} 0 {g.finger_length - g.finger_tip_radius:.9g}" '
        f'density="{PLA_DENSITY:g}" friction="{f.finger} 0 0" rgba=".2 .3 .8 1"/>')
    thumb_bend = (f'<joint name="thumb_bend" type="hinge" axis="0 1 0" stiffness="{thumb_k:.9g}" '
                  f'damping="{thumb_c:.9g}"/>')
    finger_bend = (f'<joint name="finger_bend" type="hinge" axis="0 1 0" stiffness="{finger_k:.9g}" '
                   f'damping="{finger_c:.9g}"/>')
    if g.hinge is not None:
        jaws, coupling, actuator = _pincer_jaws(spec, thumb_bend, finger_bend, tip)
    else:  # two carriages sliding on the palm, coupled, one force-limited servo on the opening
        jaws = f"""<body name="thumb_jaw">
        <joint name="thumb_slide" type="slide" axis="1 0 0" range="{-half:.9g} 0" damping="0"/>
        <inertial pos="0 0 0" mass="{JAW_MASS}" diaginertia="1e-5 1e-5 1e-5"/>
        <body name="thumb">
          {thumb_bend}
          <geom name="thumb" type="mesh" mesh="thumb" density="{PLA_DENSITY:g}" friction="{f.thumb} 0 0" rgba=".8 .3 .2 1"/>
        </body>
      </body>
      <body name="finger_jaw">
        <joint name="finger_slide" type="slide" axis="1 0 0" range="0 {half:.9g}" damping="0"/>
        <inertial pos="0 0 0" mass="{JAW_MASS}" diaginertia="1e-5 1e-5 1e-5"/>
        <body name="finger">
          {finger_bend}
          <geom name="finger" type="mesh" mesh="finger" density="{PLA_DENSITY:g}" friction="{f.finger} 0 0" rgba=".2 .3 .8 1"/>
          {tip}
        </body>
      </body>"""
        coupling = '<joint joint1="thumb_slide" joint2="finger_slide" polycoef="0 -1 0 0 0" solref="0.002 1"/>'
        actuator = f"""<position name="opening" joint="finger_slide" gear="2" kp="{spec.servo_stiffness:.9g}"
              kv="{2 * math.sqrt(spec.servo_stiffness * JAW_MASS):.9g}" forcelimited="true"
              forcerange="{-spec.grip_force:.9g} {spec.grip_force:.9g}" ctrllimited="true" ctrlrange="0 {g.max_opening:.9g}"/>"""
    return f"""<mujoco model="ungrasp">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{spec.timestep:.9g}" cone="{spec.cone}" impratio="{IMPRATIO:g}" integrator="implicitfast">
    <flag multiccd="enable"/>
  </option>
  <default>
    <geom condim="3" solref="{solref}" solimp="{solimp}" friction="0 0 0"/>
  </default>
  <asset>
    {chr(10).join('    ' + a for a in assets).strip()}
  </asset>
  <worldbody>
    <geom name="table" type="plane" size="0 0 1" pos="0 0 {spec.table_height:.9g}" friction="{f.table} 0 0"
          rgba=".8 .8 .8 1"/>
    {chr(10).join('    ' + s for s in solids).strip()}
    <body name="palm_target" mocap="true"/>
    <body name="palm" gravcomp="1">
      <freejoint name="palm"/>
      <geom name="palm" type="box" size="{g.palm_width / 2:.9g} {g.palm_thickness / 2:.9g} {g.palm_depth / 2:.9g}"
            pos="0 0 {-g.palm_depth / 2:.9g}" mass="{PALM_MASS:g}" rgba=".3 .3 .3 1"/>
      {jaws}
    </body>
    <body name="object">
      <freejoint name="object"/>
      <geom name="object" type="mesh" mesh="object" density="{obj.density:.9g}" rgba=".9 .7 .1 1"/>
    </body>
    {chr(10).join('    ' + p for p in placed).strip()}
  </worldbody>
  <contact>
    <exclude body1="thumb" body2="finger"/>
    <exclude body1="thumb_jaw" body2="finger_jaw"/>
    <exclude body1="palm" body2="thumb"/>
    <exclude body1="palm" body2="finger"/>
  </contact>
  <equality>
    <weld body1="palm_target" body2="palm" solref="{_floats(PALM_SOLREF)}" solimp="{_floats(PALM_SOLIMP)}"/>
    {coupling}
  </equality>
  <actuator>
    {actuator}
  </actuator>{_keyframe(key)}
</mujoco>
"""


def _keyframe(key: Keyframe | None) -> str:
    if key is None:
        return ""
    exact = 17  # a float's every digit: the state replays the trial's own to the last bit
    return (f'\n  <keyframe>\n    <key name="{key.name}" qpos="{_floats(key.qpos, exact)}" ctrl="{_floats(key.ctrl, exact)}"\n'
            f'         mpos="{_floats(key.mocap_pos, exact)}" mquat="{_floats(key.mocap_quat, exact)}"/>\n  </keyframe>')


def model_ids(model) -> ModelIds:
    """The ids a trial needs, looked up by name in a compiled model."""
    import mujoco

    def geom(name: str) -> int:
        return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)

    def body(name: str) -> int:
        return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)

    finger = {geom("finger")} | ({geom("finger_tip")} if geom("finger_tip") >= 0 else set())
    names = {i: mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i) or "" for i in range(model.ngeom)}
    solids = {i for i, n in names.items() if n.startswith(("solid", "placed"))}
    return ModelIds(object_body=body("object"), palm_mocap=int(model.body_mocapid[body("palm_target")]),
                    palm_body=body("palm"),
                    finger_geoms=finger, finger_dome=geom("finger_tip"), thumb_geoms={geom("thumb")}, table_geom=geom("table"),
                    solid_geoms=solids, palm_geom=geom("palm"), object_geom=geom("object"),
                    actuator=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, "opening"),
                    thumb_body=body("thumb"), finger_body=body("finger"), thumb_jaw=body("thumb_jaw"),
                    finger_jaw=body("finger_jaw"),
                    placed_bodies=[body(f"placed{k}") for k in range(model.nbody) if body(f"placed{k}") >= 0])
