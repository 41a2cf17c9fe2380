"""The touch-off a set-up makes before running a plan (robot.touch_off).

The arm's calibration leaves the table's height, as the arm sees it, uncertain by about a
millimetre, as much as the plan's clearances. A touch-off measures it where it matters: the empty
hand, at the start pinch's orientation and opening, starts `lift` above the start pinch and is
lowered straight down (world z) until a digit touches the table. Had the table been where the
scene has it, the hand would have gone `lift + clearance` (clearance: the digits' lowest point
above the table at the start pinch, as planned); every metre less is a metre the table stands
higher than the scene has it. The scene's robot.base is then lowered by that much and the plan
exported again (docs/model.md 11.14; export.write_touch_off_urscript writes the probe).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mechanics.kinematics import digits_clearance
from ..planning.result import Plan
from ..scene import Scene
from .trajectory import JointTrajectory


@dataclass(frozen=True)
class TouchOffOptions:
    """How the probe moves."""

    lift: float = 0.01
    """How far above the start pinch the probe starts (m): more than the table's uncertainty."""
    speed: float = 0.005
    """How fast the hand is lowered (m/s): slow enough that the contact is dated to a control period
    (0.01 mm at the UR e-series' 2 ms) and the digit is not marked."""


@dataclass(frozen=True)
class TouchOff:
    """The probe of one plan: where it starts and what it expects to find."""

    start_joints: tuple[float, ...]
    """Arm joints (rad) at the start pinch (the trajectory's first pose after the approach)."""
    opening: float
    """The gripper's opening at the start pinch (m); the hand is empty."""
    clearance: float
    """How far the digits' lowest point is above the table at the start pinch, as planned (m)."""
    base_z: float
    """The scene's robot.base height (m), which the measured offset corrects."""
    options: TouchOffOptions = TouchOffOptions()

    @property
    def expected_descent(self) -> float:
        """How far (m) the hand goes down from its start before a digit touches a table where the
        scene has it: lift + clearance."""
        return self.options.lift + self.clearance


def touch_off(scene: Scene, plan: Plan, trajectory: JointTrajectory,
              options: TouchOffOptions = TouchOffOptions(), prefix: str = "") -> TouchOff | None:
    """The touch-off for plan executed as trajectory (robot.pipeline.execute), None when the
    scene's robot makes none (robot.touch_off false): the start pinch is where the approach ends
    (the segment prefix + "approach": a layout's piece names its segments); the clearance is the
    digits' lowest point there (mechanics digits_clearance at the plan's first state), in metres."""
    if not scene.robot.touch_off:
        return None
    approach = next((end for name, _, end in trajectory.segments if name == prefix + "approach"), 0)
    q = trajectory.positions[approach]
    theta, d, psi = plan.states[0]
    clearance = float(digits_clearance(theta, d, psi, scene.digits)) * scene.object_length
    return TouchOff(start_joints=tuple(float(x) for x in q[:6]), opening=float(q[6]), clearance=clearance,
                    base_z=float(np.asarray(scene.robot.base)[2, 3]), options=options)
