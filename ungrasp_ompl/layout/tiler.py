"""Tiling: the order, manipulation planes and plans that put every piece of a layout into its frame.

Each piece is put down by one ungrasp in a vertical plane through an antipodal
pair (G, B) of its outline. The thumb works beyond B and the object's edge
behind G swings back as it tilts, so a pair only works where the frame and the
pieces already down leave room there: every candidate is checked in its
scene, whose solids are the frame's walls and the earlier pieces (python-fcl,
3D). The search is a depth-first search over placement orders:

1. at each step every remaining piece's approaches are screened; the piece
   with the fewest that pass goes first (the most constrained), then the one
   touching the walls least;
2. a piece's approaches are its antipodal pairs (among its outline's contact
   candidates and the feet of its double normals) that hold x-moments (G or B
   inside a straight side square to GB, or curved contacts at both:
   geometry.plane.flush and curved), both ways round, ranked by the free room
   beyond B and behind G (a ray cast against walls and placed pieces), then by
   the friction margin; near-duplicates are dropped;
3. an approach is screened (the start grasp holdable, some goal state holdable
   with room for the gripper to let go), then proved by the exact lattice
   search; the first approach proved places the piece in the search;
4. a piece that none of its approaches can place now cannot be placed by them
   later either (more pieces only add obstacles), so the search goes back one
   step at once; a set of pieces down from which no order completes the layout
   is not searched again when another order puts the same pieces down. Only
   the best `approaches` planes of a piece are tried: the search is complete
   over orders, not over every antipodal pair.

Once an order is found, each piece's approach is chosen again, with the same
pieces down before it (which an approach does not change: a piece down lies at
its target whichever way it came): among its approaches that pass the screen and
the proof, the one whose exact lattice plan has the largest tolerance of the
`paper` errors (docs/model.md 4.6), the search's order breaking ties
(TilingOptions.rank "tolerance"; the default, "first", keeps the search's choice).

Results are memoised by (pieces down, piece), so no check is repeated, and what
a screen learns that holds with other pieces down (the goal states' kinematics
and force closure, a goal state where the gripper let go, the sets of pieces
down where none could) is kept per piece and approach (GoalStates): later
screens give the same answers sooner. Likewise a proof among some pieces down
holds among any fewer (taking solids away only frees states and moves), and is
taken without building that lattice until a plan needs it. Once an order is found, each piece is
planned with the chosen planner on the lattice its proof built; should a
sampling planner find no path in its time, the lattice path (proved to exist)
is taken and the summary says so. A TilingMemo keeps the scenes, screens, proofs
and reproducible plans of one call for the next on the same layout (another order,
an approach avoided): the second search makes the same checks and finds the same
tiling, computing only what the first did not.

The pieces are planned in forked copies of this process (TilingOptions.jobs at a
time, parallel.forked), each from the moment the search proves it at its place
in the order (its seed is that place's), so that planning goes on beside the
search; a plan whose place the search gives up is given up too. Each plan is the
one this process would make: the same scene, lattice, planner options and seed.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field, replace
from enum import Enum, StrEnum
from typing import Callable, Iterator

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..parallel.forked import Forked, can_fork
from ..parallel.runner import default_jobs
from ..geometry.collision import CollisionChecker
from ..geometry.plane import curved, flush
from ..mechanics import kinematic_validity
from ..mechanics.antipodal import antipodal_pairs
from .. import planning
from ..planning.atlas import SecurityAtlas, lattice_axes, planning_box
from ..planning.lattice import optimum_cost
from ..planning.margin_table import MARGIN_TABLE
from ..planning.plan_tolerance import tolerance_scale
from ..planning.result import Plan, PlanOutcome, describe_outcome
from ..planning.setup import LATTICE, EndsProblem, PlannerOptions, seed_ompl
from ..scene import Scene
from .model import Layout

#: Room beyond B (and behind G) counted by the ranking, m: more is not better.
ROOM_CAP = 0.02


class Rank(StrEnum):
    """How a piece's approach is chosen once an order is found."""

    TOLERANCE = "tolerance"  #: the largest tolerance of its exact lattice plan among those proved
    FIRST = "first"  #: the first proved in the search's order (room, then margin)


#: A piece's planner range (state units) unless the layout or the options set one. Longer than
#: plan's 0.3: a piece's secure states are a thin share of its wide planning box (measured on the
#: tangram's last piece, RRT* found a path in 0.5 s in 7 of 8 runs at 1.0 against 4 of 8 at 0.3).
PIECE_RANGE = 1.0


