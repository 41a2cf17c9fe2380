"""Scenes: the object, the digits, friction, obstacles, start and goal (YAML files).

Units: lengths in metres, except ``digits.alpha`` and the d coordinate, which
are over the object length l (docs/model.md, section 2). Angles are radians in
code; a person types degrees in keys ending ``_deg``. Plane coordinates are
(x, z) in the manipulation plane, G at the origin, x along the table toward
B's side, z up. Every field is validated on load (scene.loader.SceneReader); a bad one raises
:class:`~ungrasp_ompl.errors.InputError` naming the field and the reason.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from enum import Enum
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError
from ..geometry.collision import Box, CollisionChecker, CollisionModel, object_solid
from ..geometry.plane import ManipulationPlane, plane_frame
from ..geometry.solids import solid_mass_properties
from ..mechanics import (DigitGeometry, force_closure, kinematic_checks, kinematic_validity, primitive_sliding_signs,
                        sliding_signs)
from ..mechanics.antipodal import effective_friction
from ..mechanics.force_closure import Friction, SectionContact
from ..mechanics.margin import Margins, friction_margin, kinematic_margins
from ..shipped import resolve, shipped_names
from .loader import read_yaml, scene_fields
from .options import GoalSpec, Object3D, PlanningOptions, RobotOptions, SimOptions

if TYPE_CHECKING:  # pragma: no cover
    from ..mechanics.cage import Cage, CageGrid


class StateClass(Enum):
    """Whether a state can be held with all contacts sticking, and if not the first check it
    fails (kinematics, then collision, then force closure)."""

    HELD = 0
    NOT_FORCE_CLOSED = 1
    COLLISION = 2
    KINEMATICS = 3


@dataclass(frozen=True)
class StateDiagnosis:
    """One state's class with its evidence: the kinematic conditions that fail (names as in
    mechanics.kinematic_checks) and the colliding body/target pairs."""

    state_class: StateClass
    failed_checks: tuple[str, ...] = ()
    contacts: tuple[str, ...] = ()

    def describe(self, what: str = "the state") -> str:
        """One phrase for a person, e.g. "the start state is in collision: thumb/wall_left"."""
        if self.state_class is StateClass.HELD:
            return f"{what} can be held"
        if self.state_class is StateClass.KINEMATICS:
            return f"{what} is kinematically invalid: " + ", ".join(self.failed_checks) + " fails"
        if self.state_class is StateClass.COLLISION:
            return f"{what} is in collision: " + ", ".join(self.contacts)
        return f"{what} is not force-closed (contacts cannot hold the object)"


@dataclass
class Scene:
    """A planar ungrasping problem (see the module docstring for units)."""

    name: str
    object_length: float
    object_thickness: float
    mu: tuple[float, float, float]  # (G, A, B)
    digits: DigitGeometry  # over l
    obstacles: list[Box]
    start: NDArray[np.float64]  # (theta, d, psi)
    goal: GoalSpec
    bounds: NDArray[np.float64]  # (2, 3): low and high of (theta, d, psi)
    options: PlanningOptions = field(default_factory=PlanningOptions)
    source: str | None = None
    object3d: "Object3D | None" = None  # the object's outline, when the scene has one
    plane: ManipulationPlane | None = None  # the manipulation plane chosen on that outline
    mu_contacts: tuple[float, float, float] | None = None  # friction at G, A, B before the plane reduces it (None: mu, a planar scene's)
    max_tilt: float = math.radians(30.0)  # roll range of the prism simulation, rad
    robot: RobotOptions = field(default_factory=RobotOptions)
    solids: tuple = ()  # convex Solids fixed in the world (a layout's frame walls, pieces placed already)
    sim: SimOptions = field(default_factory=SimOptions)  # how the scene is simulated
    planar_only: str | None = None  # why the robot cannot execute this scene's plans (None: robot-ready)
    friction_uncertainty: float = 0.0  # how far mu_contacts may be off, a fraction of each either way (docs/model.md 4.7)

    def __post_init__(self) -> None:
        if self.mu_contacts is None:  # a planar scene's contacts are its plane's
            self.mu_contacts = tuple(self.mu)

    # -- loading -----------------------------------------------------------------
    @classmethod
    def from_file(cls, path: str | os.PathLike[str]) -> "Scene":
        """Load and validate a scene file, or the shipped scene of that name ("guitar_pick"; see
        ``ungrasp-ompl scenes`` and shipped.resolve); raises InputError naming the bad field."""
        path = resolve(path, "scene")
        data = read_yaml(path, "scene")
        return cls.from_dict(data, source=shipped_names(str(path)), default_name=path.stem)

    @classmethod
    def from_dict(cls, data: Any, source: str | None = None, default_name: str = "scene") -> "Scene":
        """Build a scene from the parsed YAML mapping (scene.loader.scene_fields reads and checks
        it); raises InputError on a bad field."""
        return cls(**scene_fields(data, source, default_name))

    def __repr__(self) -> str:
        """One line in SI units (metres; angles in degrees where marked _deg; d over l as in the files)."""
        l, dg = self.object_length, self.digits
        lo, hi = self.goal.box()
        th, d, ps = self.start
        return (f"Scene({self.name!r}, length_m={l:.4g}, thickness_m={self.object_thickness:.4g}, "
                f"mu_GAB=({self.mu[0]:.3g}, {self.mu[1]:.3g}, {self.mu[2]:.3g}), "
                f"thumb_m={dg.thumb_length * l:.4g}, finger_m={(dg.thumb_length + dg.alpha) * l:.4g}, "
                f"start=(theta_deg={math.degrees(th):.4g}, d={d:.4g}, psi_deg={math.degrees(ps):.4g}), "
                f"goal=(theta_deg<={math.degrees(hi[0]):.4g}, d={lo[1]:.4g}..{hi[1]:.4g}, "
                f"psi_deg={math.degrees(lo[2]):.4g}..{math.degrees(hi[2]):.4g}), obstacles={len(self.obstacles)}"
                + (", planar_only" if self.planar_only else "") + ")")

    # -- queries -----------------------------------------------------------------
    @property
    def friction(self) -> Friction:
        """The plane's friction at G, A, B (mu) with the scene's sliding model and, when the
        friction is known only within a range (friction_uncertainty), the plane's coefficients at
        the range's ends: what force closure uses (docs/model.md 4.7)."""
        u = self.friction_uncertainty
        section = self.digits.section
        contact = None if section is None or section.is_slab else SectionContact(section, self.digits.finger_tip_radius)
        if u == 0.0:
            return Friction(self.mu, self.options.sliding_model, contact_a=contact)
        return Friction(self.mu, self.options.sliding_model, u, self.plane_friction(1.0 - u),
                        self.plane_friction(1.0 + u), contact_a=contact)

    def plane_friction(self, factor: float) -> tuple[float, float, float]:
        """The plane's coefficients at G, A, B with every contact's coefficient (mu_contacts) times
        factor, reduced at G and B as mu is (docs/model.md 5.2: mu' = tan(arccos(cos(atan mu) /
        cos beta)), NaN where the plane misses the cone); mu times factor for a scene without a
        manipulation plane."""
        if self.plane is None:
            return tuple(m * factor for m in self.mu)
        g, a, b = (m * factor for m in self.mu_contacts)
        return (float(effective_friction(g, self.plane.g.beta)), a, float(effective_friction(b, self.plane.b.beta)))

    def force_closure(self, q: ArrayLike, dq: ArrayLike | None = None) -> NDArray[np.bool_]:
        """Force closure of states q, shape (N, 3) (theta rad, d over l, psi rad).

        With dq (same shape: a velocity per state) each state is checked in the
        contact mode that velocity makes (sliding contacts push along the edge
        opposing their sliding); without it every contact sticks.
        """
        q, sa, sb = _states_and_mode(q, dq)
        return force_closure(q[:, 0], q[:, 1], q[:, 2], sa, sb, self.friction)

    def margin(self, q: ArrayLike, dq: ArrayLike | None = None) -> Margins:
        """How far states q (N, 3) (theta rad, d over l, psi rad) are from losing their grip
        (docs/model.md, section 4.4): the friction margin (rad) in the contact mode each velocity
        dq makes (every contact sticking without dq, as in :meth:`force_closure`), positive
        exactly where that holds, and the kinematic margins (m) of B on the thumb, the digits
        above the table and from the obstacles (mechanics.margin.kinematic_margins)."""
        q, sa, sb = _states_and_mode(q, dq)
        l = self.object_length
        boxes = tuple(np.array([[b.lo[0], b.lo[1]], [b.hi[0], b.lo[1]], [b.hi[0], b.hi[1]], [b.lo[0], b.hi[1]]]) / l
                      for b in self.obstacles)
        friction = friction_margin(q[:, 0], q[:, 1], q[:, 2], sa, sb, self.friction)
        return Margins(friction, kinematic_margins(q[:, 0], q[:, 1], q[:, 2], self.digits, l, boxes))

    def cage(self, q: ArrayLike, grid: CageGrid | None = None, squeeze: float = 0.0) -> list[Cage]:
        """The energy-bounded cage of each state q (N, 3) (docs/model.md, section 4.5): with the
        digits and the table where the state puts them, the energy (J) the object (its section by
        the manipulation plane, its weight from sim.density and its volume) must gain to escape.
        squeeze: a constant force (N) pressing it where the finger does. Raises InputError for an
        object without thickness (it has no weight) and for a grid too fine to hold in memory."""
        # scipy.ndimage and scipy.sparse: a second to import, loaded when a cage is computed
        from ..mechanics.cage import CageGrid, GridTooLarge, escape_energy, pinch_problem, weight_of

        q = _states(q, "q")
        if self.object_thickness <= 0.0:
            raise InputError("object.thickness", "the cage's potential energy needs an object with a thickness (m)",
                             self.source)
        if not (math.isfinite(squeeze) and squeeze >= 0.0):
            raise InputError("squeeze", f"must be a force in newtons >= 0, got {squeeze!r}")
        l = self.object_length
        centre_x, centre_z, area = l / 2, None, l * self.digits.width * l
        curved = self.digits.section is not None and not self.digits.section.is_slab
        if curved:  # the solid the planner collides with: its volume and centre of mass
            volume, centroid = solid_mass_properties(object_solid(self.digits.section, l, self.digits.width * l,
                                                                  self.object3d is not None))
            weight = weight_of(self.sim.density * volume)
            centre_x, centre_z = float(centroid[0]), float(centroid[2])
        else:
            section = self.collision_model().section
            if section is not None:
                x, y = section[:, 0], section[:, 1]
                cross = x * np.roll(y, -1) - np.roll(x, -1) * y
                area = abs(float(cross.sum())) / 2
                centre_x = float(((x + np.roll(x, -1)) * cross).sum() / (3 * cross.sum()))
            weight = weight_of(self.sim.density * area * self.object_thickness)
        boxes = tuple(np.array([[b.lo[0], b.lo[1]], [b.hi[0], b.lo[1]], [b.hi[0], b.hi[1]], [b.lo[0], b.hi[1]]])
                      for b in self.obstacles)
        grid = grid or CageGrid()
        try:
            return [escape_energy(pinch_problem(*state, self.digits, l, self.object_thickness, centre_x, weight,
                                                boxes, squeeze, centre_z), grid, l) for state in q]
        except GridTooLarge as exc:
            raise InputError("grid", f"{exc}; choose coarser steps") from None

    def plane_frame(self) -> NDArray[np.float64]:
        """The manipulation plane's frame in the world (4 x 4, m) with the object at its target: x
        along GB from G, z up: the outline's plane, or, for a scene without an outline, G at
        robot.object_position with GB at robot.object_yaw."""
        if self.plane is not None:
            return np.asarray(self.plane.frame, dtype=float)
        return plane_frame(np.zeros(2), np.array([1.0, 0.0]), self.robot.object_position, self.robot.object_yaw)

    def collision_model(self) -> CollisionModel:
        """What collision checking needs of this scene, in plane coordinates (metres)."""
        section, frame = None, None
        if self.plane is not None:
            frame = self.plane.frame
            if self.object3d is not None:
                section = (self.object3d.placed_outline() - frame[:2, 3]) @ frame[:2, :2]
        return CollisionModel(self.object_length, self.object_thickness, self.digits, tuple(self.obstacles),
                              section, tuple(self.solids), frame, self.robot.start_press, self.robot.gripper)

    def classify(self, q: ArrayLike, checker: CollisionChecker | None = None) -> NDArray[np.int8]:
        """The StateClass of each state q (N, 3), all contacts sticking: the first check each
        fails, in the order kinematics, collision, force closure."""
        q = _states(q, "q")
        kin = kinematic_validity(q[:, 0], q[:, 1], q[:, 2], self.digits)
        out = np.full(len(q), StateClass.KINEMATICS.value, dtype=np.int8)
        hit = np.zeros(len(q), dtype=bool)
        if kin.any():
            hit[kin] = (checker or CollisionChecker(self.collision_model())).in_collision(q[kin])
        fc = self.force_closure(q)
        out[kin & hit] = StateClass.COLLISION.value
        out[kin & ~hit & ~fc] = StateClass.NOT_FORCE_CLOSED.value
        out[kin & ~hit & fc] = StateClass.HELD.value
        return out

    def is_valid(self, q: ArrayLike) -> NDArray[np.bool_]:
        """States that can be held: kinematically valid, collision-free and force-closed with sticking contacts."""
        return self.classify(q) == StateClass.HELD.value

    def diagnose(self, q: ArrayLike) -> "StateDiagnosis":
        """Why one state (theta rad, d over l, psi rad) can or cannot be held, with the evidence."""
        q = _states(q, "q")[:1]
        cls = StateClass(int(self.classify(q)[0]))
        failed = tuple(k for k, ok in kinematic_checks(q[:, 0], q[:, 1], q[:, 2], self.digits).items() if not ok[0])
        contacts = tuple(CollisionChecker(self.collision_model()).contacts(q)) if cls is StateClass.COLLISION else ()
        return StateDiagnosis(cls, failed, contacts)

    def with_options(self, **changes: Any) -> "Scene":
        """A copy of the scene with some planning options replaced."""
        return replace(self, options=replace(self.options, **changes))

    def with_sim(self, **changes: Any) -> "Scene":
        """A copy of the scene with some simulation options (its ``sim`` section) replaced."""
        return replace(self, sim=replace(self.sim, **changes))

    def with_free_goal(self) -> "Scene":
        """The scene whose goal region lets d and psi take any value within the bounds (theta's
        range kept): wherever the digits can let go, not only where the scene's own digits do."""
        lo, hi = self.bounds
        goal = replace(self.goal, d=(float(lo[1]), float(hi[1])), psi=(float(lo[2]), float(hi[2])))
        return replace(self, goal=goal)

    def with_goal_cell(self, state: tuple[float, float, float]) -> "Scene":
        """The scene whose goal region is narrowed to the planning lattice's cell of state (theta rad,
        d over l, psi rad; the goal's theta range kept), the states its plans may visit still bounded
        by the region it came from (GoalSpec.within; planning.release least_moving)."""
        half = np.asarray(self.options.resolution, dtype=float) / 2
        goal = replace(self.goal, d=(state[1] - half[1], state[1] + half[1]),
                       psi=(state[2] - half[2], state[2] + half[2]), within=self.goal)
        return replace(self, goal=goal)

    def with_start_d(self, d: float) -> "Scene":
        """The scene started at d (over l), its start's theta and psi kept: where the hand takes
        the object along GB (`ungrasp-ompl starts` weighs the candidates)."""
        return replace(self, start=np.array([self.start[0], float(d), self.start[2]]))

    def with_digits(self, alpha: float | None = None, finger_tip: str | None = None,
                    finger_tip_radius: float | None = None) -> "Scene":
        """The scene with other digits, checked as the scene file's are (InputError naming the
        digits field): alpha over l; finger_tip rounded or flat (a flat tip has no radius; a
        rounded one made from a flat tip gets a dome of half its tip's thickness);
        finger_tip_radius in metres, a dome that thickens the finger's tip to twice its radius
        where the tip is thinner than that. The one way to vary a scene's digits."""
        dg, l = self.digits, self.object_length
        changes: dict[str, Any] = {}
        if alpha is not None:
            if not (math.isfinite(alpha) and -1.0 < alpha < 1.0):
                raise InputError("digits.alpha", f"must lie in (-1, 1) (over the object length), got {alpha:.4g}")
            if dg.thumb_length + alpha <= 0:
                raise InputError("digits.alpha", "makes the finger length thumb_length + alpha * l non-positive")
            changes["alpha"] = float(alpha)
        flat = dg.flat_finger_tip if finger_tip is None else finger_tip == "flat"
        if finger_tip is not None and finger_tip not in ("rounded", "flat"):
            raise InputError("digits.finger_tip", f"must be rounded (point contact at A) or flat (edge contact), "
                             f"got {finger_tip!r}")
        if flat:
            if finger_tip_radius:
                raise InputError("digits.finger_tip_radius", "needs finger_tip: rounded (a flat tip has no radius)")
            changes.update(flat_finger_tip=True, finger_tip_radius=0.0)
        else:
            radius = dg.finger_tip_radius if finger_tip_radius is None else finger_tip_radius / l
            if finger_tip_radius is None and dg.flat_finger_tip:
                radius = dg.finger_tip_thickness / 2
            if not (math.isfinite(radius) and radius >= 0.0):
                raise InputError("digits.finger_tip_radius", f"must be a length >= 0 m, got {radius * l:.4g}")
            changes.update(flat_finger_tip=False, finger_tip_radius=radius,
                           finger_tip_thickness=max(dg.finger_tip_thickness, 2 * radius))
        return replace(self, digits=replace(dg, **changes))


