"""Planning with OMPL: state space, validity, objective, goal, planner setup, lattice yardstick;
and what a plan of a scene is worth: its friction margin, tolerance, cage profile and landing.

The names below (the package's public API) load on first use (PEP 562), so that importing a light
submodule (the planner names for the command line's help) does not load OMPL and the planning stack.
"""

from .._lazy import lazy_exports

_WHERE = {"Plan": ".result", "PlanOutcome": ".result", "PrimitiveStep": ".result", "PLANNERS": ".names",
          "PlannerOptions": ".setup", "UngraspSetup": ".setup", "plan": ".setup", "Objective": ".margins",
          "Tolerance": ".plan_tolerance", "tolerance": ".plan_tolerance"}

__all__ = sorted(_WHERE)

__getattr__, __dir__ = lazy_exports(__name__, _WHERE)
