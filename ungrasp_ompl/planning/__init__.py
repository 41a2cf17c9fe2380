"""Planning with OMPL: state space, validity, objective, goal, planner setup, lattice yardstick;
and what a plan of a scene is worth: its friction margin, tolerance, cage profile and landing.

The names below (the package's public API) load on first use (PEP 562), so that importing a light
submodule (the planner names for the command line's help) does not load OMPL and the planning stack.
"""

from importlib import import_module

_WHERE = {"Plan": ".result", "PlanOutcome": ".result", "PrimitiveStep": ".result", "PLANNERS": ".names",
          "PlannerOptions": ".setup", "UngraspSetup": ".setup", "plan": ".setup", "Objective": ".margins",
          "Tolerance": ".plan_tolerance", "tolerance": ".plan_tolerance"}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(_WHERE[name], __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_WHERE))
