"""What a plan reports: the primitive sequence and its cost, and plan.json."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, replace
from enum import Enum, StrEnum
from pathlib import Path
from typing import Any, TypedDict

import numpy as np

from ..errors import InputError
from ..io import read_json_file
from ..mechanics import Friction, Primitive, primitive_sliding_signs
from ..mechanics.force_closure import SlidingModel
from ..scene import StateClass, StateDiagnosis
from ..scene.options import Termination
from ..scene.stability import describe_roll, describe_x_moments
from ..scene.tolerance import ToleranceReason, describe_tolerance
from .atlas import D, PSI, THETA, Leg, SecurityAtlas, reference_cost
from .margins import Objective

JSON_SCHEMA_VERSION = 1

_A_WORDS = {-1: "toward_B", 1: "toward_G"}  # friction on the object at A, by sign of dd
_B_WORDS = {-1: "toward_palm", 1: "toward_tip"}  # friction on the object at B, by sign of ds_B


class PathSource(StrEnum):
    """Which search found a solved plan's path (Plan.path_from; a StrEnum, so plan.json holds its value)."""

    PLANNER = "planner"  #: the planner asked for, under the objective asked for
    #: the same planner and seed under the cost objective, whose path kept more friction margin
    #: than the margin objective's own (docs/model.md 6.1)
    COST_BASELINE = "cost_baseline"
    #: the exact lattice search's widest-margin path, where the planner's kept less (docs/decisions/0104)
    LATTICE = "lattice"
    #: the exact lattice search's widest-margin path, where the planner found none in its budget
    #: (docs/decisions/0120)
    LATTICE_FALLBACK = "lattice_fallback"

    def describe(self) -> str:
        """Where the path came from, in words for a person (plan.json keeps the value)."""
        return {PathSource.PLANNER: "the planner's own search",
                PathSource.COST_BASELINE: "the cost objective's search of the same planner and seed, which kept more "
                                          "margin",
                PathSource.LATTICE: "the exact lattice search's widest-margin path, as the planner's path kept "
                                    "less",
                PathSource.LATTICE_FALLBACK: "the exact lattice search's widest-margin path, as the planner found "
                                             "none in its budget"}[self]


class StoppedBy(StrEnum):
    """Why a planner stopped (Plan.stopped_by; a StrEnum, so plan.json holds its value)."""

    PLANNER = "planner"  #: the planner returned by itself (a non-optimising planner's first path)
    ITERATIONS = "iterations"  #: the seeded run's iteration budget ran out
    TIME = "time"  #: the time limit (or a seeded run's hard cap) ran out
    OPTIMUM = "optimum"  #: the path reached the exact lattice optimum: no path can cost less
    NOT_STARTED = "not_started"  #: planning could not start (PlanOutcome's evidence says why)
    KILLED = "killed"  #: a planner that ignores its time limit was stopped after its deadline

    def describe(self) -> str:
        """Why the planner stopped, in words for a person (plan.json keeps the value)."""
        return {StoppedBy.PLANNER: "the planner returned its first path",
                StoppedBy.ITERATIONS: "its iteration budget ran out",
                StoppedBy.TIME: "its time ran out",
                StoppedBy.OPTIMUM: "it reached the exact lattice optimum: no path costs less",
                StoppedBy.NOT_STARTED: "planning could not start",
                StoppedBy.KILLED: "it ignored its time limit and was stopped"}[self]


@dataclass
class PrimitiveStep:
    """One primitive of a plan, from start to end (theta rad, d over l, psi rad).

    waypoints are the corners of its straight legs, start and end included
    (a P_dpsi may bend in (d, psi) while theta stays put); sliding maps each
    sliding contact to the direction of friction on the object there;
    stability is the 3D class (paper sec. 4.1): full with at most one
    sliding contact, partial with two (no z-moments).
    """

    type: Primitive
    direction: str
    start: list[float]
    end: list[float]
    sliding: dict[str, str]
    stability: str
    waypoints: list[list[float]] = field(default_factory=list)
    x_moments: str | None = None  # how x-moments are held (scenes with an outline)


class PlanOutcome(Enum):
    """How planning ended. Plan.evidence holds what supports it (keys named below)."""

    #: A path was found and every leg passed re-validation.
    SOLVED = "solved"
    #: The start state cannot be held: state_class, failed_checks, contacts (Scene.diagnose).
    START_NOT_HELD = "start_not_held"
    #: No lattice state of the goal region can be held with room to let go: outside_box (the region
    #: lies outside the planning box), behind_start (the coordinates along which it lies wholly
    #: behind the start, out of the forward primitives' reach), holdable (some state can be held),
    #: termination (how the gripper lets go).
    GOAL_EMPTY = "goal_empty"
    #: The exact search over the primitive lattice reaches no goal state: resolution.
    NO_SECURE_PATH = "no_secure_path"
    #: None found within the budget, though the lattice holds one: stopped_by, limit, lattice_optimum.
    NOT_FOUND = "not_found"
    #: The path returned fails re-validation in its travel direction: problem.
    INVALID_PATH = "invalid_path"
    #: The planner did not stop and was killed: deadline_s, known.
    HUNG = "hung"
    #: A path was found, but its tolerance is below planning.min_tolerance: tolerance (the path's,
    #: scene.tolerance.Tolerance.to_dict), min_tolerance.
    BELOW_MIN_TOLERANCE = "below_min_tolerance"
    #: A path was found, but the predicted landing moves more than planning.max_landing_spread over
    #: the friction's range and both cones, and no path without P_dpsi is found within it either:
    #: spread_m (the path's), max_landing_spread_m, without_p_dpsi (the spread without P_dpsi, m, or
    #: why there is none).
    LANDING_SPREAD = "landing_spread"

    def describe(self) -> str:
        """The outcome in a few words for a person, without its evidence (describe_outcome says more)."""
        return {PlanOutcome.SOLVED: "solved",
                PlanOutcome.START_NOT_HELD: "the start pinch cannot hold the object",
                PlanOutcome.GOAL_EMPTY: "no state of the goal region can be held with room to let go",
                PlanOutcome.NO_SECURE_PATH: "no secure path exists",
                PlanOutcome.NOT_FOUND: "no path found within the budget, though one exists",
                PlanOutcome.INVALID_PATH: "the path found failed re-validation",
                PlanOutcome.HUNG: "the planner did not stop and was killed",
                PlanOutcome.BELOW_MIN_TOLERANCE: "the path found tolerates less error than the scene asks "
                                                 "(planning.min_tolerance)",
                PlanOutcome.LANDING_SPREAD: "the path found lands the object less predictably than the scene asks "
                                            "(planning.max_landing_spread)"}[self]


