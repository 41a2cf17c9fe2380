"""The outcome of a simulated trial, with the paper's criterion (sec. 6.2), as typed values."""

from __future__ import annotations

import enum
import math
from dataclasses import asdict, dataclass, field


class Outcome(enum.Enum):
    """How a trial ended. Success: the grip kept until the termination begins (a digit on the
    object throughout, and the pinch, A and B, there when it begins), then after the retreat the
    object lies flat (tilt below FLAT_TILT_DEG) with no digit touching it (the paper's criterion),
    within the scene's sim.max_error of its target (docs/model.md 11.4)."""

    SUCCESS = "success"
    GRIP_LOST = "grip lost"  #: before the termination no digit touched the object, or the termination began without A or B
    B_PAST_THUMB_TIP = "B past the thumb tip"  #: the object's end slid off the thumb
    LEFT_PLANE = "object left the plane"  #: it turned out of the manipulation plane and escaped
    HIT_SOLID = "hit a wall or piece"  #: it was pushed off by a wall or a piece already down
    DIGIT_HIT_TABLE = "a digit hit the table"  #: a digit touched the table before the termination (a collision)
    NOT_FLAT = "not flat after the retreat"  #: it was let go but does not lie flat
    DIGIT_TOUCHING = "a digit still touches it"  #: after the retreat
    OFF_TARGET = "placed off target"  #: the paper's criterion holds, but farther than max_error from the target
    DIVERGED = "the simulation diverged"  #: the engine's state became non-finite: no verdict on the plan, not placed

    @property
    def success(self) -> bool:
        return self is Outcome.SUCCESS

    def describe(self) -> str:
        """What happened, in words for a person (trials.csv and summary.json keep the value)."""
        return _OUTCOME_WORDS[self]

    @property
    def placed(self) -> bool:
        """The paper's criterion holds (precision aside)."""
        return self in (Outcome.SUCCESS, Outcome.OFF_TARGET)


_OUTCOME_WORDS = {
    Outcome.SUCCESS: "placed flat on its target",
    Outcome.GRIP_LOST: "the grip was lost (no digit on the object, or the pinch gone when letting go began)",
    Outcome.B_PAST_THUMB_TIP: "the object's end B slid off the thumb's tip",
    Outcome.LEFT_PLANE: "the object turned out of the manipulation plane and escaped",
    Outcome.HIT_SOLID: "a wall or a piece already down pushed the object off",
    Outcome.DIGIT_HIT_TABLE: "a digit touched the table before letting go",
    Outcome.NOT_FLAT: "the object was let go but does not lie flat",
    Outcome.DIGIT_TOUCHING: "a digit still touches the object after the retreat",
    Outcome.OFF_TARGET: "placed flat, but farther from its target than the scene allows",
    Outcome.DIVERGED: "the physics engine's state became non-finite, so the trial ended there unjudged (counted as not placed)",
}


@dataclass(frozen=True)
class ContactTravel:
    """How far the contacts A and B moved over one primitive (mm), executed beside planned.

    Each figure is the net displacement of the contact point between the primitive's first and
    last control ticks at which both A and B touch, measured in the frame of the body named
    (the object, or the digit it touches); a contact the plan keeps sticking has a planned 0 on
    both, but a rounded finger tip's A, which rolls about r times psi's change on both. nan
    where the contact was not held at two ticks of the primitive.
    """

    primitive: str  #: the primitive's type (P_psi, P_theta, P_dpsi)
    a_on_object: float
    a_on_object_plan: float
    a_on_finger: float
    a_on_finger_plan: float
    b_on_object: float
    b_on_object_plan: float
    b_on_thumb: float
    b_on_thumb_plan: float


#: Largest tilt (deg) of an object that lies flat at the end (the paper's visual criterion).
FLAT_TILT_DEG = 2.0


