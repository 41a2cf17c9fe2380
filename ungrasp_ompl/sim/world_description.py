"""The trial's world as plain data, engine-free: what each body is, its shapes, masses, joints,
springs and frictions, built once from a SimModelSpec. Both engines' builders read it: MuJoCo's
(sim.model.build_mjcf, MJCF text) and Drake's (sim.drake_world). Nothing about the object, the
digits, the jaws or the palm is computed anywhere else, so the two engines simulate the same
bodies; what differs between them is only how each engine makes contact and drives joints
(docs/model.md 11.1, 11.19).

World frame: the scene's (x, y on the table, z up, metres); the table's top at z = table_height.
Palm frame: z from the palm toward the digits' tips, x across the gap (from the thumb toward the
finger), y along the digits' width (the manipulation plane's normal). Every geometry is given in
its body's frame.

Friction: ``friction`` of a geometry is the coefficient of its pair with the object (the spec's
sim.spec.PairFriction, the scene's mu per pair); the object's own geometry carries none (MuJoCo
takes the larger of a pair's two values, so a pair then has the other geometry's; Drake combines
two values otherwise, which its builder accounts for).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .spec import (FACE_DRAFT, JAW_MASS, PALM_MASS, PLA_DENSITY, SimModelSpec, SimObject, digit_bending,
                   digit_outline, extrude_y, prism)

#: The slide jaws' rotational inertia about each of their axes (kg m^2): a carriage's, which only
#: slides (its turns are the palm's), so it matters to nothing but the solver's conditioning.
JAW_INERTIA = 1e-5


@dataclass(frozen=True)
class Mesh:
    """A convex mesh: the hull of its vertices (N, 3), m, in its body's frame, moved by centre."""

    vertices: NDArray[np.float64]
    #: where the vertices' origin lies in the body's frame (m)
    centre: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))


@dataclass(frozen=True)
class Sphere:
    """A ball of radius (m) about centre (3,), in its body's frame."""

    radius: float
    centre: NDArray[np.float64]


@dataclass(frozen=True)
class Box:
    """A box of half sizes half (3,) about centre (3,), m, in its body's frame."""

    half: NDArray[np.float64]
    centre: NDArray[np.float64]


@dataclass(frozen=True)
class Geom:
    """One shape of a body: its name, shape, the coefficient of its pair with the object (None:
    the object's own, which carries none), and its mass: a density (kg/m^3) or a mass (kg)."""

    name: str
    shape: Mesh | Sphere | Box
    friction: float | None
    density: float | None = None
    mass: float | None = None
    rgba: str = ".5 .5 .5 1"


@dataclass(frozen=True)
class FreeBody:
    """A free body (six degrees of freedom, nothing but contacts holds it): the object, or one
    already down; its one geometry (a convex prism, or a curved section's solid) and its pose
    (4x4) where it starts."""

    name: str
    geom: Geom
    pose: NDArray[np.float64]


@dataclass(frozen=True)
class Bend:
    """A digit's bending on its jaw: a hinge about the jaw's y at the digit's base with a torsion
    spring (N m/rad) and damping (N m s/rad) that give its tip the tapered PLA cantilever's
    deflection and damping ratio (spec.digit_bending)."""

    stiffness: float
    damping: float


@dataclass(frozen=True)
class Digit:
    """A digit: its body (at position, turned by quat (w, x, y, z), in its jaw's frame), its
    geometries (the tapered cantilever, and a rounded finger's dome) and its bend."""

    name: str
    geoms: tuple[Geom, ...]
    bend: Bend
    position: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    quat: NDArray[np.float64] = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))


@dataclass(frozen=True)
class Jaw:
    """A jaw on the palm: a carriage sliding along the palm's x, or (a pincer) a link turning about
    the palm's y at its origin; its joint's range (m or rad), mass and rotational inertia, and the
    digit it carries."""

    name: str
    joint: str  #: 'slide' or 'hinge'
    axis: NDArray[np.float64]
    lower: float
    upper: float
    mass: float
    inertia: NDArray[np.float64]  #: diagonal (3,), kg m^2
    digit: Digit

    @property
    def joint_name(self) -> str:
        return f"{self.name}_{self.joint}"