class StartNotHeld(TypedDict):
    """PlanOutcome.START_NOT_HELD's evidence: the start's class and what fails (Scene.diagnose)."""

    state_class: str  #: a StateClass name
    failed_checks: list[str]  #: the kinematic conditions that fail (mechanics.kinematic_checks' names)
    contacts: list[str]  #: the colliding body/target pairs


class GoalEmpty(TypedDict, total=False):
    """PlanOutcome.GOAL_EMPTY's evidence: outside_box and behind_start (the coordinates along
    which the goal lies wholly behind the start), or holdable, termination and cut_by_start."""

    outside_box: bool
    behind_start: list[str]
    holdable: bool  #: some goal state can be held, but not let go
    termination: str  #: how the gripper lets go (a Termination value)
    cut_by_start: list[str]  #: the coordinates along which part of the goal lies behind the start, unsearched


class NoSecurePath(TypedDict):
    """PlanOutcome.NO_SECURE_PATH's evidence."""

    resolution: list[float]  #: the lattice's step (theta rad, d over l, psi rad)


class NotFound(TypedDict):
    """PlanOutcome.NOT_FOUND's evidence: the budget that ran out and the path the lattice holds."""

    resolution: list[float]  #: the lattice's step (theta rad, d over l, psi rad)
    stopped_by: str  #: a StoppedBy value
    limit: str  #: the budget in words ("6000 iterations", "1.00 s")
    lattice_optimum: float  #: the exact search's cost (reference units)


class InvalidPath(TypedDict, total=False):
    """PlanOutcome.INVALID_PATH's evidence (planning.verify.PathProblem.evidence)."""

    problem: str  #: the failure in words
    path_check: str  #: a PathCheck value
    index: int  #: the leg's index in the path
    primitive: str  #: the leg's primitive, where a leg failed
    leg_check: str  #: a LegCheck value
    state: list[float]  #: where it failed (theta rad, d over l, psi rad)
    detail: str


class Hung(TypedDict):
    """PlanOutcome.HUNG's evidence."""

    deadline_s: float  #: when the planner was stopped, s
    known: str  #: why the planner is known not to stop (UNRULY_PLANNERS), or ""


class BelowMinTolerance(TypedDict):
    """PlanOutcome.BELOW_MIN_TOLERANCE's evidence."""

    tolerance: dict[str, Any]  #: the path's tolerance (planning.plan_tolerance.Tolerance.to_dict)
    min_tolerance: float  #: planning.min_tolerance


class LandingSpread(TypedDict):
    """PlanOutcome.LANDING_SPREAD's evidence."""

    spread_m: float  #: the path's predicted landing spread, m
    max_landing_spread_m: float  #: planning.max_landing_spread, m
    without_p_dpsi: float | str  #: the spread without P_dpsi (m), or why there is none


#: What supports an outcome (Plan.evidence), by PlanOutcome: a solved plan's is empty. Mappings of
#: JSON types, as plan.json holds them.
PlanEvidence = StartNotHeld | GoalEmpty | NoSecurePath | NotFound | InvalidPath | Hung | BelowMinTolerance | \
    LandingSpread | dict[str, Any]


