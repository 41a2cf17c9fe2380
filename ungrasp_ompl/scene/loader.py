"""Reading scene and layout files: the YAML, and typed access to its fields.

SceneReader is shared by scene_fields (Scene.from_dict) and Layout.from_dict: every value is
checked where it is read (type, finiteness, range, unit) and a bad one raises
InputError naming its dotted key and the reason. A person types degrees in keys
ending ``_deg``; the reader returns radians where the docstring says so.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from dataclasses import dataclass, replace
from enum import StrEnum
from typing import Any

import numpy as np
import yaml

from ..errors import InputError, UnknownFieldError
from ..geometry.collision import Box
from ..geometry.outline import Outline, OutlineError, ellipse, polygon, rounded_polygon
from ..geometry.plane import ManipulationPlane, choose_plane
from ..io import parse_yaml
from ..mechanics import DigitGeometry
from ..mechanics.force_closure import SLIDING_MODELS, SlidingModel
from ..mechanics.pincer import PincerSpec, check_pincer
from ..mechanics.section import SECTION_KINDS, Section, SectionError
from .options import (GoalSpec, GripperKind, Landing, Object3D, Objective, PlanningOptions, Release, RobotOptions,
                      SimOptions, Termination)

#: Longest length and farthest coordinate a scene may give, m: beyond it a value is a typo.
MAX_LENGTH = 10.0
#: Largest friction coefficient a scene may give: beyond it a value is a typo.
MAX_FRICTION = 10.0
#: Largest magnitude of any number in a scene: no field means anything beyond it.
MAX_MAGNITUDE = 1e6
#: Largest landing offset a scene may give (m): a release that lands a centimetre from where the
#: model of the fall puts it is not one an offset should correct, and millimetres typed as metres
#: are caught.
MAX_LANDING_OFFSET = 0.01
#: Largest joint torque a pincer may give, N m: a hand-sized gripper's motor, beyond it a typo.
MAX_TORQUE = 100.0


def read_yaml(path: str | os.PathLike[str], what: str) -> Any:
    """The parsed YAML of a file; InputError naming what (scene, layout) when it is missing or malformed."""
    src = str(path)
    try:
        return parse_yaml(read_yaml_text(path, what))
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark else ""
        raise InputError(what, f"not valid YAML{where}", src) from None


def read_yaml_text(path: str | os.PathLike[str], what: str) -> str:
    """The text of a YAML file, as it is (comments included); InputError naming what (scene, layout)
    when it is missing or cannot be read."""
    path = Path(path)
    src = str(path)
    if not path.is_file():
        raise InputError(what, "no such file" if not path.exists() else "not a file", src)
    try:
        return path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(what, f"cannot be read ({exc.__class__.__name__})", src) from None


class SceneReader:
    """Typed access to the fields of a parsed scene or layout file: each method returns a checked
    value or raises InputError naming the field (its dotted key) and the reason."""

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
                raise UnknownFieldError(f"{prefix}.{k}" if prefix else str(k), tuple(sorted(keys)), self.source)

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

    def friction(self, top: dict) -> tuple[tuple[float, float, float], float]:
        """The contacts' friction coefficients at G, A, B (from friction, or the tangents of
        friction_angle_deg) and how far they are known: the uncertainty, a fraction of each
        coefficient either way in [0, 1) (0 when not given: known exactly)."""
        if ("friction" in top) == ("friction_angle_deg" in top):
            self.fail("friction", "give exactly one of friction (coefficients) or friction_angle_deg")
        key = "friction" if "friction" in top else "friction_angle_deg"
        f = self.mapping(top[key], key)
        self.known(f, key, {"G", "A", "B", "uncertainty"})
        uncertainty = self.number(f, f"{key}.uncertainty", "uncertainty", minimum=0.0, default=0.0,
                                  unit=" (a fraction of each coefficient)")
        if uncertainty >= 1.0:
            self.fail(f"{key}.uncertainty", f"must be below 1 (a fraction of each coefficient, either way), "
                      f"got {uncertainty:g}")
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
        return tuple(out), uncertainty

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
                                "termination_opening", "termination_angle_deg", "retreat_height", "start_press",
                                "end_press", "touch_off", "landing", "landing_offset", "landing_pairs", "object",
                                "gripper"})
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
        if term not in tuple(Termination):
            self.fail("robot.termination", f"must be one of {', '.join(Termination)}, got {term!r}")
        landing = m.get("landing", d.landing)
        if landing not in tuple(Landing):
            self.fail("robot.landing", f"must be one of {', '.join(Landing)}, got {landing!r}")
        if landing == Landing.MODELLED and term == Termination.ROTATE:
            self.fail("robot.landing", "modelled needs an opening termination (open, open_symmetric or open_lift): "
                      "the model of the fall has no turn about the thumb's tip")
        offset = self.number(m, "robot.landing_offset", "landing_offset", minimum=-MAX_LANDING_OFFSET,
                             maximum=MAX_LANDING_OFFSET, unit=" m", default=d.landing_offset)
        if offset and landing != Landing.MODELLED:
            self.fail("robot.landing_offset", f"only with landing modelled (got landing {landing}): the other "
                      "aims measure the whole landing, so an offset on top would count it twice")
        pairs = m.get("landing_pairs", d.landing_pairs)
        if isinstance(pairs, bool) or not isinstance(pairs, int) or not 1 <= pairs <= 64:
            self.fail("robot.landing_pairs", f"must be a whole number from 1 to 64, got {pairs!r}")
        obj_pos, obj_yaw = d.object_position, d.object_yaw
        if "object" in m:
            o = self.mapping(m["object"], "robot.object")
            self.known(o, "robot.object", {"position", "yaw_deg"})
            obj_pos = self.pair(o, "robot.object.position", "position") if "position" in o else obj_pos
            obj_yaw = math.radians(self.angle(o, "robot.object.yaw_deg", "yaw_deg", -360.0, 360.0, default=0.0))
        gripper = self.gripper(m.get("gripper"))
        if gripper is not None:
            self.pincer_limits(m, term)
        start_press = self.length(m, "robot.start_press", "start_press", zero=True, default=d.start_press)
        end_press = self.length(m, "robot.end_press", "end_press", zero=True) if "end_press" in m else None
        if end_press is not None and end_press > start_press:
            self.fail("robot.end_press", f"must not exceed robot.start_press ({start_press:g} m): the press is only "
                      f"let out, got {end_press:g}")
        return RobotOptions(
            base=base,
            palm_depth=self.length(m, "robot.palm_depth", "palm_depth", default=d.palm_depth),
            home=home,
            contact_speed=self.number(m, "robot.contact_speed", "contact_speed", positive=True, maximum=1.0,
                                      default=d.contact_speed, unit=" m/s"),
            termination=Termination(term),
            termination_opening=self.length(m, "robot.termination_opening", "termination_opening",
                                            default=d.termination_opening),
            termination_angle=math.radians(self.number(m, "robot.termination_angle_deg", "termination_angle_deg",
                                                       positive=True, maximum=90.0, unit=" deg",
                                                       default=math.degrees(d.termination_angle))),
            retreat_height=self.length(m, "robot.retreat_height", "retreat_height", zero=True, default=d.retreat_height),
            start_press=start_press,
            end_press=end_press,
            touch_off=self.flag(m, "robot.touch_off", "touch_off"),
            landing=Landing(landing),
            landing_offset=offset,
            landing_pairs=pairs,
            object_position=obj_pos,
            object_yaw=obj_yaw,
            gripper=gripper,
        )

    def gripper(self, value: Any) -> PincerSpec | None:
        """robot.gripper: None for the parallel jaws (kind parallel, the default, no other field), or
        the pincer's joint (kind pincer: joint_radius and joint_offset in m, joint_torque in N m,
        max_angle_deg in degrees, default 90)."""
        m = self.mapping(value, "robot.gripper")
        kind = m.get("kind", GripperKind.PARALLEL.value)
        if kind not in tuple(GripperKind):
            self.fail("robot.gripper.kind", f"must be one of {', '.join(GripperKind)}, got {kind!r}")
        if kind == GripperKind.PARALLEL:
            self.known(m, "robot.gripper", {"kind"})
            return None
        self.known(m, "robot.gripper", {"kind", "joint_radius", "joint_offset", "joint_torque", "max_angle_deg"})
        radius = self.length(m, "robot.gripper.joint_radius", "joint_radius")
        offset = self.number(m, "robot.gripper.joint_offset", "joint_offset", minimum=-radius, maximum=radius,
                             unit=" m (within the joint radius either way)")
        if abs(offset) >= radius:
            self.fail("robot.gripper.joint_offset", f"must lie strictly within the joint radius ({radius:g} m), "
                      f"got {offset:g}")
        torque = self.number(m, "robot.gripper.joint_torque", "joint_torque", positive=True, maximum=MAX_TORQUE,
                             unit=" N m")
        angle = self.number(m, "robot.gripper.max_angle_deg", "max_angle_deg", positive=True, maximum=180.0,
                            default=90.0, unit=" deg")
        return PincerSpec(joint_radius=radius, joint_offset=offset, joint_torque=torque,
                          max_angle=math.radians(angle))

    def pincer_limits(self, m: dict, termination: str) -> None:
        """What a pincer's robot section may not ask for: the release open_lift moves the digits as
        parallel jaws part; InputError naming the field. The landing modelled it may ask for with an opening termination, as the
        parallel gripper may: the model of the fall turns a pincer's digits about its joint
        (mechanics.release.pincer_hand)."""
        if termination == Termination.OPEN_LIFT:
            self.fail("robot.termination", "open_lift needs the parallel gripper (kind parallel): a pincer lets go "
                      "by open, open_symmetric or rotate")

    def sim(self, value: Any) -> SimOptions:
        m = self.mapping(value, "sim")
        d = SimOptions()
        self.known(m, "sim", set(d.__dataclass_fields__))
        out = {k: self.flag(m, f"sim.{k}", k) if isinstance(getattr(d, k), bool)
               else self.number(m, f"sim.{k}", k, positive=True, default=getattr(d, k)) for k in m}
        if out.get("density", d.density) > 25000:
            self.fail("sim.density", f"must be at most 25000 kg/m^3 (denser than any solid), got {out['density']:g}")
        for k in ("timestep", "pyramidal_timestep"):
            if out.get(k, getattr(d, k)) > 0.002:
                self.fail(f"sim.{k}", f"must be at most 0.002 s (the control period), got {out[k]:g}")
        if out.get("grip_force", d.grip_force) > 170:
            self.fail("sim.grip_force", f"must be at most 170 N (the gripper's rating), got {out['grip_force']:g}")
        for k in ("squeeze", "settle_time", "rest_time", "max_error"):
            if out.get(k, 0.0) > (0.01 if k == "squeeze" else 0.05 if k == "max_error" else 10.0):
                self.fail(f"sim.{k}", f"is absurdly large ({out[k]:g})")
        return SimOptions(**{**{k: getattr(d, k) for k in d.__dataclass_fields__}, **out})

    def objective(self, planning: dict) -> Objective:
        """planning.objective: one of the objectives' names (Objective), cost by default."""
        return self.choice(planning, "planning.objective", "objective", Objective, Objective.COST)

    def choice(self, m: dict, key: str, k: str, kind: type[StrEnum], default: StrEnum) -> StrEnum:
        """m[k]: one of the names of the StrEnum kind (default when absent), else an error naming key."""
        name = m.get(k, default.value)
        if name not in tuple(kind):
            self.fail(key, f"must be one of {', '.join(kind)}, got {name!r}")
        return kind(name)

    def margin_weight(self, planning: dict) -> float:
        """planning.margin_weight: the balanced objective's weight (cost x deg), in [0, 1e4]."""
        return self.number(planning, "planning.margin_weight", "margin_weight", minimum=0.0, maximum=1e4, default=1.0,
                           unit=" (cost x deg)")

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

    def section(self, obj: dict, thickness: float, length: float) -> Section | None:
        """object.section, over the object length: None for a slab (the default, or ``slab``);
        ``semi_ellipse``, ``lens`` or ``rounded_rim`` (a name, or a mapping of it to its fields: a
        lens's ``bottom``, m below GB, half the thickness unless given; a rounded rim's ``radius``, m,
        half the thickness unless given) on object.thickness; or
        ``profile`` with ``points`` ([x, z] in m from G's end, x = 0, to B's end, x = the object
        length; the top's heights above GB) and ``smoothing`` (m: how far, root mean square, the
        spline may pass from them; 0, the default, through them)."""
        if "section" not in obj:
            return None
        value, key = obj["section"], "object.section"
        if isinstance(value, str):
            kind, spec = value, {}
        elif isinstance(value, dict):
            self.known(value, key, set(SECTION_KINDS))
            if len(value) != 1:
                self.fail(key, f"give exactly one of: {', '.join(SECTION_KINDS)}")
            (kind, spec), = value.items()
            spec = self.mapping(spec, f"{key}.{kind}")
        else:
            self.fail(key, f"must be one of {', '.join(SECTION_KINDS)} or a mapping of one to its fields, got {value!r}")
        if kind not in SECTION_KINDS:
            self.fail(key, f"must be one of {', '.join(SECTION_KINDS)}, got {kind!r}")
        sub = f"{key}.{kind}"
        if kind in ("slab", "semi_ellipse"):
            self.known(spec, sub, set())
        if kind in ("semi_ellipse", "lens", "rounded_rim") and thickness <= 0.0:
            self.fail("object.thickness", f"must be > 0 for a {kind} section (it sets the section's height)")
        try:
            if kind == "slab":
                return None
            if kind == "semi_ellipse":
                return Section.semi_ellipse(thickness / length)
            if kind == "lens":
                self.known(spec, sub, {"bottom"})
                bottom = self.length(spec, f"{sub}.bottom", "bottom", zero=True, default=thickness / 2)
                if bottom >= thickness:
                    self.fail(f"{sub}.bottom", f"must be smaller than object.thickness ({thickness:g} m), got {bottom:g}")
                return Section.lens(thickness / length, bottom / length)
            if kind == "rounded_rim":
                self.known(spec, sub, {"radius"})
                radius = self.length(spec, f"{sub}.radius", "radius", default=thickness / 2)
                if radius > thickness or radius > length / 2:
                    self.fail(f"{sub}.radius", f"must be at most object.thickness ({thickness:g} m) and half the "
                              f"object length, got {radius:g}")
                return Section.rounded_rim(thickness / length, radius / length)
            self.known(spec, sub, {"points", "smoothing"})
            pts = np.array(self.points(self.require(spec, "points"), f"{sub}.points"))
            smoothing = self.length(spec, f"{sub}.smoothing", "smoothing", zero=True, default=0.0)
            if len(pts) < 4:
                self.fail(f"{sub}.points", f"must give at least 4 points, got {len(pts)}")
            if abs(pts[0, 0]) > 1e-6 or abs(pts[-1, 0] - length) > 0.01 * length:
                self.fail(f"{sub}.points", f"must run from G's end (x = 0) to B's end (x = the object length "
                          f"{length:.6g} m), got x from {pts[0, 0]:.6g} to {pts[-1, 0]:.6g} m")
            scaled = np.column_stack([(pts[:, 0] - pts[0, 0]) / (pts[-1, 0] - pts[0, 0]), pts[:, 1] / length])
            section = Section.profile(scaled, (smoothing / length) ** 2)
        except SectionError as exc:
            self.fail(sub, str(exc))
        height = section.thickness * length
        if thickness > 0.0 and abs(height - thickness) > 1e-6 + 0.01 * thickness:
            self.fail("object.thickness", f"must be the profile's height ({height:.6g} m) or be left out, got "
                      f"{thickness:g}")
        return section

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


