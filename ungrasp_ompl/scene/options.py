"""The options a scene fixes (planning, robot execution, simulation) and the object's 3D shape.

Units: metres, radians, seconds, newtons; each attribute's docstring names its unit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..geometry.outline import Outline
from ..mechanics.force_closure import SlidingModel
from ..mechanics.pincer import PincerSpec


class Termination(StrEnum):
    """How the gripper lets go at the end of a plan (a member is its name as a string)."""

    #: The jaws open by robot.termination_opening, the arm moving the palm by half of it so that
    #: the thumb stays on B.
    OPEN = "open"
    #: The jaws open by robot.termination_opening about the palm, which stays where it is (the
    #: gripper's own opening): the thumb backs off B by half of it as the finger leaves A.
    OPEN_SYMMETRIC = "open_symmetric"
    #: The jaws open by robot.termination_opening while the arm moves the palm so that the
    #: finger leaves A along the face's normal (nothing drags the object toward G) and the thumb,
    #: going down as far as in open_symmetric, backs off B across as well (docs/model.md 7).
    OPEN_LIFT = "open_lift"
    #: The hand turns about the thumb's tip by robot.termination_angle.
    ROTATE = "rotate"

    def describe(self) -> str:
        """How the gripper lets go, in words for a person (files keep the name)."""
        return {Termination.OPEN: "opening its jaws with the thumb kept on B",
                Termination.OPEN_SYMMETRIC: "opening its jaws about the palm",
                Termination.OPEN_LIFT: "opening its jaws as the finger lifts off the object",
                Termination.ROTATE: "turning about the thumb's tip"}[self]


class GripperKind(StrEnum):
    """How the gripper's digits move (robot.gripper.kind; a member is its name as a string)."""

    #: Two jaws sliding apart on the palm, the digits parallel (RH-P12-RN class): the default.
    PARALLEL = "parallel"
    #: Two digits turning apart about one revolute joint (mechanics.pincer).
    PINCER = "pincer"


class Landing(StrEnum):
    """Where the hand aims the object (a member is its name as a string)."""

    #: As the plan has it: the object turns flat about G where the last state leaves it.
    PLANNED = "planned"
    #: Where the release, simulated with no error drawn, lands it: the hand is moved back by the
    #: landing's offset from the target and its turn (docs/model.md 11.12).
    SIMULATED = "simulated"
    #: Where the release lands it on average under the `paper` errors: the hand is moved back by
    #: the mean landing of robot.landing_pairs antithetic pairs of simulated releases
    #: (docs/model.md 11.12).
    EXPECTED = "expected"
    #: Where the model of the fall (mechanics.release) puts it over friction 0.7-1.3 times the
    #: scene's and both friction cones: the hand is moved back by the middle of that range (record
    #: 0123), no release simulated (docs/model.md 11.17); an opening termination only.
    MODELLED = "modelled"


class Objective(StrEnum):
    """What a plan optimises (docs/model.md, section 6)."""

    COST = "cost"  #: the weighted L1 length plus a penalty per primitive change
    MARGIN = "margin"  #: the smallest friction margin along the path, the cost breaking ties
    BALANCED = "balanced"  #: the cost plus planning.margin_weight times a penalty growing as the margin shrinks
    TOLERANCE = "tolerance"  #: the smallest tolerance of the `paper` errors along the path, the cost breaking ties

    @property
    def maximin(self) -> bool:
        """It maximises the path's smallest value (margin or tolerance) first, the cost breaking ties."""
        return self in (Objective.MARGIN, Objective.TOLERANCE)


class Release(StrEnum):
    """Where in the goal region a plan ends (planning.release; a member is its name as a string)."""

    #: Wherever the plan's objective takes it.
    OBJECTIVE = "objective"
    #: At the goal state, at the goal's largest theta and reachable from the start, whose landing by
    #: the model of the fall moves farthest least over friction 0.7-1.3 times the scene's and both
    #: friction cones; a plan reaching it through a P_dpsi is weighed against the plan to the
    #: least-moving state at the start's d by each one's own carried landing (docs/model.md 11.17,
    #: records 0128 and 0130).
    LEAST_MOVING = "least_moving"


