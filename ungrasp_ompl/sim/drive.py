"""What the simulated gripper is told: the palm pose and the commanded opening against time.

The exported joint trajectory is what a robot controller gets. The simulator samples it the
way a UR e-series streams it (linear interpolation of the joint samples at the 2 ms
control period), takes the palm pose of each sample by forward kinematics of the arm model,
and the gripper opening from the trajectory's last column.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..robot.model import RobotModel, tcp_pose
from ..robot.trajectory import JointTrajectory

#: The UR e-series control period (s): the palm pose is updated this often.
CONTROL_PERIOD = 0.002
#: Segments of a placement that the drive leaves out (robot.pipeline's names): the trial starts with
#: the object in the pinch, and a start press is the settling's.
UNDRIVEN = ("approach", "return", "press")


@dataclass(frozen=True)
class GripperDrive:
    """Palm poses and openings at the control ticks of one placement.

    times: (K,) s from the start of the placement's first primitive; palm: (K, 4, 4) world
    poses of the palm frame; opening: (K,) m between the digit faces; phases: (name, start s,
    end s) of each primitive, the termination and the retreat, in order; press_from: the palm's
    world pose (4, 4) where a start press (robot.start_press) begins, the planned start pinch,
    or None without one (the trial's settling then brings the palm from there to palm[0]).
    """

    times: NDArray[np.float64]
    palm: NDArray[np.float64]
    opening: NDArray[np.float64]
    phases: tuple[tuple[str, float, float], ...]
    press_from: NDArray[np.float64] | None = None

    def phase_at(self, t: float) -> tuple[int, str]:
        """Index and name of the phase running at time t (s); the last phase after the end."""
        for k, (name, a, b) in enumerate(self.phases):
            if t <= b:
                return k, name
        return len(self.phases) - 1, self.phases[-1][0]

    def phase_start(self, name: str) -> float:
        """Start (s) of the first phase of that name; the end of the drive if there is none."""
        return next((a for n, a, _ in self.phases if n == name), float(self.times[-1]))

    def until(self, t: float) -> "GripperDrive":
        """The drive cut after its first tick at or past t (s), its phases as they are (a phase
        that starts at t still starts there)."""
        k = int(np.searchsorted(self.times, t, side="left")) + 1
        return replace(self, times=self.times[:k], palm=self.palm[:k], opening=self.opening[:k])


def drive_from_trajectory(traj: JointTrajectory, robot: RobotModel, prefix: str = "",
                          period: float = CONTROL_PERIOD) -> GripperDrive:
    """The drive of one placement of a trajectory: from the start of its first primitive
    (the approach, where the object is carried, is left out: the trial starts with the object
    in the pinch; so is a start press, which the trial's settling makes from its first pose) to
    the end of its retreat. prefix selects a piece of a tiling trajectory ('square/'); segments
    are named as robot.pipeline names them."""
    ours = [(name[len(prefix):], a, b) for name, a, b in traj.segments if name.startswith(prefix)]
    mine = [(name, a, b) for name, a, b in ours if name not in UNDRIVEN]
    press = next((a for name, a, _ in ours if name == "press"), None)
    if not mine:
        raise ValueError(f"the trajectory has no segments named {prefix}<primitive>")
    i0, i1 = mine[0][1], mine[-1][2]
    t0, t1 = float(traj.times[i0]), float(traj.times[i1])
    ticks = np.arange(0.0, t1 - t0 + 1e-12, period)
    if ticks[-1] < t1 - t0 - 1e-9:
        ticks = np.append(ticks, t1 - t0)
    t = traj.times[i0:i1 + 1] - t0
    q = np.column_stack([np.interp(ticks, t, traj.positions[i0:i1 + 1, j]) for j in range(traj.positions.shape[1])])
    palm = np.array([tcp_pose(robot, row[:-1]) for row in q])
    phases = tuple((name, float(traj.times[a]) - t0, float(traj.times[b]) - t0) for name, a, b in mine)
    press_from = None if press is None else tcp_pose(robot, traj.positions[press, :-1])
    return GripperDrive(ticks, palm, q[:, -1].copy(), phases, press_from)