@dataclass(frozen=True)
class TilingOptions:
    """How to tile a layout."""

    planner: PlannerOptions = PlannerOptions()
    """How each piece is planned (planning.setup.PlannerOptions): an OMPL planner by name, or
    lattice; its time per piece (s); its seed: piece k of the order is planned with seed + k (None:
    not reproducible); its range, the longest motion (state units; None: the layout's
    planning.range, else PIECE_RANGE)."""
    approaches: int = 6
    """Manipulation planes (G, B pairs) tried per piece."""
    max_checks: int = 400
    """Cap on approach checks over the whole search for an order."""
    rank: Rank = Rank.FIRST
    """How each piece's approach is chosen once the order is found (Rank). The search's own choice
    by default: on the tangram the most tolerant approaches place no more in simulation
    (docs/results.md)."""
    avoid: tuple[tuple[str, tuple[float, float], tuple[float, float]], ...] = ()
    """Approaches not to take: (piece name, G, B in the piece's own coordinates, m), each matched
    within 1 um (sim.tiling.tile_aimed avoids those whose landing's aim does not fit)."""
    jobs: int | None = None
    """Processes planning pieces beside the search (forked copies of this one, each planning one
    piece at a time; parallel.forked): None, one per core (parallel.runner.default_jobs); 1, none:
    every piece planned here after the search. The plans are the same whichever (the order's, each
    piece's seed its own); only the search's rank "first" plans ahead."""

    def job_count(self) -> int:
        """How many processes jobs asks for: jobs, or one per core where it is None."""
        return default_jobs() if self.jobs is None else self.jobs

    def validated(self) -> "TilingOptions":
        jobs = self.jobs
        if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1):
            raise InputError("jobs", f"must be a positive integer, got {jobs!r}")
        if not isinstance(self.approaches, int) or self.approaches < 1:
            raise InputError("approaches", f"must be a positive integer, got {self.approaches!r}")
        longest = self.planner.range
        if longest is not None and not (isinstance(longest, (int, float)) and longest > 0):
            raise InputError("range", f"must be positive, got {longest!r}")
        if not isinstance(self.max_checks, int) or self.max_checks < 1:
            raise InputError("max_checks", f"must be a positive integer, got {self.max_checks!r}")
        if self.rank not in tuple(Rank):
            raise InputError("rank", f"must be one of {', '.join(Rank)}, got {self.rank!r}")
        return replace(self, rank=Rank(self.rank))


@dataclass(frozen=True)
class TilingProgress:
    """Where tile() is, for a progress indicator: stage "search" (finding an order; done is the
    number of pieces down in the order being tried) or "plan" (done pieces of total planned so
    far), the approaches checked so far and the piece being worked on."""

    stage: str
    done: int
    total: int
    checks: int
    piece: str


@dataclass(frozen=True)
class Approach:
    """A manipulation plane of a piece: G and B in its own coordinates (m), the world direction of
    GB (rad), the friction margin (rad), and the free room beyond B and behind G (m, capped)."""

    g: NDArray[np.float64]
    b: NDArray[np.float64]
    yaw: float
    margin: float
    room_b: float
    room_g: float

    def describe(self) -> str:
        return (f"G ({self.g[0] * 1000:.1f}, {self.g[1] * 1000:.1f}) B ({self.b[0] * 1000:.1f}, "
                f"{self.b[1] * 1000:.1f}) mm, GB toward {math.degrees(self.yaw):.0f} deg")


@dataclass
class Placement:
    """A piece put down: its order (1-based), approach, scene and plan."""

    order: int
    index: int
    name: str
    approach: Approach
    scene: Scene
    plan: Plan
    note: str | None = None  # how the plan was made, when not by the planner asked for
    tolerance: float | None = None
    """The plan's tolerance of the `paper` errors (scale of their box; docs/model.md 4.6)."""
    ranked: int = 1
    """How many approaches were proved and measured when this one was chosen (Rank.TOLERANCE)."""

    def summary(self) -> str:
        p, sc = self.plan, self.scene
        prims = " -> ".join(s.type for s in p.primitives)
        stab = p.stability_report or {}
        partial = sorted({s.type for s in p.primitives if s.stability != "full"})
        restoring = "self-restoring" if stab.get("self_restoring") else "not self-restoring"
        xm = (stab.get("x_moments") or {}).get("mechanism", "?")
        g, b = sc.plane.g, sc.plane.b
        return (f"{self.order}. {self.name}: G ({g.point[0] * 1000:.1f}, {g.point[1] * 1000:.1f}) mm {g.kind}, "
                f"B ({b.point[0] * 1000:.1f}, {b.point[1] * 1000:.1f}) mm {b.kind}, l {sc.object_length * 1000:.1f} mm, "
                f"GB toward {math.degrees(self.approach.yaw):.0f} deg\n"
                f"   {prims}; cost {p.cost:.2f}; tolerance {self.tolerance:.3f}"
                + (f" (the most of {self.ranked} approaches proved)" if self.ranked > 1 else "") + "; 3D stability full"
                f"{' except on ' + ', '.join(partial) + ' (partial)' if partial else ' on every leg'}; "
                f"x-moments by {xm}; {restoring}" + (f"\n   note: {self.note}" if self.note else ""))

    def to_dict(self) -> dict:
        return {"order": self.order, "piece": self.name, "approach": {
            "G": self.approach.g.tolist(), "B": self.approach.b.tolist(), "yaw_rad": self.approach.yaw,
            "margin_rad": self.approach.margin, "room_beyond_B_m": self.approach.room_b,
            "room_behind_G_m": self.approach.room_g}, "note": self.note, "tolerance": self.tolerance,
                "approaches_ranked": self.ranked, "plan": self.plan.to_dict()}


@dataclass
class Tiling:
    """The outcome: placements in order; when a piece cannot be placed, its name and why."""

    layout: str
    placements: list[Placement] = field(default_factory=list)
    failed_piece: str | None = None
    reasons: list[ApproachRejected] = field(default_factory=list)
    """Why the failed piece cannot be placed, approach by approach."""
    down_before: list[str] | None = None
    """The pieces down before the failed one in the deepest order tried (None: not a search failure)."""
    capped: int | None = None
    """The cap of approach checks, when the search stopped at it before trying every order."""
    checks: int = 0
    time_s: float = 0.0

    @property
    def solved(self) -> bool:
        return self.failed_piece is None

    def summary(self) -> str:
        stats = f"{self.checks} approaches checked, {self.time_s:.1f} s"
        if self.placements or self.solved:
            lines = [f"{self.layout}: order " + ", ".join(p.name for p in self.placements)
                     + f" ({len(self.placements)} pieces, {stats})"]
        else:
            lines = [f"{self.layout}: no order puts every piece down ({stats})"]
        lines += [p.summary() for p in self.placements]
        if not self.solved:
            lines.append(f"piece {self.failed_piece!r} cannot be placed:")
            lines += [f"   {r}" for r in self.reasons]
            if self.down_before is not None:
                lines.append(f"   (pieces down before it in the deepest order tried: {', '.join(self.down_before) or 'none'})")
        if self.capped is not None:
            lines.append(f"   (the search stopped at its cap of {self.capped} approach checks, TilingOptions.max_checks, "
                         "before trying every order)")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"layout": self.layout, "solved": self.solved, "order": [p.name for p in self.placements],
                "placements": [p.to_dict() for p in self.placements], "failed_piece": self.failed_piece,
                "reasons": [r.to_dict() for r in self.reasons], "down_before": self.down_before,
                "search_capped_at": self.capped, "approaches_checked": self.checks, "time_s": self.time_s}


