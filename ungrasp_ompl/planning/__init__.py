"""Planning with OMPL: state space, validity, objective, goal, planner setup, lattice yardstick."""

from .result import Plan, PlanOutcome, PrimitiveStep
from .setup import PLANNERS, PlannerOptions, UngraspSetup, plan

__all__ = ["PLANNERS", "Plan", "PlanOutcome", "PlannerOptions", "PrimitiveStep", "UngraspSetup", "plan"]
