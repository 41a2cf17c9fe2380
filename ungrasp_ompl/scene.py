"""Scenes: the object, the digits, friction, obstacles, start and goal (YAML files).

Units: lengths in metres, except ``digits.alpha`` and the d coordinate, which
are over the object length l (docs/model.md, section 2). Angles are radians in
code; a person types degrees in keys ending ``_deg``. Plane coordinates are
(x, z) in the manipulation plane, G at the origin, x along the table toward
B's side, z up. Every field is validated on load; a bad one raises
:class:`~ungrasp_ompl.errors.InputError` naming the field and the reason.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import ArrayLike, NDArray

from .errors import InputError
from .geometry.outline import Outline, OutlineError, ellipse, polygon, rounded_polygon
from .geometry.plane import ManipulationPlane, choose_plane
from .mechanics import DigitGeometry, force_closure, kinematic_validity, sliding_signs
from .mechanics.force_closure import SLIDING_MODELS


#: The gripper housing's extent normal to the manipulation plane when a scene does not give it, m.
DEFAULT_PALM_THICKNESS = 0.06
#: Longest length and farthest coordinate a scene may give, m: beyond it a value is a typo.
MAX_LENGTH = 10.0
#: Largest friction coefficient a scene may give: beyond it a value is a typo.
MAX_FRICTION = 10.0
#: Largest magnitude of any number in a scene: no field means anything beyond it.
MAX_MAGNITUDE = 1e6
#: Most lattice states planning.resolution may make over the bounds (memory and time stay bounded).
MAX_LATTICE_STATES = 25_000_000


@dataclass(frozen=True)
class Box:
    """An obstacle: an axis-aligned box in the plane, extruded normal to it (metres)."""

    name: str
    lo: tuple[float, float]  # (x, z) of the lower-left corner
    hi: tuple[float, float]  # (x, z) of the upper-right corner


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


@dataclass(frozen=True)
class PlanningOptions:
    """Options of the planar planner that a scene fixes.

    resolution: lattice step in (theta rad, d over l, psi rad) on which
    force closure, kinematics and collision are checked along motions.
    reverse_primitives: allow the reverse directions (pivot up, thumb
    closing, finger sliding back). forbid_partial: no leg with two sliding
    contacts (P_dpsi), so every leg keeps full 3D stability. cost weights are in the reference units:
    1 per degree of theta or psi, d_weight per unit d, mode_change_penalty per
    change of primitive.
    """

    sliding_model: str = "relaxed"
    reverse_primitives: bool = False
    resolution: tuple[float, float, float] = (math.radians(0.5), 0.005, math.radians(0.5))
    d_weight: float = 100.0
    mode_change_penalty: float = 1.0
    forbid_partial: bool = False


@dataclass(frozen=True)
class Object3D:
    """A thin object: outline in its own plane (metres), thickness, and target pose on the table."""

    outline: Outline
    thickness: float
    position: tuple[float, float] = (0.0, 0.0)
    yaw: float = 0.0

    def placed_outline(self) -> NDArray[np.float64]:
        """The outline's vertices (N, 2) turned by yaw and moved to position (the frame of position)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return self.outline.vertices @ np.array([[c, s], [-s, c]]) + np.asarray(self.position)

    def to_dict(self) -> dict:
        return {"outline": self.outline.vertices.tolist(), "thickness_m": self.thickness,
                "target": {"position": list(self.position), "yaw_rad": self.yaw}}


@dataclass(frozen=True)
class RobotOptions:
    """How the plan is executed by the UR5e and its gripper (the scene's `robot` section).

    base: 4x4 pose of the arm's base in the world (metres). palm_depth: from the UR
    flange to the gripper's palm (m). home: arm joint angles the approach starts
    from (rad). contact_speed: cap on the digit tips' speed along the primitives (m/s).
    termination: 'open' (open the gripper by termination_opening, m) or 'rotate'
    (turn the gripper about the thumb tip by termination_angle, rad). retreat_height:
    lift of the palm after termination (m). object_position: where G lies on the
    table (world x, y, m) for scenes without an outline (those with one use its target pose).
    """

    base: tuple = ((1.0, 0, 0, 0), (0, 1.0, 0, 0), (0, 0, 1.0, 0), (0, 0, 0, 1.0))
    palm_depth: float = 0.11
    home: tuple[float, ...] = (0.0, -math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0.0)
    contact_speed: float = 0.01
    termination: str = "open"
    termination_opening: float = 0.01
    termination_angle: float = math.radians(10.0)
    retreat_height: float = 0.05
    object_position: tuple[float, float] = (0.45, 0.10)
    object_yaw: float = 0.0