@dataclass(frozen=True)
class PlanningOptions:
    """Options of the planar planner that a scene fixes (the scene's `planning` section). Costs
    are in the reference units: 1 per degree of theta or psi."""

    sliding_model: SlidingModel = SlidingModel.RELAXED
    """How a sliding contact's friction is modelled: relaxed or strict (docs/model.md, section 4)."""
    reverse_primitives: bool = False
    """Allow the reverse directions too (pivot up, thumb closing, finger sliding back)."""
    resolution: tuple[float, float, float] = (math.radians(0.5), 0.005, math.radians(0.5))
    """Lattice step (theta rad, d over l, psi rad) at which states and motions are checked."""
    d_weight: float = 100.0
    """Cost per unit of d (over l)."""
    mode_change_penalty: float = 1.0
    """Cost per change of primitive."""
    forbid_partial: bool = False
    """No leg with two sliding contacts (P_dpsi), so every leg keeps full 3D stability."""
    margin_weight: float = 1.0
    """The balanced objective's weight on friction margin (cost x deg): a step costs this times its L1 length over its margin in deg."""
    min_tolerance: float = 0.0
    """The least tolerance of the `paper` errors (a scale of their box, dimensionless; docs/model.md 4.6) a plan must have; 0: no floor."""
    max_landing_spread: float | None = None
    """The most the predicted landing may move along GB over friction x0.7-1.3 and both cones (m;
    mechanics.release, docs/model.md 11.17); a plan with P_dpsi beyond it is planned again without
    P_dpsi; None: no bound."""
    range: float | None = None
    """The tree planners' longest motion for this scene, in state units (theta and psi in rad, d over
    l): shorter where the secure states lie in thin bands that a long motion leaves; None: the
    objective's default (planning.setup.DEFAULT_RANGE); a planner's own range overrides it."""
    objective: Objective = Objective.COST
    """What this scene's plans optimise where the caller names no objective (docs/model.md 6.1);
    the roadmap planners, which optimise the cost only, optimise the cost."""
    release: Release = Release.OBJECTIVE
    """Where in the goal region the plan ends: where its objective takes it, or where the model of
    the fall moves the object least (record 0128)."""


