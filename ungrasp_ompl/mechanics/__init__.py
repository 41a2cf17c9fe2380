"""Planar ungrasping mechanics: pure numpy, no OMPL (docs/model.md, sections 2-4).

All lengths here are over the object length l; angles are radians. The plane is
the manipulation plane with G at the origin, x along the table toward B's side
and z up; a state is (theta, d, psi).

The functions imported here are the shorthand the floors above use (``from ..mechanics import
force_closure``); the public names are ``__all__``'s.
"""

from .contact import (  # noqa: F401 (the shorthand, as the docstring says)
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

__all__ = ["Primitive", "SlidingModel"]
