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
from ..geometry.collision import Box, CollisionChecker, CollisionModel
from ..geometry.plane import ManipulationPlane, choose_plane
from ..mechanics import (DigitGeometry, force_closure, kinematic_checks, kinematic_validity, primitive_sliding_signs,
                        sliding_signs)
from ..mechanics.antipodal import effective_friction
from ..mechanics.force_closure import SLIDING_MODELS, Friction, SectionContact, SlidingModel
from ..mechanics.margin import Margins, friction_margin, kinematic_margins
from ..mechanics.pincer import check_pincer
from ..shipped import resolve, shipped_names
from .loader import MAX_LENGTH, SceneReader, read_yaml
from .options import Object3D, PlanningOptions, RobotOptions, SimOptions

if TYPE_CHECKING:  # pragma: no cover
    from ..mechanics.cage import Cage, CageGrid


#: The gripper housing's extent normal to the manipulation plane when a scene does not give it, m.
DEFAULT_PALM_THICKNESS = 0.06
#: Most lattice states planning.resolution may make over the bounds (memory and time stay bounded).
MAX_LATTICE_STATES = 25_000_000


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


@dataclass(frozen=True)
class GoalSpec:
    """Goal region: theta at most theta_max, d and psi within ranges (radians, over l)."""

    theta_max: float
    d: tuple[float, float]
    psi: tuple[float, float]
    theta_min: float = 0.0

    def box(self) -> NDArray[np.float64]:
        """Lower and upper corners, shape (2, 3), in (theta, d, psi)."""
        return np.array([[self.theta_min, self.d[0], self.psi[0]], [self.theta_max, self.d[1], self.psi[1]]])

    def contains(self, q: ArrayLike, tol: float = 1e-9) -> NDArray[np.bool_]:
        q = np.atleast_2d(np.asarray(q, dtype=float))
        lo, hi = self.box()
        return np.all((q >= lo - tol) & (q <= hi + tol), axis=-1)


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
        """Build a scene from the parsed YAML mapping; raises InputError on a bad field."""
        r = SceneReader(source)
        top = r.mapping(data, "scene")
        r.known(top, "", {"name", "description", "object", "friction", "friction_angle_deg", "digits",
                          "obstacles", "start", "goal", "bounds", "planning", "contacts", "stability", "robot",
                          "sim", "planar_only"})
        name = r.name(top, "name", default_name)

        obj = r.mapping(r.require(top, "object"), "object")
        r.known(obj, "object", {"length", "thickness", "outline", "target", "section"})
        thickness = r.length(obj, "object.thickness", "thickness", zero=True, default=0.0)
        mu_contacts, uncertainty = r.friction(top)
        object3d, plane = None, None
        if "outline" in obj:
            if "length" in obj:
                raise InputError("object.length", "is set by the outline (the distance from G to B); remove it", source)
            object3d = r.object3d(obj["outline"], obj.get("target", {}), thickness)
            fixed = None
            if "contacts" in top:
                ct = r.mapping(top["contacts"], "contacts")
                r.known(ct, "contacts", {"G", "B"})
                fixed = (r.pair(ct, "contacts.G", "G"), r.pair(ct, "contacts.B", "B"))
            plane = choose_plane(object3d.outline, mu_contacts[0], mu_contacts[2], object3d.position,
                                 object3d.yaw, fixed, source)
            length = plane.length
            if length > MAX_LENGTH:
                raise InputError("object.outline", f"makes the object length |GB| {length:.4g} m, over {MAX_LENGTH:g} m",
                                 source)
            mu = (plane.mu_g, mu_contacts[1], plane.mu_b)
            if uncertainty > 0.0:  # the plane must meet every cone over the whole range (Assumption 2)
                key = "friction" if "friction" in top else "friction_angle_deg"
                for contact, m, beta in (("G", mu_contacts[0], plane.g.beta), ("B", mu_contacts[2], plane.b.beta)):
                    low = m * (1.0 - uncertainty)
                    if not beta < math.atan(low):
                        raise InputError(f"{key}.uncertainty", f"puts the friction angle at {contact} as low as "
                                         f"{math.degrees(math.atan(low)):.1f} deg, not above the "
                                         f"{math.degrees(beta):.1f} deg GB makes with the boundary normal there, so "
                                         "the manipulation plane misses that friction cone (Assumption 2)", source)
        else:
            if "contacts" in top:
                raise InputError("contacts", "needs object.outline", source)
            length = r.length(obj, "object.length", "length")
            mu = mu_contacts
        if thickness >= length:
            raise InputError("object.thickness", f"must be smaller than the object length ({length:.4g} m)", source)
        section = r.section(obj, thickness, length)  # None: the slab
        if section is not None:
            thickness = section.thickness * length  # a profile's height
            if object3d is not None:
                if not (isinstance(obj["outline"], dict) and "circle" in obj["outline"]):
                    raise InputError("object.section", "needs a circle outline (the section is turned about the "
                                     "object's centre to make its solid) or no outline", source)
                object3d = replace(object3d, thickness=thickness)
        d_max = 1.0 if section is None else section.top_length  # the slide coordinate's reach (mechanics.section)

        dig = r.mapping(r.require(top, "digits"), "digits")
        r.known(dig, "digits", {"alpha", "thumb_length", "finger_length", "thumb_tip_thickness",
                                "thumb_base_thickness", "finger_tip_thickness", "finger_base_thickness",
                                "width", "max_aperture", "finger_tip", "finger_tip_radius", "palm_width",
                                "palm_length", "palm_thickness"})
        lengths = {}
        for key in ("thumb_length", "thumb_tip_thickness", "thumb_base_thickness",
                    "finger_tip_thickness", "finger_base_thickness", "width"):
            lengths[key] = r.length(dig, f"digits.{key}", key) / length
        thumb_len = lengths["thumb_length"]
        if "alpha" in dig:
            alpha = r.number(dig, "digits.alpha", "alpha")
        elif "finger_length" in dig:  # alpha follows from the lengths and l
            alpha = r.length(dig, "digits.finger_length", "finger_length") / length - thumb_len
        else:
            raise InputError("digits.alpha", "is missing (give alpha, over the object length, or finger_length)", source)
        if not -1.0 < alpha < 1.0:
            raise InputError("digits.alpha", f"must lie in (-1, 1) (over the object length), got {alpha:.4g}", source)
        if "finger_length" in dig and "alpha" in dig:
            finger = r.length(dig, "digits.finger_length", "finger_length")
            if abs(finger / length - (thumb_len + alpha)) > 1e-6:
                raise InputError("digits.finger_length", "must equal thumb_length + alpha * object length "
                                 f"({(thumb_len + alpha) * length:.6g} m), got {finger:g}", source)
        if thumb_len + alpha <= 0:
            raise InputError("digits.alpha", "makes the finger length thumb_length + alpha * l non-positive", source)
        max_ap = r.length(dig, "digits.max_aperture", "max_aperture", default=math.inf) / length
        finger_tip = dig.get("finger_tip", "rounded")
        if finger_tip not in ("rounded", "flat"):
            raise InputError("digits.finger_tip", f"must be rounded (point contact at A) or flat (edge contact), got {finger_tip!r}", source)
        if finger_tip == "flat":
            if "finger_tip_radius" in dig:
                raise InputError("digits.finger_tip_radius", "needs finger_tip: rounded (a flat tip has no radius)", source)
            tip_radius = 0.0
        else:  # a dome across the tip's thickness unless given; a segment object keeps a point finger
            default_radius = lengths["finger_tip_thickness"] * length / 2 if thickness > 0 else 0.0
            tip_radius = r.number(dig, "digits.finger_tip_radius", "finger_tip_radius", minimum=0.0,
                                  default=default_radius) / length
            if tip_radius > lengths["finger_tip_thickness"] / 2 + 1e-12:
                raise InputError("digits.finger_tip_radius", "must be at most half of finger_tip_thickness "
                                 f"({lengths['finger_tip_thickness'] * length / 2:.4g} m)", source)
        palm = {k: r.length(dig, f"digits.{k}", k, zero=True, default=0.0) / length for k in ("palm_width", "palm_length")}
        # the housing's extent normal to the plane: the RH-P12-RN class's 60 mm unless given
        palm["palm_thickness"] = r.length(dig, "digits.palm_thickness", "palm_thickness",
                                          default=DEFAULT_PALM_THICKNESS) / length
        digits = DigitGeometry(alpha=alpha, max_aperture=max_ap, flat_finger_tip=finger_tip == "flat",
                               finger_tip_radius=tip_radius, **lengths, **palm)

        obstacles = r.obstacles(top.get("obstacles", []))

        st = r.mapping(r.require(top, "start"), "start")
        r.known(st, "start", {"theta_deg", "d", "psi_deg"})
        start = np.array([
            math.radians(r.number(st, "start.theta_deg", "theta_deg")),
            r.number(st, "start.d", "d"),
            math.radians(r.number(st, "start.psi_deg", "psi_deg")),
        ])

        bd = r.mapping(top.get("bounds", {}), "bounds")
        r.known(bd, "bounds", {"theta_deg", "d", "psi_deg"})
        bounds = np.array([
            r.interval(bd, "bounds.theta_deg", "theta_deg", default=(0.0, 90.0), degrees=True),
            r.interval(bd, "bounds.d", "d", default=(0.0, d_max)),
            r.interval(bd, "bounds.psi_deg", "psi_deg", default=(0.0, 120.0), degrees=True),
        ]).T
        if bounds[0, 0] < 0.0 or bounds[1, 0] > math.pi / 2 + 1e-12:
            raise InputError("bounds.theta_deg", "must lie within [0, 90]", source)
        if bounds[0, 1] < 0.0 or bounds[1, 1] > d_max + 1e-12:
            raise InputError("bounds.d", "must lie within [0, 1] (over the object length)" if section is None else
                             f"must lie within [0, {d_max:.6g}] (the section's top, over the object length)", source)
        if bounds[0, 2] < 0.0 or bounds[1, 2] >= math.pi:
            raise InputError("bounds.psi_deg", "must lie within [0, 180)", source)
        for i, key in enumerate(("start.theta_deg", "start.d", "start.psi_deg")):
            if not bounds[0, i] - 1e-12 <= start[i] <= bounds[1, i] + 1e-12:
                raise InputError(key, "lies outside the bounds", source)

        gl = r.mapping(r.require(top, "goal"), "goal")
        r.known(gl, "goal", {"theta_max_deg", "d", "psi_deg"})
        theta_max = math.radians(r.angle(gl, "goal.theta_max_deg", "theta_max_deg", 0.0, 90.0))
        goal_psi = r.interval(gl, "goal.psi_deg", "psi_deg", within=(0.0, 180.0), unit=" deg")
        if goal_psi[1] >= 180.0:
            raise InputError("goal.psi_deg", f"must lie within [0, 180) deg, got high {goal_psi[1]:g}", source)
        goal = GoalSpec(
            theta_max=min(theta_max, bounds[1, 0]),
            d=r.interval(gl, "goal.d", "d", within=(0.0, d_max), unit=" (over the object length)"),
            psi=(math.radians(goal_psi[0]), math.radians(goal_psi[1])),
            theta_min=bounds[0, 0],
        )
        glo, ghi = goal.box()
        if np.any(np.minimum(ghi, bounds[1]) < np.maximum(glo, bounds[0])):
            raise InputError("goal", "lies outside the bounds", source)

        pl = r.mapping(top.get("planning", {}), "planning")
        r.known(pl, "planning", {"sliding_model", "reverse_primitives", "resolution", "d_weight",
                                 "mode_change_penalty", "forbid_partial", "thumb_tip_margin", "margin_weight",
                                 "min_tolerance", "table_clearance", "across_margin", "max_landing_spread"})
        margin = r.length(pl, "planning.thumb_tip_margin", "thumb_tip_margin", zero=True, default=0.0)
        if margin >= digits.thumb_length * length:
            raise InputError("planning.thumb_tip_margin", "must be shorter than the thumb", source)
        clearance = r.length(pl, "planning.table_clearance", "table_clearance", zero=True, default=0.0)
        across = r.length(pl, "planning.across_margin", "across_margin", zero=True, default=0.0)
        support = (0.0, 0.0) if plane is None else \
            (min(plane.g.span) / length, min(min(plane.b.span) / length, lengths["width"] / 2))
        digits = replace(digits, thumb_tip_margin=margin / length, table_clearance=clearance / length,
                         object_thickness=thickness / length, support=support, across_margin=across / length,
                         section=section)
        model = pl.get("sliding_model", "relaxed")
        if model not in SLIDING_MODELS:
            raise InputError("planning.sliding_model", f"must be one of {', '.join(SLIDING_MODELS)}, got {model!r}", source)
        reverse = r.flag(pl, "planning.reverse_primitives", "reverse_primitives")
        forbid_partial = r.flag(pl, "planning.forbid_partial", "forbid_partial")
        stab = r.mapping(top.get("stability", {}), "stability")
        r.known(stab, "stability", {"max_tilt_deg"})
        max_tilt = math.radians(r.angle(stab, "stability.max_tilt_deg", "max_tilt_deg", 1.0, 90.0, default=30.0))
        res = r.mapping(pl.get("resolution", {}), "planning.resolution")
        r.known(res, "planning.resolution", {"theta_deg", "d", "psi_deg"})
        resolution = (
            math.radians(r.number(res, "planning.resolution.theta_deg", "theta_deg", positive=True, maximum=10.0,
                                  default=0.5, unit=" deg")),
            r.number(res, "planning.resolution.d", "d", positive=True, maximum=0.1, default=0.005),
            math.radians(r.number(res, "planning.resolution.psi_deg", "psi_deg", positive=True, maximum=10.0,
                                  default=0.5, unit=" deg")),
        )
        states = float(np.prod(np.floor((bounds[1] - bounds[0]) / np.asarray(resolution)) + 1))
        if states > MAX_LATTICE_STATES:
            raise InputError("planning.resolution", f"is too fine for the bounds: its lattice would hold {states:.3g} "
                             f"states (at most {MAX_LATTICE_STATES:.3g}); coarsen it or narrow the bounds", source)
        options = PlanningOptions(
            sliding_model=SlidingModel(model),
            reverse_primitives=reverse,
            forbid_partial=forbid_partial,
            margin_weight=r.margin_weight(pl),
            min_tolerance=r.number(pl, "planning.min_tolerance", "min_tolerance", minimum=0.0, maximum=5.0, default=0.0),
            max_landing_spread=(r.length(pl, "planning.max_landing_spread", "max_landing_spread")
                                if "max_landing_spread" in pl else None),
            resolution=resolution,
            d_weight=r.number(pl, "planning.d_weight", "d_weight", positive=True, maximum=1e4, default=100.0),
            mode_change_penalty=r.number(pl, "planning.mode_change_penalty", "mode_change_penalty",
                                         minimum=0.0, maximum=1e4, default=1.0),
        )
        robot = r.robot(top.get("robot", {}))
        if robot.gripper is not None and section is not None:
            raise InputError("object.section", "needs the parallel gripper (robot.gripper kind parallel): the pincer's "
                             "kinematics place its finger on a slab", source)
        if robot.gripper is not None:  # a pincer's joint must carry these digits (mechanics.pincer)
            check_pincer(robot.gripper, digits, length, source)
        if robot.start_press > clearance:
            raise InputError("robot.start_press", f"must not exceed planning.table_clearance ({clearance:g} m): "
                             "the pressed digits would run into the table", source)
        digits = replace(digits, press=robot.start_press / length)
        planar_only = top.get("planar_only")
        if planar_only is not None and not (isinstance(planar_only, str) and planar_only.strip()):
            raise InputError("planar_only", f"must say why the robot cannot execute the scene, got {planar_only!r}",
                             source)
        return cls(name, length, thickness, mu, digits, obstacles, start, goal, bounds, options, source,
                   object3d, plane, mu_contacts, max_tilt, robot, sim=r.sim(top.get("sim", {})),
                   planar_only=planar_only and planar_only.strip(), friction_uncertainty=uncertainty)

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
        centre_x, area = l / 2, l * self.digits.width * l
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
                                                boxes, squeeze), grid, l) for state in q]
        except GridTooLarge as exc:
            raise InputError("grid", f"{exc}; choose coarser steps") from None

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
