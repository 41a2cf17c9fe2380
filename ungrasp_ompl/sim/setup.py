"""From a scene and its executed plan to what every trial shares (a TrialSetup).

Data flow: scene + plan -> robot trajectory (robot.pipeline) -> palm poses and openings
(sim.drive) + the world's bodies (sim.model) -> trials (sim.trial).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..planning.result import Plan
from ..robot.model import RobotModel
from ..robot.pipeline import Aim, aimed_frame
from ..robot.placement import plane_points
from ..robot.trajectory import JointTrajectory
from ..scene import Scene
from .drive import drive_from_trajectory
from .spec import GripperGeometry, PairFriction, SimModelSpec, SimObject, curved_solid
from .trial import PlannedTravel, TrialSetup


@dataclass(frozen=True)
class Variant:
    """A deliberate difference between the simulated object or digits and the planned ones (the
    experiments' controls; sim.world.World holds the differences of the world's physics); the
    defaults simulate the scene as planned."""

    thickness: float | None = None  #: the simulated object's thickness (m) instead of the scene's
    equal_digits: bool = False  #: the thumb made as long as the finger (alpha 0), the motion unchanged


#: How far (m) the simulated object's facets may stray from its curved outline: a tenth of the
#: 0.02 mm Hertz indentation of its contacts (docs/model.md 11.1), so that the contacts feel the
#: curve, with its own curvature on both sides of G and B, and not the planner's samples.
OUTLINE_SAGITTA = 2e-6


def object_outline(scene: Scene) -> NDArray[np.float64]:
    """The object's outline (N, 2) in its body frame (the manipulation plane's frame at the
    target: x along GB from G, y across), m, its curves filled in to OUTLINE_SAGITTA. Without an
    outline: a strip of the object's length and the digits' width."""
    if scene.object3d is not None and scene.plane is not None:
        frame = scene.plane.frame
        return (scene.object3d.placed_outline(OUTLINE_SAGITTA) - frame[:2, 3]) @ frame[:2, :2]
    l, w = scene.object_length, scene.digits.width * scene.object_length
    return np.array([[0.0, -w / 2], [l, -w / 2], [l, w / 2], [0.0, w / 2]])


def tilted(frame: NDArray, theta: float) -> NDArray[np.float64]:
    """The object's body pose (4x4) at tilt theta (rad) about G: the plane frame turned about its
    y axis so that x rises toward z."""
    c, s = math.cos(theta), math.sin(theta)
    turn = np.eye(4)
    turn[:3, :3] = [[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]]
    return frame @ turn


def gripper_geometry(scene: Scene, robot: RobotModel, equal_digits: bool = False) -> GripperGeometry:
    """The simulated gripper: the scene's digits (m) on the robot model's housing; a pincer's
    (mechanics.pincer) run from their tips to its joint's level and turn on its hinge."""
    l, dg, g = scene.object_length, scene.digits, robot.gripper
    finger = dg.finger_length * l
    thumb = finger if equal_digits else dg.thumb_length * l
    if robot.pincer is not None:  # equal digits: the thumb's face reaches as far as the finger's
        finger = robot.pincer.finger_length
        thumb = finger if equal_digits else robot.pincer.thumb_reach
    return GripperGeometry(thumb_length=thumb, finger_length=finger,
                           thumb_tip_thickness=dg.thumb_tip_thickness * l,
                           thumb_base_thickness=dg.thumb_base_thickness * l,
                           finger_tip_thickness=dg.finger_tip_thickness * l,
                           finger_base_thickness=dg.finger_base_thickness * l, width=dg.width * l,
                           finger_tip_radius=dg.finger_tip_radius * l, max_opening=g.max_opening,
                           palm_width=g.palm_width, palm_thickness=g.palm_thickness, palm_depth=g.palm_depth,
                           hinge=robot.pincer)


def planned_travel(scene: Scene, plan: Plan) -> tuple[PlannedTravel, ...]:
    """How far each primitive of the plan moves A and B (m): on the object (in its plane's frame:
    along GB and across it) and on the digits (along the digit axis and across the gap), net
    between the primitive's first and last states, where the export puts the digits."""
    out = []
    for prim in plan.primitives:
        p = plane_points(scene, [prim.start, prim.end])
        u = np.column_stack([np.cos([prim.start[0], prim.end[0]]), np.sin([prim.start[0], prim.end[0]])])
        top = np.column_stack([-u[:, 1], u[:, 0]])

        def moved(point: NDArray, origin: NDArray | None, x: NDArray, y: NDArray) -> float:
            rel = point - (origin if origin is not None else 0.0)
            local = np.column_stack([np.sum(rel * x, axis=1), np.sum(rel * y, axis=1)])
            return float(np.linalg.norm(local[1] - local[0]))

        out.append(PlannedTravel(prim.type, moved(p["a"], None, u, top), moved(p["a"], p["finger"], p["e"], p["n"]),
                                 moved(p["b"], None, u, top), moved(p["b"], p["thumb"], p["e"], p["n"])))
    return tuple(out)


def trial_setup(scene: Scene, plan: Plan, trajectory: JointTrajectory, robot: RobotModel,
                variant: Variant = Variant(), prefix: str = "",
                placed: tuple[tuple[str, SimObject, NDArray[np.float64]], ...] = (),
                aim: Aim = Aim()) -> TrialSetup:
    """What every trial of the placement of scene's object by plan shares. trajectory and robot:
    the executed plan (robot.pipeline), its motion moved by aim from the plan's frame; prefix: the
    piece's segment prefix in a tiling trajectory; placed: objects already down (free bodies) with
    their poses."""
    opts = scene.sim
    frame = scene.plane_frame()
    l = scene.object_length
    thickness = variant.thickness if variant.thickness is not None else scene.object_thickness
    turned = scene.object3d is not None and scene.plane is not None  # a round object's section turns about its axis
    obj = SimObject(object_outline(scene), thickness, opts.density,
                    curved_solid(scene.digits.section, l, scene.digits.width * l, turned))
    # a pincer's servo is on its joint: its torque limit gives the pinch at the joint radius (the
    # squeeze, m at the fingertip, is commanded as the angle that turns the fingertip that far:
    # TrialSetup.servo_squeeze)
    links = robot.pincer
    grip_force = opts.grip_force if links is None else links.pinch_force
    spec = SimModelSpec(obj=obj, gripper=gripper_geometry(scene, robot, variant.equal_digits),
                        friction=PairFriction.from_contacts(scene.mu_contacts),
                        solids=tuple((s.name, np.asarray(s.vertices)) for s in scene.solids),
                        placed=placed, timestep=opts.timestep, grip_force=grip_force,
                        servo_stiffness=2 * grip_force / opts.squeeze)
    theta0, d0, _ = plan.states[0]
    return TrialSetup(spec=spec, drive=drive_from_trajectory(trajectory, robot, prefix),
                      start_pose=tilted(aimed_frame(scene, aim), theta0), target_pose=frame.copy(),
                      grasp_point=np.array([(1.0 - d0) * l, 0.0, thickness]), b_point=np.array([l, 0.0, 0.0]),
                      sim=opts, planned=planned_travel(scene, plan), touch_off=scene.robot.touch_off,
                      aim=Aim(*map(float, aim)))