@dataclass
class TrialResult:
    """One trial: the outcome and its evidence.

    outcome: the strict verdict (Outcome), which success counts; paper_outcome: the paper's
    criterion alone, the same but that a digit on the table or a turn out of the plane while held
    fails it only if the grip is then lost (docs/model.md 11.4).
    phase / phase_index / time_s: where the failure began (the primitive, 'termination' or
    'retreat', and the time in s from the first primitive's start); None on success.
    position_error_mm: distance in the table's plane between the object's final outline
    centroid and its target's; yaw_error_deg: its turn about the vertical against the target;
    tilt_deg: its final tilt from the table; roll_deg: the largest turn of the object out of the
    manipulation plane while held (deg). params: the perturbation drawn for the trial.
    max_penetration_mm: the deepest the object sank into a digit or the table at any control
    tick of the primitives (until a failure); a_off_dome_share: the share of A's normal impulse over the
    primitives carried by finger geoms other than a rounded tip's dome (None for a flat tip);
    contacts: per primitive, how far A and B moved against the plan.
    """

    outcome: Outcome
    paper_outcome: Outcome  #: by the paper's criterion alone: only a grip lost before the termination, or the checks after the retreat, fail it
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
    final_pose: list = field(default_factory=list)  #: 4x4 world pose of the object's body at the end (at the failure, if it failed)
    placed_poses: list = field(default_factory=list)  #: 4x4 poses of the objects already down, at the end
    max_penetration_mm: float = 0.0
    a_off_dome_share: float | None = None
    contacts: list[ContactTravel] = field(default_factory=list)
    digit_table_force_n: float = 0.0  #: the largest normal force (N) a digit pressed the table with before the termination (0: it never touched)
    a_gap_s: float = 0.0  #: the longest stretch (s) the finger's contact A was absent before the termination (or the loss)
    b_gap_s: float = 0.0  #: the same for the thumb's contact B
    offset_along_mm: float = float("nan")  #: the placement offset (position_error_mm's vector) along GB at the target, + toward B (mm)
    offset_across_mm: float = float("nan")  #: ... and across GB, + to GB's left seen from above (mm)
    table_found_mm: float | None = None  #: how much higher than the plan has it the touch-off found the table (mm, the arm's z); None without one
    probe_error_mm: float | None = None  #: the touch-off's found height less the truth (mm), for the record: the trial never reads it

    @property
    def success(self) -> bool:
        return self.outcome.success

    @property
    def placed(self) -> bool:
        """Placed by the paper's criterion, whatever the error; a digit that touched the table or a
        turn out of the plane while held fail only the strict verdict (outcome)."""
        return self.paper_outcome.placed

    def cause(self) -> str:
        """The outcome for a person: 'grip lost in primitive 3 (P_dpsi) at 4.21 s'."""
        if self.success:
            return "success"
        if self.outcome is Outcome.OFF_TARGET:
            return f"{self.outcome.value} by {self.position_error_mm:.1f} mm"
        if self.phase is None:
            return self.outcome.value
        where = (f"primitive {self.phase_index + 1} ({self.phase})" if self.phase.startswith("P_")
                 else f"the {self.phase}")
        if where in self.outcome.value:  # 'not flat after the retreat' names its phase already
            return f"{self.outcome.value} at {self.time_s:.2f} s"
        return f"{self.outcome.value} in {where} at {self.time_s:.2f} s"

    def to_row(self) -> dict:
        """A flat dict for trials.csv (the perturbation's fields prefixed with p_)."""
        row = asdict(self)
        row["outcome"] = self.outcome.name.lower()
        row["paper_outcome"] = self.paper_outcome.name.lower()
        row["cause"] = self.cause()
        params = row.pop("params")
        row.pop("final_pose")
        row.pop("placed_poses")
        for k, travel in enumerate(row.pop("contacts"), 1):
            kind = travel.pop("primitive")
            row.update({f"prim{k}_{kind}_{name}_mm": v for name, v in travel.items()})
        row.update({f"p_{k}": v for k, v in params.items()})
        return {k: (round(v, 6) if isinstance(v, float) and math.isfinite(v) else v) for k, v in row.items()}
