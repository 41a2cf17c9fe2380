"""ungrasp-ompl: plan dexterous ungrasping of thin objects with OMPL.

Quick use::

    from ungrasp_ompl import Scene, plan, tolerance
    scene = Scene.from_file("scenes/reference_asymmetric.yaml")
    result = plan(scene, planner="RRTstar", time=1.0, seed=1)
    print(result.to_json())
    print(tolerance(scene, result).describe())

``__all__`` is the public API of the package (docs/api.md lists it, with that of each
subpackage); any other name is internal. The names below load on first use (PEP 562): ``import
ungrasp_ompl`` alone costs nothing, and the command line loads only what a command needs.
"""

from ._lazy import lazy_exports

__version__ = "0.1.0"

_WHERE = {"InputError": ".errors", "NoSolutionError": ".errors", "ToolError": ".errors", "UngraspError": ".errors",
          "PLANNERS": ".planning", "Plan": ".planning", "PlanOutcome": ".planning", "PlannerOptions": ".planning",
          "plan": ".planning", "tolerance": ".planning", "Scene": ".scene"}

__all__ = sorted(_WHERE) + ["__version__"]

__getattr__, __dir__ = lazy_exports(__name__, _WHERE)