def describe_outcome(outcome: PlanOutcome, evidence: PlanEvidence, planner: str = "the planner") -> str:
    """One sentence for a person from an outcome and its evidence."""
    e = evidence
    if outcome is PlanOutcome.SOLVED:
        return "solved"
    if outcome is PlanOutcome.START_NOT_HELD:
        return StateDiagnosis(StateClass[e["state_class"]], tuple(e.get("failed_checks", ())),
                              tuple(e.get("contacts", ()))).describe("start state")
    if outcome is PlanOutcome.GOAL_EMPTY:
        if e.get("behind_start"):
            axes = " and ".join(e["behind_start"])
            return (f"goal region lies behind the start along {axes}, which the forward primitives move one way only "
                    "(theta and d down, psi up; planning.reverse_primitives allows both)")
        if e.get("outside_box"):
            return "goal region lies outside the planning box"
        where, there = "goal region is empty", "inside it"
        if e.get("cut_by_start"):
            where = (f"goal region is empty where the start reaches it (along {' and '.join(e['cut_by_start'])} part "
                     "of it lies behind the start, which the forward primitives move one way only: theta and d down, "
                     "psi up)")
            there = "there"
        if e.get("holdable"):
            how = e.get("termination", "open")
            how = Termination(how).describe() if how in tuple(Termination) else how
            return f"{where}: the gripper cannot let go ({how}) at any goal state without a collision"
        return f"{where}: no lattice state {there} is kinematically valid, collision-free and force-closed"
    if outcome is PlanOutcome.NO_SECURE_PATH:
        return f"no secure path exists: the exact search over the primitive lattice ({_at(e)}) reaches no goal state"
    if outcome is PlanOutcome.NOT_FOUND:
        return (f"no path found within {e['limit']}; the exact lattice search ({_at(e)}) finds one of cost "
                f"{e['lattice_optimum']:.2f}: allow more time or try another planner")
    if outcome is PlanOutcome.INVALID_PATH:
        return f"the returned path fails re-validation: {e['problem']}"
    if outcome is PlanOutcome.BELOW_MIN_TOLERANCE:
        return (f"the path found survives errors up to {e['tolerance']['scale']:.3f} times the "
                f"{e['tolerance']['perturbation']} error bounds, below planning.min_tolerance {e['min_tolerance']:g} "
                f"(beyond that, {ToleranceReason(e['tolerance']['reason']).describe()}); try --objective tolerance")
    if outcome is PlanOutcome.LANDING_SPREAD:
        other = e["without_p_dpsi"]
        other = f"{1000 * other:.2f} mm" if isinstance(other, float) else other
        return (f"the path found lands the object {1000 * e['spread_m']:.2f} mm apart over friction x0.7-1.3 and both "
                f"cones, beyond planning.max_landing_spread {1000 * e['max_landing_spread_m']:.2f} mm; without P_dpsi: "
                f"{other}")
    return f"{planner} did not stop within {e['deadline_s']:.0f} s and was killed: {e['known']}"


def _at(evidence: dict[str, Any]) -> str:
    res = evidence.get("resolution")
    if not res:
        return "its resolution"
    return f"{math.degrees(res[0]):g} deg / {res[1]:g} / {math.degrees(res[2]):g} deg"


@dataclass(frozen=True)
class HoldableMap:
    """The planner's lattice, as the C-space picture shades it: which states can be held with all
    contacts sticking. Kept with a plan in memory (never written to plan.json), so drawing does
    not build the lattice again."""

    axes: tuple[np.ndarray, np.ndarray, np.ndarray]  #: lattice values of theta (rad), d (over l), psi (rad)
    holdable: np.ndarray  #: bool, shape (len(theta), len(d), len(psi))

    @classmethod
    def of(cls, atlas: SecurityAtlas) -> "HoldableMap":
        return cls(tuple(atlas.axes), atlas.holdable)


@dataclass(frozen=True)
class Solution:
    """The path of a solved plan (empty otherwise)."""

    states: list[list[float]] = field(default_factory=list)
    """The corner states [theta rad, d over l, psi rad], the start first."""
    primitives: list[PrimitiveStep] = field(default_factory=list)
    """The merged primitives, in order, with their waypoints."""
    cost: float | None = None
    """Weighted L1 length plus the penalty of each primitive change (docs/model.md, section 6)."""
    l1_length: float | None = None
    """The weighted L1 length alone (theta and psi in degrees)."""
    mode_switches: int | None = None
    """Primitive changes along the path (count)."""


@dataclass(frozen=True)
class Diagnostics:
    """How planning went, and the friction margins it found along the path."""

    time_to_first_solution_s: float | None = None
    """s from the start of solving to the first path."""
    planning_time_s: float = 0.0
    """s of solving."""
    setup_time_s: float = 0.0
    """s building the lattice, the space and the planner."""
    iterations: int = 0
    """Termination checks while solving (count)."""
    stopped_by: StoppedBy | None = None
    """Why solving stopped; None before solving."""
    resolution: list[float] = field(default_factory=list)
    """The lattice's step in theta (rad), d (over l) and psi (rad)."""
    lattice_optimum: float | None = None
    """The exact lattice search's cost, where it was run."""
    min_margin_deg: float | None = None
    """Smallest friction margin along the path, the start included (path_friction_margin), deg."""
    margin_profile_deg: list[float] = field(default_factory=list)
    """The smallest friction margin of each primitive, in order, deg."""
    margin_bottleneck_deg: float | None = None
    """The most friction margin any secure lattice path keeps (robust objectives), deg."""
    margin_forced: bool | None = None
    """min_margin_deg is the bottleneck: no secure lattice path passes more."""
    start_margin_deg: float | None = None
    """The start's friction margin with every contact sticking, deg."""
    path_from: PathSource | None = None
    """Which search found the path (PathSource); None: no path."""
    release: str = "objective"
    """Where in the goal region the plan was asked to end (planning.release: objective or
    least_moving, record 0128)."""


class TargetRecord(TypedDict):
    """Where the object is to lie (scene.options.Object3D's target)."""

    position: list[float]  #: (x, y) of the object's frame on the table, world, m
    yaw_rad: float  #: its turn about the vertical, rad


class ObjectRecord(TypedDict):
    """Report3D.object: the object with an outline (scene.options.Object3D.to_dict)."""

    outline: list[list[float]]  #: the outline's vertices (N, 2), the object's frame, m
    thickness_m: float  #: m
    target: TargetRecord


class AtGB(TypedDict):
    """A figure at G and at B (its unit is the field's that holds it)."""

    G: float
    B: float


class AtGAB(TypedDict):
    """A figure at G, A and B (its unit is the field's that holds it)."""

    G: float
    A: float
    B: float


