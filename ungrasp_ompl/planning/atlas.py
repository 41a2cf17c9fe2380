"""The secure lattice: where each primitive leg may run, precomputed for a scene.

Motions are checked on a lattice aligned with the start state, at the scene's
resolution (``planning.resolution``): a leg is secure when every lattice state
it passes is kinematically valid, collision-free and force-closed in the
contact mode the leg's velocity makes there. Precomputing this once per
scene, vectorised, turns a motion check during planning into a few array
look-ups (docs/model.md, section 8.2: the check must cost microseconds).

Legs (one primitive each, docs/model.md, section 3.3):

=====  ============  ==============================  ===================
leg    primitive     moves                           sliding
=====  ============  ==============================  ===================
``T``  P_theta       theta                           none
``P``  P_psi         psi                             B
``D``  P_dpsi        d alone                         A, and B unless psi = 90 deg
``X``  P_dpsi        d and psi, opposite signs       A and B (sign of ds_B per state)
``Y``  P_dpsi        psi, while the P_dpsi slides d  A and B (the lattice search's step only)
=====  ============  ==============================  ===================

A T, P or D leg is secure between its lattice states too: each lattice step it makes is
force-closed all the way in the leg's mode (SecurityAtlas.step_ok, with the re-validation's own
check, planning.verify.first_loss_along, over the pieces that re-validation samples), so that a
thin band where the grip is lost between two states that hold (a curved section's, where the
finger's contact passes from its face to its rounded tip) is not stepped over.

A straight motion between two lattice states is realised by a staircase of
such legs, one leg per moving coordinate (or one X leg for d and psi); the
atlas tries every order and takes the one with fewest legs.
"""

from __future__ import annotations

import copy
import functools
import itertools
import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..geometry.collision import CollisionChecker
from ..mechanics import force_closure, kinematic_validity, primitive_sliding_signs
from ..mechanics.contact import sliding_signs
from ..mechanics.section import finger_contact
from ..scene import PlanningOptions, Scene
from ..scene.options import GoalSpec
from .verify import SAMPLES_PER_STEP, first_loss_along

THETA, D, PSI = 0, 1, 2
LEG_PRIMITIVE = {"T": "P_theta", "P": "P_psi", "D": "P_dpsi", "X": "P_dpsi", "Y": "P_dpsi"}
LEG_AXES = {"T": (THETA,), "P": (PSI,), "D": (D,), "X": (D, PSI), "Y": (PSI,)}
#: Forward (paper) direction of each coordinate: theta down, d down, psi up.
FORWARD = np.array([-1, -1, 1])
#: The coordinates' names, in index order.
AXIS_NAMES = ("theta", "d", "psi")


@dataclass(frozen=True)
class Leg:
    """One primitive leg between two lattice indices (both inclusive)."""

    kind: str  # T, P, D or X
    start: tuple[int, int, int]
    end: tuple[int, int, int]

    @property
    def primitive(self) -> str:
        return LEG_PRIMITIVE[self.kind]


#: Motions whose answer (motion_secure) an atlas remembers before the memory is cleared.
MOTION_MEMORY = 200_000

#: The planning options the tables of an atlas depend on (SecurityAtlas.with_options): the sliding
#: model (force closure), the reverse primitives (the legs' directions) and the resolution.
LATTICE_OPTIONS = ("sliding_model", "reverse_primitives", "resolution")

#: Above this share of the lattice's states, force closure is computed over the whole lattice from
#: its axes rather than state by state (the two cost about the same at a quarter, measured on the
#: shipped scenes: state by state costs some 3.5 times as much per state).
SUBSET_SHARE = 0.25


