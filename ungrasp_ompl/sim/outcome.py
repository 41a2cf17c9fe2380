"""The outcome of a simulated trial, with the paper's criterion (sec. 6.2), as typed values."""

from __future__ import annotations

import enum
import math
from dataclasses import asdict, dataclass, field


class Outcome(enum.Enum):
    """How a trial ended. Success: A and B kept until the termination begins, then after the
    retreat the object lies flat (tilt below FLAT_TILT_DEG) with no digit touching it."""

    SUCCESS = "success"
    GRIP_LOST = "grip lost"  #: A or B let go of the object before the termination
    B_PAST_THUMB_TIP = "B past the thumb tip"  #: the object's end slid off the thumb
    LEFT_PLANE = "object left the plane"  #: it turned out of the manipulation plane and escaped
    HIT_SOLID = "hit a wall or piece"  #: it was pushed off by a wall or a piece already down
    NOT_FLAT = "not flat after the retreat"  #: it was let go but does not lie flat
    DIGIT_TOUCHING = "a digit still touches it"  #: after the retreat

    @property
    def success(self) -> bool:
        return self is Outcome.SUCCESS


#: Largest tilt (deg) of an object that lies flat at the end (the paper's visual criterion).
FLAT_TILT_DEG = 2.0


@dataclass
class TrialResult:
    """One trial: the outcome and its evidence.

    phase / phase_index / time_s: where the failure began (the primitive, 'termination' or
    'retreat', and the time in s from the first primitive's start); None on success.
    position_error_mm: distance in the table's plane between the object's final outline
    centroid and its target's; yaw_error_deg: its turn about the vertical against the target;
    tilt_deg: its final tilt from the table; roll_deg: the largest turn of the object out of the
    manipulation plane while held (deg). params: the perturbation drawn for the trial.
    """

    outcome: Outcome
    phase: str | None
    phase_index: int | None
    time_s: float | None
    position_error_mm: float
    yaw_error_deg: float
    tilt_deg: float
    roll_deg: float
    params: dict = field(default_factory=dict)
    trial: int = 0
    seed: int | None = None
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0
    final_pose: list = field(default_factory=list)  #: 4x4 world pose of the object's body at the end
    placed_poses: list = field(default_factory=list)  #: 4x4 poses of the objects already down, at the end


    @property
    def success(self) -> bool:
        return self.outcome.success

    def cause(self) -> str:
        """The outcome for a person: 'grip lost in primitive 3 (P_dpsi) at 4.21 s'."""
        if self.success:
            return "success"
        if self.phase is None:
            return self.outcome.value
        where = (f"primitive {self.phase_index + 1} ({self.phase})" if self.phase.startswith("P_")
                 else f"the {self.phase}")
        return f"{self.outcome.value} in {where} at {self.time_s:.2f} s"

    def to_row(self) -> dict:
        """A flat dict for trials.csv (the perturbation's fields prefixed with p_)."""
        row = asdict(self)
        row["outcome"] = self.outcome.name.lower()
        row["cause"] = self.cause()
        params = row.pop("params")
        row.pop("final_pose")
        row.pop("placed_poses")
        row.update({f"p_{k}": v for k, v in params.items()})
        return {k: (round(v, 6) if isinstance(v, float) and math.isfinite(v) else v) for k, v in row.items()}