# -- approaches ----------------------------------------------------------------------

def _segments(layout: Layout, placed: list[int]) -> NDArray[np.float64]:
    """Edges (M, 2, 2) of the frame's inner boundary and of the placed pieces (world x, y)."""
    polys = [layout.frame.inner_corners()] + [layout.footprint(j) for j in placed]
    return np.concatenate([np.stack([p, np.roll(p, -1, axis=0)], axis=1) for p in polys])


def _room(origins: NDArray, direction: NDArray, segments: NDArray) -> NDArray[np.float64]:
    """Per ray bundle k: the smallest distance from any of origins[k] (K, 2) along direction[k]
    (2,) to a segment, capped at ROOM_CAP (m); origins (N, K, 2), direction (N, 2)."""
    a, b = segments[:, 0], segments[:, 1]
    e = b - a
    d = direction[:, None, None, :]  # (N, 1, 1, 2) against (N, K, M, 2)
    denom = d[..., 0] * e[:, 1] - d[..., 1] * e[:, 0]
    w = a - origins[:, :, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[..., 0] * e[:, 1] - w[..., 1] * e[:, 0]) / denom
        s = (w[..., 0] * d[..., 1] - w[..., 1] * d[..., 0]) / denom
    hit = (np.abs(denom) > 1e-12) & (t > 1e-7) & (s >= 0) & (s <= 1)
    return np.where(hit, t, ROOM_CAP).min(axis=(1, 2), initial=ROOM_CAP)


def approaches(layout: Layout, i: int, placed: list[int], count: int,
               avoid: tuple[tuple[str, tuple[float, float], tuple[float, float]], ...] = ()) -> list[Approach]:
    """Up to count distinct manipulation planes of piece i, best first (see the module docstring),
    none of those in avoid (TilingOptions.avoid)."""
    piece = layout.pieces[i].object3d
    own = layout.scene(i)  # built once, at load
    mu = tuple(m * (1.0 - own.friction_uncertainty) for m in own.mu_contacts)  # antipodal over the friction's range
    cand = piece.outline.candidates().joined(piece.outline.double_normals())
    gi, bi, margins = antipodal_pairs(cand.points, cand.normal_lo, cand.normal_hi, piece.outline.vertices,
                                      math.atan(mu[0]), math.atan(mu[2]))
    (px, py), yaw = layout.world_pose(i)
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s], [s, c]])
    segs = _segments(layout, placed)
    half_width = own.digits.width * own.object_length / 2  # metres
    # only planes whose contacts hold x-moments: a side square to GB at G or B, or curves at both
    flush_g, flush_b = flush(piece.outline.vertices, cand.points[gi], cand.points[bi])
    x_stable = flush_g | flush_b | (curved(cand.radius[gi]) & curved(cand.radius[bi]))
    pairs, ends, units = [], [], []  # per pair: (G, B, margin); G, B in the world (2, 2); GB's direction
    for g_k, b_k, margin in zip(gi[x_stable], bi[x_stable], margins[x_stable]):
        g, b = cand.points[g_k], cand.points[b_k]
        gw, bw = rot @ g + (px, py), rot @ b + (px, py)
        pairs.append((g, b, float(margin)))
        ends.append((gw, bw))
        units.append((bw - gw) / np.linalg.norm(bw - gw))
    if not pairs:
        return []
    ends, units = np.array(ends), np.array(units)
    side = np.stack([-units[:, 1], units[:, 0]], axis=1)[:, None, :] * half_width  # (N, 1, 2)
    rays = np.stack([np.zeros_like(units), side[:, 0], -side[:, 0]], axis=1)  # offsets across GB (N, 3, 2)
    room_b = _room(ends[:, 1, None, :] + rays, units, segs)
    room_g = _room(ends[:, 0, None, :] + rays, -units, segs)
    out = [Approach(g, b, math.atan2(u[1], u[0]), margin, float(rb), float(rg))
           for (g, b, margin), u, rb, rg in zip(pairs, units, room_b, room_g)]
    name = layout.pieces[i].name
    shunned = [(np.asarray(g), np.asarray(b)) for n, g, b in avoid if n == name]
    out = [a for a in out if not any(np.allclose(a.g, g, atol=1e-6) and np.allclose(a.b, b, atol=1e-6)
                                     for g, b in shunned)]
    out.sort(key=lambda a: (-round(a.room_b, 4), -round(a.margin, 6), -round(a.room_g, 4)))
    chosen: list[Approach] = []
    for a in out:
        if all(_distinct(a, c) for c in chosen):
            chosen.append(a)
        if len(chosen) == count:
            break
    return chosen


def _distinct(a: Approach, b: Approach) -> bool:
    """Planes differ when their directions differ by over 10 deg or their contacts by over 5 mm."""
    turn = abs((a.yaw - b.yaw + math.pi) % (2 * math.pi) - math.pi)
    return turn > math.radians(10) or max(np.linalg.norm(a.g - b.g), np.linalg.norm(a.b - b.b)) > 0.005