class SecurityAtlas:
    """Secure lattice states per leg kind and direction, for one scene and a box of states.

    box: (2, 3) lower and upper corner in (theta rad, d, psi rad); the lattice
    covers the lattice states inside it. resolution defaults to the scene's.
    """

    def __init__(self, scene: Scene, box: ArrayLike, resolution: ArrayLike | None = None):
        self.scene = scene
        self.res = np.asarray(resolution if resolution is not None else scene.options.resolution, dtype=float)
        self.origin = np.asarray(scene.start, dtype=float)
        self.lo_index, self.axes = lattice_axes(self.origin, self.res, box)
        self.shape = tuple(len(ax) for ax in self.axes)
        if min(self.shape) < 1:
            raise ValueError("the box holds no lattice state")
        th, d, ps = self._lattice = tuple(np.reshape(ax, s) for ax, s in zip(self.axes, ((-1, 1, 1), (1, -1, 1), (1, 1, -1))))
        self.kinematic = np.broadcast_to(kinematic_validity(th, d, ps, scene.digits), self.shape).copy()
        check = self._fc(0, 0, self.kinematic)
        self._checker = CollisionChecker(scene.collision_model())
        self._releasable: dict[tuple, NDArray[np.bool_]] = {}
        self.collision = self._checker.in_collision_lattice(self.axes, where=check)
        #: States that can be held with all contacts sticking.
        self.holdable = check & ~self.collision
        self._mode_ok: dict[tuple[int, int], NDArray[np.bool_]] = {(0, 0): self.holdable}
        self._runs: dict[tuple[str, int], NDArray[np.int32]] = {}
        self._steps: dict[tuple[str, int], NDArray[np.bool_]] = {}
        self._reverse = scene.options.reverse_primitives
        self._no_dpsi = scene.options.forbid_partial  # P_dpsi slides A and B: partial 3D stability
        #: motion_secure's answers by (a, b), and the X legs' by (start, end): a planner asks for
        #: the same lattice motions again (a third of RRT*'s checks on the tangram's pieces)
        self._motions: dict[tuple, bool] = {}
        self._diagonals: dict[tuple, bool] = {}
        self._x_modes: dict[int, NDArray[np.bool_]] = {}  # per A's sign: mode_ok for B's -1, 0, 1
        #: lattice_search's cost optima by goal box (planning.lattice fills it: the lattice planner
        #: and a failure's explanation search once).
        self.cost_optima: dict[tuple, object] = {}
        #: optimum_cost's optima (their costs alone) by goal box: tiling's proof and the planner's
        #: stop at the optimum search once.
        self.optimum_costs: dict[tuple, float | None] = {}
        #: planning.margins.LatticeMargins by objective and goal box (LatticeMargins.of): the margin
        #: search, its cost baseline's report and the lattice's widest path compute them once.
        self.margins: dict[tuple, object] = {}
        self._index_consts = tuple(tuple(float(x) for x in v) for v in (self.origin, self.res)) + (
            tuple(int(x) for x in self.lo_index), self.shape)
        #: with_options's atlases by their options.
        self._twins: dict[PlanningOptions, SecurityAtlas] = {}

    def with_options(self, options: PlanningOptions) -> "SecurityAtlas":
        """This lattice for this atlas's scene with other planning options (with_landing_spread's
        replan without P_dpsi: planning.forbid_partial on, no landing bound), made once per options
        and kept: an atlas whose scene is the scene with those options, the same as one built for
        it (SecurityAtlas(scene, box)), which shares every table of a lattice state with this one
        (its kinematics, collisions, force closure per contact mode, secure steps and runs, goal
        states the gripper can let go from), since none depends on the options that may differ;
        the answers that depend on them (which legs are secure: forbid_partial; the searches'
        optima and margins) are its own. ValueError for options that change those tables (the
        sliding model, reverse primitives, the resolution)."""
        own = self.scene.options
        changed = [f for f in LATTICE_OPTIONS if getattr(options, f) != getattr(own, f)]
        if changed:
            raise ValueError(f"planning options {', '.join(changed)} change the lattice's tables: build an atlas")
        if options == own:
            return self
        if options not in self._twins:
            twin = copy.copy(self)
            twin.scene = replace(self.scene, options=options)
            twin._no_dpsi = options.forbid_partial
            for name in ("_releasable", "_mode_ok", "_runs", "_steps", "_x_modes"):  # tables: shared, each kept apart
                setattr(twin, name, dict(getattr(self, name)))
            twin._motions, twin._diagonals, twin._twins = {}, {}, {}  # which legs are secure: the twin's own
            twin.cost_optima, twin.optimum_costs, twin.margins = {}, {}, {}
            self._twins[options] = twin
        return self._twins[options]

    def prepare(self) -> None:
        """Compute every leg table planning may need now, so none is built lazily while planning."""
        directions = (1, -1) if self._reverse else (1,)
        for sign in directions:
            for kind, axis in (("T", THETA), ("P", PSI), ("D", D)):
                self.runs(kind, int(sign * FORWARD[axis]))
            sa = int(sign * FORWARD[D])
            for sb in (-1, 0, 1):  # X legs pick their B mode per state
                self.mode_ok(sa, sb)

    # -- lattice coordinates -----------------------------------------------------
    def index(self, q: ArrayLike) -> tuple[int, int, int] | None:
        """Lattice index of the state nearest q, or None outside the lattice."""
        (o0, o1, o2), (r0, r1, r2), (l0, l1, l2), (n0, n1, n2) = self._index_consts  # unrolled: a planner hot path
        i, j, k = round((q[0] - o0) / r0) - l0, round((q[1] - o1) / r1) - l1, round((q[2] - o2) / r2) - l2
        if 0 <= i < n0 and 0 <= j < n1 and 0 <= k < n2:
            return i, j, k
        return None

    def state(self, idx: ArrayLike) -> NDArray[np.float64]:
        """The state (theta, d, psi) of a lattice index."""
        idx = np.asarray(idx)
        return self.origin + self.res * (idx + self.lo_index)

    def holdable_in(self, box: ArrayLike) -> NDArray[np.bool_]:
        """Holdable lattice states inside box ((2, 3) corners), shape of the lattice."""
        box = np.asarray(box, dtype=float)
        inside = [(ax >= box[0, a] - 1e-9) & (ax <= box[1, a] + 1e-9) for a, ax in enumerate(self.axes)]
        return self.holdable & inside[0][:, None, None] & inside[1][None, :, None] & inside[2][None, None, :]

    def releasable_in(self, box: ArrayLike) -> NDArray[np.bool_]:
        """Holdable lattice states inside box from which the gripper lets go (the scene's termination,
        robot.termination) without hitting the table, an obstacle or a solid; shape of the lattice.
        These are the goal states: a plan that ends where the gripper cannot let go is no plan."""
        key = tuple(np.asarray(box, dtype=float).ravel().round(12))
        if key not in self._releasable:
            mask = self.holdable_in(box)
            idx = np.flatnonzero(mask)
            if len(idx):
                mask.flat[idx[self._no_let_go(idx)]] = False
            self._releasable[key] = mask
        return self._releasable[key]

    def can_let_go_in(self, box: ArrayLike, chunk: int = 64) -> bool:
        """Whether some holdable state in box lets the gripper go: releasable_in(box).any(), but
        checked a chunk of states at a time and stopping at the first that does."""
        key = tuple(np.asarray(box, dtype=float).ravel().round(12))
        if key in self._releasable:
            return bool(self._releasable[key].any())
        idx = np.flatnonzero(self.holdable_in(box))
        return any(not self._no_let_go(idx[k:k + chunk]).all() for k in range(0, len(idx), chunk))

    def _no_let_go(self, idx: NDArray) -> NDArray[np.bool_]:
        """For flat lattice indices: the scene's termination maneuver would collide."""
        r = self.scene.robot
        q = np.column_stack([ax[i] for ax, i in zip(self.axes, np.unravel_index(idx, self.shape))])
        return self._checker.termination_collides(q, r.termination, r.termination_amount)

    # -- per-mode security -------------------------------------------------------
    def _fc(self, sa: int, sb: int, where: NDArray[np.bool_]) -> NDArray[np.bool_]:
        """Force closure in contact mode (sa, sb) at the lattice states where is True (False at
        the others), shape of the lattice. Where few states are asked for (a tenth of a wide
        lattice is kinematically valid), only those are computed; otherwise the whole lattice from
        its axes, which shares the work of every state with the same theta and d or theta and psi
        (force_closure). Force closure is decided state by state, so both give the same answer."""
        if np.count_nonzero(where) > SUBSET_SHARE * where.size:
            return force_closure(*self._lattice, sa, sb, self.scene.friction) & where
        idx = np.nonzero(where)
        out = np.zeros(self.shape, dtype=bool)
        if len(idx[0]):
            out[idx] = force_closure(*(ax[i] for ax, i in zip(self.axes, idx)), sa, sb, self.scene.friction)
        return out

    def mode_ok(self, sa: int, sb: int) -> NDArray[np.bool_]:
        """Secure lattice states for contact mode (sa, sb), shape of the lattice.

        Only states where a primitive can make that mode are computed: with A
        sliding, B slides the other way or sticks only where psi >= 90 deg.
        """
        key = (sa, sb)
        if key not in self._mode_ok:
            where = self.holdable.copy()
            if sa != 0 and sb != sa:
                where[:, :, :int(np.searchsorted(self.axes[PSI], math.pi / 2 - 1e-9))] = False
            self._mode_ok[key] = self._fc(sa, sb, where)
        return self._mode_ok[key]

    def leg_ok(self, kind: str, direction: int) -> NDArray[np.bool_]:
        """Secure lattice states for an axis leg (T, P or D) run in a direction (+1 or -1 along its coordinate)."""
        if kind == "T":
            return self.holdable
        if kind == "P":
            _, sb = primitive_sliding_signs("P_psi", 1.0, 0.0, 0.0, direction)
            return self.mode_ok(0, int(sb))
        # D: A slides with dd, B with cos(psi) dd (sticks at psi = 90 deg exactly)
        d, psi = np.meshgrid(self.axes[D], self.axes[PSI], indexing="ij")
        _, sb = primitive_sliding_signs("P_dpsi", d, psi, direction, 0.0)
        out = np.zeros(self.shape, dtype=bool)
        for b in np.unique(sb):
            out |= self.mode_ok(direction, int(b)) & (sb == b)[None]
        return out

    def step_ok(self, kind: str, direction: int) -> NDArray[np.bool_]:
        """Per lattice state: a leg of this kind (T, P or D) run in direction (+1 or -1 along its
        coordinate) is secure at this state and the next one along its coordinate (leg_ok) and
        force-closed all the way between them in its contact mode: at the SAMPLES_PER_STEP pieces'
        ends the re-validation samples and between them (planning.verify.first_loss_along) where
        the finger's contact on a curved section passes between its face and its rounded tip
        (_contact_turns: the one place where the contact wrenches turn at a rate that changes at
        once); False at the lattice's last state that way. Shape of the lattice."""
        key = (kind, direction)
        if key not in self._steps:
            axis = LEG_AXES[kind][0]
            ok = self.leg_ok(kind, direction)
            src, dst = [slice(None)] * 3, [slice(None)] * 3
            src[axis], dst[axis] = (slice(0, -1), slice(1, None)) if direction > 0 else (slice(1, None), slice(0, -1))
            both = np.zeros(self.shape, dtype=bool)
            both[tuple(src)] = ok[tuple(src)] & ok[tuple(dst)]
            idx = np.nonzero(both)
            q0 = np.column_stack([ax[i] for ax, i in zip(self.axes, idx)])
            move = np.zeros(3)
            move[axis] = direction * self.res[axis] / SAMPLES_PER_STEP
            sa, sb = primitive_sliding_signs(LEG_PRIMITIVE[kind], q0[:, D], q0[:, PSI], move[D], move[PSI])
            secure = np.ones(len(q0), dtype=bool)
            turns = self._contact_turns(axis, direction)
            for j in range(SAMPLES_PER_STEP):
                live = np.flatnonzero(secure & turns[j][idx[D], idx[PSI]])
                start = q0[live] + j * move
                secure[live] = np.isnan(first_loss_along(start, start + move, sa[live], sb[live], self.scene.friction))
            both[idx] = secure
            self._steps[key] = both
        return self._steps[key]

    def _contact_turns(self, axis: int, direction: int) -> list[NDArray[np.bool_]]:
        """For each of the SAMPLES_PER_STEP pieces of a lattice step along axis in direction: per
        (d, psi) of the lattice (shape (n_d, n_psi)), whether the finger's contact on the scene's
        curved section passes between its face and its rounded tip within the piece (there a
        contact wrench turns at a rate that changes at once, and force closure can be lost and
        regained within the piece); all False for a flat object or along theta, which moves no
        contact over the object."""
        shape = (len(self.axes[D]), len(self.axes[PSI]))
        contact = self.scene.friction.contact_a
        if contact is None or axis == THETA:
            return [np.zeros(shape, dtype=bool)] * SAMPLES_PER_STEP
        on_face = []
        for j in range(SAMPLES_PER_STEP + 1):
            shift = np.zeros(3)
            shift[axis] = direction * self.res[axis] * j / SAMPLES_PER_STEP
            d, psi = self.axes[D][:, None] + shift[D], self.axes[PSI][None, :] + shift[PSI]
            on_face.append(finger_contact(contact.section, d, psi, contact.tip_radius).on_face)
        return [a != b for a, b in zip(on_face[:-1], on_face[1:])]

    def runs(self, kind: str, direction: int) -> NDArray[np.int32]:
        """How many consecutive secure states a leg finds from each lattice state on, its start
        included, each reached by a secure step (step_ok) from the one before."""
        key = (kind, direction)
        if key not in self._runs:
            axis = LEG_AXES[kind][0]
            ok = np.moveaxis(self.leg_ok(kind, direction), axis, -1)
            link = np.moveaxis(self.step_ok(kind, direction), axis, -1)
            if direction < 0:
                ok, link = ok[..., ::-1], link[..., ::-1]
            # secure steps in a row from each state on, walking toward the end of the axis
            n = ok.shape[-1]
            pos = np.arange(n)
            blocked = np.where(link, n, pos)
            nxt = np.minimum.accumulate(blocked[..., ::-1], axis=-1)[..., ::-1]
            run = np.where(ok, nxt - pos + 1, 0).astype(np.int32)
            if direction < 0:
                run = run[..., ::-1]
            self._runs[key] = np.ascontiguousarray(np.moveaxis(run, -1, axis))
        return self._runs[key]

    # -- legs and motions --------------------------------------------------------
    def allowed(self, step: tuple[int, int, int]) -> bool:
        """Whether the coordinate signs of a motion are allowed (all forward unless reverse primitives are on)."""
        if self._reverse:
            return True
        return step[THETA] <= 0 and step[D] <= 0 and step[PSI] >= 0

    def leg_secure(self, kind: str, start: tuple[int, int, int], end: tuple[int, int, int]) -> bool:
        """Whether a single leg from lattice index start to end is secure."""
        if self._no_dpsi and kind in "DX":
            return False
        if kind == "X":
            return self._diagonal_secure(start, end)
        axis = LEG_AXES[kind][0]
        n = end[axis] - start[axis]
        if n == 0:
            return bool(self.holdable[start])
        return bool(self.runs(kind, 1 if n > 0 else -1)[start] > abs(n))

    def _diagonal_secure(self, start: tuple[int, int, int], end: tuple[int, int, int]) -> bool:
        """An X leg: every lattice state it passes (its d and psi rounded along the straight line)
        secure in the mode the leg's own direction makes there (A slides with dd, B with the sign
        of ds_B, per state: mechanics.contact's P_dpsi)."""
        key = (start, end)
        known = self._diagonals.get(key)
        if known is not None:
            return known
        dj, dk = end[D] - start[D], end[PSI] - start[PSI]
        n = max(abs(dj), abs(dk))
        t = np.arange(n + 1) / n
        jj = start[D] + np.rint(t * dj).astype(int)
        kk = start[PSI] + np.rint(t * dk).astype(int)
        _, sb = sliding_signs(self.axes[D][jj], self.axes[PSI][kk], dj * self.res[D], dk * self.res[PSI])
        sa = 1 if dj > 0 else -1
        if sa not in self._x_modes:
            self._x_modes[sa] = np.stack([self.mode_ok(sa, b) for b in (-1, 0, 1)])
        secure = bool(self._x_modes[sa][sb.astype(np.intp) + 1, start[THETA], jj, kk].all())
        self._diagonals[key] = secure
        return secure

    def realisations(self, a: tuple[int, int, int], b: tuple[int, int, int]):
        """Candidate leg sequences (lists of Leg) from lattice index a to b, fewest legs first."""
        for order in _orders(*_signs(a, b)):
            legs, cur = [], a
            for kind in order:
                nxt = list(cur)
                for axis in LEG_AXES[kind]:
                    nxt[axis] = b[axis]
                nxt = tuple(nxt)
                legs.append(Leg(kind, cur, nxt))
                cur = nxt
            yield legs

    def realise(self, a: tuple[int, int, int], b: tuple[int, int, int]) -> list[list[Leg]]:
        """Every secure leg sequence from a to b ([] if none). A motion that stays put gives [[]] when a is holdable."""
        if not self.allowed(tuple(b[k] - a[k] for k in range(3))):
            return []
        if a == b:
            return [[]] if self.holdable[a] else []
        return [legs for legs in self.realisations(a, b) if all(self.leg_secure(l.kind, l.start, l.end) for l in legs)]

    def motion_secure(self, a: tuple[int, int, int], b: tuple[int, int, int]) -> bool:
        """Whether some staircase of secure legs leads from lattice index a to b (first found wins)."""
        key = (a, b)
        known = self._motions.get(key)
        if known is None:
            if len(self._motions) >= MOTION_MEMORY:
                self._motions.clear()
                self._diagonals.clear()
            known = self._motions[key] = self._staircase_secure(a, b)
        return known

    def _staircase_secure(self, a: tuple[int, int, int], b: tuple[int, int, int]) -> bool:
        """motion_secure, worked out."""
        if not self.allowed(tuple(b[k] - a[k] for k in range(3))):
            return False
        if a == b:
            return bool(self.holdable[a])
        for order in _orders(*_signs(a, b)):  # realisations' orders, without Leg objects
            cur = a
            for kind in order:
                nxt = list(cur)
                for axis in LEG_AXES[kind]:
                    nxt[axis] = b[axis]
                nxt = tuple(nxt)
                if not self.leg_secure(kind, cur, nxt):
                    break
                cur = nxt
            else:
                return True
        return False