class TouchedFrom(TypedDict):
    """How far from a contact the table or the thumb's face first touches the outline (m)."""

    along: float  #: along the face's push, m
    across: float  #: across it, m


class OutlineContact(TypedDict):
    """G or B on the outline (geometry.plane.ContactPoint.to_dict)."""

    kind: str  #: 'corner', 'edge' or 'smooth'
    radius_m: float | None  #: the outline's radius of curvature there (m); None on a straight side
    edge_contact: bool  #: a straight side square to GB: a segment contact that holds x-moments
    point: list[float]  #: (x, y) in the object's frame, m
    touched_from_m: TouchedFrom
    span_m: list[float]  #: how far a straight side reaches across GB each way (right, left of the push), m


class FingerContact(TypedDict):
    """A, the finger's tip on the object (scene.stability.analyse)."""

    kind: str  #: 'flat finger tip' or 'rounded finger tip'
    radius_m: None  #: the outline's radius is G's and B's only
    edge_contact: bool  #: a flat tip: an edge across the object
    point: None  #: A moves along GB: no one point


class PlaneContacts(TypedDict):
    """The manipulation plane's contacts on the outline."""

    G: OutlineContact
    B: OutlineContact


class PlaneRecord(TypedDict):
    """Report3D.manipulation_plane (geometry.plane.ManipulationPlane.to_dict)."""

    G: list[float]  #: G, where the object touches the table, (x, y) in the object's frame, m
    B: list[float]  #: B, where the thumb holds it, the same
    length_m: float  #: l = |GB|, m
    margin_rad: float  #: how far GB lies inside the friction cones at G and B, rad
    mu_eff: AtGB  #: the plane's friction coefficients at G and B (dimensionless)
    beta_rad: AtGB  #: the angle between GB and the outline's inward normal at G and B, rad
    contacts: PlaneContacts
    frame: list[list[float]]  #: 4x4, the plane's frame in the world with the object at its target (m)
    fixed_by_user: bool  #: the scene's contacts chose G and B


class StabilityContacts(TypedDict):
    """The grasp's three contacts (scene.stability.StabilityReport.contacts)."""

    G: OutlineContact
    B: OutlineContact
    A: FingerContact


class XMoments(TypedDict):
    """How the grasp holds the object against rolling about GB."""

    mechanism: str  #: the mechanism in words
    ok: bool  #: it holds


class RestoringTilt(TypedDict):
    """The tilts about GB (deg) from which the prism rolls back, each way: (low, high), or None."""

    positive: list[float] | tuple[float, float] | None
    negative: list[float] | tuple[float, float] | None


class RollRecord(TypedDict):
    """The prism's roll about GB simulated at one state (scene.stability.RollReport.to_dict)."""

    label: str  #: 'start' or 'end'
    state: list[float]  #: (theta rad, d over l, psi rad)
    self_restoring: bool  #: it rolls back from any tilt up to max_tilt_deg
    restoring_tilt_deg: RestoringTilt
    max_tilt_deg: float  #: the largest tilt simulated, deg
    across_support_m: float | None  #: A's distance inside the supports across the plane (m); None: no such support


class StabilityRecord(TypedDict):
    """Report3D.stability_report (scene.stability.StabilityReport.to_dict)."""

    contacts: StabilityContacts
    edge_contacts: list[str]  #: the contacts ('G', 'A', 'B') that are edge contacts
    x_moments: XMoments
    roll_simulation: list[RollRecord]
    self_restoring: bool  #: the prism rolls back at every state simulated


@dataclass(frozen=True)
class Report3D:
    """What a plan of a scene with an outline says in 3D (JSON types, as plan.json holds them;
    docs/plan-json.md). Each field's keys and units are its TypedDict's."""

    object: ObjectRecord
    """The outline, thickness and target pose."""
    manipulation_plane: PlaneRecord
    """G, B, the friction margin, the effective friction, the frame in the world."""
    mu_eff: AtGAB
    """The friction coefficients used in the plane at G, A and B (dimensionless)."""
    stability_report: StabilityRecord
    """The contacts, how x-moments are held, the prism roll at the start and the end."""