def wall_contact(layout: Layout, i: int) -> float:
    """Length (m) of piece i's outline within 10 mm of the frame's inner walls."""
    pts = layout.footprint(i, world=False)
    w, d = layout.frame.inner
    nxt = np.roll(pts, -1, axis=0)
    total = 0.0
    for a, b in zip(pts, nxt):
        mid = (a + b) / 2
        if min(mid[0], mid[1], w - mid[0], d - mid[1]) < 0.01:
            total += float(np.linalg.norm(b - a))
    return total


# -- checking one approach -------------------------------------------------------------
@dataclass(frozen=True)
class DigitsDoNotFit:
    """Why an approach has no scene: the scene's own validation refuses the digits on its plane."""

    field: str
    """The scene's field that is out of range (digits.alpha: over the plane's length |GB|)."""
    reason: str
    """The scene's reason."""

    def __str__(self) -> str:
        return f"the digits do not fit this plane ({self.field}: {self.reason})"


class Rejection(Enum):
    """Why an approach of a piece was given up (the ``kind`` of tiling.json's reasons)."""

    DIGITS_DO_NOT_FIT = "digits_do_not_fit"  #: the scene refuses the digits on that plane (evidence: DigitsDoNotFit)
    ENDS = "ends"  #: the start cannot be held, or no goal state can be let go (evidence: EndsProblem)
    NO_SECURE_PATH = "no_secure_path"  #: the exact lattice search finds no path
    NOT_PLANNED = "not_planned"  #: the planner found no plan for a proven approach (evidence: the Plan)
    NO_ANTIPODAL_PAIR = "no_antipodal_pair"  #: no pair of the outline fits the friction (no approach at all)
    OUT_OF_CHECKS = "out_of_checks"  #: the search's cap of approach checks was reached (evidence: the cap)


@dataclass(frozen=True)
class ApproachRejected:
    """One reason a piece cannot be placed: what failed, for which approach, with its evidence."""

    kind: Rejection
    """What failed."""
    approach: Approach | None = None
    """The approach that failed (None for a reason about the piece as a whole)."""
    evidence: DigitsDoNotFit | EndsProblem | Plan | int | None = None
    """The value behind it, by kind (see Rejection)."""

    def __str__(self) -> str:
        k, e = self.kind, self.evidence
        if k is Rejection.NO_ANTIPODAL_PAIR:
            return "no antipodal pair on its outline fits the friction"
        if k is Rejection.OUT_OF_CHECKS:
            return f"stopped after {e} approach checks"
        what = ("no secure path (exact lattice search)" if k is Rejection.NO_SECURE_PATH
                else f"{e.planner} found no plan ({e.reason})" if k is Rejection.NOT_PLANNED
                else describe_outcome(e.outcome, e.evidence) if k is Rejection.ENDS else str(e))
        return f"{self.approach.describe()}: {what}" if self.approach is not None else what

    def to_dict(self) -> dict:
        return {"kind": self.kind.value, "approach": None if self.approach is None else self.approach.describe(),
                "detail": str(self)}


def approach_scene(layout: Layout, i: int, approach: Approach, placed: list[int]) -> Scene | DigitsDoNotFit:
    """Piece i's scene in the approach's manipulation plane among the pieces placed, or why there
    is none: the digits' asymmetry (digits.alpha, over the plane's length |GB|) out of range for a
    plane that short or long."""
    try:
        return layout.scene(i, (approach.g, approach.b), placed)
    except InputError as exc:
        return DigitsDoNotFit(exc.field, exc.reason)