def _signs(a: tuple[int, int, int], b: tuple[int, int, int]) -> tuple[int, int, int]:
    """The sign of each coordinate's change from lattice index a to b."""
    return tuple((y > x) - (y < x) for x, y in zip(a, b))


@functools.lru_cache(maxsize=None)
def _orders(dtheta: int, dd: int, dpsi: int) -> tuple[tuple[str, ...], ...]:
    """The leg kinds of every staircase of a step with these coordinate signs, in every order,
    fewest legs first: T if theta moves, then D and P, or one X where d and psi move oppositely."""
    kinds = ("T",) if dtheta else ()
    groups = [kinds + (("D",) if dd else ()) + (("P",) if dpsi else ())]
    if dd and dpsi and dd * dpsi < 0:
        groups.append(kinds + ("X",))
    groups.sort(key=len)
    return tuple(order for group in groups for order in itertools.permutations(group))


def lattice_axes(origin: NDArray, res: NDArray, box: ArrayLike) -> tuple[NDArray[np.int_], list[NDArray]]:
    """The lattice through origin with steps res ((theta rad, d, psi rad) each) inside box ((2, 3)
    corners): the index of its lowest state per coordinate (in steps from origin) and the values
    along each coordinate (an axis may be empty)."""
    box = np.asarray(box, dtype=float)
    lo = np.ceil((box[0] - origin) / res - 1e-9).astype(int)
    hi = np.floor((box[1] - origin) / res + 1e-9).astype(int)
    return lo, [origin[a] + res[a] * np.arange(lo[a], hi[a] + 1) for a in range(3)]