@dataclass(frozen=True)
class Plan:
    """The result of planning a scene (docs/plan-json.md lists every field): how it ended, the
    path, how planning went and, for a scene with an outline, the 3D report. Frozen: a changed plan
    is a new one (dataclasses.replace). The parts' fields read as the plan's own (plan.states,
    plan.cost, plan.stopped_by, plan.mu_eff), as plan.json lists them side by side."""

    outcome: PlanOutcome
    scene: str
    planner: str
    seed: int | None
    sliding_model: str
    objective: Objective = Objective.COST  # what the planner optimised (docs/model.md, section 6)
    evidence: PlanEvidence = field(default_factory=dict)  # what supports the outcome (see PlanOutcome)
    solution: Solution = field(default_factory=Solution)
    diagnostics: Diagnostics = field(default_factory=Diagnostics)
    report: Report3D | None = None  # scenes with an outline
    tolerance: dict | None = None  # the plan's tolerance of the paper errors (scene.tolerance.Tolerance.to_dict)
    friction: dict | None = None  # the friction planned with and its range (friction_record)
    predicted_landing: dict | None = None  # where the release puts the object (planning.predicted_landing)
    holdable_map: HoldableMap | None = field(default=None, repr=False, compare=False)  # in memory only

    @property
    def solved(self) -> bool:
        """A path was found and passed re-validation."""
        return self.outcome is PlanOutcome.SOLVED

    @property
    def secure_over(self) -> tuple[float, float] | None:
        """The factors (low, high) of the scene's friction coefficients over which every state of
        the solved plan is force-closed in its leg's contact mode (docs/model.md 4.7): (1 - u,
        1 + u) for the friction's uncertainty u; None when unsolved or the plan does not say."""
        u = self.friction.get("uncertainty") if isinstance(self.friction, dict) else None
        if not self.solved or isinstance(u, bool) or not isinstance(u, (int, float)) or not 0.0 <= u < 1.0:
            return None
        return 1.0 - u, 1.0 + u

    @property
    def reason(self) -> str | None:
        """Why there is no solution, for a person (None when solved)."""
        return None if self.solved else describe_outcome(self.outcome, self.evidence, self.planner)

    def fail(self, outcome: PlanOutcome, **evidence: Any) -> "Plan":
        """This plan ended without a solution, with the evidence."""
        return replace(self, outcome=outcome, evidence=evidence)

    def with_diagnostics(self, **changes: Any) -> "Plan":
        """This plan with some of its diagnostics changed."""
        return replace(self, diagnostics=replace(self.diagnostics, **changes))

    def to_dict(self) -> dict[str, Any]:
        """plan.json's mapping: the plan's own fields and its parts' side by side."""
        report = asdict(self.report) if self.report is not None else {k: None for k in Report3D.__dataclass_fields__}
        d = {"solved": self.solved, "outcome": self.outcome.value, "scene": self.scene, "planner": self.planner,
             "seed": self.seed, "sliding_model": self.sliding_model, **asdict(self.solution),
             **asdict(self.diagnostics), "evidence": self.evidence, **report, "objective": self.objective,
             "tolerance": self.tolerance, "reason": self.reason, "schema_version": JSON_SCHEMA_VERSION}
        if isinstance(self.friction, dict):
            secure = self.secure_over
            d["friction"] = {**self.friction, "secure_over": None if secure is None else list(secure)}
        else:
            d["friction"] = self.friction
        d["predicted_landing"] = self.predicted_landing
        return d

    def to_json(self) -> str:
        """plan.json text: the fields of the plan, angles in radians, d over l."""
        return json.dumps(self.to_dict(), indent=2) + "\n"

    @classmethod
    def from_dict(cls, doc: Any, source: str | None = None) -> "Plan":
        """A plan from plan.json's mapping; InputError naming the field when it is malformed.
        Only what executing it needs is checked: a solved plan, its start state and each
        primitive's type and waypoints (states of three finite numbers)."""
        if not isinstance(doc, dict):
            raise InputError("plan", f"must be a mapping, got {type(doc).__name__}", source)
        if doc.get("schema_version") != JSON_SCHEMA_VERSION:
            raise InputError("schema_version", f"is {doc.get('schema_version')!r}; this reader understands "
                             f"{JSON_SCHEMA_VERSION}", source)
        if doc.get("solved") is not True:
            raise InputError("solved", "the plan is not a solution (nothing to execute)", source)

        def state(value: Any, field: str) -> list[float]:
            if (not isinstance(value, list) or len(value) != 3
                    or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
                    or not all(math.isfinite(v) for v in value)):
                raise InputError(field, f"must be a state [theta_rad, d, psi_rad] of finite numbers, got {value!r:.80}",
                                 source)
            if not (0.0 <= value[0] <= math.pi / 2 and 0.0 <= value[1] <= 1.0 and 0.0 <= value[2] < math.pi):
                raise InputError(field, "must lie within theta [0, pi/2] rad, d [0, 1], psi [0, pi) rad (the widest "
                                 f"bounds of any scene), got {value!r:.80}", source)
            return [float(v) for v in value]

        states = doc.get("states")
        if not isinstance(states, list) or not states:
            raise InputError("states", "must be a non-empty list of states", source)
        prims = doc.get("primitives")
        if not isinstance(prims, list) or not prims:
            raise InputError("primitives", "must be a non-empty list", source)
        steps = []
        for i, p in enumerate(prims):
            key = f"primitives[{i}]"
            if not isinstance(p, dict):
                raise InputError(key, "must be a mapping", source)
            if p.get("type") not in tuple(Primitive):
                raise InputError(f"{key}.type", f"must be P_theta, P_psi or P_dpsi, got {p.get('type')!r}", source)
            ways = p.get("waypoints")
            if not isinstance(ways, list) or len(ways) < 2:
                raise InputError(f"{key}.waypoints", "must list at least the start and end states", source)
            ways = [state(w, f"{key}.waypoints[{k}]") for k, w in enumerate(ways)]
            sliding = p.get("sliding", {})
            steps.append(PrimitiveStep(Primitive(p["type"]), str(p.get("direction", "forward")), ways[0], ways[-1],
                                       dict(sliding) if isinstance(sliding, dict) else {},
                                       str(p.get("stability", "")), ways, p.get("x_moments")))
        ends = [state(states[0], "states[0]")] + [st.end for st in steps[:-1]]
        for i, (st, end) in enumerate(zip(steps, ends)):
            if max(abs(a - b) for a, b in zip(st.start, end)) > 1e-9:
                raise InputError(f"primitives[{i}].waypoints[0]", f"must be where the path is before it, {end}, "
                                 f"got {st.start}", source)

        def part(kind, skip=()):
            return {k: doc[k] for k in kind.__dataclass_fields__ if k in doc and k not in skip}

        own = part(cls, ("outcome", "solution", "diagnostics", "report", "holdable_map"))
        own.setdefault("scene", "plan")
        own.setdefault("planner", "unknown")
        own.setdefault("seed", None)
        own.setdefault("sliding_model", "relaxed")
        if "objective" in own:
            own["objective"] = _member(Objective, own["objective"], "objective", source)
        if not isinstance(own.get("predicted_landing"), (dict, type(None))):
            raise InputError("predicted_landing", f"must be a mapping or null, got {own['predicted_landing']!r:.80}",
                             source)
        report = part(Report3D)
        solution = Solution(**{**part(Solution, ("states", "primitives")),
                               "states": [state(s, f"states[{k}]") for k, s in enumerate(states)], "primitives": steps})
        diagnostics = part(Diagnostics)
        for key, kind in (("stopped_by", StoppedBy), ("path_from", PathSource)):
            if diagnostics.get(key) is not None:
                diagnostics[key] = _member(kind, diagnostics[key], key, source, " or null")
        return cls(outcome=PlanOutcome.SOLVED, solution=solution, diagnostics=Diagnostics(**diagnostics),
                   report=Report3D(**report) if len(report) == len(Report3D.__dataclass_fields__)
                   and None not in report.values() else None, **own)

    def summary(self) -> str:
        """What `plan` prints, for a person: the plane (3D scenes), the outcome, the cost against the
        exact lattice optimum, what holds the object and how much error the plan survives, the
        predicted landing, how planning went, the primitives and how the object is held out of
        the plane. Identifiers stay in plan.json."""
        lines = []
        mp = self.manipulation_plane
        if mp is not None:
            g, b, kinds = mp["G"], mp["B"], mp["contacts"]
            lines.append(f"manipulation plane (docs/model.md 5): the vertical plane through G, where the object touches "
                         f"the table, at ({g[0] * 1000:.2f}, {g[1] * 1000:.2f}) mm on its outline "
                         f"({_OUTLINE_WORDS.get(kinds['G']['kind'], kinds['G']['kind'])}), and B, where the thumb holds "
                         f"it, at ({b[0] * 1000:.2f}, {b[1] * 1000:.2f}) mm "
                         f"({_OUTLINE_WORDS.get(kinds['B']['kind'], kinds['B']['kind'])}); l = |GB| = "
                         f"{mp['length_m'] * 1000:.2f} mm; GB lies {math.degrees(mp['margin_rad']):.2f} deg inside the "
                         "friction cones at G and B")
            lines.append(f"friction in that plane: {self.mu_eff['G']:.3f} at G (object on table), {self.mu_eff['A']:.3f} "
                         f"at A (finger on object), {self.mu_eff['B']:.3f} at B (object on thumb)")
        if not self.solved:
            lines.append(f"no solution for {self.scene} with {self.planner}: {self.reason}")
            return "\n".join(lines)
        changes = self.cost - self.l1_length
        lines.append(f"solved {self.scene} with {self.planner} (seed {self.seed}): {len(self.primitives)} primitives, "
                     f"cost {self.cost:.2f} = path length {self.l1_length:.2f} (theta and psi in degrees, d weighted; "
                     f"docs/model.md 6) + {changes:.2f} for {self.mode_switches} "
                     f"{'change' if self.mode_switches == 1 else 'changes'} of primitive")
        lines.append("  " + self._against_optimum())
        lines.append(f"  optimised for {_OBJECTIVE_WORDS.get(self.objective, str(self.objective))}")
        if self.diagnostics.release == "least_moving":
            lines.append("  ending where the model of the fall moves the object least over friction 0.7 to 1.3 times "
                         "the scene's and either friction-cone model, of the goal states the start reaches "
                         "(planning.release least_moving)")
        secure = self.secure_over
        over = (f", with friction anywhere from {secure[0]:.2f} to {secure[1]:.2f} times the scene's"
                if secure is not None and secure != (1.0, 1.0) else "")
        sliding = (SlidingModel(self.sliding_model).describe() if self.sliding_model in tuple(SlidingModel)
                   else f"sliding model {self.sliding_model}")
        lines.append(f"  every state is force-closed in its contact mode{over}: the contacts can resist any push in "
                     f"the plane ({sliding})")
        if self.min_margin_deg is not None:
            lines.append(f"  friction margin (how far every friction cone could narrow before a contact slips, "
                         f"docs/model.md 4.4): {self.min_margin_deg:.3f} deg at the least along the path{self._forced()}; "
                         f"{self.start_margin_deg:.3f} deg at the start, held still")
            lines.append("  friction margin of each primitive, at its least: "
                         + ", ".join(f"{k}. {p.type} {m:.3f} deg" for k, (p, m)
                                     in enumerate(zip(self.primitives, self.margin_profile_deg), 1)))
        if self.path_from not in (None, PathSource.PLANNER):
            lines.append(f"  the path is {self.path_from.describe()}")
        if self.tolerance is not None:
            lines.append("  " + describe_tolerance(self.tolerance).replace("\n", "\n  "))
        if self.predicted_landing is not None:
            p = self.predicted_landing
            lines.append(f"  where the object lands, by the model of its fall (docs/model.md 11.17): "
                         f"on average {_along(p['along_m'])}; {_span(p['low_m'], p['high_m'])} "
                         f"with friction 0.7 to 1.3 times the scene's and either friction-cone model (a spread of "
                         f"{1000 * p['spread_m']:.2f} mm)"
                         + (f"; the middle of that range, where robot.landing modelled aims, {_along(p['middle_m'])}"
                            if "middle_m" in p else ""))
        first = self.time_to_first_solution_s
        first = f"the first path after {first:.3f} s" if first is not None else "the planner found no path"
        why = self.stopped_by.describe() if self.stopped_by is not None else "it did not run"
        if self.stopped_by is StoppedBy.TIME and self.seed is not None:
            why += " before its iteration budget did, so the same seed may plan otherwise on a faster machine"
        lines.append(f"  planning took {self.planning_time_s:.2f} s, {first}; it stopped "
                     f"after {self.iterations} iterations because {why}; building the lattice took "
                     f"{self.setup_time_s:.2f} s")
        lines.append("  the primitives (theta: the object's angle to the table; d: how far the finger's contact A lies "
                     "from B, as a fraction of l; psi: the thumb's angle to the object at B):")
        for k, p in enumerate(self.primitives, 1):
            lines.append(f"  {k}. {_primitive_words(p)}")
        if self.stability_report is not None:
            rep = self.stability_report
            lines.append("  rolling about GB, on every primitive: " + describe_x_moments(rep))
            for r in rep["roll_simulation"]:
                tilts = r["restoring_tilt_deg"]
                lines.append(f"  at the {r['label']}: " + describe_roll({1: tilts["positive"], -1: tilts["negative"]},
                                                                         r["self_restoring"], r.get("max_tilt_deg")))
        return "\n".join(lines)

    def _against_optimum(self) -> str:
        """The plan's cost against the exact lattice optimum, or why it is not compared."""
        opt, objective = self.lattice_optimum, self.objective
        if opt is None:
            return "exact optimum: not computed (--planner lattice runs the exact search)"
        more = self.cost - opt
        if self.planner == "lattice" and more <= 1e-9:
            best = "no secure path on it costs less" if objective == Objective.COST else \
                f"no secure path on it does better for the {objective} objective"
            return f"exact optimum: this is the exact search's path over the planning lattice: {best}"
        if self.planner == "lattice":  # docs/model.md 8.2: no straight legs realise the optimum's path
            return (f"exact optimum: the exact search's optimum costs {opt:.2f}, but no straight legs realise its "
                    f"path; this plan, the best without such steps, costs {more:.2f} more")
        if more <= 1e-9:
            return f"exact optimum: no secure path on the planning lattice costs less than this plan's {opt:.2f}"
        return (f"exact optimum: the cheapest secure path on the planning lattice costs {opt:.2f}; this plan costs "
                f"{more:.2f} ({100 * more / opt:.1f} %) more")

    def _forced(self) -> str:
        """How the smallest margin compares with the lattice's bottleneck, when known."""
        if self.margin_forced is None:
            return ""
        if self.margin_forced:
            return " (the most any secure lattice path keeps)"
        return f" (some secure lattice path keeps {self.margin_bottleneck_deg:.3f} deg)"


