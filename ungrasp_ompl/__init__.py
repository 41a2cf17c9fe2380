"""ungrasp-ompl: plan dexterous ungrasping of thin objects with OMPL.

Quick use::

    from ungrasp_ompl import Scene, plan
    scene = Scene.from_file("scenes/reference_asymmetric.yaml")
    result = plan(scene, planner="RRTstar", time=1.0, seed=1)
    print(result.to_json())
"""

from .errors import InputError, UngraspError
from .planning import PLANNERS, Plan, PlanOutcome, PlannerOptions, plan
from .scene import Scene

__version__ = "0.1.0"

__all__ = ["PLANNERS", "InputError", "Plan", "PlanOutcome", "PlannerOptions", "Scene", "UngraspError", "plan", "__version__"]
