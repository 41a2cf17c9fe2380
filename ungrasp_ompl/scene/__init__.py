"""The scene: what is put down, by which digits, on what, from where to where.

``model`` holds :class:`Scene` and its queries of states (force closure, margins, the cage,
collision); ``loader`` reads and validates the YAML file, naming the field of any error;
``options`` holds the dataclasses of the scene's option blocks (planning, robot, simulation, the
3D object); ``stability`` and ``stability3d`` the stability of its states; ``perturbation`` the
errors of a set-up and ``tolerance`` the tolerance of states to them. A plan's tolerance is
planning's (``planning.tolerance``).
"""

from .model import Scene, StateClass, StateDiagnosis
from .options import Object3D, PlanningOptions, RobotOptions, SimOptions
from .tolerance import ToleranceOptions

__all__ = ["Object3D", "PlanningOptions", "RobotOptions", "Scene", "SimOptions", "StateClass", "StateDiagnosis",
           "ToleranceOptions"]