#: The kinds of outline at G and B (geometry.plane.ContactPoint.kind) in words.
_OUTLINE_WORDS = {"edge": "a straight side", "corner": "a sharp corner", "smooth": "a curve"}

#: What each objective optimises, in words (planning.margins.Objective).
_OBJECTIVE_WORDS = {
    Objective.COST: "the cost: the shortest path with the fewest changes of primitive",
    Objective.MARGIN: "the largest friction margin along the path, then the cost",
    Objective.BALANCED: "the cost, with a penalty where the friction margin is small",
    Objective.TOLERANCE: "the largest tolerance of errors along the path, then the cost",
}

#: PrimitiveStep.sliding's friction directions on the object, as the contact moves.
_SLIDE_WORDS = {("A", "toward_B"): "the finger slides toward B", ("A", "toward_G"): "the finger slides toward G",
                ("B", "toward_palm"): "the object's end slides toward the thumb's tip",
                ("B", "toward_tip"): "the object's end slides toward the thumb's base"}


def _primitive_words(p: PrimitiveStep) -> str:
    """One primitive for a person: what it does, what moves from where to where, which contacts
    slide which way, and how it holds the object out of the plane."""
    what = Primitive(p.type).describe() if p.type in tuple(Primitive) else str(p.type)
    if p.direction != "forward":
        what += ", run backwards"
    moves, still = [], []
    for k, (name, unit) in enumerate((("theta", " deg"), ("d", ""), ("psi", " deg"))):
        a, b = p.start[k], p.end[k]
        fmt = (lambda x: f"{x:.3f}") if k == 1 else (lambda x: f"{math.degrees(x):.1f}")
        (moves if abs(a - b) > 1e-12 else still).append(f"{name} {fmt(a)} -> {fmt(b)}{unit}" if abs(a - b) > 1e-12
                                                          else f"{name} {fmt(a)}{unit}")
    slides = [_SLIDE_WORDS.get((c, w), f"{c} slides") for c, ways in p.sliding.items() for w in ways.split("/")]
    contacts = "; ".join(slides) if slides else "no contact slides"
    held = {"full": "stable against pushes and twists out of the plane",
            "partial": "out of the plane, it resists sideways pushes but not twists about the vertical (two contacts "
                       "slide)"}.get(p.stability, p.stability)
    return f"{p.type}, {what}: {', '.join(moves)} ({', '.join(still)}); {contacts}; {held}"


