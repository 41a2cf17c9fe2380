"""Reading scene and layout files: the YAML, and typed access to its fields.

SceneReader is shared by Scene.from_dict and Layout.from_dict: every value is
checked where it is read (type, finiteness, range, unit) and a bad one raises
InputError naming its dotted key and the reason. A person types degrees in keys
ending ``_deg``; the reader returns radians where the docstring says so.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from ..errors import InputError, UnknownFieldError
from ..geometry.collision import Box
from ..geometry.outline import Outline, OutlineError, ellipse, polygon, rounded_polygon
from ..io import parse_yaml
from ..mechanics.pincer import PincerSpec
from ..mechanics.section import SECTION_KINDS, Section, SectionError
from .options import GripperKind, Landing, Object3D, RobotOptions, SimOptions, Termination

#: Longest length and farthest coordinate a scene may give, m: beyond it a value is a typo.
MAX_LENGTH = 10.0
#: Largest friction coefficient a scene may give: beyond it a value is a typo.
MAX_FRICTION = 10.0
#: Largest magnitude of any number in a scene: no field means anything beyond it.
MAX_MAGNITUDE = 1e6
#: Largest joint torque a pincer may give, N m: a hand-sized gripper's motor, beyond it a typo.
MAX_TORQUE = 100.0


def read_yaml(path: str | os.PathLike[str], what: str) -> Any:
    """The parsed YAML of a file; InputError naming what (scene, layout) when it is missing or malformed."""
    path = Path(path)
    src = str(path)
    if not path.is_file():
        raise InputError(what, "no such file" if not path.exists() else "not a file", src)
    try:
        return parse_yaml(path.read_text())
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark else ""
        raise InputError(what, f"not valid YAML{where}", src) from None
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
                                "end_press", "touch_off", "landing", "landing_pairs", "object", "gripper"})
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
            self.pincer_limits(m, term, landing)
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

    def pincer_limits(self, m: dict, termination: str, landing: str) -> None:
        """What a pincer's robot section may not ask for: the release open_lift and the landing
        modelled move the digits as parallel jaws part, and the touch-off expects the parallel
        digits' lowest point; InputError naming the field."""
        if termination == Termination.OPEN_LIFT:
            self.fail("robot.termination", "open_lift needs the parallel gripper (kind parallel): a pincer lets go "
                      "by open, open_symmetric or rotate")
        if landing == Landing.MODELLED:
            self.fail("robot.landing", "modelled needs the parallel gripper (kind parallel): the model of the fall "
                      "moves the digits as parallel jaws part")
        if self.flag(m, "robot.touch_off", "touch_off"):
            self.fail("robot.touch_off", "needs the parallel gripper (kind parallel): the probe expects the parallel "
                      "digits' lowest point")

    def sim(self, value: Any) -> SimOptions:
        m = self.mapping(value, "sim")
        d = SimOptions()
        self.known(m, "sim", set(d.__dataclass_fields__))
        out = {k: self.flag(m, f"sim.{k}", k) if isinstance(getattr(d, k), bool)
               else self.number(m, f"sim.{k}", k, positive=True, default=getattr(d, k)) for k in m}
        if out.get("density", d.density) > 25000:
            self.fail("sim.density", f"must be at most 25000 kg/m^3 (denser than any solid), got {out['density']:g}")
        if out.get("timestep", d.timestep) > 0.002:
            self.fail("sim.timestep", f"must be at most 0.002 s (the control period), got {out['timestep']:g}")
        if out.get("grip_force", d.grip_force) > 170:
            self.fail("sim.grip_force", f"must be at most 170 N (the gripper's rating), got {out['grip_force']:g}")
        for k in ("squeeze", "settle_time", "rest_time", "max_error"):
            if out.get(k, 0.0) > (0.01 if k == "squeeze" else 0.05 if k == "max_error" else 10.0):
                self.fail(f"sim.{k}", f"is absurdly large ({out[k]:g})")
        return SimOptions(**{**{k: getattr(d, k) for k in d.__dataclass_fields__}, **out})

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
