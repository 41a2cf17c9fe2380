"""The OMPL state space over (theta, d, psi) and conversions of its states."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from ompl import base as ob


def make_state_space(box: ArrayLike) -> ob.RealVectorStateSpace:
    """A RealVectorStateSpace over (theta rad, d over l, psi rad) bounded by box ((2, 3) corners)."""
    box = np.asarray(box, dtype=float)
    space = ob.RealVectorStateSpace(3)
    bounds = ob.RealVectorBounds(3)
    for i in range(3):
        bounds.setLow(i, float(box[0, i]))
        bounds.setHigh(i, float(box[1, i]))
    space.setBounds(bounds)
    space.setName("UngraspSpace(theta,d,psi)")
    return space


def state_to_tuple(state) -> tuple[float, float, float]:
    """The (theta, d, psi) values of an OMPL state."""
    return (state[0], state[1], state[2])


def set_state(state, q: ArrayLike) -> None:
    """Write (theta, d, psi) into an OMPL state."""
    state[0], state[1], state[2] = (float(x) for x in q)


def path_states(path) -> NDArray[np.float64]:
    """The states of an og.PathGeometric as an (N, 3) array."""
    return np.array([state_to_tuple(path.getState(i)) for i in range(path.getStateCount())])
