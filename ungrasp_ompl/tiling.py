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
2. a piece's approaches are its antipodal pairs that hold x-moments (an edge
   contact at G or B, or no cusp at either), both ways round, ranked by the
   free room beyond B and behind G (a ray cast against walls and placed
   pieces), then by the friction margin; near-duplicates are dropped;
3. an approach is screened (the start grasp holdable, some goal state holdable
   with room for the gripper to let go), then proved by the exact lattice
   search; the first approach proved places the piece;
4. a piece that none of its approaches can place now cannot be placed by them
   later either (more pieces only add obstacles), so the search goes back one
   step at once. Only the best `approaches` planes of a piece are tried: the
   search is complete over orders, not over every antipodal pair.

Results are memoised by (pieces down, piece), so no check is repeated. Once an
order is found, each piece is planned with the chosen planner; should a
sampling planner find no path in its time, the lattice path (proved to exist)
is taken and the summary says so.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from numpy.typing import NDArray

from .errors import InputError
from .layout import Layout
from .mechanics.antipodal import antipodal_pairs
from .planning import plan as plan_scene
from .geometry.collision import CollisionChecker
from .mechanics import kinematic_validity
from .planning.atlas import SecurityAtlas, lattice_axes, planning_box
from .planning.lattice import lattice_search
from .planning.result import Plan, PlanOutcome, describe_outcome
from .planning.setup import LATTICE
from .scene import Scene, StateClass

#: Room beyond B (and behind G) counted by the ranking, m: more is not better.
ROOM_CAP = 0.02


@dataclass(frozen=True)
class TilingOptions:
    """How to tile a layout."""

    planner: str = "RRTstar"
    """The planner per piece: an OMPL planner by name, or lattice."""
    time: float = 1.0
    """Planning time per piece (s)."""
    seed: int | None = None
    """Seed: piece k of the order is planned with seed + k. None: not reproducible."""
    range: float = 1.0
    """The planner's longest motion (state units). Longer than plan's 0.3: a piece's secure states
    are a thin share of its wide planning box (measured on the tangram's last piece, RRT* found a
    path in 0.5 s in 7 of 8 runs at 1.0 against 4 of 8 at 0.3)."""
    approaches: int = 6
    """Manipulation planes (G, B pairs) tried per piece."""
    max_checks: int = 400
    """Cap on approach checks over the whole search for an order."""

    def validated(self) -> "TilingOptions":
        if not isinstance(self.approaches, int) or self.approaches < 1:
            raise InputError("approaches", f"must be a positive integer, got {self.approaches!r}")
        if not (isinstance(self.range, (int, float)) and self.range > 0):
            raise InputError("range", f"must be positive, got {self.range!r}")
        if not isinstance(self.max_checks, int) or self.max_checks < 1:
            raise InputError("max_checks", f"must be a positive integer, got {self.max_checks!r}")
        return self


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
                f"   {prims}; cost {p.cost:.2f}; 3D stability full"
                f"{' except on ' + ', '.join(partial) + ' (partial)' if partial else ' on every leg'}; "
                f"x-moments by {xm}; {restoring}" + (f"\n   note: {self.note}" if self.note else ""))

    def to_dict(self) -> dict:
        return {"order": self.order, "piece": self.name, "approach": {
            "G": self.approach.g.tolist(), "B": self.approach.b.tolist(), "yaw_rad": self.approach.yaw,
            "margin_rad": self.approach.margin, "room_beyond_B_m": self.approach.room_b,
            "room_behind_G_m": self.approach.room_g}, "note": self.note, "plan": self.plan.to_dict()}


@dataclass
class Tiling:
    """The outcome: placements in order; when a piece cannot be placed, its name and why."""

    layout: str
    placements: list[Placement] = field(default_factory=list)
    failed_piece: str | None = None
    reasons: list[str] = field(default_factory=list)
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
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"layout": self.layout, "solved": self.solved, "order": [p.name for p in self.placements],
                "placements": [p.to_dict() for p in self.placements], "failed_piece": self.failed_piece,
                "reasons": self.reasons, "approaches_checked": self.checks, "time_s": self.time_s}


# -- approaches ----------------------------------------------------------------------

def _segments(layout: Layout, placed: list[int]) -> NDArray[np.float64]:
    """Edges (M, 2, 2) of the frame's inner boundary and of the placed pieces (world x, y)."""
    polys = [layout.frame.inner_corners()] + [layout.footprint(j) for j in placed]
    return np.concatenate([np.stack([p, np.roll(p, -1, axis=0)], axis=1) for p in polys])


