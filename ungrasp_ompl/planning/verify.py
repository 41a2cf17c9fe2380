"""Independent re-validation of planned legs with the exact mechanics (no atlas).

Every leg is sampled in its travel direction at a resolution no coarser than
the lattice's (default: half a lattice step), and each sample is checked for
kinematic validity, collision (python-fcl) and force closure in the contact
mode the leg's velocity makes there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np
from numpy.typing import ArrayLike

from ..geometry.collision import CollisionChecker
from ..mechanics import force_closure, kinematic_checks, primitive_sliding_signs
from ..scene import Scene


class LegCheck(Enum):
    """The check a leg fails first (verify_leg runs them in this order)."""

    #: A kinematic condition (LegFailure.detail names it: "d", "s_B >= 0", "thumb clearance", ...).
    KINEMATICS = "kinematics"
    #: Not force-closed in the contact mode the leg's velocity makes there.
    FORCE_CLOSURE = "force_closure"
    #: The digits or the object meet the table or an obstacle (LegFailure.detail names the pairs).
    COLLISION = "collision"


@dataclass(frozen=True)
class LegFailure:
    """Why a leg is not secure: the check that fails and the first state where it does."""

    check: LegCheck
    """The first check that fails."""
    state: tuple[float, float, float]
    """The first failing sample: theta (rad), d (over l), psi (rad)."""
    detail: str = ""
    """The kinematic condition, or the colliding pairs ("thumb-table, ..."); empty for force closure."""

    def describe(self) -> str:
        """One phrase for a person, e.g. "s_B >= 0 fails at (theta 30.00 deg, d 0.8000, psi 0.00 deg)"."""
        where = _fmt(self.state)
        if self.check is LegCheck.KINEMATICS:
            return f"{self.detail} fails at {where}"
        if self.check is LegCheck.FORCE_CLOSURE:
            return f"not force-closed in its contact mode at {where}"
        return f"collision {self.detail} at {where}"

    __str__ = describe



class PathCheck(Enum):
    """Why a planner's path cannot be executed as primitive legs (UngraspSetup.path_legs)."""

    #: A state of the path lies outside the planning box.
    OUTSIDE_BOX = "outside_box"
    #: An edge of the path has no secure primitive legs in its travel direction (PathProblem.index).
    NO_SECURE_LEGS = "no_secure_legs"
    #: A leg fails re-validation with the exact mechanics (PathProblem.index, .primitive, .failure).
    LEG_FAILS = "leg_fails"


@dataclass(frozen=True)
class PathProblem:
    """The first reason a path is not a secure sequence of legs."""

    check: PathCheck
    """What fails."""
    index: int | None = None
    """The path's edge (NO_SECURE_LEGS) or the realised leg (LEG_FAILS), from 0."""
    primitive: str | None = None
    """The failing leg's primitive (LEG_FAILS)."""
    failure: LegFailure | None = None
    """Why the leg fails (LEG_FAILS)."""

    def describe(self) -> str:
        """One phrase for a person."""
        if self.check is PathCheck.OUTSIDE_BOX:
            return "a state lies outside the planning box"
        if self.check is PathCheck.NO_SECURE_LEGS:
            return f"edge {self.index} has no secure primitive legs in its travel direction"
        return f"leg {self.index} ({self.primitive}) {self.failure}"

    __str__ = describe

    def evidence(self) -> dict:
        """Plan.evidence of an invalid path: the phrase and the values behind it (JSON types)."""
        out = {"problem": self.describe(), "path_check": self.check.value, "index": self.index}
        if self.failure is not None:
            out.update(primitive=self.primitive, leg_check=self.failure.check.value, state=list(self.failure.state),
                       detail=self.failure.detail)
        return out


def verify_leg(
    scene: Scene,
    primitive: str,
    q0: ArrayLike,
    q1: ArrayLike,
    resolution: ArrayLike,
    checker: CollisionChecker | None = None,
) -> LegFailure | None:
    """Check one leg from q0 to q1 (states (theta, d, psi)); None if secure, else why not."""
    q0, q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
    step = q1 - q0
    n = max(1, int(math.ceil(np.max(np.abs(step) / np.asarray(resolution)) - 1e-9)))
    q = q0 + np.linspace(0.0, 1.0, n + 1)[:, None] * step
    th, d, ps = q.T
    for name, ok in kinematic_checks(th, d, ps, scene.digits).items():
        if not ok.all():
            return LegFailure(LegCheck.KINEMATICS, _state(q[np.argmin(ok)]), name)
    sa, sb = primitive_sliding_signs(primitive, d, ps, step[1], step[2])
    fc = force_closure(th, d, ps, sa, sb, scene.friction)
    if not fc.all():
        return LegFailure(LegCheck.FORCE_CLOSURE, _state(q[np.argmin(fc)]))
    checker = checker or CollisionChecker(scene.collision_model())
    hit = checker.in_collision(q)
    if hit.any():
        bad = q[np.argmax(hit)]
        return LegFailure(LegCheck.COLLISION, _state(bad), ", ".join(checker.contacts(bad)))
    return None


def _state(q: ArrayLike) -> tuple[float, float, float]:
    th, d, ps = (float(x) for x in q)
    return th, d, ps


def _fmt(q: ArrayLike) -> str:
    th, d, ps = q
    return f"(theta {math.degrees(th):.2f} deg, d {d:.4f}, psi {math.degrees(ps):.2f} deg)"