@dataclass(frozen=True)
class SimOptions:
    """How the scene is simulated in MuJoCo (the scene's `sim` section)."""

    density: float = 1250.0  #: the object's density (kg/m^3); 1250 is a stiff plastic (celluloid, PLA)
    grip_force: float = 5.0  #: the jaws' force limit (N): how hard the gripper squeezes
    squeeze: float = 0.001  #: how far inside the planned opening the jaws are commanded (m)
    timestep: float = 0.0005  #: simulation step (s)
    settle_time: float = 0.3  #: stillness with the object in the pinch before the motion (s)
    rest_time: float = 0.5  #: stillness after the retreat before the outcome is read (s)


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
    mu_contacts: tuple[float, float, float] | None = None  # friction at G, A, B before the plane reduces it
    max_tilt: float = math.radians(30.0)  # roll range of the prism simulation, rad
    robot: RobotOptions = field(default_factory=RobotOptions)
    solids: tuple = ()  # convex Solids fixed in the world (a layout's frame walls, pieces placed already)
    sim: SimOptions = field(default_factory=SimOptions)  # how the scene is simulated

    # -- loading -----------------------------------------------------------------
    @classmethod
    def from_file(cls, path: str | os.PathLike[str]) -> "Scene":
        """Load and validate a scene file; raises InputError naming the bad field."""
        data = read_yaml(path, "scene")
        return cls.from_dict(data, source=str(path), default_name=Path(path).stem)

    @classmethod
    def from_dict(cls, data: Any, source: str | None = None, default_name: str = "scene") -> "Scene":
        """Build a scene from the parsed YAML mapping; raises InputError on a bad field."""
        r = _Reader(source)
        top = r.mapping(data, "scene")
        r.known(top, "", {"name", "description", "object", "friction", "friction_angle_deg", "digits",
                          "obstacles", "start", "goal", "bounds", "planning", "contacts", "stability", "robot",
                          "sim"})
        name = r.name(top, "name", default_name)

        obj = r.mapping(r.require(top, "object"), "object")
        r.known(obj, "object", {"length", "thickness", "outline", "target"})
        thickness = r.length(obj, "object.thickness", "thickness", zero=True, default=0.0)
        mu_contacts = r.friction(top)
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
        else:
            if "contacts" in top:
                raise InputError("contacts", "needs object.outline", source)
            length = r.length(obj, "object.length", "length")
            mu = mu_contacts
        if thickness >= length:
            raise InputError("object.thickness", f"must be smaller than the object length ({length:.4g} m)", source)

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
            r.interval(bd, "bounds.d", "d", default=(0.0, 1.0)),
            r.interval(bd, "bounds.psi_deg", "psi_deg", default=(0.0, 120.0), degrees=True),
        ]).T
        if bounds[0, 0] < 0.0 or bounds[1, 0] > math.pi / 2 + 1e-12:
            raise InputError("bounds.theta_deg", "must lie within [0, 90]", source)
        if bounds[0, 1] < 0.0 or bounds[1, 1] > 1.0:
            raise InputError("bounds.d", "must lie within [0, 1] (over the object length)", source)
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
            d=r.interval(gl, "goal.d", "d", within=(0.0, 1.0), unit=" (over the object length)"),
            psi=(math.radians(goal_psi[0]), math.radians(goal_psi[1])),
            theta_min=bounds[0, 0],
        )
        glo, ghi = goal.box()
        if np.any(np.minimum(ghi, bounds[1]) < np.maximum(glo, bounds[0])):
            raise InputError("goal", "lies outside the bounds", source)

        pl = r.mapping(top.get("planning", {}), "planning")
        r.known(pl, "planning", {"sliding_model", "reverse_primitives", "resolution", "d_weight",
                                 "mode_change_penalty", "forbid_partial", "thumb_tip_margin"})
        margin = r.length(pl, "planning.thumb_tip_margin", "thumb_tip_margin", zero=True, default=0.0)
        if margin >= digits.thumb_length * length:
            raise InputError("planning.thumb_tip_margin", "must be shorter than the thumb", source)
        digits = replace(digits, thumb_tip_margin=margin / length, object_thickness=thickness / length)
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
            sliding_model=model,
            reverse_primitives=reverse,
            forbid_partial=forbid_partial,
            resolution=resolution,
            d_weight=r.number(pl, "planning.d_weight", "d_weight", positive=True, maximum=1e4, default=100.0),
            mode_change_penalty=r.number(pl, "planning.mode_change_penalty", "mode_change_penalty",
                                         minimum=0.0, maximum=1e4, default=1.0),
        )
        robot = r.robot(top.get("robot", {}))
        return cls(name, length, thickness, mu, digits, obstacles, start, goal, bounds, options, source,
                   object3d, plane, mu_contacts, max_tilt, robot, sim=r.sim(top.get("sim", {})))

    # -- queries -----------------------------------------------------------------
    def force_closure(self, q: ArrayLike, dq: ArrayLike | None = None) -> NDArray[np.bool_]:
        """Force closure of states q, shape (N, 3) (theta rad, d over l, psi rad).

        With dq (same shape: a velocity per state) each state is checked in the
        contact mode that velocity makes (sliding contacts push along the edge
        opposing their sliding); without it every contact sticks.
        """
        q = _states(q, "q")
        if dq is None:
            sa = sb = np.zeros(len(q), dtype=np.int8)
        else:
            dq = _states(dq, "dq")
            if dq.shape != q.shape:
                raise InputError("dq", f"must have the shape of q {q.shape}, got {dq.shape}")
            sa, sb = sliding_signs(q[:, 1], q[:, 2], dq[:, 1], dq[:, 2])
        return force_closure(q[:, 0], q[:, 1], q[:, 2], sa, sb, self.mu, self.options.sliding_model)

    def is_valid(self, q: ArrayLike) -> NDArray[np.bool_]:
        """States that can be held: kinematically valid, collision-free and force-closed with sticking contacts."""
        from .geometry.collision import CollisionChecker

        q = _states(q, "q")
        ok = kinematic_validity(q[:, 0], q[:, 1], q[:, 2], self.digits) & self.force_closure(q)
        ok[ok] = ~CollisionChecker(self).in_collision(q[ok])
        return ok

    def with_options(self, **changes: Any) -> "Scene":
        """A copy of the scene with some planning options replaced."""
        return replace(self, options=replace(self.options, **changes))


