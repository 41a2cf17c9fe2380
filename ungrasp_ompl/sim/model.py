"""The MuJoCo model of one trial: table, object, gripper, the scene's solids (MJCF text).

The bodies, their shapes, masses, springs and frictions come from the world description
(sim.world_description.describe), which Drake's builder (sim.drake_world) reads too; this module
adds what is MuJoCo's own (the contacts' solref and solimp, the palm's weld to its mocap target,
the equality coupling the jaws, the position servo); the engine-free parts are sim.spec's.

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

Friction: each contact pair has the scene's physical coefficient (sim.spec.PairFriction: table-object
mu_G, finger-object mu_A, thumb-object mu_B; walls and pieces already down mu_G), never more. The
object's own geom has friction 0, so MuJoCo's rule (the larger of the two geoms' values)
gives each pair the value of the other geom. Contacts use elliptic (Coulomb) cones with
sliding friction only (condim 3).

Contact stiffness, the timestep and the fingertip's shape are chosen from the materials
(PLA digits, celluloid, wood, chalk, a laminate table); docs/model.md section 11.2 gives
the reasons and the figures they come from.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .spec import IMPRATIO, PALM_SOLIMP, PALM_SOLREF, SOLIMP, SOLREF, SimModelSpec
from .world_description import WorldDescription, describe

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


def _exponent(values) -> str:
    """_floats with the exponents written without a leading zero ('1e-5'), as the slide jaws'
    inertia has always been written (the MJCF text stays the same, byte for byte)."""
    return _floats(values).replace("e-0", "e-").replace("e+0", "e+")


@dataclass(frozen=True)
class Keyframe:
    """A state of the compiled model, as MuJoCo's <key> holds it (the model's own orders)."""

    name: str
    qpos: NDArray[np.float64]
    ctrl: NDArray[np.float64]
    mocap_pos: NDArray[np.float64]  #: (nmocap, 3) m
    mocap_quat: NDArray[np.float64]  #: (nmocap, 4) w, x, y, z


def _pincer_jaws(world: WorldDescription, thumb_bend: str, finger_bend: str, tip: str) -> tuple[str, str, str]:
    """A pincer's jaws (GripperGeometry.hinge; the world description's hinged jaws), MJCF: their
    bodies, their coupling and their servo; ctrl is the joint angle (rad)."""
    bodies = []
    for jaw, bend, extra in ((world.thumb, thumb_bend, ""), (world.finger, finger_bend, tip)):
        name, digit, geom = jaw.name, jaw.digit, jaw.digit.geoms[0]
        bodies.append(
            f'<body name="{name}_jaw">\n'
            f'        <joint name="{jaw.joint_name}" type="hinge" axis="0 1 0" range="{jaw.lower:.9g} {jaw.upper:.9g}" damping="0"/>\n'
            f'        <inertial pos="0 0 0" mass="{jaw.mass}" diaginertia="{_floats(jaw.inertia)}"/>\n'
            f'        <body name="{name}" pos="{_floats(digit.position)}" '
            f'quat="{_floats(digit.quat)}">\n'
            f'          {bend}\n'
            f'          <geom name="{name}" type="mesh" mesh="{name}" density="{geom.density:g}" friction="{geom.friction} 0 0" '
            f'rgba="{geom.rgba}"/>\n'
            f'          {extra}\n'
            f'        </body>\n'
            f'      </body>')
    coupling = '<joint joint1="thumb_hinge" joint2="finger_hinge" polycoef="0 -1 0 0 0" solref="0.002 1"/>'
    servo = world.servo
    actuator = (f'<position name="opening" joint="{servo.joint}" gear="{servo.gear:g}" kp="{servo.stiffness:.9g}"\n'
                f'              kv="{servo.damping:.9g}" forcelimited="true"\n'
                f'              forcerange="{-servo.force_limit:.9g} {servo.force_limit:.9g}" ctrllimited="true" '
                f'ctrlrange="0 {servo.command_max:.9g}"/>')
    return "\n      ".join(bodies), coupling, actuator


def build_mjcf(spec: SimModelSpec, key: Keyframe | None = None) -> str:
    """The MJCF text of the trial's world (see the module docstring for what moves how), with
    key as a <keyframe> when given: the world description's bodies (sim.world_description) with
    MuJoCo's contacts, weld and servo."""

    world = describe(spec)
    solref, solimp = _floats((spec.contact_time, SOLREF[1])), _floats(SOLIMP)
    thumb, finger, dome, obj = world.thumb, world.finger, world.dome, world.object.geom
    assets = [f'<mesh name="object" vertex="{_floats(obj.shape.vertices)}"/>',
              f'<mesh name="thumb" vertex="{_floats(thumb.digit.geoms[0].shape.vertices)}"/>',
              f'<mesh name="finger" vertex="{_floats(finger.digit.geoms[0].shape.vertices)}"/>']
    solids = []
    for k, solid in enumerate(world.solids):
        assets.append(f'<mesh name="solid{k}" vertex="{_floats(solid.shape.vertices)}"/>')
        solids.append(f'<geom name="solid{k}" type="mesh" mesh="solid{k}" pos="{_floats(solid.shape.centre)}" '
                      f'friction="{solid.friction} 0 0" rgba="{solid.rgba}"/>')
    placed = []
    for k, other in enumerate(world.placed):
        assets.append(f'<mesh name="placed{k}" vertex="{_floats(other.geom.shape.vertices)}"/>')
        quat = _quat(other.pose[:3, :3])
        placed.append(f'<body name="placed{k}" pos="{_floats(other.pose[:3, 3])}" quat="{_floats(quat)}">'
                      f'<freejoint/><geom name="placed{k}" type="mesh" mesh="placed{k}" density="{other.geom.density:.9g}" '
                      f'friction="{other.geom.friction} 0 0" rgba="{other.geom.rgba}"/></body>')
    tip = "" if dome is None else (
        f'<geom name="finger_tip" type="sphere" size="{dome.shape.radius:.9g}" '
        f'pos="{dome.shape.centre[0]:.9g} 0 {dome.shape.centre[2]:.9g}" '
        f'density="{dome.density:g}" friction="{dome.friction} 0 0" rgba="{dome.rgba}"/>')
    thumb_bend = (f'<joint name="thumb_bend" type="hinge" axis="0 1 0" stiffness="{thumb.digit.bend.stiffness:.9g}" '
                  f'damping="{thumb.digit.bend.damping:.9g}"/>')
    finger_bend = (f'<joint name="finger_bend" type="hinge" axis="0 1 0" stiffness="{finger.digit.bend.stiffness:.9g}" '
                   f'damping="{finger.digit.bend.damping:.9g}"/>')
    if thumb.joint == "hinge":
        jaws, coupling, actuator = _pincer_jaws(world, thumb_bend, finger_bend, tip)
    else:
        jaws, coupling, actuator = _parallel_jaws(world, thumb_bend, finger_bend, tip)
    palm = world.palm
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
    <geom name="table" type="plane" size="0 0 1" pos="0 0 {world.table_height:.9g}" friction="{world.table_friction} 0 0"
          rgba=".8 .8 .8 1"/>
    {chr(10).join('    ' + s for s in solids).strip()}
    <body name="palm_target" mocap="true"/>
    <body name="palm" gravcomp="1">
      <freejoint name="palm"/>
      <geom name="palm" type="box" size="{_floats(palm.shape.half)}"
            pos="0 0 {palm.shape.centre[2]:.9g}" mass="{palm.mass:g}" rgba="{palm.rgba}"/>
      {jaws}
    </body>
    <body name="object">
      <freejoint name="object"/>
      <geom name="object" type="mesh" mesh="object" density="{obj.density:.9g}" rgba="{obj.rgba}"/>
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


