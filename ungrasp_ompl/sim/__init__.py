"""Simulated execution in MuJoCo: does the exported trajectory put the object down?"""

from .world import World

__all__ = ["World"]
