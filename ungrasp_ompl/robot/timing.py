"""Time parameterisation: TOPPRA along the fixed contact path, Ruckig for the free moves.

Along a primitive the joint path is fixed (the contacts must follow their
planned kinematics), so only its timing is free: TOPPRA finds the fastest
timing under joint velocity and acceleration limits and a cap on the contact
speed (the primitives are quasi-static). The cap enters as one more path
coordinate, the distance the contacts have travelled, with the cap as its
velocity limit. Free moves (approach, retreat) are joint-space moves from rest
to rest with Ruckig under velocity, acceleration and jerk limits.
"""

from __future__ import annotations

import functools
import importlib
import math
import sys
import types
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np
from numpy.typing import NDArray
from ruckig import InputParameter, Result, Ruckig, Trajectory

from ..errors import NoSolutionError


class _Deferred(types.ModuleType):
    """Stands for a module not loaded yet: the first attribute looked up imports the real one."""

    def __getattr__(self, attr: str):
        return getattr(importlib.import_module(self.__name__), attr)


@functools.cache
def _toppra() -> tuple[types.ModuleType, types.ModuleType, types.ModuleType]:
    """TOPPRA and its algorithm and constraint modules, imported at the first timing: with SciPy's
    interpolation they cost about 0.9 s, which planning without an export need not pay.

    Imported without matplotlib: TOPPRA imports matplotlib.pyplot at its own import only for
    plotting helpers that nothing here calls, and loading it costs 0.6 s of every export; while
    TOPPRA is imported, stand-ins take its place (TOPPRA's helpers still work: their first use
    imports the real pyplot), then the module table is left as it was."""
    def load():
        return tuple(importlib.import_module(m) for m in ("toppra", "toppra.algorithm", "toppra.constraint"))

    names = ("matplotlib", "matplotlib.pyplot")
    if any(n in sys.modules for n in names):
        return load()
    package, pyplot = _Deferred(names[0]), _Deferred(names[1])
    package.pyplot = pyplot
    sys.modules.update(zip(names, (package, pyplot)))
    try:
        return load()
    finally:
        for name, stand_in in zip(names, (package, pyplot)):
            if sys.modules.get(name) is stand_in:
                del sys.modules[name]


#: Share of the joint limits TOPPRA plans against (the rest absorbs its between-grid-point error).
TOPPRA_MARGIN = 0.9


class Untimeable(Enum):
    """Why a path cannot be timed (TimingError.kind)."""

    NO_PARAMETERISATION = "no_parameterisation"  #: TOPPRA found no timing of the contact path within the limits
    FREE_MOVE = "free_move"  #: Ruckig could not plan a free move
    LIMITS = "limits"  #: the timed trajectory leaves the robot's limits


class TimingError(NoSolutionError):
    """A path that cannot be timed within the limits. kind: why (Untimeable); evidence: its
    figures (FREE_MOVE ``result``, Ruckig's result's name; LIMITS ``violations``, each limit
    left, in words)."""

    def __init__(self, kind: Untimeable, message: str, **evidence: Any):
        super().__init__(message)
        self.kind = kind
        self.evidence = evidence


@dataclass
class Samples:
    """A timed piece: times (N,) from 0, positions, velocities, accelerations (N, dof)."""

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    qdd: NDArray[np.float64]


def _sample_times(duration: float, period: float) -> NDArray[np.float64]:
    n = max(1, int(math.ceil(duration / period - 1e-9)))
    return np.linspace(0.0, duration, n + 1)


#: TOPPRA's grid points (count) when the fine grid finds no parameterisation.
COARSE_GRID = 50


def toppra_path(q: NDArray, travel: NDArray, v_max: NDArray, a_max: NDArray, contact_speed: float,
                period: float) -> Samples:
    """Time the joint path q (N, dof) from rest to rest under |qd| <= v_max, |qdd| <= a_max
    and contact speed <= contact_speed (m/s), travel (N,) being the contacts' cumulative distance (m)."""
    if len(q) < 2 or np.allclose(q[0], q[-1]) and travel[-1] <= 0:
        return Samples(np.zeros(1), q[:1].copy(), np.zeros((1, q.shape[1])), np.zeros((1, q.shape[1])))
    # path parameter: cumulative joint-space length, with the contact travel as an extra coordinate
    aug = np.column_stack([q, travel])
    seg = np.linalg.norm(np.diff(aug, axis=0), axis=1)
    keep = np.concatenate([[True], seg > 1e-12])
    aug = aug[keep]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(aug, axis=0), axis=1))])
    s /= s[-1]
    ta, algo, constraint = _toppra()
    path = ta.SplineInterpolator(s, aug)
    # TOPPRA holds the limits at its grid points; between them the spline may go a little
    # beyond, so it plans against a margin and every sample is checked after
    v = np.append(v_max * TOPPRA_MARGIN, contact_speed)
    a = np.append(a_max * TOPPRA_MARGIN, 1e3)
    vlim, alim = np.column_stack([-v, v]), np.column_stack([-a, a])
    constraints = [constraint.JointVelocityConstraint(vlim), constraint.JointAccelerationConstraint(alim)]
    # TOPPRA's solver can lose feasibility on a path a fraction of a millimetre long at a fine grid
    # (a 0.15 mm P_psi found none at 100 points and more, one at 50): a coarser grid is tried then,
    # its samples checked against the limits like any other's (check_limits)
    for points in (min(4000, max(200, 4 * len(aug))), COARSE_GRID):
        traj = algo.TOPPRA(constraints, path, gridpoints=np.linspace(0, 1, points),
                           parametrizer="ParametrizeConstAccel").compute_trajectory(0, 0)
        if traj is not None:
            break
    if traj is None:
        raise TimingError(Untimeable.NO_PARAMETERISATION,
                          "the contact path cannot be timed within the joint limits (TOPPRA found no parameterisation)")
    t = _sample_times(traj.duration, period)
    return Samples(t, traj(t)[:, :-1], traj(t, 1)[:, :-1], traj(t, 2)[:, :-1])


def ruckig_move(q_from: NDArray, q_to: NDArray, v_max: NDArray, a_max: NDArray, j_max: NDArray,
                period: float) -> Samples:
    """A joint-space move from rest at q_from to rest at q_to with Ruckig (jerk-limited)."""
    dof = len(q_from)
    otg = Ruckig(dof)
    inp = InputParameter(dof)
    inp.current_position, inp.target_position = list(map(float, q_from)), list(map(float, q_to))
    inp.current_velocity = inp.current_acceleration = [0.0] * dof
    inp.target_velocity = inp.target_acceleration = [0.0] * dof
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = (list(map(float, x)) for x in (v_max, a_max, j_max))
    traj = Trajectory(dof)
    result = otg.calculate(inp, traj)
    if result not in (Result.Working, Result.Finished):
        raise TimingError(Untimeable.FREE_MOVE, f"Ruckig could not plan the free move ({result})", result=str(result))
    t = _sample_times(traj.duration, period)
    q, qd, qdd = (np.array(x) for x in zip(*(traj.at_time(float(ti)) for ti in t)))
    return Samples(t, q, qd, qdd)
