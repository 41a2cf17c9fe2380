"""OMPL validity: which states can be held and which motions primitives realise.

Both look states up in a :class:`~ungrasp_ompl.planning.atlas.SecurityAtlas`,
so a check costs a few microseconds of Python (the planner calls back here
for every motion it tries).
"""

from __future__ import annotations

from ompl import base as ob

from .atlas import SecurityAtlas


class LatticeValidityChecker(ob.StateValidityChecker):
    """A state is valid when its lattice state is kinematically valid, collision-free
    and force-closed with all contacts sticking (it can be held at rest)."""

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas):
        super().__init__(si)
        self.atlas = atlas

    def isValid(self, state) -> bool:
        idx = self.atlas.index((state[0], state[1], state[2]))
        return idx is not None and bool(self.atlas.holdable[idx])


class PrimitiveMotionValidator(ob.MotionValidator):
    """Accepts a motion s1 -> s2 only when a staircase of primitive legs realises it,
    every leg secure in its own contact mode (see SecurityAtlas.motion_secure).

    Motions are directed: s1 -> s2 being secure says nothing of s2 -> s1.

    A motion asked for more than REPEAT_LIMIT times in a row is refused until another
    motion is asked for: a planner that does so is in a loop that does not end by itself. (AORRTC in the ompl 2.0.1
    wheel: its connect loop re-adds one state toward a target, checking the same
    motion each time and never its time limit; refusing the motion ends the loop.)
    """

    REPEAT_LIMIT = 100

    def __init__(self, si: ob.SpaceInformation, atlas: SecurityAtlas):
        super().__init__(si)
        self.atlas = atlas
        self.checks = 0
        self.refused_repeats = 0  # checks refused as repeats
        self._last: tuple | None = None
        self._repeats = 0

    def checkMotion(self, s1, s2, *last_valid) -> bool:
        self.checks += 1
        key = (s1[0], s1[1], s1[2], s2[0], s2[1], s2[2])
        if key == self._last:
            self._repeats += 1
            if self._repeats >= self.REPEAT_LIMIT:
                self.refused_repeats += 1
                return False
        else:
            self._last, self._repeats = key, 0
        index = self.atlas.index
        a = index(key[:3])
        b = index(key[3:])
        if a is None or b is None:
            return False
        return self.atlas.motion_secure(a, b)
