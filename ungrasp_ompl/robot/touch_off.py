"""The touch-off a set-up makes before running a plan (robot.touch_off).

The arm's calibration leaves the table's height, as the arm sees it, uncertain by about a
millimetre, as much as the plan's clearances. A touch-off measures it where it matters: the empty
hand, at the start pinch's orientation and opening, starts `lift` above the start pinch and is
lowered straight down (the arm's z) at `speed`; each control period the wrist's force sensor is
read, and the descent stops at the first period whose vertical reading passes `threshold`. The
hand has then gone on past the first touch by the digits' and the contacts' give at that force
(`deflection`, a calibration of the cell made once on a surface of known height); less that, the
commanded descent is how far the hand went before a digit met the table. Had the table been where
the scene has it, that is `lift + clearance` (clearance: the digits' lowest point above the table
at the start pinch, as planned); every metre less is a metre the table stands higher than the
scene has it. The scene's robot.base is then lowered by that much and the plan exported again
(docs/model.md 11.14; export.write_touch_off_urscript writes the probe, and sim.probe simulates it
with the same options).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mechanics.kinematics import digits_clearance
from ..mechanics.pincer import pincer_clearance
from ..planning.result import Plan
from ..scene import Scene
from .trajectory import JointTrajectory

#: The UR5e's built-in force/torque sensor, force along x, y, z (its data sheet, docs/model.md
#: 11.14): the range, the precision and the accuracy (N).
FORCE_RANGE, FORCE_PRECISION, FORCE_ACCURACY = 50.0, 3.5, 4.0
#: One standard deviation (N) of one force reading: the data sheet's precision read as the
#: two-sigma band (95 %) of repeated readings, each reading's noise Gaussian and independent of
#: the others'.
FORCE_NOISE = FORCE_PRECISION / 2


@dataclass(frozen=True)
class TouchOffOptions:
    """How the probe moves and when it stops (the exported program's and the simulator's)."""

    lift: float = 0.01
    """How far above the start pinch the probe starts (m): more than the arm's vertical calibration
    error at the digits (some 3 mm at worst in the `paper` box), so that the empty hand never starts
    on the table."""
    speed: float = 0.005
    """How fast the hand is lowered (m/s): slow enough that the stop is dated to 0.01 mm (a control
    period's travel) and that the digits meet the table gently."""
    threshold: float = 10.0
    """The vertical force reading (N, either sign) that stops the descent: 5.7 FORCE_NOISE, which the
    noise alone passes once in 9e7 readings (a probe reads free air 1400 to 1800 times: a stop in
    free air once in 5e4 probes); above the sensor's accuracy (4 N), a fifth of its range (50 N)."""
    overtravel: float = 0.005
    """How far (m) past the expected touch (lift + clearance) the hand may go without the reading
    passing the threshold before the probe gives up: the arm's calibration error and the digits'
    give at the threshold (about 1 mm), with room."""
    period: float = 0.002
    """The control period (s) at which the sensor is read and the hand's target moves: the UR
    e-series' 500 Hz."""

    @property
    def step(self) -> float:
        """How far (m) the hand's target goes down in one control period."""
        return self.speed * self.period


@dataclass(frozen=True)
class TouchOff:
    """The probe of one plan: where it starts and what it expects to find."""

    start_joints: tuple[float, ...]
    """Arm joints (rad) at the start pinch (the trajectory's first pose after the approach)."""
    opening: float
    """The gripper's opening at the start pinch (m; a pincer's joint angle, rad); the hand is empty."""
    clearance: float
    """How far the digits' lowest point is above the table at the start pinch, as planned (m)."""
    base_z: float
    """The scene's robot.base height (m), which the measured offset corrects."""
    options: TouchOffOptions = TouchOffOptions()
    pincer: bool = False
    """Whether the gripper is a pincer (robot.gripper.kind pincer), whose opening is its joint angle."""
    deflection: float = 0.0
    """How far (m) the hand goes on past the first touch before the reading passes the threshold:
    the digits' and the contacts' give at that force, a calibration of the cell made once with this
    probe over a surface of known height (sim.probe.calibrate gives the simulated hand's); 0: not
    calibrated, the table is then found lower than it is by the give."""

    @property
    def expected_descent(self) -> float:
        """How far (m) the hand goes down from its start before a digit touches a table where the
        scene has it: lift + clearance."""
        return self.options.lift + self.clearance


def touch_off(scene: Scene, plan: Plan, trajectory: JointTrajectory,
              options: TouchOffOptions = TouchOffOptions(), prefix: str = "",
              deflection: float = 0.0) -> TouchOff | None:
    """The touch-off for plan executed as trajectory (robot.pipeline.execute), None when the
    scene's robot makes none (robot.touch_off false): the start pinch is where the approach ends
    (the segment prefix + "approach": a layout's piece names its segments); the clearance is the
    digits' lowest point there (mechanics digits_clearance, or a pincer's pincer_clearance, at the
    plan's first state), in metres;
    deflection (m): the cell's calibration of its probe (TouchOff.deflection)."""
    if not scene.robot.touch_off:
        return None
    approach = next((end for name, _, end in trajectory.segments if name == prefix + "approach"), 0)
    q = trajectory.positions[approach]
    theta, d, psi = plan.states[0]
    pincer = scene.robot.gripper
    low = (digits_clearance(theta, d, psi, scene.digits) if pincer is None
           else pincer_clearance(theta, d, psi, scene.digits, *pincer.scaled(scene.object_length)))
    return TouchOff(start_joints=tuple(float(x) for x in q[:6]), opening=float(q[6]),
                    clearance=float(low) * scene.object_length, base_z=float(np.asarray(scene.robot.base)[2, 3]),
                    options=options, pincer=pincer is not None, deflection=float(deflection))
