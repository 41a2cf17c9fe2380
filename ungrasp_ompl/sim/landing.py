"""Where the object lands when a placement's release is simulated with no error drawn, and the aim
that corrects the hand for it (robot.landing: simulated; docs/model.md 11.12).

The plan ends with the object pinched at a small theta, its end G on the table; the termination
lets go and the object falls flat. The plan takes the object to turn flat about G, but a falling
object's end rides down the thumb's face as the thumb backs away, and the object comes to rest a
millimetre or so toward G, and an object held off its centre of mass turns a little about the
vertical as it falls. The table is flat and the same everywhere, so the same release run a few
millimetres away, or turned a few degrees about the vertical, lands the same way, moved by as
much: moving the hand's whole motion by the inverse of the landing's move puts the object on its
target, at its heading. The trial that measures it is the
placement's own, with no error drawn (TrialParams()), so that nothing of the errors a campaign
draws enters it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..perturbation import TrialParams
from ..robot.pipeline import Aim
from .outcome import Outcome
from .trial import TrialSetup, placement_offset, placement_turn, run_trial


@dataclass(frozen=True)
class LandingPrediction:
    """One release simulated with no error: where the object came to rest against its target."""

    offset: tuple[float, float]
    """World (x, y) of the object's outline centroid at rest less its target's (m)."""
    outcome: Outcome
    """How that trial ended, by the strict verdict."""
    turn: float = 0.0
    """The object's turn about the vertical at rest against its target (rad, counter-clockwise)."""
    correction: Aim = Aim()
    """The aim that undoes the landing's move (offset and turn), whether or not it landed."""

    @property
    def landed(self) -> bool:
        """The object was let go flat with nothing gone wrong before, whatever the error (the strict
        verdict placed it: no digit on the table, no turn out of the plane), so its offset says where
        the release lands it; an object that turned out of the plane first lands where that took it."""
        return self.outcome.placed

    @property
    def aim(self) -> Aim:
        """How to move the hand's motion to put the object on its target at its heading: the
        correction where it landed, none where it did not."""
        return self.correction if self.landed else Aim()


def landing_offset(setup: TrialSetup, final_pose: NDArray[np.float64]) -> NDArray[np.float64]:
    """World (x, y) of the outline centroid of the object at final_pose (4 x 4) less its target's
    (m, shape (2,)): the offset whose length a trial's placement error is."""
    return placement_offset(np.asarray(final_pose, dtype=float), setup.target_pose, setup.spec.obj.outline)


def landing_correction(setup: TrialSetup, final_pose: NDArray[np.float64]) -> tuple[float, Aim]:
    """The object's turn about the vertical at final_pose (4 x 4) against its target (rad), and the
    aim (robot.pipeline.Aim, about the target frame's origin G) that moves a landing there back onto
    the target: the landing maps the target's planar pose to the final one, p -> R(turn) (p - g) + o
    (g, o: the target's and the final pose's origins), and the aim is its inverse, the turn undone
    about g and the shift R(-turn) (g - o)."""
    final, target = np.asarray(final_pose, dtype=float), setup.target_pose
    turn = placement_turn(final, target)
    c, s = math.cos(turn), math.sin(turn)
    gx, gy = target[:2, 3] - final[:2, 3]
    return turn, Aim(float(c * gx + s * gy), float(-s * gx + c * gy), -turn)


def predict_landing(setup: TrialSetup) -> LandingPrediction:
    """Simulate the placement, as setup has it unaimed, once with no error drawn and say where the
    object landed."""
    result = run_trial(setup, TrialParams())
    final = np.array(result.final_pose)
    x, y = landing_offset(setup, final)
    turn, correction = landing_correction(setup, final)
    return LandingPrediction((float(x), float(y)), result.outcome, turn, correction)


__all__ = ["LandingPrediction", "landing_correction", "landing_offset", "predict_landing"]