def read_yaml(path: str | os.PathLike[str], what: str) -> Any:
    """The parsed YAML of a file; InputError naming what (scene, layout) when it is missing or malformed."""
    path = Path(path)
    src = str(path)
    if not path.is_file():
        raise InputError(what, "no such file" if not path.exists() else "not a file", src)
    try:
        return yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark else ""
        raise InputError(what, f"not valid YAML{where}", src) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(what, f"cannot be read ({exc.__class__.__name__})", src) from None


def _states(q: ArrayLike, name: str) -> NDArray[np.float64]:
    a = np.asarray(q, dtype=float)
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != 3:
        raise InputError(name, f"must have shape (N, 3) as (theta, d, psi), got {np.shape(q)}")
    return a


class _Reader:
    """Typed field access that raises InputError naming the field."""

    def __init__(self, source: str | None):
        self.source = source

    def fail(self, key: str, reason: str) -> None:
        raise InputError(key, reason, self.source)

    def mapping(self, value: Any, key: str) -> dict:
        if value is None:
            return {}
        if not isinstance(value, dict):
            self.fail(key, f"must be a mapping, got {type(value).__name__}")
        return value

    def require(self, m: dict, key: str) -> Any:
        if key not in m:
            self.fail(key, "is missing")
        return m[key]

    def known(self, m: dict, prefix: str, keys: set[str]) -> None:
        for k in m:
            if k not in keys:
                self.fail(f"{prefix}.{k}" if prefix else str(k), f"unknown field (expected one of: {', '.join(sorted(keys))})")

    def number(self, m: dict, key: str, k: str, *, positive: bool = False, minimum: float | None = None,
               default: float | None = None, maximum: float | None = None, unit: str = "") -> float:
        """A finite number, at most MAX_MAGNITUDE in size; minimum and maximum are inclusive bounds."""
        if k not in m:
            if default is None:
                self.fail(key, "is missing")
            return default
        v = m[k]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.fail(key, f"must be a number, got {v!r}")
        try:
            v = float(v)
        except OverflowError:  # an integer too large for a float
            self.fail(key, f"must be a number of magnitude at most {MAX_MAGNITUDE:g}, got {v:.6g}")
        if not math.isfinite(v):
            self.fail(key, f"must be finite, got {v}")
        if positive and v <= 0:
            self.fail(key, f"must be > 0, got {v:g}")
        if minimum is not None and v < minimum:
            self.fail(key, f"must be >= {minimum:g}{unit}, got {v:g}")
        if maximum is not None and v > maximum:
            self.fail(key, f"must be at most {maximum:g}{unit}, got {v:g}")
        if abs(v) > MAX_MAGNITUDE:
            self.fail(key, f"is absurdly large ({v:g}; no field goes beyond {MAX_MAGNITUDE:g})")
        return v

    def length(self, m: dict, key: str, k: str, *, default: float | None = None, zero: bool = False) -> float:
        """A length in metres: > 0 (>= 0 with zero) and at most MAX_LENGTH."""
        return self.number(m, key, k, positive=not zero, minimum=0.0 if zero else None, default=default,
                           maximum=MAX_LENGTH, unit=" m")

    def angle(self, m: dict, key: str, k: str, lo: float, hi: float, *, default: float | None = None) -> float:
        """An angle in degrees within [lo, hi]."""
        return self.number(m, key, k, minimum=lo, maximum=hi, default=default, unit=" deg")

    def interval(self, m: dict, key: str, k: str, *, default: tuple[float, float] | None = None,
                 degrees: bool = False, within: tuple[float, float] | None = None,
                 unit: str = "") -> tuple[float, float]:
        """A [low, high] pair, low <= high, both within the closed range within when given."""
        if k not in m and default is not None:
            lo, hi = default
        else:
            v = self.require(m, k) if default is None else m[k]
            if not isinstance(v, (list, tuple)) or len(v) != 2:
                self.fail(key, f"must be a [low, high] pair, got {v!r}")
            a, b = within if within is not None else (None, None)
            lo, hi = (self.number({0: x}, key, 0, minimum=a, maximum=b, unit=unit) for x in v)
            if lo > hi:
                self.fail(key, f"low {lo:g} exceeds high {hi:g}")
        if degrees:
            lo, hi = math.radians(lo), math.radians(hi)
        return lo, hi

    def friction(self, top: dict) -> tuple[float, float, float]:
        if ("friction" in top) == ("friction_angle_deg" in top):
            self.fail("friction", "give exactly one of friction (coefficients) or friction_angle_deg")
        key = "friction" if "friction" in top else "friction_angle_deg"
        f = self.mapping(top[key], key)
        self.known(f, key, {"G", "A", "B"})
        out = []
        for c in "GAB":
            v = self.number(f, f"{key}.{c}", c)
            if key == "friction":
                if not 0 <= v <= MAX_FRICTION:
                    self.fail(f"{key}.{c}", f"must lie in [0, {MAX_FRICTION:g}] (a friction coefficient), got {v:g}")
                out.append(v)
            else:
                if not 0 <= v < 90:
                    self.fail(f"{key}.{c}", f"must lie in [0, 90) degrees, got {v:g}")
                out.append(math.tan(math.radians(v)))
        return tuple(out)

    def obstacles(self, value: Any) -> list[Box]:
        if not isinstance(value, list):
            self.fail("obstacles", f"must be a list, got {type(value).__name__}")
        boxes = []
        for i, item in enumerate(value):
            key = f"obstacles[{i}]"
            o = self.mapping(item, key)
            name = self.name(o, f"{key}.name", f"obstacle{i}")
            if "corner" in o:
                # A corner point and the quadrant the obstacle fills, as the
                # reference planner describes its upper obstacle.
                self.known(o, key, {"name", "corner", "extends"})
                x, z = self.pair(o, f"{key}.corner", "corner")
                sx, sz = self.pair(o, f"{key}.extends", "extends")
                if sx not in (-1, 1) or sz not in (-1, 1):
                    self.fail(f"{key}.extends", "must be [+-1, +-1]: the quadrant the obstacle fills from its corner")
                far = 100.0
                xs, zs = sorted((x, x + sx * far)), sorted((z, z + sz * far))
                boxes.append(Box(name, (xs[0], zs[0]), (xs[1], zs[1])))
            else:
                self.known(o, key, {"name", "center", "size"})
                cx, cz = self.pair(o, f"{key}.center", "center")
                sx, sz = self.pair(o, f"{key}.size", "size")
                if sx <= 0 or sz <= 0:
                    self.fail(f"{key}.size", "must be positive")
                boxes.append(Box(name, (cx - sx / 2, cz - sz / 2), (cx + sx / 2, cz + sz / 2)))
        return boxes

    def robot(self, value: Any) -> RobotOptions:
        m = self.mapping(value, "robot")
        self.known(m, "robot", {"base", "palm_depth", "home_deg", "contact_speed", "termination",
                                "termination_opening", "termination_angle_deg", "retreat_height", "object"})
        d = RobotOptions()
        base = d.base
        if "base" in m:
            b = self.mapping(m["base"], "robot.base")
            self.known(b, "robot.base", {"position", "yaw_deg"})
            pos = b.get("position", [0.0, 0.0, 0.0])
            if not isinstance(pos, list) or len(pos) != 3:
                self.fail("robot.base.position", f"must be [x, y, z] in metres, got {pos!r}")
            x, y, z = (self.number({0: v}, "robot.base.position", 0, minimum=-MAX_LENGTH, maximum=MAX_LENGTH,
                                   unit=" m") for v in pos)
            yaw = math.radians(self.angle(b, "robot.base.yaw_deg", "yaw_deg", -360.0, 360.0, default=0.0))
            c, s_ = math.cos(yaw), math.sin(yaw)
            base = ((c, -s_, 0.0, x), (s_, c, 0.0, y), (0.0, 0.0, 1.0, z), (0.0, 0.0, 0.0, 1.0))
        home = d.home
        if "home_deg" in m:
            h = m["home_deg"]
            if not isinstance(h, list) or len(h) != 6:
                self.fail("robot.home_deg", f"must list 6 joint angles in degrees, got {h!r}")
            home = tuple(math.radians(self.angle({0: v}, "robot.home_deg", 0, -360.0, 360.0)) for v in h)
        term = m.get("termination", d.termination)
        if term not in ("open", "rotate"):
            self.fail("robot.termination", f"must be open or rotate, got {term!r}")
        obj_pos, obj_yaw = d.object_position, d.object_yaw
        if "object" in m:
            o = self.mapping(m["object"], "robot.object")
            self.known(o, "robot.object", {"position", "yaw_deg"})
            obj_pos = self.pair(o, "robot.object.position", "position") if "position" in o else obj_pos
            obj_yaw = math.radians(self.angle(o, "robot.object.yaw_deg", "yaw_deg", -360.0, 360.0, default=0.0))
        return RobotOptions(
            base=base,
            palm_depth=self.length(m, "robot.palm_depth", "palm_depth", default=d.palm_depth),
            home=home,
            contact_speed=self.number(m, "robot.contact_speed", "contact_speed", positive=True, maximum=1.0,
                                      default=d.contact_speed, unit=" m/s"),
            termination=term,
            termination_opening=self.length(m, "robot.termination_opening", "termination_opening",
                                            default=d.termination_opening),
            termination_angle=math.radians(self.number(m, "robot.termination_angle_deg", "termination_angle_deg",
                                                       positive=True, maximum=90.0, unit=" deg",
                                                       default=math.degrees(d.termination_angle))),
            retreat_height=self.length(m, "robot.retreat_height", "retreat_height", zero=True, default=d.retreat_height),
            object_position=obj_pos,
            object_yaw=obj_yaw,
        )

    def sim(self, value: Any) -> SimOptions:
        m = self.mapping(value, "sim")
        d = SimOptions()
        self.known(m, "sim", set(d.__dataclass_fields__))
        out = {k: self.number(m, f"sim.{k}", k, positive=True, default=getattr(d, k)) for k in m}
        if out.get("density", d.density) > 25000:
            self.fail("sim.density", f"must be at most 25000 kg/m^3 (denser than any solid), got {out['density']:g}")
        if out.get("timestep", d.timestep) > 0.002:
            self.fail("sim.timestep", f"must be at most 0.002 s (the control period), got {out['timestep']:g}")
        if out.get("grip_force", d.grip_force) > 170:
            self.fail("sim.grip_force", f"must be at most 170 N (the gripper's rating), got {out['grip_force']:g}")
        for k in ("squeeze", "settle_time", "rest_time"):
            if out.get(k, 0.0) > (0.01 if k == "squeeze" else 10.0):
                self.fail(f"sim.{k}", f"is absurdly large ({out[k]:g})")
        return SimOptions(**{**{k: getattr(d, k) for k in d.__dataclass_fields__}, **out})

    def flag(self, m: dict, key: str, k: str) -> bool:
        v = m.get(k, False)
        if not isinstance(v, bool):
            self.fail(key, f"must be true or false, got {v!r}")
        return v

    def points(self, value: Any, key: str) -> list:
        if not isinstance(value, list) or not value:
            self.fail(key, "must be a list of [x, y] points")
        return [self.pair({0: p}, f"{key}[{i}]", 0) for i, p in enumerate(value)]

    def object3d(self, outline: Any, target: Any, thickness: float, prefix: str = "object") -> Object3D:
        """An outline and its target pose, the fields named under prefix (object, or pieces[i] of a layout)."""
        spec = self.mapping(outline, f"{prefix}.outline")
        shapes = {"polygon", "rounded_polygon", "ellipse", "circle", "curve"}
        self.known(spec, f"{prefix}.outline", shapes)
        if len(spec) != 1:
            self.fail(f"{prefix}.outline", f"give exactly one of: {', '.join(sorted(shapes))}")
        (kind, value), = spec.items()
        key = f"{prefix}.outline.{kind}"
        try:
            if kind == "polygon":
                outline = polygon(self.points(value, key))
            elif kind == "curve":  # a smooth closed curve given by its samples
                outline = Outline.make(self.points(value, key), smooth=True)
            elif kind == "rounded_polygon":
                m = self.mapping(value, key)
                self.known(m, key, {"vertices", "radius"})
                radius = m.get("radius")
                radii = [self.length({0: x}, f"{key}.radius", 0, zero=True) for x in
                         (radius if isinstance(radius, list) else [self.require(m, "radius")])]
                vertices = self.points(self.require(m, "vertices"), f"{key}.vertices")
                if len(radii) not in (1, len(vertices)):
                    self.fail(f"{key}.radius", f"must be one radius or one per vertex ({len(vertices)}), "
                              f"got {len(radii)}")
                outline = rounded_polygon(vertices, radii if len(radii) > 1 else radii[0])
            elif kind == "ellipse":
                m = self.mapping(value, key)
                self.known(m, key, {"a", "b"})
                outline = ellipse(self.length(m, f"{key}.a", "a"), self.length(m, f"{key}.b", "b"))
            else:
                m = self.mapping(value, key)
                self.known(m, key, {"radius"})
                rad = self.length(m, f"{key}.radius", "radius")
                outline = ellipse(rad, rad)
        except OutlineError as exc:
            self.fail(key, str(exc))
        tg = self.mapping(target, f"{prefix}.target")
        self.known(tg, f"{prefix}.target", {"position", "yaw_deg"})
        position = self.pair(tg, f"{prefix}.target.position", "position") if "position" in tg else (0.0, 0.0)
        yaw = math.radians(self.angle(tg, f"{prefix}.target.yaw_deg", "yaw_deg", -360.0, 360.0, default=0.0))
        return Object3D(outline, thickness, position, yaw)

    def pair(self, m: dict, key: str, k: str) -> tuple[float, float]:
        """Two coordinates in metres, each within +-MAX_LENGTH."""
        v = self.require(m, k)
        if not isinstance(v, (list, tuple)) or len(v) != 2:
            self.fail(key, f"must be an [x, z] pair, got {v!r}")
        return tuple(self.number({0: x}, key, 0, minimum=-MAX_LENGTH, maximum=MAX_LENGTH, unit=" m") for x in v)

    def name(self, m: dict, key: str, default: str) -> str:
        """A name: a string or a number, usable in a file name and a picture's title (no path
        separator, control character or $, which starts a formula in matplotlib)."""
        v = m.get("name", default)
        if isinstance(v, bool) or not isinstance(v, (str, int, float)):
            self.fail(key, f"must be a string, got {v!r}")
        v = str(v)
        if not v.strip() or any(c in v for c in "/\\$") or any(ord(c) < 32 for c in v):
            self.fail(key, f"must be a non-empty name without /, \\, $ or control characters, got {v!r}")
        return v