@dataclass(frozen=True)
class Servo:
    """The gripper's one position servo: on the finger's jaw joint, whose coordinate times gear is
    the commanded quantity (the opening, m; a pincer's joint angle, rad), the thumb's joint coupled
    to minus the finger's. force = stiffness (command - gear q) - damping gear q', clamped to
    +-force_limit, acts on the commanded quantity (gear times it on the joint); its command lies in
    [0, command_max]."""

    joint: str
    gear: float
    stiffness: float
    damping: float
    force_limit: float
    command_max: float


@dataclass(frozen=True)
class WorldDescription:
    """A trial's world (see the module). spec: what it was built from."""

    spec: SimModelSpec
    table_height: float  #: m, the table's top
    table_friction: float  #: the object's pair with the table
    object: FreeBody
    placed: tuple[FreeBody, ...]  #: objects already down
    solids: tuple[Geom, ...]  #: fixed convex bodies (walls, obstacles), in the world frame
    palm: Geom  #: the housing, a box behind the palm (mass PALM_MASS, carried by the arm)
    jaws: tuple[Jaw, Jaw]  #: the thumb's and the finger's
    servo: Servo

    @property
    def thumb(self) -> Jaw:
        return self.jaws[0]

    @property
    def finger(self) -> Jaw:
        return self.jaws[1]

    @property
    def dome(self) -> Geom | None:
        """A rounded finger's dome (None for a flat tip)."""
        return next((g for g in self.finger.digit.geoms if isinstance(g.shape, Sphere)), None)

    def digit_geoms(self) -> tuple[Geom, ...]:
        return self.thumb.digit.geoms + self.finger.digit.geoms


def object_body(name: str, obj: SimObject, pose: NDArray, friction: float | None, rgba: str) -> FreeBody:
    """A free convex body: a curved section's true solid (obj.solid, its heights scaled so that it
    is obj's thickness from bottom to top), or else the prism of obj's outline from z = 0 to its
    thickness, in its body frame; its mass from obj's density."""
    if obj.solid is None:
        vertices = prism(obj.outline, 0.0, obj.thickness)
    else:
        vertices = np.asarray(obj.solid, dtype=float)
        scale = obj.thickness / np.ptp(vertices[:, 2])
        if scale != 1.0:
            vertices = vertices * np.array([1.0, 1.0, scale])
    return FreeBody(name, Geom(name, Mesh(np.asarray(vertices, dtype=float)), friction, obj.density, rgba=rgba),
                    np.asarray(pose, dtype=float))


