"""The scene: what is put down, by which digits, on what, from where to where.

``model`` holds :class:`Scene` and its queries (force closure, margins, the cage, the tolerance of a
plan, collision); ``loader`` reads and validates the YAML file, naming the field of any error;
``options`` holds the dataclasses of the scene's option blocks (planning, robot, simulation, the
3D object). Every name a caller needs is importable from ``ungrasp_ompl.scene``.
"""

from .model import *  # noqa: F401,F403
from .model import __all__