@dataclass(frozen=True)
class Object3D:
    """A thin object: outline in its own plane (metres), thickness, and target pose on the table."""

    outline: Outline
    thickness: float
    position: tuple[float, float] = (0.0, 0.0)
    yaw: float = 0.0

    def placed_outline(self, max_sagitta: float | None = None) -> NDArray[np.float64]:
        """The outline's vertices (N, 2) turned by yaw and moved to position (the frame of position);
        with max_sagitta (m), its curves filled in that finely (Outline.refined)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        v = self.outline.vertices if max_sagitta is None else self.outline.refined(max_sagitta)
        return v @ np.array([[c, s], [-s, c]]) + np.asarray(self.position)

    def to_dict(self) -> dict:
        return {"outline": self.outline.vertices.tolist(), "thickness_m": self.thickness,
                "target": {"position": list(self.position), "yaw_rad": self.yaw}}


@dataclass(frozen=True)
class RobotOptions:
    """How the plan is executed by the UR5e and its gripper (the scene's `robot` section)."""

    base: tuple = ((1.0, 0, 0, 0), (0, 1.0, 0, 0), (0, 0, 1.0, 0), (0, 0, 0, 1.0))
    """4 x 4 pose of the arm's base in the world (metres)."""
    palm_depth: float = 0.11
    """From the UR flange to the gripper's palm (m)."""
    home: tuple[float, ...] = (0.0, -math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0.0)
    """Arm joint angles the approach starts from (rad)."""
    contact_speed: float = 0.01
    """Cap on the digit tips' speed along the primitives (m/s)."""
    termination: Termination = Termination.OPEN
    """How the gripper lets go: open, open_symmetric or open_lift (by termination_opening) or rotate
    (about the thumb tip)."""
    termination_opening: float = 0.01
    """How far the gripper opens to let go (m)."""
    termination_angle: float = math.radians(10.0)
    """How far the gripper turns about the thumb tip to let go (rad)."""
    retreat_height: float = 0.05
    """Lift of the palm after letting go (m)."""
    start_press: float = 0.0
    """How far below the plan the hand works (m): from the start pinch it comes straight down by
    this much, the object's end held by the table, and runs the whole plan that much lower, so that
    a hand up to this much too high still starts with the object on the table (docs/model.md 11.8);
    B keeps planning.thumb_tip_margin also where the press puts the object. At most
    planning.table_clearance."""
    end_press: float | None = None
    """How far below the plan the hand ends the plan's last primitive when it is a P_theta (m):
    the press is let out to this over that P_theta, where every contact sticks and the pinch
    holds the object without the table; None: start_press, nothing let out (docs/model.md 11.11).
    At most start_press."""
    touch_off: bool = False
    """Whether the set-up measures the table's height under the start pinch by touching it with the
    empty hand (export writes the probe program, touch_off.urscript) and runs the plan from it, so
    that the arm's vertical calibration error there is left to the probe's (docs/model.md 11.14);
    False: the plan runs open loop on the calibration alone, as the paper's set-up did."""
    landing: Landing = Landing.PLANNED
    """Where the hand aims the object: planned (the plan's last state turned flat about G),
    simulated (corrected by where the release, simulated with no error, puts it and how it turns
    it: robot.pipeline.Aim), expected (corrected by where it puts it on average under the
    `paper` errors, over a range of worlds) or modelled (corrected by the middle of where the model
    of the fall puts it over the friction's range and both cones)."""
    landing_offset: float = 0.0
    """With landing modelled: how far along GB the release lands beyond where the model of the fall
    puts it, on average over the errors and worlds it is measured in (m, + toward B; measured on the
    cell by a few releases, or in the simulator by tools/landing_offset.py); the aim moves the hand
    back by it too (docs/model.md 11.17)."""
    landing_pairs: int = 4
    """Antithetic pairs of `paper` draws whose simulated releases landing expected averages
    (count); each pair costs two trials when the plan is executed."""
    object_position: tuple[float, float] = (0.45, 0.10)
    """Where G lies on the table (world x, y, m) for scenes without an outline (those with one use
    its target pose)."""
    object_yaw: float = 0.0
    """Direction of GB on the table (world yaw, rad) for scenes without an outline."""
    gripper: PincerSpec | None = None
    """The gripper: None for the parallel jaws (robot.gripper.kind parallel, the default), or the
    pincer's joint (kind pincer: mechanics.pincer.PincerSpec, m, N m, rad)."""

    @property
    def gripper_kind(self) -> GripperKind:
        """How the gripper's digits move: parallel or pincer."""
        return GripperKind.PARALLEL if self.gripper is None else GripperKind.PINCER

    @property
    def final_press(self) -> float:
        """How far below the plan the hand ends the last P_theta (m): end_press (no deeper than
        start_press), or start_press."""
        return self.start_press if self.end_press is None else min(self.end_press, self.start_press)

    @property
    def termination_amount(self) -> float:
        """How far the termination goes: the opening (m) or, for rotate, the turn (rad)."""
        return self.termination_angle if self.termination == Termination.ROTATE else self.termination_opening


@dataclass(frozen=True)
class SimOptions:
    """How the scene is simulated in MuJoCo (the scene's `sim` section)."""

    density: float = 1250.0
    """The object's density (kg/m^3); 1250 is a stiff plastic (celluloid, PLA)."""
    grip_force: float = 5.0
    """The jaws' force limit (N): how hard the gripper squeezes."""
    squeeze: float = 0.001
    """How far inside the planned opening the jaws are commanded (m)."""
    timestep: float = 0.000025
    """Simulation step (s), an eighth of the contacts' 0.2 ms time constant: the step at which the
    campaigns' outcomes converge pooled over rows (docs/decisions/0112-the-elliptic-step-is-tested-pooled-over-rows.md)."""
    pyramidal_timestep: float = 0.0000125
    """Simulation step (s) in a world with pyramidal friction cones (sim.world.Cone), at which
    their outcomes converge (docs/decisions/0111-pyramidal-cones-run-at-the-step-they-converge-at.md)."""
    settle_time: float = 0.3
    """Stillness with the object in the pinch before the motion (s)."""
    rest_time: float = 0.5
    """Stillness after the retreat before the outcome is read (s)."""
    max_error: float = 0.003
    """Largest placement error (m) of a trial that counts as placed: the outline centroid's
    distance in the table's plane from its target's; beyond it, the outcome is 'placed off target'."""
    handed_over: bool = False
    """How the object comes to the start (bool): false, carried there in the hand, so that a hand
    too high leaves it hanging with G above the table; true, set into the open gripper at the start
    pose with its end on the table, so that it starts slid along GB in the pinch until it rests
    there (docs/model.md 11.3)."""


@dataclass(frozen=True)
class GoalSpec:
    """Goal region: theta at most theta_max, d and psi within ranges (radians, over l)."""

    theta_max: float
    d: tuple[float, float]
    psi: tuple[float, float]
    theta_min: float = 0.0
    within: GoalSpec | None = None
    """The scene's goal region this one was narrowed from (planning.release least_moving), or None.
    A plan must end in this goal; the states it may visit on the way are still bounded by the
    region it was narrowed from (planning.atlas.planning_box), as they are without the narrowing."""

    def region(self) -> GoalSpec:
        """The scene's own goal region: the one this goal was narrowed from, else this goal."""
        return self.within.region() if self.within is not None else self

    def box(self) -> NDArray[np.float64]:
        """Lower and upper corners, shape (2, 3), in (theta, d, psi)."""
        return np.array([[self.theta_min, self.d[0], self.psi[0]], [self.theta_max, self.d[1], self.psi[1]]])

    def contains(self, q: ArrayLike, tol: float = 1e-9) -> NDArray[np.bool_]:
        q = np.atleast_2d(np.asarray(q, dtype=float))
        lo, hi = self.box()
        return np.all((q >= lo - tol) & (q <= hi + tol), axis=-1)
