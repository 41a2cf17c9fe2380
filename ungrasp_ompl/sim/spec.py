"""What a simulated trial's world is made of, engine-free: the object, the gripper's geometry, the
contacts' frictions and parameters, the digits' bending, and the shape helpers (metres, kg, s).

sim.world_description turns a SimModelSpec into bodies and shapes; sim.model (MuJoCo) and
sim.drake_world (Drake) build their engines' models from that description. The contacts'
parameters are chosen from the materials (docs/model.md 11.2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..geometry.collision import object_solid
from ..mechanics.pincer import PincerLinks
from ..mechanics.section import Section

#: Contact softness: MuJoCo's reference time constant (s) and damping ratio. 0.2 ms is the
#: contact's own time scale between stiff solids (a gram-heavy object on a PLA dome of Hertz
#: stiffness ~2.5e5 N/m at 5 N rings at ~0.1-0.4 ms), twice the 0.1 ms step as MuJoCo asks;
#: critically damped (no bounce between stiff plastics). Steady sinking scales with its square.
SOLREF = (0.0002, 1.0)
#: Impedance: 0.95 at first touch rising to 0.995 over 0.02 mm, the Hertz deformation of a 1 mm
#: PLA dome on celluloid at 5 N (docs/model.md 11.2), with MuJoCo's default sigmoid shape.
SOLIMP = (0.95, 0.995, 0.00002, 0.5, 2.0)
#: Ratio of frictional to normal constraint impedance: > 1 makes sticking contacts stiffer
#: (less creep), as MuJoCo advises with elliptic cones. It does not change the friction coefficient.
IMPRATIO = 10.0
#: How far a rounded finger's face leans back from its dome toward the palm (rad).
FACE_DRAFT = math.radians(3.0)
#: Mass of each jaw (kg): the gripper's moving finger carriage the digit is fixed to.
JAW_MASS = 0.05
#: Mass of the palm (kg): the gripper's housing (the RH-P12-RN weighs about half a kilogram); the
#: arm carries its weight (gravity compensated), so it only sets how hard the weld pulls.
PALM_MASS = 0.5
#: The weld that makes the palm follow its target: reference time constant (s) and damping ratio
#: as stiff as the contacts' (SOLREF, the least MuJoCo's 0.1 ms step allows), critically damped;
#: an impedance of 0.99 and more lets 10 N of pinch move a 0.5 kg palm by about 1e-8 m.
PALM_SOLREF = (0.0002, 1.0)
PALM_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)
#: The 3D-printed digits' material, PLA as printed (docs/model.md 11.2): Young's modulus (Pa),
#: density (kg/m^3) and damping ratio (half the loss factor of about 0.1 of printed PLA).
PLA_MODULUS = 3.0e9
PLA_DENSITY = 1240.0
PLA_DAMPING_RATIO = 0.05
#: The samples a curved section's solid is built with (geometry.collision.object_solid: as many
#: turns of the section about the axis, and twice as many points along its top): the hull's facets
#: then stray at most 1.2 um from the Go stone's dome and 0.9 um from the coin's rim, within the
#: 2 um the outlines' curves are filled in to (sim.setup.OUTLINE_SAGITTA; tests/test_curved_sim.py).
SOLID_SAMPLES = 128


def digit_bending(length: float, t_tip: float, t_base: float, width: float,
                  modulus: float = PLA_MODULUS, density: float = PLA_DENSITY) -> tuple[float, float]:
    """A tapered digit as a rigid link on a torsion spring at its base: (stiffness N m/rad, damping
    N m s/rad) that give its tip the deflection of the cantilever (Euler-Bernoulli, second moment
    w h(z)^3 / 12 with the thickness h tapering from t_base at the palm to t_tip) and the
    vibration's damping ratio PLA_DAMPING_RATIO. Tip deflection under a tip force F:
    F * integral (L - z)^2 / (E I(z)) dz, so the spring is L^2 / that integral."""
    z = np.linspace(0.0, length, 401)
    h = t_base + (t_tip - t_base) * z / length
    compliance = np.trapezoid((length - z) ** 2 / (modulus * width * h ** 3 / 12), z)
    stiffness = length ** 2 / compliance
    inertia = np.trapezoid(density * width * h * z ** 2, z)  # about the base, kg m^2
    return float(stiffness), float(2 * PLA_DAMPING_RATIO * math.sqrt(stiffness * inertia))


@dataclass(frozen=True)
class GripperGeometry:
    """The gripper as the simulator builds it (m). Digit lengths run from the palm (palm z = 0)
    to the tip along palm z; thicknesses are behind each contact face (palm x), at the tip and
    the base; width along palm y. finger_tip_radius 0 is a flat tip (an edge across the width);
    otherwise a dome of that radius ends the finger, touching the object at one point."""

    thumb_length: float  #: palm to thumb tip (m)
    finger_length: float  #: palm to finger tip (m)
    thumb_tip_thickness: float  #: behind the thumb's face at its tip (m)
    thumb_base_thickness: float  #: behind the thumb's face at the palm (m)
    finger_tip_thickness: float  #: behind the finger's face at its tip (m)
    finger_base_thickness: float  #: behind the finger's face at the palm (m)
    width: float  #: both digits along palm y (m)
    finger_tip_radius: float  #: the finger's rounded tip (m); 0 for a flat tip
    max_opening: float  #: the gripper's stroke between the digit faces (m)
    palm_width: float  #: housing across the gap, palm x (m)
    palm_thickness: float  #: housing along palm y (m)
    palm_depth: float  #: housing along palm z, behind the palm (m)
    hinge: PincerLinks | None = None  #: a pincer's links (m, rad): the jaws turn on one hinge; None: they slide


@dataclass(frozen=True)
class SimObject:
    """The object as the simulator builds it: its outline's convex prism, or the true solid of a
    curved section.

    outline: (N, 2) vertices (m) in the body frame's xy plane; the body frame is the
    manipulation plane's frame when the object lies at its target (origin at G on the
    table, x toward B, z up), so the prism spans z in [0, thickness]. solid: a curved section's
    solid (curved_solid), the convex hull of its vertices (N, 3), m, in the same frame; None: the
    outline's prism. The solid's heights are scaled to thickness (a trial's drawn thickness error,
    a variant's thickness), its outline on the table unchanged.
    """

    outline: NDArray[np.float64]
    thickness: float  #: m
    density: float  #: kg/m^3
    solid: NDArray[np.float64] | None = None  #: (N, 3) m, the curved solid's vertices; None: the prism


@dataclass(frozen=True)
class PairFriction:
    """The Coulomb coefficient of each pair of bodies the object makes, as the simulator uses them
    (dimensionless).

    From the scene's friction: its physical coefficients at G, A and B (Scene.mu_contacts, the
    YAML's friction before the manipulation plane reduces G and B), one per pair: the table's is
    mu_G, the finger's mu_A, the thumb's mu_B, and the walls' and pieces' already down mu_G, as the
    table's (from_contacts). The planner's value of the same friction is
    mechanics.force_closure.Friction: the plane's coefficients (G and B reduced where GB meets the
    outline off its normal) with their range; the simulator has no plane and uses the physical ones.
    A trial scales them by its drawn errors and its world's factors (sim.trial.trial_spec)."""

    table: float  #: object on the table (the scene's mu_G)
    finger: float  #: object on the finger (mu_A)
    thumb: float  #: object on the thumb (mu_B)
    solids: float  #: object on walls and pieces already down (mu_G)

    @classmethod
    def from_contacts(cls, mu_contacts: tuple[float, float, float]) -> "PairFriction":
        """The pairs' coefficients from the physical coefficients at G, A and B (Scene.mu_contacts)."""
        mu_g, mu_a, mu_b = (float(m) for m in mu_contacts)
        return cls(table=mu_g, finger=mu_a, thumb=mu_b, solids=mu_g)