# -- a scene file, step by step ------------------------------------------------------------------
#: The top-level keys of a scene file.
SCENE_KEYS = {"name", "description", "object", "friction", "friction_angle_deg", "digits", "obstacles", "start",
              "goal", "bounds", "planning", "contacts", "stability", "robot", "sim", "planar_only"}
#: The gripper housing's extent normal to the manipulation plane when a scene does not give it, m.
DEFAULT_PALM_THICKNESS = 0.06
#: Most lattice states planning.resolution may make over the bounds (memory and time stay bounded).
MAX_LATTICE_STATES = 25_000_000


@dataclass(frozen=True)
class _ObjectPart:
    """What the object block and the friction make of a scene: the object's size, its 3D outline and
    manipulation plane (with an outline), its section, and the friction at G, A, B."""

    length: float  #: l = |GB|, m
    thickness: float  #: m (a curved section's height)
    mu: tuple[float, float, float]  #: the plane's coefficients at G, A, B
    mu_contacts: tuple[float, float, float]  #: the contacts' own coefficients at G, A, B
    uncertainty: float  #: the friction's uncertainty, a fraction either way
    object3d: Object3D | None
    plane: ManipulationPlane | None
    section: Section | None  #: None: a slab
    d_max: float  #: the slide coordinate's reach, over l


