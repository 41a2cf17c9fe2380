"""Friction margins on the secure lattice, per state and contact mode, for the robust objectives
(docs/model.md, sections 4.4 and 6).

:class:`LatticeMargins` keeps, beside a :class:`~ungrasp_ompl.planning.atlas.SecurityAtlas`, the
friction margin (rad, :func:`~ungrasp_ompl.mechanics.margin.friction_margin`) of every lattice
state in every contact mode a primitive leg makes there, computed the first time a mode is
needed and only where the atlas finds that mode secure (-inf elsewhere). From them:

* the margin of a leg: the smallest margin of the lattice states it passes, each in the leg's
  own contact mode (the states the atlas checks for its security), the start state left out:
  every plan leaves the start, whose margin is the grasp as handed over, so a path's margin is
  that of the states its motion reaches (the start's is reported on its own);
* the margin penalty of a leg: the sum over its lattice steps of the step's weighted L1 length
  (reference units, docs/model.md section 6) divided by the step's margin in degrees (the smaller
  of its two ends), an integral of 1 / margin along the path like OMPL's clearance objectives;
* the same for a motion: over the secure staircases that realise it, the best one.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..mechanics import primitive_sliding_signs
from ..mechanics.margin import friction_margin
from .atlas import D, LEG_AXES, PSI, Leg, SecurityAtlas, reference_cost

#: Margins below this (deg) count as this in the penalty, so that it stays finite.
MARGIN_FLOOR_DEG = 1e-6

#: Motions whose (margin, penalty) is remembered before the memory is cleared.
MOTION_CACHE = 200_000

#: The objectives a plan can optimise (docs/model.md, section 6).
OBJECTIVES = ("cost", "margin", "balanced")


class LatticeMargins:
    """Friction margins (rad) of an atlas's lattice states per contact mode (see the module
    docstring). ``computed_states`` counts the margins evaluated so far."""

    def __init__(self, atlas: SecurityAtlas):
        self.atlas = atlas
        #: The start's lattice index: every plan leaves it, so its margin (the grasp as handed
        #: over, the same for every plan) is left out of a path's margin and reported on its own.
        self.start = atlas.index(atlas.scene.start)
        self._mode: dict[tuple[int, int], NDArray[np.float64]] = {}
        self._move: dict[tuple, NDArray[np.float64]] = {}
        self._relevant: NDArray[np.bool_] | None = None
        self._motions: dict[tuple, tuple[float, float]] = {}
        self.computed_states = 0

    @property
    def relevant(self) -> NDArray[np.bool_]:
        """Lattice states on some secure lattice path from the start to the goal region (the
        others lie on no plan, so their margins are never needed): reachable from the start and
        reaching a releasable goal state, by breadth-first search over the lattice's secure moves."""
        if self._relevant is None:
            from scipy.sparse import coo_matrix
            from scipy.sparse.csgraph import breadth_first_order

            from .lattice import moves_graph

            atlas = self.atlas
            n = int(np.prod(atlas.shape))
            src, dst = moves_graph(atlas)
            goal = np.flatnonzero(atlas.releasable_in(atlas.scene.goal.box()).ravel())
            out = np.zeros(n, dtype=bool)
            if self.start is not None and len(goal):
                fw = coo_matrix((np.ones(len(src)), (src, dst)), shape=(n, n)).tocsr()
                ahead = breadth_first_order(fw, int(np.ravel_multi_index(self.start, atlas.shape)), directed=True,
                                            return_predecessors=False)
                # backward from every goal state at once: a virtual node n leads to each of them
                bw = coo_matrix((np.ones(len(src) + len(goal)), (np.concatenate([dst, np.full(len(goal), n)]),
                                                                 np.concatenate([src, goal]))), shape=(n + 1, n + 1)).tocsr()
                behind = breadth_first_order(bw, n, directed=True, return_predecessors=False)
                out[ahead] = True
                keep = np.zeros(n + 1, dtype=bool)
                keep[behind] = True
                out &= keep[:n]
            self._relevant = out.reshape(atlas.shape)
        return self._relevant

    def prepare(self) -> None:
        """Compute the margins of every contact mode the lattice's moves make now (so that none is
        computed while a planner runs)."""
        from .lattice import _moves

        opts = self.atlas.scene.options
        for kind, _, step in _moves(opts.reverse_primitives):
            if not (opts.forbid_partial and kind in "DX"):
                self.move(kind, tuple(step))

    # -- per state -------------------------------------------------------------------------------
    def mode(self, sa: int, sb: int) -> NDArray[np.float64]:
        """Friction margin (rad) in contact mode (sa, sb) of every lattice state, -inf where the
        atlas finds the mode insecure or the state lies on no plan (relevant); shape of the lattice."""
        key = (int(sa), int(sb))
        if key not in self._mode:
            ok = self.atlas.mode_ok(*key) & self.relevant
            out = np.full(self.atlas.shape, -np.inf)
            idx = np.nonzero(ok)
            if len(idx[0]):
                th, d, ps = (self.atlas.axes[a][idx[a]] for a in range(3))
                s = self.atlas.scene
                out[idx] = friction_margin(th, d, ps, key[0], key[1], s.mu, s.options.sliding_model)
                self.computed_states += len(idx[0])
            self._mode[key] = out
        return self._mode[key]

    def move(self, kind: str, step: tuple[int, int, int]) -> NDArray[np.float64]:
        """The margin (rad) at every lattice state in the contact mode of a leg of this kind moving
        by the index step (T, P, D along one axis; X along d and psi), -inf where insecure: the
        mode the atlas's leg_ok (and the lattice search) checks there."""
        key = (kind,) + tuple(int(np.sign(x)) for x in step)
        if key not in self._move:
            atlas = self.atlas
            if kind == "T":
                out = self.mode(0, 0)
            elif kind == "P":
                _, sb = primitive_sliding_signs("P_psi", 1.0, 0.0, 0.0, float(step[PSI]))
                out = self.mode(0, int(sb))
            else:
                d, psi = np.meshgrid(atlas.axes[D], atlas.axes[PSI], indexing="ij")
                dpsi = step[PSI] * atlas.res[PSI] if kind == "X" else 0.0
                sa, sb = primitive_sliding_signs("P_dpsi", d, psi, step[D] * atlas.res[D], dpsi)
                out = np.full(atlas.shape, -np.inf)
                for b in np.unique(sb):
                    sel = (sb == b)[None]
                    out = np.where(sel, self.mode(int(sa.flat[0]), int(b)), out)
            self._move[key] = out
        return self._move[key]

    # -- legs and motions ------------------------------------------------------------------------
    def leg_states(self, leg: Leg) -> tuple[NDArray[np.int_], NDArray[np.float64]]:
        """The lattice indices a leg passes (n, 3), ends included, and the margin (rad) of each in
        the leg's mode there (n,)."""
        a, b = np.asarray(leg.start), np.asarray(leg.end)
        diff = b - a
        n = int(np.max(np.abs(diff)))
        if n == 0:
            idx = a[None]
            return idx, np.array([self.mode(0, 0)[tuple(a)]])
        t = np.arange(n + 1) / n
        idx = a[None] + np.rint(t[:, None] * diff[None]).astype(int)
        step = np.sign(diff).astype(int)
        if leg.kind == "X":  # B's mode from the diagonal's own direction, as the atlas checks it
            d = self.atlas.axes[D][idx[:, D]]
            psi = self.atlas.axes[PSI][idx[:, PSI]]
            sa, sb = primitive_sliding_signs("P_dpsi", d, psi, diff[D] * self.atlas.res[D], diff[PSI] * self.atlas.res[PSI])
            m = np.empty(n + 1)
            for bsign in np.unique(sb):
                sel = sb == bsign
                m[sel] = self.mode(int(sa.flat[0]), int(bsign))[tuple(idx[sel].T)]
            return idx, m
        return idx, self.move(leg.kind, tuple(step))[tuple(idx.T)]

    def _skip_start(self, idx: NDArray[np.int_], m: NDArray[np.float64]) -> NDArray[np.float64]:
        """m with the start state's entries left out (+inf)."""
        if self.start is None:
            return m
        at = np.all(idx == np.asarray(self.start), axis=1)
        return np.where(at, np.inf, m) if at.any() else m

    def _axis_margins(self, leg: Leg) -> NDArray[np.float64] | None:
        """For a leg along one axis (T, P, D): the margins of the states it passes in travel order,
        the start state's +inf, by slicing (what leg_states gives, faster); None for X."""
        if leg.kind == "X":
            return None
        axis = LEG_AXES[leg.kind][0]
        a, b = leg.start, leg.end
        if a == b:
            return None
        step = [0, 0, 0]
        forward = b[axis] > a[axis]
        step[axis] = 1 if forward else -1
        index: list = list(a)
        index[axis] = slice(a[axis], b[axis] + 1) if forward else slice(b[axis], a[axis] + 1)
        vals = self.move(leg.kind, tuple(step))[tuple(index)]
        if not forward:
            vals = vals[::-1]
        if a == self.start:
            vals = vals.copy()
            vals[0] = np.inf
        return vals

    def leg_margin(self, leg: Leg) -> float:
        """The smallest margin (rad) along a leg, in its mode, the start state left out (+inf for
        a leg that passes nothing else)."""
        vals = self._axis_margins(leg)
        if vals is not None:
            return float(vals.min())
        idx, m = self.leg_states(leg)
        return float(self._skip_start(idx, m).min())

    def leg_penalty(self, leg: Leg) -> float:
        """Sum over the leg's lattice steps of the step's weighted L1 length over its margin in
        degrees (reference units per degree), a step's margin being the smaller of its ends' (the
        start left out); inf on an insecure step."""
        m = self._axis_margins(leg)
        if m is not None:
            unit = np.zeros(3)
            axis = LEG_AXES[leg.kind][0]
            unit[axis] = 1
        else:
            idx, m = self.leg_states(leg)
            if len(idx) < 2:
                return 0.0
            m = self._skip_start(idx, m)
            unit = idx[1] - idx[0]
        edge = np.minimum(m[:-1], m[1:])
        if not np.all(np.isfinite(edge) | (edge == np.inf)) or np.any(edge == -np.inf):
            return math.inf
        length = reference_cost(unit * self.atlas.res, self.atlas.scene.options.d_weight)
        return float(np.sum(length / np.maximum(np.degrees(edge), MARGIN_FLOOR_DEG)))

    def motion(self, a: tuple[int, int, int], b: tuple[int, int, int]) -> tuple[float, float]:
        """(margin rad, penalty) of the motion from lattice index a to b: over its secure
        realisations, the largest smallest margin and the smallest penalty; (-inf, inf) when no
        secure staircase realises it."""
        key = (a, b)
        if key in self._motions:
            return self._motions[key]
        if len(self._motions) > MOTION_CACHE:
            self._motions.clear()
        out = self._motion(a, b)
        self._motions[key] = out
        return out

    def _motion(self, a: tuple[int, int, int], b: tuple[int, int, int]) -> tuple[float, float]:
        atlas = self.atlas
        if not atlas.allowed(tuple(b[k] - a[k] for k in range(3))):
            return -math.inf, math.inf
        if a == b:
            return (float(self.mode(0, 0)[a]), 0.0) if atlas.holdable[a] else (-math.inf, math.inf)
        best_m, best_p = -math.inf, math.inf
        for legs in atlas.realisations(a, b):
            if all(atlas.leg_secure(l.kind, l.start, l.end) for l in legs):
                best_m = max(best_m, min(self.leg_margin(l) for l in legs))
                best_p = min(best_p, sum(self.leg_penalty(l) for l in legs))
        return best_m, best_p


__all__ = ["LatticeMargins", "MARGIN_FLOOR_DEG", "OBJECTIVES"]