@dataclass(frozen=True)
class SimModelSpec:
    """Everything the MJCF needs; plain data, so that it crosses to worker processes."""

    obj: SimObject
    gripper: GripperGeometry
    friction: PairFriction  #: the Coulomb coefficient of each pair the object makes
    solids: tuple[tuple[str, NDArray[np.float64]], ...] = ()  #: (name, world vertices (N, 3)) convex bodies
    placed: tuple[tuple[str, SimObject, NDArray[np.float64]], ...] = ()  #: free objects already down: name, object, 4x4 pose
    timestep: float = 0.0001  #: s
    table_height: float = 0.0  #: m, where the table's top really is (a calibration error moves it)
    grip_force: float = 5.0  #: N, the jaws' force limit (squeeze on the object; a pincer's at its joint radius)
    servo_stiffness: float = 1.0e4  #: N/m of opening error, below the force limit (a pincer's: at its joint radius)
    contact_time: float = SOLREF[0]  #: s, the contacts' reference time constant (MuJoCo's solref)
    cone: str = "elliptic"  #: the contacts' friction cone: elliptic or pyramidal (MuJoCo's option)



def curved_solid(section: Section | None, length: float, width: float, turned: bool) -> NDArray[np.float64] | None:
    """The vertices (N, 3) of the solid the planner collides with (geometry.collision.object_solid,
    SOLID_SAMPLES), m, in the object's body frame (x along GB from G, y across, z up from GB): the
    section (over length, m) turned about the vertical through its centre (turned: a round object)
    or carried across width (m). None for a slab or no section: the simulator builds the outline's
    prism. sim.world_description scales its heights to the SimObject's thickness."""
    if section is None or section.is_slab:
        return None
    return object_solid(section, length, width, turned, SOLID_SAMPLES)


def prism(outline: NDArray, bottom: float, top: float) -> NDArray[np.float64]:
    lo = np.column_stack([outline, np.full(len(outline), bottom)])
    hi = np.column_stack([outline, np.full(len(outline), top)])
    return np.vstack([lo, hi])


def digit_outline(length: float, t_tip: float, t_base: float, side: float, tip_cut: float = 0.0,
           relief: float = 0.0, draft: float = 0.0) -> NDArray[np.float64]:
    """A tapered digit's outline (x, z) in its jaw frame, on the side of x given by side (extruded
    along y by extrude_y), the thickness measured from x = 0. The contact face runs from z = 0
    to length - tip_cut; relief > 0 stands it back behind x = 0 (where a rounded tip's dome
    touches) at its tip end, and draft (rad) tilts it further back toward the palm."""
    end = length - tip_cut
    t_end = t_base + (t_tip - t_base) * end / length
    return np.array([[side * (relief + end * math.tan(draft)), 0.0], [side * relief, end], [side * t_end, end],
                     [side * t_base, 0.0]])


def extrude_y(xz: NDArray, width: float) -> NDArray[np.float64]:
    return np.vstack([np.column_stack([xz[:, 0], np.full(len(xz), s * width / 2), xz[:, 1]]) for s in (-1, 1)])