def _along(offset: float) -> str:
    """An offset along GB (m, + toward B) in words: '2.62 mm from the plan's landing, toward G along GB'."""
    mm = 1000 * offset
    if abs(mm) < 0.005:
        return "0.00 mm from the plan's landing"
    return f"{abs(mm):.2f} mm from the plan's landing, toward {'B' if mm > 0 else 'G'} along GB"


def _span(low: float, high: float) -> str:
    """The range of offsets along GB (m, + toward B) in words."""
    lo, hi = 1000 * low, 1000 * high
    if hi <= 0.0:
        return f"{abs(hi):.2f} to {abs(lo):.2f} mm toward G"
    if lo >= 0.0:
        return f"{lo:.2f} to {hi:.2f} mm toward B"
    return f"{abs(lo):.2f} mm toward G to {hi:.2f} mm toward B"


def _member(kind: type[StrEnum], value: Any, field: str, source: str | None, other: str = "") -> Any:
    """plan.json's value of an enum field as its member; InputError naming the field otherwise."""
    if value not in tuple(kind):
        raise InputError(field, f"must be one of {', '.join(kind)}{other}, got {value!r:.80}", source)
    return kind(value)


def _part_field(part: str, name: str) -> property:
    def get(plan: Plan) -> Any:
        value = getattr(plan, part)
        return None if value is None else getattr(value, name)
    return property(get, doc=f"{part}.{name}")


