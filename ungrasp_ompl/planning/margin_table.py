"""Friction margins of lattice states, each computed once for every lattice that has the state.

The friction margin of a state in a contact mode (mechanics.margin.friction_margin, rad) is a
function of its arguments alone: the state (theta rad, d over l, psi rad), the mode (the sliding
signs at A and B) and the plane's friction (its coefficients and their range, the sliding model,
and on a curved section the finger's contact; mechanics.force_closure.Friction). The object's
size and outline, the digits, the solids around it and the planning options do not enter it. The
lattices of scenes with the same start, resolution and planning box have the same axes, so scenes
with the same friction share every state's margin: a layout's pieces (d is a fraction of each
piece's own length, theta and psi are angles), whatever their shape, and a scene's replan without
P_dpsi (planning.setup.with_landing_spread).

MarginTable keeps, per friction, lattice axes and mode, the margin of every lattice state computed
so far, keyed by those values themselves (the floats by their bits, never an object), and computes
a state's margin where it is first asked for. friction_margin decides each state on its own, so a
margin is the same bits whichever states it is computed with: the table's answers are
friction_margin's.

A table can be shared with the processes this one forks afterwards (MarginTable.share, before the
fork): its values then live in memory that the parent and its children map alike, so a margin one
child computes serves the others. Each value is one aligned 64-bit word, written whole, and a word
still zero is a state not computed yet (the values are stored as their bits exclusive-or a NaN that
friction_margin never returns), so a process reads either nothing or the whole value; two processes
computing one state write the same bits.
"""

from __future__ import annotations

import math
import mmap
import pickle
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..mechanics import Friction
from ..mechanics.margin import friction_margin

#: The stored word of a state not computed yet is 0: a value is stored as its bits exclusive-or
#: these, the bits of a NaN whose payload no arithmetic makes (friction_margin returns finite
#: margins, -inf, or at worst the default NaN).
_UNKNOWN = np.uint64(0x7FF8_0000_DEAD_BEEF)

#: The contact modes (A's sliding sign, B's) a primitive leg can make: every table share() makes.
MODES = tuple((a, b) for a in (-1, 0, 1) for b in (-1, 0, 1))

#: The most bytes of tables a MarginTable keeps (their lattices' states times 8 per mode); beyond
#: it the oldest table is dropped first (its margins are computed again when asked for).
MAX_BYTES = 64 * 2 ** 20


class MarginTable:
    """Friction margins (rad) of lattice states by friction, lattice axes and contact mode, each
    computed once (see the module docstring)."""

    def __init__(self, max_bytes: int = MAX_BYTES):
        """max_bytes: the most bytes of tables kept (MAX_BYTES)."""
        self.max_bytes = max_bytes
        self._tables: dict[tuple, NDArray[np.uint64]] = {}
        self._buffers: dict[tuple, mmap.mmap] = {}  # the shared tables' memory, kept open with them
        #: States whose margin was computed here (not found in a table), over every call.
        self.computed_states = 0

    def margins(self, axes: Sequence[NDArray[np.float64]], idx: tuple[NDArray[np.intp], ...], a_sign: int,
                b_sign: int, friction: Friction) -> NDArray[np.float64]:
        """The friction margins (rad) of the lattice states idx (index arrays into axes: theta rad,
        d over l, psi rad) in contact mode (a_sign, b_sign) with friction: what
        friction_margin(axes[0][idx[0]], axes[1][idx[1]], axes[2][idx[2]], a_sign, b_sign, friction)
        returns, bit for bit, the states not computed before computed now."""
        table = self._table(_key(axes, a_sign, b_sign, friction), tuple(len(ax) for ax in axes))
        codes = table[idx]
        todo = codes == 0
        if todo.any():
            new = tuple(i[todo] for i in idx)
            values = friction_margin(*(ax[i] for ax, i in zip(axes, new)), a_sign, b_sign, friction)
            codes[todo] = values.view(np.uint64) ^ _UNKNOWN
            table[new] = codes[todo]
            self.computed_states += len(values)
        return (codes ^ _UNKNOWN).view(np.float64)

    def share(self, axes: Sequence[NDArray[np.float64]], friction: Friction) -> None:
        """Keep the tables of these lattice axes and friction, in every contact mode (MODES), in
        memory that the processes this one forks from now on share with it (and with each other):
        a margin any of them computes then serves them all. Margins computed here before are kept."""
        shape = tuple(len(ax) for ax in axes)
        for a, b in MODES:
            key = _key(axes, a, b, friction)
            if key in self._buffers:
                continue
            size = max(math.prod(shape), 1) * 8
            buffer = mmap.mmap(-1, size)  # anonymous and shared: a forked child maps the same pages
            table = np.frombuffer(buffer, dtype=np.uint64, count=math.prod(shape)).reshape(shape)
            if key in self._tables:
                table[...] = self._tables.pop(key)
            self._store(key, table, buffer)

    def _table(self, key: tuple, shape: tuple[int, ...]) -> NDArray[np.uint64]:
        """The table of key (a lattice of shape), made empty (every word 0) on first use."""
        table = self._tables.get(key)
        if table is None:
            table = np.zeros(shape, dtype=np.uint64)  # untouched pages cost nothing
            self._store(key, table, None)
        return table

    def _store(self, key: tuple, table: NDArray[np.uint64], buffer: mmap.mmap | None) -> None:
        """Keep table under key (its shared memory buffer, if any), dropping the oldest tables
        beyond max_bytes."""
        self._tables[key] = table
        if buffer is not None:
            self._buffers[key] = buffer
        while len(self._tables) > 1 and sum(t.nbytes for t in self._tables.values()) > self.max_bytes:
            oldest = next(iter(self._tables))
            del self._tables[oldest]
            self._buffers.pop(oldest, None)  # closed when no array uses it any more


def _key(axes: Sequence[NDArray[np.float64]], a_sign: int, b_sign: int, friction: Friction) -> tuple:
    """What a state's margin depends on besides the state: the lattice's axes (their values'
    bits), the mode and the friction (its floats' bits, its model, and the finger's contact on a
    curved section by its pickled value)."""
    floats = tuple(float(x).hex() for x in (*friction.mu, *friction.low, *friction.high, friction.uncertainty))
    contact = None if friction.contact_a is None else pickle.dumps(friction.contact_a)
    lattice = tuple(np.ascontiguousarray(ax, dtype=np.float64).tobytes() for ax in axes)
    return lattice, int(a_sign), int(b_sign), floats, str(friction.model), contact


#: The table LatticeMargins computes its friction margins through: one per process (and, shared,
#: across the processes a tiling forks).
MARGIN_TABLE = MarginTable()