def scene_fields(data: Any, source: str | None = None, default_name: str = "scene") -> dict[str, Any]:
    """The fields of a Scene from a scene file's parsed mapping, each read and checked in turn (the
    object and friction, the digits, where it starts and ends, the planning options, the robot);
    InputError naming the first bad field."""
    r = SceneReader(source)
    top = r.mapping(data, "scene")
    r.known(top, "", SCENE_KEYS)
    name = r.name(top, "name", default_name)
    part = _object_part(r, top)
    digits, width = _digits(r, top, part)
    obstacles = r.obstacles(top.get("obstacles", []))
    start, bounds, goal = _start_bounds_goal(r, top, part)
    options, digits, clearance = _planning(r, top, part, digits, bounds, width)
    robot = r.robot(top.get("robot", {}))
    if robot.gripper is not None and part.section is not None:
        raise InputError("object.section", "needs the parallel gripper (robot.gripper kind parallel): the pincer's "
                         "kinematics place its finger on a slab", source)
    if robot.gripper is not None:  # a pincer's joint must carry these digits (mechanics.pincer)
        check_pincer(robot.gripper, digits, part.length, source)
    if robot.start_press > clearance:
        raise InputError("robot.start_press", f"must not exceed planning.table_clearance ({clearance:g} m): "
                         "the pressed digits would run into the table", source)
    digits = replace(digits, press=robot.start_press / part.length)
    planar_only = top.get("planar_only")
    if planar_only is not None and not (isinstance(planar_only, str) and planar_only.strip()):
        raise InputError("planar_only", f"must say why the robot cannot execute the scene, got {planar_only!r}",
                         source)
    stab = r.mapping(top.get("stability", {}), "stability")
    r.known(stab, "stability", {"max_tilt_deg"})
    max_tilt = math.radians(r.angle(stab, "stability.max_tilt_deg", "max_tilt_deg", 1.0, 90.0, default=30.0))
    return dict(name=name, object_length=part.length, object_thickness=part.thickness, mu=part.mu, digits=digits,
                obstacles=obstacles, start=start, goal=goal, bounds=bounds,
                options=options, source=source, object3d=part.object3d, plane=part.plane,
                mu_contacts=part.mu_contacts, max_tilt=max_tilt, robot=robot, sim=r.sim(top.get("sim", {})),
                planar_only=planar_only and planar_only.strip(), friction_uncertainty=part.uncertainty)