def _room(origins: NDArray, direction: NDArray, segments: NDArray) -> float:
    """Smallest distance from any of origins (K, 2) along direction (2,) to a segment, capped (m)."""
    a, b = segments[:, 0], segments[:, 1]
    e = b - a
    best = ROOM_CAP
    for o in origins:
        denom = direction[0] * e[:, 1] - direction[1] * e[:, 0]
        w = a - o
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / denom
            s = (w[:, 0] * direction[1] - w[:, 1] * direction[0]) / denom
        hit = (np.abs(denom) > 1e-12) & (t > 1e-7) & (s >= 0) & (s <= 1)
        if hit.any():
            best = min(best, float(t[hit].min()))
    return best


def approaches(layout: Layout, i: int, placed: list[int], count: int) -> list[Approach]:
    """Up to count distinct manipulation planes of piece i, best first (see the module docstring)."""
    piece = layout.pieces[i].object3d
    own = layout.scene(i)  # built once, at load
    mu = own.mu_contacts
    cand = piece.outline.candidates()
    gi, bi, margins = antipodal_pairs(cand.points, cand.normal_lo, cand.normal_hi, piece.outline.vertices,
                                      math.atan(mu[0]), math.atan(mu[2]))
    (px, py), yaw = layout.world_pose(i)
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s], [s, c]])
    segs = _segments(layout, placed)
    half_width = own.digits.width * own.object_length / 2  # metres
    out = []
    # only planes whose contacts hold x-moments: an edge contact at G or B, or no cusp at either
    x_stable = (cand.kind[gi] == "edge") | (cand.kind[bi] == "edge") | ((cand.radius[gi] > 0) & (cand.radius[bi] > 0))
    for g_k, b_k, margin in zip(gi[x_stable], bi[x_stable], margins[x_stable]):
        g, b = cand.points[g_k], cand.points[b_k]
        gw, bw = rot @ g + (px, py), rot @ b + (px, py)
        u = (bw - gw) / np.linalg.norm(bw - gw)
        side = np.array([-u[1], u[0]]) * half_width
        room_b = _room(np.array([bw, bw + side, bw - side]), u, segs)
        room_g = _room(np.array([gw, gw + side, gw - side]), -u, segs)
        out.append(Approach(g, b, math.atan2(u[1], u[0]), float(margin), room_b, room_g))
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

def screen(scene: Scene, chunk: int = 8192) -> str | None:
    """Why an approach cannot work, from the start grasp and the goal region alone; None if it may.

    The answer of planning.setup.ends_problem on the goal's lattice states, found a chunk of
    states at a time: it stops at the first state that can be held and let go."""
    box = planning_box(scene)
    glo, ghi = scene.goal.box()
    goal_box = np.array([np.maximum(box[0], glo), np.minimum(box[1], ghi)])
    if np.any(goal_box[0] > goal_box[1]):
        return describe_outcome(PlanOutcome.GOAL_EMPTY, {"outside_box": True})
    checker = CollisionChecker(scene.collision_model())
    if scene.classify(scene.start, checker)[0] != StateClass.HELD.value:
        start = scene.diagnose(scene.start)
        return describe_outcome(PlanOutcome.START_NOT_HELD, dict(
            state_class=start.state_class.name, failed_checks=list(start.failed_checks), contacts=list(start.contacts)))
    _, axes = lattice_axes(np.asarray(scene.start, dtype=float), np.asarray(scene.options.resolution, dtype=float),
                           goal_box)
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    r = scene.robot
    amount = r.termination_opening if r.termination == "open" else r.termination_angle
    holdable = False
    for k in range(0, len(grid), chunk):
        q = grid[k:k + chunk]
        q = q[kinematic_validity(q[:, 0], q[:, 1], q[:, 2], scene.digits)]
        q = q[scene.force_closure(q)]
        q = q[~checker.in_collision(q)] if len(q) else q
        holdable |= bool(len(q))
        for j in range(0, len(q), 64):  # letting go costs most: a few states at a time
            if not checker.termination_collides(q[j:j + 64], r.termination, amount).all():
                return None
    return describe_outcome(PlanOutcome.GOAL_EMPTY, dict(holdable=holdable, termination=r.termination))


def prove(scene: Scene) -> tuple[str | None, SecurityAtlas]:
    """Whether the exact lattice search finds a secure path (None, or why not) and the secure
    lattice it searched, which planning the piece then reuses."""
    atlas = SecurityAtlas(scene, planning_box(scene))
    if not lattice_search(atlas, scene.goal.box()).reachable:
        return "no secure path (exact lattice search)", atlas
    return None, atlas


# -- the search ----------------------------------------------------------------------