class GoalStates:
    """What screen() learns of one piece and approach among some solids that holds among others:
    whether the start state is kinematically valid and force-closed, the goal's lattice states
    (inside the planning box) that are, a chunk of the lattice at a time as they are first needed,
    a goal state where the gripper could let go (a witness) and the solids (by name) among which
    it and the start are known to be free, and the sets of solids among which no goal state can
    be let go (with whether one could be held)."""

    def __init__(self, scene: Scene, chunk: int = 8192):
        """scene: the piece's scene with the approach's G and B (its solids are not used)."""
        self._scene = scene
        start = np.asarray(scene.start, dtype=float)[None]
        #: Whether the start state is kinematically valid and force-closed (as in Scene.classify).
        self.start_ok = bool(kinematic_validity(start[:, 0], start[:, 1], start[:, 2], scene.digits)[0]
                             and scene.force_closure(start)[0])
        box = planning_box(scene)
        glo, ghi = scene.goal.box()
        goal_box = np.array([np.maximum(box[0], glo), np.minimum(box[1], ghi)])
        #: Whether the goal region misses the planning box.
        self.outside_box = bool(np.any(goal_box[0] > goal_box[1]))
        self._grid = np.empty((0, 3))
        if not self.outside_box:
            _, axes = lattice_axes(start[0], np.asarray(scene.options.resolution, dtype=float), goal_box)
            # from the highest theta, d and psi down: where the gripper can let go, if anywhere, it
            # mostly can at the goal's highest theta (the order does not change the answer)
            self._grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)[::-1].copy()
        self._chunk = chunk
        self._held: list[NDArray[np.float64]] = []
        #: A goal state (theta rad, d over l, psi rad) that can be held and let go, or None.
        self.witness: NDArray[np.float64] | None = None
        #: The solids (names) the witness and the start state are known to be free of.
        self.free_of: frozenset[str] = frozenset()
        #: Solids (names) among which no goal state can be let go, and whether one can be held.
        self.failed: list[tuple[frozenset[str], bool]] = []

    def chunks(self) -> Iterator[NDArray[np.float64]]:
        """The kinematically valid, force-closed goal states (theta rad, d over l, psi rad), one
        (K, 3) array per chunk of the lattice."""
        scene = self._scene
        for k in range(0, len(self._grid), self._chunk):
            if len(self._held) <= k // self._chunk:
                q = self._grid[k:k + self._chunk]
                q = q[kinematic_validity(q[:, 0], q[:, 1], q[:, 2], scene.digits)]
                self._held.append(q[scene.force_closure(q)])
            yield self._held[k // self._chunk]


def screen(scene: Scene, goal: GoalStates | None = None) -> EndsProblem | None:
    """Why an approach cannot work, from the start grasp and the goal region alone; None if it may.

    The answer of planning.setup.ends_problem on the goal's lattice states, found a chunk of
    states at a time: it stops at the first state that can be held and let go. goal: what
    earlier screens of the same piece and approach among other solids (of one layout, named
    alike) learnt, which gives the same answer sooner. The kinematics and force closure of the
    start and goal states do not depend on the solids; a state collides among solids exactly
    when it collides with one of them (or the table), so a state free of some solids needs
    checking against the others only, and where no goal state can be let go among some solids
    none can among more; and the answer only asks whether some goal state can be held and let go."""
    goal = goal if goal is not None else GoalStates(scene)
    if goal.outside_box:
        return EndsProblem(PlanOutcome.GOAL_EMPTY, {"outside_box": True})
    names = frozenset(s.name for s in scene.solids)
    r = scene.robot
    amount = r.termination_amount
    checker = None
    if goal.witness is not None:  # the start is held and the witness let go among goal.free_of
        new = tuple(s for s in scene.solids if s.name not in goal.free_of)
        if not new:
            return None
        others = CollisionChecker(replace(scene.collision_model(), solids=new))
        hit = others.in_collision(np.vstack([scene.start, goal.witness]))
        if not hit.any() and not others.termination_collides(goal.witness, r.termination, amount)[0]:
            goal.free_of |= names
            return None
        start_held = not hit[0]
    else:
        checker = CollisionChecker(scene.collision_model()) if goal.start_ok else None
        start_held = checker is not None and not checker.in_collision(scene.start)[0]
    if not start_held:
        start = scene.diagnose(scene.start)
        return EndsProblem(PlanOutcome.START_NOT_HELD, dict(
            state_class=start.state_class.name, failed_checks=list(start.failed_checks), contacts=list(start.contacts)))
    checker = checker or CollisionChecker(scene.collision_model())
    fewer = [holdable for solids, holdable in goal.failed if solids <= names]
    if fewer:  # no goal state can be let go among fewer solids: none can here; only holdable is asked
        holdable = all(fewer) and any(len(q) and not checker.in_collision(q).all() for q in goal.chunks())
    else:
        holdable = False
        for q in goal.chunks():
            q = q[~checker.in_collision(q)] if len(q) else q
            holdable |= bool(len(q))
            for j in range(0, len(q), 64):  # letting go costs most: a few states at a time
                free = ~checker.termination_collides(q[j:j + 64], r.termination, amount)
                if free.any():
                    goal.witness, goal.free_of = q[j:j + 64][free][:1], names
                    return None
    goal.failed.append((names, holdable))
    return EndsProblem(PlanOutcome.GOAL_EMPTY, dict(holdable=holdable, termination=r.termination))


def _at(placed: list[int], i: int, a: Approach) -> tuple[frozenset[int], int, bytes, bytes]:
    """The memo's key of piece i's approach a with the pieces placed down (TilingMemo)."""
    return frozenset(placed), i, a.g.tobytes(), a.b.tobytes()


def prove(scene: Scene) -> tuple[PlanOutcome | None, SecurityAtlas]:
    """Whether the exact lattice optimum exists, i.e. a secure path (None, or NO_SECURE_PATH), and
    the secure lattice searched, which planning the piece then reuses."""
    atlas = SecurityAtlas(scene, planning_box(scene))
    if optimum_cost(atlas, scene.goal.box()) is None:
        return PlanOutcome.NO_SECURE_PATH, atlas
    return None, atlas


def _reproducible(piece: PlannerOptions) -> bool:
    """Whether a piece's planner options give the same plan every time: the lattice, or a seed."""
    return piece.planner == LATTICE or piece.seed is not None


def _plan_piece(scene: Scene, atlas: SecurityAtlas, piece: PlannerOptions) -> tuple[Plan, float | None]:
    """The piece's plan with its planner options on its proof's lattice, and the plan's tolerance's
    scale (None unsolved)."""
    p = planning.plan(scene, piece, atlas=atlas)
    return p, tolerance_scale(scene, p) if p.solved else None


def _plans_of_piece(scene: Scene, atlas: SecurityAtlas, key: tuple, lattice_key: tuple
                    ) -> list[tuple[tuple, tuple[Plan, float | None]]]:
    """In a forked child (_Tiler.plan_ahead): the plans plan_pieces makes of one piece, by their
    plan keys: the planner's (key), and where it finds no path, the lattice's (lattice_key). An
    unseeded planner draws afresh: the child's OMPL generator is a copy of its parent's."""
    piece = key[1]
    if piece.seed is None:
        seed_ompl(int.from_bytes(os.urandom(4), "little"))
    found = [(key, _plan_piece(scene, atlas, piece))]
    if not found[0][1][0].solved and piece.planner != LATTICE:
        found.append((lattice_key, _plan_piece(scene, atlas, lattice_key[1])))
    return found


# -- the search ----------------------------------------------------------------------

@dataclass
class TilingMemo:
    """What tile() works out about one layout, kept for later calls on it (sim.tiling.tile_aimed
    tiles a layout again with an approach avoided). Keyed by the set of pieces down, the piece
    and the approach's G and B: the approach's scene, its screen's answer and its proof (with the
    secure lattice searched); and, by those and the planner's options, each plan a reproducible
    planner made (the lattice, or a seeded one) with its tolerance's scale. None of it depends on
    the search's order or options, so a call with the memo finds what it would without, sooner.
    A memo serves the Layout object it was first used with; tile raises ValueError for another."""

    layout: Layout | None = None
    """The layout the memo holds answers for (set by the first tile call)."""
    scenes: dict = field(default_factory=dict)
    """(pieces down, piece, G bytes, B bytes) -> the approach's Scene, or DigitsDoNotFit."""
    screens: dict = field(default_factory=dict)
    """The same keys -> screen()'s answer (EndsProblem or None)."""
    proofs: dict = field(default_factory=dict)
    """The same keys -> prove()'s answer and the secure lattice it searched."""
    secure_among: dict = field(default_factory=dict)
    """(piece, G bytes, B bytes) -> the sets of pieces down among which a proof found a secure
    path: one is then known among any subset of them (fewer solids only free states and moves)."""
    goals: dict = field(default_factory=dict)
    """(piece, G bytes, B bytes) -> GoalStates: what screens learnt, over any pieces down."""
    plans: dict = field(default_factory=dict)
    """(the same keys, the piece's PlannerOptions: planner, time s, seed, range ...) -> (Plan, its
    tolerance's scale)."""

    def claim(self, layout: Layout) -> "TilingMemo":
        """This memo, bound to layout on first use; ValueError for another layout."""
        if self.layout is None:
            self.layout = layout
        elif self.layout is not layout:
            raise ValueError(f"this TilingMemo holds answers for layout {self.layout.name!r}, not {layout.name!r}")
        return self


def tile(layout: Layout, options: TilingOptions = TilingOptions(),
         progress: Callable[[TilingProgress], None] | None = None, memo: TilingMemo | None = None) -> Tiling:
    """Find an order and a plan per piece that put every piece of layout into its frame.

    progress, when given, is called with a TilingProgress at each approach checked during the
    search and before and after each piece is planned (it must not raise). memo, when given,
    answers what an earlier call on this layout worked out and keeps what this one does."""
    return _Tiler(layout, options.validated(), progress, memo).run()


def order_exists(layout: Layout, options: TilingOptions = TilingOptions(), memo: TilingMemo | None = None) -> bool:
    """Whether tile() with these options finds an order in which every piece can be placed: its
    first step alone, the search, here in this process and with nothing planned. False means tile()
    fails (unsolved) with the same options and memo; True that it goes on to plan the pieces."""
    return _Tiler(layout, options.validated(), None, memo).search([], []) is not None


class _Tiler:
    """One tiling of a layout, in two named steps: search an order in which every piece can be
    proven placeable (search), then plan the pieces in that order (plan_pieces). It keeps what both
    steps share: the answers of the screens and proofs by the set of pieces down, and the result."""

    def __init__(self, layout: Layout, opts: TilingOptions, progress: Callable[[TilingProgress], None] | None,
                 memo: TilingMemo | None):
        self.layout, self.opts, self.progress = layout, opts, progress
        self.memo = (TilingMemo() if memo is None else memo).claim(layout)
        self.result = Tiling(layout.name)
        self.n = len(layout.pieces)
        self.walls = [wall_contact(layout, i) for i in range(self.n)]
        self.screened: dict[tuple[frozenset, int], tuple[list, list[ApproachRejected]]] = {}
        self.proven: dict[tuple[frozenset, int], tuple[Approach, Scene, SecurityAtlas | None] | None] = {}
        self.deepest: dict = {"depth": -1, "piece": None, "reasons": [], "placed": []}
        self.dead: set[frozenset[int]] = set()  # sets of pieces down from which no order completes the layout
        #: Plans made ahead by a not reproducible planner, by planned()'s key (the memo keeps the others).
        self.ahead: dict = {}
        #: The forked children planning pieces ahead (None: every piece is planned here, in turn).
        self.pool: Forked | None = None

    def run(self) -> Tiling:
        """The tiling: an order found and every piece planned, or where and why it failed."""
        t0 = time.perf_counter()
        jobs = self.opts.job_count()
        if jobs > 1 and can_fork() and self.opts.rank is Rank.FIRST:
            self.pool = Forked(jobs)
        try:
            found = self.search([], [])
            if found is None:
                self.explain_failure()
            else:
                self.plan_pieces(found)
        finally:
            if self.pool is not None:
                self.pool.close()
                self.pool = None
        self.result.time_s = time.perf_counter() - t0
        return self.result

    # -- what the steps share ---------------------------------------------------------------
    def report(self, stage: str, done: int, i: int) -> None:
        if self.pool is not None:  # a child that ended hands its worker to the next plan waiting
            self.pool.poll()
        if self.progress is not None:
            self.progress(TilingProgress(stage, done, self.n, self.result.checks, self.layout.pieces[i].name))

    def out_of_checks(self) -> bool:
        return self.result.checks >= self.opts.max_checks

    def viable(self, i: int, placed: list[int]) -> tuple[list[tuple[Approach, Scene]], list[ApproachRejected]]:
        """Approaches of piece i that pass the screen with placed down, and why the others fail."""
        key = (frozenset(placed), i)
        if key not in self.screened:
            ok, why = [], []
            memo = self.memo
            for a in approaches(self.layout, i, placed, self.opts.approaches, self.opts.avoid):
                self.result.checks += 1
                self.report("search", len(placed), i)
                at = _at(placed, i, a)
                if at not in memo.scenes:
                    memo.scenes[at] = approach_scene(self.layout, i, a, placed)
                scene = memo.scenes[at]
                if isinstance(scene, DigitsDoNotFit):
                    why.append(ApproachRejected(Rejection.DIGITS_DO_NOT_FIT, a, scene))
                    continue
                plane = at[1:]
                if plane not in memo.goals:
                    memo.goals[plane] = GoalStates(scene)
                if at not in memo.screens:
                    memo.screens[at] = screen(scene, memo.goals[plane])
                problem = memo.screens[at]
                if problem:
                    why.append(ApproachRejected(Rejection.ENDS, a, problem))
                else:
                    ok.append((a, scene))
            if not ok and not why:
                why.append(ApproachRejected(Rejection.NO_ANTIPODAL_PAIR))
            self.screened[key] = (ok, why)
        return self.screened[key]

    def proved(self, placed: list[int], i: int, a: Approach, scene: Scene
               ) -> tuple[PlanOutcome | None, SecurityAtlas | None]:
        """prove()'s answer for piece i's approach a with placed down and its secure lattice; the
        lattice None (built when wanted: atlas) where a proof among more pieces found a secure path
        (TilingMemo.secure_among), which then exists among these."""
        at = _at(placed, i, a)
        if at in self.memo.proofs:
            return self.memo.proofs[at]
        if any(at[0] <= among for among in self.memo.secure_among.get(at[1:], ())):
            return None, None
        self.atlas(placed, i, a, scene)
        return self.memo.proofs[at]

    def atlas(self, placed: list[int], i: int, a: Approach, scene: Scene) -> SecurityAtlas:
        """The secure lattice of piece i's approach a with placed down (prove()'s, kept in the memo)."""
        at = _at(placed, i, a)
        if at not in self.memo.proofs:
            self.memo.proofs[at] = prove(scene)
            if self.memo.proofs[at][0] is None:
                self.memo.secure_among.setdefault(at[1:], []).append(at[0])
        return self.memo.proofs[at][1]

    def plan_key(self, placed: list[int], i: int, a: Approach, scene: Scene, planner: str,
                 seed: int | None = None) -> tuple:
        """The key of piece i's plan by planner (and seed) with placed down (TilingMemo.plans):
        the approach's and the piece's planner options."""
        own = self.opts.planner
        longest = own.range if own.range is not None else (scene.options.range or PIECE_RANGE)
        return _at(placed, i, a), replace(own, planner=planner, seed=seed, range=longest)

    def planned(self, placed: list[int], i: int, a: Approach, scene: Scene, atlas: SecurityAtlas | None,
                planner: str, seed: int | None = None) -> tuple[Plan, float | None]:
        """Piece i's plan by planner on its proof's lattice (atlas; None: built now), and its
        tolerance's scale (None unsolved); kept in the memo where the planner is reproducible (the
        lattice, or a seed)."""
        key = self.plan_key(placed, i, a, scene, planner, seed)
        if key in self.memo.plans:
            return self.memo.plans[key]
        if key in self.ahead:
            return self.ahead.pop(key)
        found = _plan_piece(scene, atlas if atlas is not None else self.atlas(placed, i, a, scene), key[1])
        if _reproducible(key[1]):
            self.memo.plans[key] = found
        return found

    def order_seed(self, k: int) -> int | None:
        """The seed of the order's piece k (from 0): the planner's seed + k (None: none)."""
        seed = self.opts.planner.seed
        return None if seed is None else seed + k

    def plan_ahead(self, placed: list[int], i: int, a: Approach, scene: Scene, atlas: SecurityAtlas | None) -> None:
        """Start planning piece i in a forked child (the pool's; none without one) as plan_pieces
        plans it when it comes next after placed: by the planner, with the seed of its place, and
        where that finds no path, by the lattice; unless that plan is made already."""
        if self.pool is None:
            return
        key = self.plan_key(placed, i, a, scene, self.opts.planner.planner, self.order_seed(len(placed)))
        if key not in self.memo.plans and key not in self.ahead:  # the most holdable states first: the longest
            atlas = atlas if atlas is not None else self.atlas(placed, i, a, scene)
            MARGIN_TABLE.share(atlas.axes, scene.friction)  # the pieces' lattices share their states' margins
            self.pool.submit(key, _plans_of_piece, scene, atlas, key, self.plan_key(placed, i, a, scene, LATTICE),
                             weight=float(np.count_nonzero(atlas.holdable)))

    def drop_ahead(self, placed: list[int], i: int, a: Approach, scene: Scene) -> None:
        """Give up planning piece i ahead after placed (plan_ahead): no order needs that plan."""
        if self.pool is not None:
            self.pool.discard(self.plan_key(placed, i, a, scene, self.opts.planner.planner,
                                             self.order_seed(len(placed))))

    def take_ahead(self, key: tuple) -> None:
        """Wait for the plans made ahead under key, if any, and keep them as planned() keeps its own
        (a child that failed leaves them to planned())."""
        if self.pool is None or key not in self.pool:
            return
        ok, found = self.pool.result(key)
        self.pool.discard(key)
        for plan_key, value in found if ok else ():
            if _reproducible(plan_key[1]):
                self.memo.plans[plan_key] = value
            else:
                self.ahead[plan_key] = value

    def fail(self, i: int, placed: list[int], reasons: list[ApproachRejected]) -> None:
        if len(placed) > self.deepest["depth"]:
            self.deepest.update(depth=len(placed), piece=i, reasons=reasons, placed=list(placed))

    # -- step 1: an order --------------------------------------------------------------------
    def search(self, placed: list[int], chosen: list) -> list | None:
        """chosen extended to every piece after placed, or None. Whether it can be depends on the
        set of pieces down, not on their order (the screens and proofs are kept by that set), so a
        set that failed in one order is not searched again in another."""
        down = frozenset(placed)
        if down in self.dead:
            return None
        found = self.extend(placed, chosen)
        if found is None:
            self.dead.add(down)
        return found

    def extend(self, placed: list[int], chosen: list) -> list | None:
        if len(placed) == self.n:
            return chosen
        if self.out_of_checks():
            return None
        remaining = [i for i in range(self.n) if i not in placed]
        options = {i: self.viable(i, placed) for i in remaining}
        for i in remaining:  # a piece with no approach now has none later either: more pieces only add obstacles
            if not options[i][0]:
                self.fail(i, placed, options[i][1])
                return None
        # the most constrained piece first; among equals the one touching the walls least
        for i in sorted(remaining, key=lambda k: (len(options[k][0]), self.walls[k], k)):
            proof = self.first_proven(i, placed, options[i])
            if proof is None:  # it cannot be placed now, nor after more pieces
                return None
            found = self.search(placed + [i], chosen + [(i, *proof)])
            if found is not None:
                return found
            self.drop_ahead(placed, i, proof[0], proof[1])  # no order completes the layout from placed and i
        return None

    def first_proven(self, i: int, placed: list[int], options: tuple[list, list[ApproachRejected]]
                     ) -> tuple[Approach, Scene, SecurityAtlas | None] | None:
        """Piece i's first screened approach whose secure lattice reaches the goal with placed down
        (kept by the set down), or None, the reasons recorded."""
        key = (frozenset(placed), i)
        if key not in self.proven:
            self.proven[key] = None
            why = list(options[1])
            for a, scene in options[0]:
                if self.out_of_checks():
                    why.append(ApproachRejected(Rejection.OUT_OF_CHECKS, evidence=self.opts.max_checks))
                    break
                self.result.checks += 1
                self.report("search", len(placed), i)
                problem, atlas = self.proved(placed, i, a, scene)
                if problem is None:
                    self.proven[key] = (a, scene, atlas)
                    self.plan_ahead(placed, i, a, scene, atlas)  # while the search goes on
                    break
                why.append(ApproachRejected(Rejection.NO_SECURE_PATH, a))
            if self.proven[key] is None:
                self.fail(i, placed, why)
        elif self.proven[key] is None:
            return None
        return self.proven[key]

    def explain_failure(self) -> None:
        """The result's failed piece, its reasons and the pieces down before it: the deepest failure."""
        result, deepest, pieces = self.result, self.deepest, self.layout.pieces
        result.failed_piece = pieces[deepest["piece"]].name if deepest["piece"] is not None else None
        result.reasons = list(deepest["reasons"])
        result.down_before = [pieces[j].name for j in deepest["placed"]]
        if result.failed_piece is None:
            result.failed_piece, result.reasons, result.down_before = "?", [], None
        if self.out_of_checks():
            result.capped = self.opts.max_checks

    # -- step 2: the plans -------------------------------------------------------------------
    def plan_pieces(self, found: list) -> None:
        """Plan every piece in the order found, each on its proof's lattice (the lattice's own plan
        where the planner finds none), into the result's placements."""
        opts, result, pieces = self.opts, self.result, self.layout.pieces
        if self.pool is not None:  # every piece of the order planned ahead; the plans of other orders given up
            wanted = set()
            for k, (i, a, scene, atlas) in enumerate(found):
                down = [j for j, *_ in found[:k]]
                self.plan_ahead(down, i, a, scene, atlas)
                wanted.add(self.plan_key(down, i, a, scene, opts.planner.planner, self.order_seed(k)))
            for key in self.pool.keys():
                if key not in wanted:
                    self.pool.discard(key)
        placed_before: list[int] = []
        for k, (i, a, scene, atlas) in enumerate(found):
            self.report("plan", k, i)
            ranked = 1
            if opts.rank is Rank.TOLERANCE:
                a, scene, atlas, ranked = self.most_tolerant(i, placed_before, (a, scene, atlas))
            down = list(placed_before)
            placed_before.append(i)
            planner, seed = opts.planner.planner, self.order_seed(k)
            self.take_ahead(self.plan_key(down, i, a, scene, planner, seed))
            p, tol = self.planned(down, i, a, scene, atlas, planner, seed)  # on the lattice the proof searched
            note = None
            if not p.solved and planner != LATTICE:  # the search proved a path: take the lattice's
                note = f"{planner} found no path ({p.reason}); the exact lattice plan is used"
                p, tol = self.planned(down, i, a, scene, atlas, LATTICE)  # the proof's lattice again
            if not p.solved:
                result.failed_piece = pieces[i].name
                result.reasons = [ApproachRejected(Rejection.NOT_PLANNED, a, p)]
                return
            result.placements.append(Placement(k + 1, i, pieces[i].name, a, scene, p, note, tol, ranked))
            self.report("plan", k + 1, i)

    def most_tolerant(self, i: int, placed: list[int], first: tuple[Approach, Scene, SecurityAtlas | None]
                      ) -> tuple[Approach, Scene, SecurityAtlas | None, int]:
        """Of piece i's approaches that pass the screen and the proof with placed down, the one
        whose exact lattice plan tolerates most (the first in the search's order among equals),
        and how many were measured."""
        best, best_tol, measured = first, -math.inf, 0
        for a, scene in self.viable(i, placed)[0]:
            if a is first[0]:
                atlas = first[2]
            else:
                self.result.checks += 1
                self.report("plan", len(placed), i)
                problem, atlas = self.proved(placed, i, a, scene)
                if problem is not None:
                    continue
            p, tol = self.planned(placed, i, a, scene, atlas, LATTICE)
            if not p.solved:
                continue
            measured += 1
            if tol > best_tol:
                best, best_tol = (a, scene, atlas), tol
        return (*best, max(measured, 1))