def describe(spec: SimModelSpec) -> WorldDescription:
    """The world a spec asks for (see the module docstring)."""
    g, f = spec.gripper, spec.friction
    flat = g.finger_tip_radius <= 0.0
    thumb_mesh = extrude_y(digit_outline(g.thumb_length, g.thumb_tip_thickness, g.thumb_base_thickness, -1.0), g.width)
    # a rounded finger is a ball-nosed digit: its body ends at the dome's centre. On a slab its
    # face stands back by the dome's radius there, and further toward the palm (FACE_DRAFT), so
    # that nothing but the dome reaches the object, even where it turns a little in the grasp
    # (psi < 0), as the plan's A is the dome. On a curved section the plan's finger rolls on the
    # object with its face, tangent to the dome (mechanics.kinematics.section_pinch), and so does
    # this one: its face is flush with the dome's front
    r = 0.0 if flat else g.finger_tip_radius
    curved = spec.obj.solid is not None
    finger_mesh = extrude_y(digit_outline(g.finger_length, g.finger_tip_thickness, g.finger_base_thickness, 1.0, r,
                                          0.0 if curved else r, 0.0 if flat or curved else FACE_DRAFT), g.width)
    thumb_bend = Bend(*digit_bending(g.thumb_length, g.thumb_tip_thickness, g.thumb_base_thickness, g.width))
    finger_bend = Bend(*digit_bending(g.finger_length, g.finger_tip_thickness, g.finger_base_thickness, g.width))
    thumb_geoms = (Geom("thumb", Mesh(thumb_mesh), f.thumb, PLA_DENSITY, rgba=".8 .3 .2 1"),)
    finger_geoms = (Geom("finger", Mesh(finger_mesh), f.finger, PLA_DENSITY, rgba=".2 .3 .8 1"),)
    if not flat:
        finger_geoms += (Geom("finger_tip", Sphere(g.finger_tip_radius, np.array(
            [g.finger_tip_radius, 0.0, g.finger_length - g.finger_tip_radius])), f.finger, PLA_DENSITY,
            rgba=".2 .3 .8 1"),)
    y = np.array([0.0, 1.0, 0.0])
    if g.hinge is None:  # two carriages sliding on the palm, coupled, one force-limited servo on the opening
        half = g.max_opening / 2
        inertia = np.full(3, JAW_INERTIA)
        jaws = (Jaw("thumb", "slide", np.array([1.0, 0.0, 0.0]), -half, 0.0, JAW_MASS, inertia,
                    Digit("thumb", thumb_geoms, thumb_bend)),
                Jaw("finger", "slide", np.array([1.0, 0.0, 0.0]), 0.0, half, JAW_MASS, inertia,
                    Digit("finger", finger_geoms, finger_bend)))
        servo = Servo("finger_slide", 2.0, spec.servo_stiffness, 2 * math.sqrt(spec.servo_stiffness * JAW_MASS),
                      spec.grip_force, g.max_opening)
    else:
        # a pincer (GripperGeometry.hinge, mechanics.pincer): each jaw turns on a hinge about the
        # palm's y axis at the palm's origin (the joint), the thumb's by -phi/2 and the finger's by
        # +phi/2 (phi the joint angle, rad), its digit turned half the closed angle within it and
        # its face's foot off the axis. A jaw is a rod of the parallel carriage's mass over the
        # joint radius; the servo's stiffness and force limit are the parallel's (N/m, N) moved to
        # the joint radius (N m/rad, N m), so that the fingertip feels the same servo
        links = g.hinge
        half = links.max_angle / 2
        rod = JAW_MASS * links.radius ** 2 / 3  # kg m^2 about the joint
        stiffness = spec.servo_stiffness * links.radius ** 2
        jaws = []
        for name, sign, across, (lo, hi), geoms, bend in (
                ("thumb", -1.0, links.offset, (-half, 0.0), thumb_geoms, thumb_bend),
                ("finger", 1.0, links.tip_radius, (0.0, half), finger_geoms, finger_bend)):
            a = sign * links.closed_angle / 2
            digit = Digit(name, geoms, bend, np.array([-across * math.cos(a), 0.0, across * math.sin(a)]),
                          np.array([math.cos(a / 2), 0.0, math.sin(a / 2), 0.0]))
            jaws.append(Jaw(name, "hinge", y, lo, hi, JAW_MASS, np.full(3, rod), digit))
        jaws = tuple(jaws)
        servo = Servo("finger_hinge", 2.0, stiffness, 2 * math.sqrt(stiffness * rod), spec.grip_force * links.radius,
                      links.max_angle)
    solids = []
    for k, (name, verts) in enumerate(spec.solids):
        centre = np.asarray(verts).mean(axis=0)
        solids.append(Geom(f"solid{k}", Mesh(np.asarray(verts) - centre, centre), f.solids, rgba=".55 .45 .35 1"))
    placed = tuple(object_body(f"placed{k}", other, pose, f.solids, ".6 .6 .2 1")
                   for k, (name, other, pose) in enumerate(spec.placed))
    palm = Geom("palm", Box(np.array([g.palm_width / 2, g.palm_thickness / 2, g.palm_depth / 2]),
                            np.array([0.0, 0.0, -g.palm_depth / 2])), None, mass=PALM_MASS, rgba=".3 .3 .3 1")
    obj = object_body("object", spec.obj, np.eye(4), None, ".9 .7 .1 1")
    return WorldDescription(spec, spec.table_height, f.table, obj, placed, tuple(solids), palm, jaws, servo)
