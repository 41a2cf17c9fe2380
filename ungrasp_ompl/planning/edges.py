"""The secure lattice's edges: one per lattice step of a primitive that is secure in its contact
mode at both ends (docs/model.md, section 8.2), and for a T, P or D step force-closed between them
(SecurityAtlas.step_ok), built from the atlas's tables a move at a time.
The exact search (lattice.py) and the robust objectives' margins (margins.py) both search them.
Indices are flat lattice indices; lengths in reference units."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..mechanics import primitive_sliding_signs
from .atlas import D, FORWARD, LEG_AXES, PSI, THETA, SecurityAtlas, reference_cost


def _moves(reverse: bool, turns: bool = False):
    """(leg kind, primitive slot, index step) of every lattice move; turns: with the Y steps."""
    out = []
    for sign in (1, -1) if reverse else (1,):
        base = 0 if sign == 1 else 3
        t = [0, 0, 0]
        t[THETA] = sign * FORWARD[THETA]
        p = [0, 0, 0]
        p[PSI] = sign * FORWARD[PSI]
        dd = [0, 0, 0]
        dd[D] = sign * FORWARD[D]
        x = [0, 0, 0]
        x[D], x[PSI] = sign * FORWARD[D], sign * FORWARD[PSI]
        out += [("T", base + 0, t), ("P", base + 1, p), ("D", base + 2, dd), ("X", base + 2, x)]
        if turns:
            out.append(("Y", base + 2, p))
    return out


def _move_ok(atlas: SecurityAtlas, kind: str, step: list[int], turns: bool = False) -> NDArray[np.bool_]:
    """Per lattice state: the leg's mode is secure there (for X, in the diagonal's own B mode;
    with turns, a P_dpsi step in some mode a P_dpsi makes there, dpsi_region)."""
    if turns and kind in "DXY":
        sa = step[D] if kind != "Y" else step[PSI] * FORWARD[PSI] * FORWARD[D]  # Y: the P_dpsi's own sense
        return dpsi_region(atlas, int(sa))
    if kind != "X":
        axis = {"T": THETA, "P": PSI, "D": D}[kind]
        return atlas.leg_ok(kind, step[axis])
    d, psi = np.meshgrid(atlas.axes[D], atlas.axes[PSI], indexing="ij")
    sa, sb = primitive_sliding_signs("P_dpsi", d, psi, step[D] * atlas.res[D], step[PSI] * atlas.res[PSI])
    out = np.zeros(atlas.shape, dtype=bool)
    for b in np.unique(sb):
        out |= atlas.mode_ok(int(sa.flat[0]), int(b)) & (sb == b)[None]
    return out


def dpsi_region(atlas: SecurityAtlas, sa: int) -> NDArray[np.bool_]:
    """Lattice states secure in some contact mode a P_dpsi sliding d with sign sa (psi still or
    moving the other way, at any slope) makes there: A slides with sa, B with the sign of ds_B,
    which runs from d alone's (cos(psi) sa) to psi alone's limit (sa d sin(psi)) as the slope
    steepens, through every sign between (one sign below psi = 90 deg); shape of the lattice."""
    d, psi = np.meshgrid(atlas.axes[D], atlas.axes[PSI], indexing="ij")
    _, alone = primitive_sliding_signs("P_dpsi", d, psi, float(sa), 0.0)
    _, steep = primitive_sliding_signs("P_dpsi", d, psi, sa * 1e-6, -float(sa))
    lo, hi = np.minimum(alone, steep), np.maximum(alone, steep)
    out = np.zeros(atlas.shape, dtype=bool)
    for b in (-1, 0, 1):
        if ((lo <= b) & (b <= hi)).any():
            out |= atlas.mode_ok(int(sa), b) & ((lo <= b) & (b <= hi))[None]
    return out


def _shifted(shape: tuple[int, ...], step: list[int]) -> tuple[tuple[slice, ...], tuple[slice, ...]]:
    """Slices of the lattice for the sources and destinations of a move by step."""
    src = [slice(None)] * 3
    dst = [slice(None)] * 3
    for a in range(3):
        if step[a] > 0:
            src[a], dst[a] = slice(0, shape[a] - step[a]), slice(step[a], None)
        elif step[a] < 0:
            src[a], dst[a] = slice(-step[a], None), slice(0, shape[a] + step[a])
    return tuple(src), tuple(dst)


@dataclass(frozen=True)
class LatticeEdges:
    """The lattice's secure moves: an edge per lattice step of a primitive that is secure in its
    contact mode at both ends, grouped by move (edges offsets[k]:offsets[k + 1] are moves[k])."""

    moves: list[tuple[str, int, list[int]]]  #: (leg kind, primitive slot, index step) of each move
    offsets: NDArray[np.int_]  #: where each move's edges begin, and the end (len(moves) + 1)
    src: NDArray[np.int_]  #: flat lattice index of each edge's start
    dst: NDArray[np.int_]  #: flat lattice index of each edge's end
    length: NDArray[np.float64]  #: weighted L1 length of each edge (reference units)


@dataclass(frozen=True)
class LatticeMove:
    """One allowed move of the lattice and where it arrives."""

    kind: str  #: leg kind: T, P, D, X, or Y (a P_dpsi's psi step)
    slot: int  #: primitive slot (0 P_theta, 1 P_psi, 2 P_dpsi; 3-5 the same reversed)
    step: list[int]  #: index step (theta, d, psi)
    length: float  #: weighted L1 length of a step (reference units)
    arrives: NDArray[np.bool_]  #: per lattice state: the move's edge into it is secure at both ends


def lattice_moves(atlas: SecurityAtlas, turns: bool = False) -> list[LatticeMove]:
    """The lattice's allowed moves (forward, or either way with reverse primitives; no P_dpsi when
    partial stability is forbidden), each with the states its secure edges arrive at; turns: with
    the P_dpsi's Y steps, its steps secure in dpsi_region (the cost objective's graph)."""
    opts = atlas.scene.options
    out = []
    for kind, slot, step in _moves(opts.reverse_primitives, turns):
        if opts.forbid_partial and kind in "DXY":
            continue
        ok = _move_ok(atlas, kind, step, turns)
        src, dst = _shifted(atlas.shape, step)
        arrives = np.zeros(atlas.shape, dtype=bool)
        arrives[dst] = ok[src] & ok[dst]
        if kind in "TPD" and not (turns and kind == "D"):  # force-closed between its ends too
            arrives[dst] &= atlas.step_ok(kind, step[LEG_AXES[kind][0]])[src]
        out.append(LatticeMove(kind, slot, step, float(reference_cost(np.asarray(step) * atlas.res, opts.d_weight)),
                               arrives))
    return out


def lattice_edges(atlas: SecurityAtlas, turns: bool = False) -> LatticeEdges:
    """The secure moves of the atlas's lattice (what lattice_search searches, without the last
    primitive) as edges: lattice_moves' moves from every state where they are secure at both ends."""
    shape = atlas.shape
    cell = np.arange(int(np.prod(shape))).reshape(shape)
    moves = lattice_moves(atlas, turns)
    srcs, dsts, lengths = [], [], []
    for move in moves:
        src, dst = _shifted(shape, move.step)
        good = move.arrives[dst]
        srcs.append(cell[src][good])
        dsts.append(cell[dst][good])
        lengths.append(np.full(len(srcs[-1]), move.length))
    offsets = np.concatenate([[0], np.cumsum([len(x) for x in srcs])])
    return LatticeEdges([(m.kind, m.slot, m.step) for m in moves], offsets, np.concatenate(srcs), np.concatenate(dsts),
                        np.concatenate(lengths))


def moved_from(shape: tuple[int, ...], step: list[int], index: NDArray[np.int_], none: int) -> NDArray[np.int_]:
    """Per lattice state: index's value at the state a move by step comes from, none where no
    state of the lattice is that far back; index has the lattice's shape."""
    src, dst = _shifted(shape, step)
    out = np.full(shape, none, dtype=index.dtype)
    out[dst] = index[src]
    return out