def _states_and_mode(q: ArrayLike, dq: ArrayLike | None) -> tuple[NDArray[np.float64], NDArray, NDArray]:
    """States q (N, 3) and the sliding signs at A and B (N,) each of the contact mode velocities dq
    (N, 3) make there (every contact sticking without dq); InputError naming q or dq when malformed."""
    q = _states(q, "q")
    if dq is None:
        return q, np.zeros(len(q), dtype=np.int8), np.zeros(len(q), dtype=np.int8)
    dq = _states(dq, "dq")
    if dq.shape != q.shape:
        raise InputError("dq", f"must have the shape of q {q.shape}, got {dq.shape}")
    sa, sb = sliding_signs(q[:, 1], q[:, 2], dq[:, 1], dq[:, 2])
    # psi alone is a P_psi, whose B slides against dpsi even at psi = 0 (primitive_sliding_signs), as
    # the planner and a plan's margin take it
    turn = (dq[:, 0] == 0) & (dq[:, 1] == 0) & (dq[:, 2] != 0)
    sb[turn] = primitive_sliding_signs("P_psi", q[turn, 1], q[turn, 2], 0.0, dq[turn, 2])[1]
    return q, sa, sb


def _states(q: ArrayLike, name: str) -> NDArray[np.float64]:
    """q as an (N, 3) float array; InputError naming it when it is not numbers of that shape, or
    not finite."""
    try:
        a = np.asarray(q, dtype=float)
    except (TypeError, ValueError):
        raise InputError(name, f"must be numbers of shape (N, 3) as (theta, d, psi), got {q!r:.60}") from None
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != 3:
        raise InputError(name, f"must have shape (N, 3) as (theta, d, psi), got {np.shape(q)}")
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        raise InputError(name, f"must be finite, got {a[bad][0].tolist()} in row {int(np.argmax(bad))}")
    return a
