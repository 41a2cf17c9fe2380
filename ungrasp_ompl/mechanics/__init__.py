"""Planar ungrasping mechanics: pure numpy, no OMPL (docs/model.md, sections 2-4).

All lengths here are over the object length l; angles are radians. The plane is
the manipulation plane with G at the origin, x along the table toward B's side
and z up; a state is (theta, d, psi).
"""

from .contact import (
    PRIMITIVES,
    ContactMode,
    Primitive,
    contact_mode,
    friction_directions,
    primitive_of,
    primitive_sliding_signs,
    sliding_signs,
)
from .force_closure import (
    REFERENCE_FRICTION,
    SLIDING_MODELS,
    Friction,
    SlidingModel,
    cone_edges,
    contact_wrenches,
    force_closure,
    force_closure_margin,
)
from .kinematics import (
    DigitGeometry,
    across_support,
    aperture,
    digit_polygons,
    finger_tip,
    kinematic_checks,
    kinematic_validity,
    s_b,
    thumb_clearance,
    thumb_tip,
)

__all__ = [
    "PRIMITIVES",
    "REFERENCE_FRICTION",
    "SLIDING_MODELS",
    "ContactMode",
    "DigitGeometry",
    "Friction",
    "Primitive",
    "SlidingModel",
    "across_support",
    "aperture",
    "cone_edges",
    "contact_mode",
    "contact_wrenches",
    "digit_polygons",
    "finger_tip",
    "force_closure",
    "force_closure_margin",
    "friction_directions",
    "kinematic_checks",
    "kinematic_validity",
    "primitive_of",
    "primitive_sliding_signs",
    "s_b",
    "sliding_signs",
    "thumb_clearance",
    "thumb_tip",
]