def tile(layout: Layout, options: TilingOptions = TilingOptions(),
         progress: Callable[[TilingProgress], None] | None = None) -> Tiling:
    """Find an order and a plan per piece that put every piece of layout into its frame.

    progress, when given, is called with a TilingProgress at each approach checked during the
    search and before and after each piece is planned (it must not raise)."""
    opts = options.validated()
    t0 = time.perf_counter()
    result = Tiling(layout.name)
    n = len(layout.pieces)

    def report(stage: str, done: int, i: int) -> None:
        if progress is not None:
            progress(TilingProgress(stage, done, n, result.checks, layout.pieces[i].name))
    walls = [wall_contact(layout, i) for i in range(n)]
    screened: dict[tuple[frozenset, int], tuple[list, list[str]]] = {}
    proven: dict[tuple[frozenset, int], tuple[Approach, Scene, SecurityAtlas] | None] = {}
    deepest: dict = {"depth": -1, "piece": None, "reasons": [], "placed": []}

    def out_of_checks() -> bool:
        return result.checks >= opts.max_checks

    def viable(i: int, placed: list[int]) -> tuple[list[tuple[Approach, Scene]], list[str]]:
        """Approaches of piece i that pass the screen with placed down, and why the others fail."""
        key = (frozenset(placed), i)
        if key not in screened:
            ok, why = [], []
            for a in approaches(layout, i, placed, opts.approaches):
                result.checks += 1
                report("search", len(placed), i)
                scene = layout.scene(i, (a.g, a.b), placed)
                problem = screen(scene)
                if problem:
                    why.append(f"{a.describe()}: {problem}")
                else:
                    ok.append((a, scene))
            if not ok and not why:
                why.append("no antipodal pair on its outline fits the friction")
            screened[key] = (ok, why)
        return screened[key]

    def fail(i: int, placed: list[int], reasons: list[str]) -> None:
        if len(placed) > deepest["depth"]:
            deepest.update(depth=len(placed), piece=i, reasons=reasons, placed=list(placed))

    def search(placed: list[int], chosen: list) -> list | None:
        if len(placed) == n:
            return chosen
        if out_of_checks():
            return None
        remaining = [i for i in range(n) if i not in placed]
        options = {i: viable(i, placed) for i in remaining}
        for i in remaining:  # a piece with no approach now has none later either: more pieces only add obstacles
            if not options[i][0]:
                fail(i, placed, options[i][1])
                return None
        # the most constrained piece first; among equals the one touching the walls least
        for i in sorted(remaining, key=lambda k: (len(options[k][0]), walls[k], k)):
            key = (frozenset(placed), i)
            if key not in proven:
                proven[key] = None
                why = list(options[i][1])
                for a, scene in options[i][0]:
                    if out_of_checks():
                        why.append(f"stopped after {opts.max_checks} approach checks")
                        break
                    result.checks += 1
                    report("search", len(placed), i)
                    problem, atlas = prove(scene)
                    if problem is None:
                        proven[key] = (a, scene, atlas)
                        break
                    why.append(f"{a.describe()}: {problem}")
                if proven[key] is None:  # it cannot be placed now, nor after more pieces
                    fail(i, placed, why)
                    return None
            found = search(placed + [i], chosen + [(i, *proven[key])])
            if found is not None:
                return found
        return None

    found = search([], [])
    if found is None:
        result.failed_piece = layout.pieces[deepest["piece"]].name if deepest["piece"] is not None else None
        down = ", ".join(layout.pieces[j].name for j in deepest["placed"]) or "none"
        result.reasons = deepest["reasons"] + [f"(pieces down before it in the deepest order tried: {down})"]
        if result.failed_piece is None:
            result.failed_piece = "?"
            result.reasons = []
        if out_of_checks():
            result.reasons.append(f"(the search stopped at its cap of {opts.max_checks} approach checks, "
                                  "TilingOptions.max_checks, before trying every order)")
        result.time_s = time.perf_counter() - t0
        return result
    for k, (i, a, scene, atlas) in enumerate(found):
        report("plan", k, i)
        seed = None if opts.seed is None else opts.seed + k
        p = plan_scene(scene, planner=opts.planner, time=opts.time, seed=seed, range=opts.range,
                       atlas=atlas)  # the lattice the proof searched
        note = None
        if not p.solved and opts.planner != LATTICE:  # the search proved a path: take the lattice's
            note = f"{opts.planner} found no path ({p.reason}); the exact lattice plan is used"
            p = plan_scene(scene, planner=LATTICE)
        if not p.solved:
            result.failed_piece = layout.pieces[i].name
            result.reasons = [f"{a.describe()}: {p.planner} found no plan ({p.reason})"]
            break
        result.placements.append(Placement(k + 1, i, layout.pieces[i].name, a, scene, p, note))
        report("plan", k + 1, i)
    result.time_s = time.perf_counter() - t0
    return result