def _object_part(r: SceneReader, top: dict) -> _ObjectPart:
    """The object block with the friction: its outline and plane, or its length; its section."""
    source = r.source
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
    return _ObjectPart(length, thickness, tuple(mu), tuple(mu_contacts), uncertainty, object3d, plane, section, d_max)


def _digits(r: SceneReader, top: dict, part: _ObjectPart) -> tuple[DigitGeometry, float]:
    """The digits block, over l, and the digits' width over l."""
    source, length, thickness = r.source, part.length, part.thickness
    dig = r.mapping(r.require(top, "digits"), "digits")
    r.known(dig, "digits", {"alpha", "thumb_length", "finger_length", "thumb_tip_thickness",
                            "thumb_base_thickness", "finger_tip_thickness", "finger_base_thickness",
                            "width", "max_aperture", "finger_tip", "finger_tip_radius", "palm_width",
                            "palm_length", "palm_thickness"})
    lengths = {key: r.length(dig, f"digits.{key}", key) / length
               for key in ("thumb_length", "thumb_tip_thickness", "thumb_base_thickness",
                           "finger_tip_thickness", "finger_base_thickness", "width")}
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
        raise InputError("digits.finger_tip", f"must be rounded (point contact at A) or flat (edge contact), got "
                         f"{finger_tip!r}", source)
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
    return digits, lengths["width"]


