"""Where the object lands when a placement's release is simulated with no error drawn, and the aim
that corrects the hand for it (robot.landing: simulated; docs/model.md 11.12).

The plan ends with the object pinched at a small theta, its end G on the table; the termination
lets go and the object falls flat. The plan takes the object to turn flat about G, but a falling
object's end rides down the thumb's face as the thumb backs away, and the object comes to rest a
millimetre or so toward G. The table is flat and the same everywhere, so the same release run a
few millimetres away lands the same way, shifted by as much: moving the hand's whole motion by the
landing's offset, the other way, puts the object on its target. The trial that measures it is the
placement's own, with no error drawn (TrialParams()), so that nothing of the errors a campaign
draws enters it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..perturbation import TrialParams
from .outcome import Outcome
from .trial import TrialSetup, placement_offset, run_trial


@dataclass(frozen=True)
class LandingPrediction:
    """One release simulated with no error: where the object came to rest against its target."""

    offset: tuple[float, float]
    """World (x, y) of the object's outline centroid at rest less its target's (m)."""
    outcome: Outcome
    """How that trial ended, by the strict verdict."""

    @property
    def landed(self) -> bool:
        """The object was let go flat with nothing gone wrong before, whatever the error (the strict
        verdict placed it: no digit on the table, no turn out of the plane), so its offset says where
        the release lands it; an object that turned out of the plane first lands where that took it."""
        return self.outcome.placed

    @property
    def aim(self) -> tuple[float, float]:
        """The hand's world (x, y) shift that puts the object on its target (m): minus the offset
        where it landed, none where it did not."""
        return (-self.offset[0], -self.offset[1]) if self.landed else (0.0, 0.0)


def landing_offset(setup: TrialSetup, final_pose: NDArray[np.float64]) -> NDArray[np.float64]:
    """World (x, y) of the outline centroid of the object at final_pose (4 x 4) less its target's
    (m, shape (2,)): the offset whose length a trial's placement error is."""
    return placement_offset(np.asarray(final_pose, dtype=float), setup.target_pose, setup.spec.obj.outline)


def predict_landing(setup: TrialSetup) -> LandingPrediction:
    """Simulate the placement once with no error drawn and say where the object landed."""
    result = run_trial(setup, TrialParams())
    x, y = landing_offset(setup, np.array(result.final_pose))
    return LandingPrediction((float(x), float(y)), result.outcome)


__all__ = ["LandingPrediction", "landing_offset", "predict_landing"]
