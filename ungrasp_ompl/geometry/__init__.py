"""Geometry of the manipulation plane: collision of the digits and the object."""

from .collision import CollisionChecker

__all__ = ["CollisionChecker"]