def _parallel_jaws(world: WorldDescription, thumb_bend: str, finger_bend: str, tip: str) -> tuple[str, str, str]:
    """The parallel gripper's MJCF: two carriages sliding on the palm, each with its digit on its
    bend, coupled, one force-limited servo on the opening: (the jaws' bodies, the coupling, the
    actuator)."""
    thumb, finger = world.jaws
    tg, fg, servo = thumb.digit.geoms[0], finger.digit.geoms[0], world.servo
    jaws = f"""<body name="thumb_jaw">
        <joint name="thumb_slide" type="slide" axis="1 0 0" range="{thumb.lower:.9g} {thumb.upper:.9g}" damping="0"/>
        <inertial pos="0 0 0" mass="{thumb.mass}" diaginertia="{_exponent(thumb.inertia)}"/>
        <body name="thumb">
          {thumb_bend}
          <geom name="thumb" type="mesh" mesh="thumb" density="{tg.density:g}" friction="{tg.friction} 0 0" rgba="{tg.rgba}"/>
        </body>
      </body>
      <body name="finger_jaw">
        <joint name="finger_slide" type="slide" axis="1 0 0" range="{finger.lower:.9g} {finger.upper:.9g}" damping="0"/>
        <inertial pos="0 0 0" mass="{finger.mass}" diaginertia="{_exponent(finger.inertia)}"/>
        <body name="finger">
          {finger_bend}
          <geom name="finger" type="mesh" mesh="finger" density="{fg.density:g}" friction="{fg.friction} 0 0" rgba="{fg.rgba}"/>
          {tip}
        </body>
      </body>"""
    coupling = '<joint joint1="thumb_slide" joint2="finger_slide" polycoef="0 -1 0 0 0" solref="0.002 1"/>'
    actuator = f"""<position name="opening" joint="{servo.joint}" gear="{servo.gear:g}" kp="{servo.stiffness:.9g}"
              kv="{servo.damping:.9g}" forcelimited="true"
              forcerange="{-servo.force_limit:.9g} {servo.force_limit:.9g}" ctrllimited="true" ctrlrange="0 {servo.command_max:.9g}"/>"""
    return jaws, coupling, actuator


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
