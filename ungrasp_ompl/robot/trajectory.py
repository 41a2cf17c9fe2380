"""A timed joint trajectory: the hand-over between time parameterisation and export."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

#: The UR ROS 2 driver's arm joint names, then the gripper's.
ARM_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
              "wrist_3_joint")
GRIPPER_JOINT = "gripper_opening"  # distance between the digit faces, metres
JOINT_NAMES = ARM_JOINTS + (GRIPPER_JOINT,)
#: A pincer's joint (mechanics.pincer): the angle the digits are turned apart from closed, radians.
PINCER_JOINT = "gripper_angle"
PINCER_JOINT_NAMES = ARM_JOINTS + (PINCER_JOINT,)


@dataclass
class JointTrajectory:
    """Samples of the 6 arm joints (rad) and the gripper opening (m; a pincer's joint angle, rad)
    against time (s).

    times (N,), positions, velocities, accelerations (N, 7), in joint_names order: JOINT_NAMES, or
    PINCER_JOINT_NAMES for a pincer.
    segments: (name, start index, end index) of the phases (approach, each primitive,
    termination, retreat), for people and for checks.
    """

    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    accelerations: NDArray[np.float64]
    joint_names: tuple[str, ...] = JOINT_NAMES
    segments: list[tuple[str, int, int]] = field(default_factory=list)

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0])