def planning_box(scene: Scene) -> NDArray[np.float64]:
    """The states a plan can visit: the scene bounds, cut down to the box between start
    and goal when only forward primitives run (each coordinate then moves one way). Along a
    coordinate where the goal lies wholly behind the start (goal_behind_start) the box keeps the
    start's value alone. A goal narrowed from the scene's region (GoalSpec.within) keeps the
    region's box: narrowing says where a plan ends, not where it may pass."""
    box = _forward_box(scene, scene.goal.region())
    behind = box[0] > box[1]
    box[:, behind] = scene.start[behind]
    return box


def goal_behind_start(scene: Scene) -> list[str]:
    """The coordinates (names as in AXIS_NAMES) along which the goal region lies wholly behind the
    start, so that primitives moving only forward (theta and d down, psi up) never reach it."""
    box = _forward_box(scene, scene.goal)
    return [AXIS_NAMES[a] for a in range(3) if box[0, a] > box[1, a]]


def goal_cut_by_start(scene: Scene) -> list[str]:
    """The coordinates (names as in AXIS_NAMES) along which part of the goal region lies behind
    the start, so that primitives moving only forward reach the rest alone: a goal whose d range
    reaches above the start's d, or whose psi range begins below the start's psi."""
    if scene.options.reverse_primitives:
        return []
    glo, ghi = scene.goal.box()
    start = scene.start
    return [AXIS_NAMES[a] for a, sign in enumerate(FORWARD)
            if (ghi[a] > start[a] if sign < 0 else glo[a] < start[a])]


def _forward_box(scene: Scene, goal: GoalSpec) -> NDArray[np.float64]:
    """planning_box toward goal, before an empty coordinate range is replaced by the start's value."""
    box = scene.bounds.copy()
    if scene.options.reverse_primitives:
        return box
    glo, ghi = goal.box()
    start = scene.start
    for a, sign in enumerate(FORWARD):
        if sign < 0:  # coordinate decreases from the start to the goal
            box[:, a] = [max(box[0, a], glo[a]), min(box[1, a], start[a])]
        else:
            box[:, a] = [max(box[0, a], start[a]), min(box[1, a], ghi[a])]
    return box


def reference_cost(step: ArrayLike, d_weight: float) -> float:
    """Weighted L1 length of a step (dtheta, dd, dpsi) in the reference units: degrees + d_weight * d."""
    s = np.abs(np.asarray(step, dtype=float))
    return math.degrees(s[..., THETA] + s[..., PSI]) + d_weight * s[..., D]