for _part, _kind in (("solution", Solution), ("diagnostics", Diagnostics), ("report", Report3D)):
    for _name in _kind.__dataclass_fields__:
        setattr(Plan, _name, _part_field(_part, _name))


def friction_record(friction: Friction) -> dict[str, Any]:
    """plan.json's friction (without secure_over, which Plan.to_dict adds): the plane's
    coefficients at G, A, B planned with (mu), how far they are known (uncertainty, a fraction
    either way) and the plane's coefficients at the range's ends (mu_low, mu_high)."""
    return {"mu": list(friction.mu), "uncertainty": friction.uncertainty, "mu_low": list(friction.low),
            "mu_high": list(friction.high)}


def read_plan(path: str) -> Plan:
    """Read a plan.json, or the plan.json of a directory (what plan --out DIR or --export DIR
    wrote); InputError naming the field (or the file) when it cannot be used."""
    path = Path(path)
    if path.is_dir():
        if not (path / "plan.json").is_file():
            raise InputError("plan", "holds no plan.json (plan --out DIR or plan --export DIR writes one)",
                             str(path))
        path = path / "plan.json"

    return Plan.from_dict(read_json_file(path, "plan"), source=str(path))


def _deg(q: list[float]) -> str:
    return f"(theta {math.degrees(q[0]):5.1f}, d {q[1]:.3f}, psi {math.degrees(q[2]):5.1f})"


def leg_sliding(atlas: SecurityAtlas, leg: Leg) -> dict[str, str]:
    """Sliding contacts of a leg and the friction direction on the object at each."""
    q0, q1 = atlas.state(leg.start), atlas.state(leg.end)
    step = q1 - q0
    n = max(abs(leg.end[k] - leg.start[k]) for k in range(3))
    q = q0 + np.linspace(0.0, 1.0, n + 1)[:, None] * step
    sa, sb = primitive_sliding_signs(leg.primitive, q[:, D], q[:, PSI], step[D], step[PSI])
    out = {}
    for contact, signs, words in (("A", sa, _A_WORDS), ("B", sb, _B_WORDS)):
        moving = sorted({int(x) for x in signs if x})
        if moving:
            out[contact] = "/".join(words[s] for s in moving)
    return out


def merge_legs(atlas: SecurityAtlas, legs: list[Leg]) -> list[PrimitiveStep]:
    """Consecutive legs of the same primitive and direction become one primitive."""
    steps: list[PrimitiveStep] = []
    for leg in legs:
        q0, q1 = atlas.state(leg.start), atlas.state(leg.end)
        forward = {"P_theta": q1[THETA] < q0[THETA], "P_psi": q1[PSI] > q0[PSI], "P_dpsi": q1[D] < q0[D]}
        direction = "forward" if forward[leg.primitive] else "reverse"
        sliding = leg_sliding(atlas, leg)
        if steps and steps[-1].type == leg.primitive and steps[-1].direction == direction:
            last = steps[-1]
            last.end = q1.tolist()
            last.waypoints.append(q1.tolist())
            for c, w in sliding.items():
                words = set(last.sliding.get(c, "").split("/")) - {""} | set(w.split("/"))
                last.sliding[c] = "/".join(sorted(words))
        else:
            steps.append(PrimitiveStep(Primitive(leg.primitive), direction, q0.tolist(), q1.tolist(), sliding, "",
                                       [q0.tolist(), q1.tolist()]))
    for s in steps:
        s.waypoints = _corners(s.waypoints)
        s.sliding = dict(sorted(s.sliding.items()))
        s.stability = "full" if len(s.sliding) <= 1 else "partial"
    return steps


def _corners(points: list[list[float]]) -> list[list[float]]:
    """The points where a polyline turns (collinear middle points dropped)."""
    out = [points[0]]
    for k in range(1, len(points) - 1):
        a, b, c = (np.asarray(x) for x in (out[-1], points[k], points[k + 1]))
        u, v = b - a, c - b
        if np.linalg.norm(np.cross(u, v)) > 1e-12 * max(1.0, np.linalg.norm(u) * np.linalg.norm(v)):
            out.append(points[k])
    out.append(points[-1])
    return out


def sequence_cost(atlas: SecurityAtlas, steps: list[PrimitiveStep]) -> tuple[float, float, int]:
    """(cost, L1 length, primitive changes) of a merged sequence, in the reference units."""
    opts = atlas.scene.options
    l1 = float(sum(reference_cost(np.subtract(s.end, s.start), opts.d_weight) for s in steps))
    switches = max(0, len(steps) - 1)
    return l1 + opts.mode_change_penalty * switches, l1, switches