def _start_bounds_goal(r: SceneReader, top: dict, part: _ObjectPart) -> tuple[np.ndarray, np.ndarray, GoalSpec]:
    """The start state (rad, over l, rad), the bounds (2, 3) and the goal region, each within the bounds."""
    source, d_max = r.source, part.d_max
    st = r.mapping(r.require(top, "start"), "start")
    r.known(st, "start", {"theta_deg", "d", "psi_deg"})
    start = np.array([math.radians(r.number(st, "start.theta_deg", "theta_deg")), r.number(st, "start.d", "d"),
                      math.radians(r.number(st, "start.psi_deg", "psi_deg"))])
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
        raise InputError("bounds.d", "must lie within [0, 1] (over the object length)" if part.section is None else
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
    goal = GoalSpec(theta_max=min(theta_max, bounds[1, 0]),
                    d=r.interval(gl, "goal.d", "d", within=(0.0, d_max), unit=" (over the object length)"),
                    psi=(math.radians(goal_psi[0]), math.radians(goal_psi[1])), theta_min=bounds[0, 0])
    glo, ghi = goal.box()
    if np.any(np.minimum(ghi, bounds[1]) < np.maximum(glo, bounds[0])):
        raise InputError("goal", "lies outside the bounds", source)
    return start, bounds, goal


def _planning(r: SceneReader, top: dict, part: _ObjectPart, digits: DigitGeometry, bounds: np.ndarray,
              width: float) -> tuple[PlanningOptions, DigitGeometry, float]:
    """The planning block: its options, the digits with their margins and the object's section, and
    the table clearance (m)."""
    source, length = r.source, part.length
    pl = r.mapping(top.get("planning", {}), "planning")
    r.known(pl, "planning", {"sliding_model", "reverse_primitives", "resolution", "d_weight",
                             "mode_change_penalty", "forbid_partial", "thumb_tip_margin", "margin_weight",
                             "min_tolerance", "table_clearance", "across_margin", "max_landing_spread", "range",
                             "objective", "release"})
    margin = r.length(pl, "planning.thumb_tip_margin", "thumb_tip_margin", zero=True, default=0.0)
    if margin >= digits.thumb_length * length:
        raise InputError("planning.thumb_tip_margin", "must be shorter than the thumb", source)
    clearance = r.length(pl, "planning.table_clearance", "table_clearance", zero=True, default=0.0)
    across = r.length(pl, "planning.across_margin", "across_margin", zero=True, default=0.0)
    plane = part.plane
    support = (0.0, 0.0) if plane is None else (min(plane.g.span) / length, min(min(plane.b.span) / length, width / 2))
    digits = replace(digits, thumb_tip_margin=margin / length, table_clearance=clearance / length,
                     object_thickness=part.thickness / length, support=support, across_margin=across / length,
                     section=part.section)
    model = pl.get("sliding_model", "relaxed")
    if model not in SLIDING_MODELS:
        raise InputError("planning.sliding_model", f"must be one of {', '.join(SLIDING_MODELS)}, got {model!r}", source)
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
        reverse_primitives=r.flag(pl, "planning.reverse_primitives", "reverse_primitives"),
        forbid_partial=r.flag(pl, "planning.forbid_partial", "forbid_partial"),
        margin_weight=r.margin_weight(pl),
        min_tolerance=r.number(pl, "planning.min_tolerance", "min_tolerance", minimum=0.0, maximum=5.0, default=0.0),
        max_landing_spread=(r.length(pl, "planning.max_landing_spread", "max_landing_spread")
                            if "max_landing_spread" in pl else None),
        resolution=resolution,
        d_weight=r.number(pl, "planning.d_weight", "d_weight", positive=True, maximum=1e4, default=100.0),
        mode_change_penalty=r.number(pl, "planning.mode_change_penalty", "mode_change_penalty",
                                     minimum=0.0, maximum=1e4, default=1.0),
        range=r.number(pl, "planning.range", "range", positive=True, maximum=10.0) if "range" in pl else None,
        objective=r.objective(pl),
        release=r.choice(pl, "planning.release", "release", Release, Release.OBJECTIVE),
    )
    return options, digits, clearance
