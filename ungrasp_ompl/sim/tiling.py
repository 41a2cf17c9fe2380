"""A whole layout simulated: every piece put down in order by the one tiling trajectory.

Each attempt runs the pieces one after another. Piece k's world holds the frame's walls
(fixed) and the pieces already down as free bodies, starting where their own trials left
them, so a piece that ends askew is in the way of the next, and a later piece can push an
earlier one. An attempt succeeds when every piece's own trial succeeds and, at the end, all
pieces lie flat inside the frame (paper sec. 6.2.4); it is placed by the paper's criterion when
every piece is placed by it (TrialResult.placed) and all lie flat inside the frame, so an attempt
goes on past a piece that fails only the strict verdict.

The trajectory itself comes from aim_tiling (each piece aimed by its own landing where its scene
has robot.landing simulated, as far as the aim does not collide) or tile_aimed (which also tiles
the layout again, avoiding the approach of a piece aimed short, where that takes more of the
aims).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from contextlib import closing
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..geometry.collision import CollisionChecker
from ..geometry.solids import Solid
from ..layout.model import Layout
from ..parallel import RunOptions
from ..layout.tiler import Placement, Tiling, TilingMemo, TilingOptions, TilingProgress, order_exists, tile
from ..parallel.forked import Forked, can_fork
from ..planning.result import Plan
from ..robot.model import RobotModel
from ..robot.pipeline import Aim, CollisionError, Execution, aim_along, execute_sequence, modelled_aim
from ..robot.placement import densify
from ..robot.trajectory import JointTrajectory
from ..scene import Scene
from ..scene.options import Landing
from ..scene.perturbation import Perturbation
from .campaign import ENGINES, run_engine_trial, trial_runner
from .landing import robot_landing
from .outcome import FLAT_TILT_DEG, TrialResult
from .setup import trial_setup
from .trial import TrialSetup


@dataclass
class TilingAttempt:
    """One attempt at the whole layout: each piece's trial in order, and the verdict."""

    attempt: int
    pieces: list[TrialResult] = field(default_factory=list)
    names: list[str] = field(default_factory=list)
    flat_inside: list[bool] = field(default_factory=list)  #: per piece, at the end of the attempt

    @property
    def success(self) -> bool:
        return self.placed and all(t.success for t in self.pieces)

    @property
    def placed(self) -> bool:
        """The paper's criterion: every piece placed by it, all flat inside the frame at the end."""
        return len(self.pieces) == len(self.names) and all(t.placed for t in self.pieces) and all(self.flat_inside)

    def cause(self) -> str:
        if self.success:
            return "success"
        for name, t in zip(self.names, self.pieces):
            if not t.success:
                return f"{name}: {t.cause()}"
        bad = [n for n, ok in zip(self.names, self.flat_inside) if not ok]
        return f"not flat inside the frame at the end: {', '.join(bad)}"


def tiling_setups(layout: Layout, tiling: Tiling, trajectory: JointTrajectory, robot: RobotModel,
                  aims: Sequence[Aim] | None = None) -> list[tuple[str, TrialSetup]]:
    """Each piece's trial setup, in order: its scene with the frame's walls as the only fixed solids
    (earlier pieces come in as free bodies), its part of the tiling trajectory, whose motion aims[k]
    moved (none: as planned)."""
    if not tiling.solved:
        raise InputError("layout", "the tiling is not solved: nothing to simulate")
    walls = tuple(layout.frame.walls())
    aims = aims or [Aim()] * len(tiling.placements)
    return [(p.name, trial_setup(replace(p.scene, solids=walls), p.plan, trajectory, robot, prefix=f"{p.name}/",
                                 aim=aim)) for p, aim in zip(tiling.placements, aims)]


class ShortAim(NamedTuple):
    """A piece aimed short of its landing, because its whole aim would take the piece or the robot
    into a wall or a piece (aim_tiling)."""

    name: str
    """The piece."""
    taken: float
    """The shift its aim takes (m; the turn in the same share)."""
    asked: float
    """The shift its landing asked for (m)."""
    stopped_by: str
    """What a larger share would meet: the piece's or a digit's body and the solid, with the state's
    theta (deg) where the piece, carried along its plan, first meets it, or the robot's colliding
    links and solids and the trajectory's phase."""


@dataclass(frozen=True)
class AimedTiling:
    """A solved tiling on the arm, each piece aimed by where its release lands it (robot.landing
    simulated), and the trial setups of that trajectory."""

    execution: Execution
    """The one trajectory putting every piece down, each piece's motion moved by its aim."""
    setups: list[tuple[str, TrialSetup]]
    """Per piece in order: its name and trial setup (tiling_setups) on that trajectory."""
    short: tuple[ShortAim, ...] = ()
    """Pieces aimed short of their landing, in order."""


def describe_short(short: tuple[ShortAim, ...]) -> list[str]:
    """The summary's line on the pieces aimed short of their landing (none: no line)."""
    return [("aimed short of the landing (the whole aim would take the piece or the robot into a wall or a piece): "
             + ", ".join(f"{a.name} {a.taken * 1000:.2f} of {a.asked * 1000:.2f} mm ({a.stopped_by})" for a in short))
            ] if short else []


def _aimed_checker(scene: Scene, aim: Aim) -> CollisionChecker:
    """The scene's collision checker with the hand moved by aim: its walls and pieces down moved
    the other way."""
    back = np.linalg.inv(aim.transform(scene.plane_frame()[:3, 3]))
    solids = tuple(Solid(s.name, np.asarray(s.vertices) @ back[:3, :3].T + back[:3, 3]) for s in scene.solids)
    return CollisionChecker(replace(scene, solids=solids).collision_model())


def _clear_share(scene: Scene, plan: Plan, aim: Aim, halvings: int = 8) -> tuple[float, str]:
    """The largest share of aim (to 2^-halvings, bisected; Aim.scaled) that keeps the piece and the
    digits, along its plan's legs (every 0.5 deg), clear of the walls and pieces down; 1 when the
    whole aim does. With it, what the next share up meets (ShortAim.stopped_by; "" for 1)."""
    states, _ = densify(plan, angle_step=math.radians(0.5))
    if not _aimed_checker(scene, aim).in_collision(states).any():
        return 1.0, ""
    lo, hi = 0.0, 1.0
    for _ in range(halvings):
        mid = (lo + hi) / 2
        lo, hi = (lo, mid) if _aimed_checker(scene, aim.scaled(mid)).in_collision(states).any() else (mid, hi)
    checker = _aimed_checker(scene, aim.scaled(hi))
    first = int(np.argmax(checker.in_collision(states)))
    met = ", ".join("the {} meets {}".format(*pair.split("/", 1)) for pair in checker.contacts(states[first]))
    return lo, f"{met or 'a collision'} at theta {math.degrees(states[first][0]):.1f} deg"


#: An aim the robot's collision check cuts is halved at most this many times before it is dropped.
AIM_HALVINGS = 4


def aim_tiling(layout: Layout, tiling: Tiling, landings: dict | None = None, kept: dict | None = None) -> AimedTiling:
    """Execute the solved tiling, and aim each piece whose scene has robot.landing simulated as
    `plan` and `simulate` aim one object (sim.landing: its release simulated with no error, or on
    average over drawn ones, the pieces before it absent, since the table is the same beside
    them), each piece whose scene has robot.landing modelled by the model of its fall
    (modelled_aim); then execute aimed. The unaimed execution is made only where it is needed: for
    a release to simulate, or when no piece is aimed (as `plan` executes a modelled aim at once).
    Where the whole aim would take the piece, carried along its plan, into a wall or a piece put
    down before, the piece is aimed as far as it stays clear (bisected); where it would take the
    robot there (CollisionError of that piece's part), its aim is halved, up to AIM_HALVINGS
    times, then dropped. landings, when given, keeps the aims the landings asked for by piece,
    approach and plan, across calls (tile_aimed): a piece planned the same way again is not
    simulated again, since its release runs alone on the same table whatever its place in the
    order. kept keeps each piece's part of the robot's trajectory, by its plan and aim, across the
    executions here and, when given, across calls (robot.pipeline.execute_sequence)."""
    if not tiling.solved:
        raise InputError("layout", "the tiling is not solved: nothing to execute")
    jobs = [(p.scene, p.plan) for p in tiling.placements]
    labels = [p.name for p in tiling.placements]
    kept = {} if kept is None else kept
    landings = {} if landings is None else landings
    keys = [_landing_key(p) for p in tiling.placements]
    _modelled_aims(tiling, landings)  # the model's aims need no execution
    plain: tuple[Execution, list[tuple[str, TrialSetup]]] | None = None

    def unaimed() -> tuple[Execution, list[tuple[str, TrialSetup]]]:
        nonlocal plain
        if plain is None:
            execution = execute_sequence(jobs, labels=labels, kept=kept)
            plain = execution, tiling_setups(layout, tiling, execution.trajectory, execution.robot)
        return plain

    for k, (p, key) in enumerate(zip(tiling.placements, keys)):  # the releases simulated
        if key not in landings:
            landing = robot_landing(unaimed()[1][k][1], p.scene.robot)
            landings[key] = Aim() if landing is None else landing.aim
    asked = [landings[key] for key in keys]
    if not any(any(a) for a in asked):
        return AimedTiling(*unaimed())
    share, stopped = map(list, zip(*[_clear_share(p.scene, p.plan, a) if any(a) else (1.0, "")
                                      for p, a in zip(tiling.placements, asked)]))
    halved = [0] * len(jobs)
    while True:
        aims = [a.scaled(f) for a, f in zip(asked, share)]
        try:
            execution = execute_sequence(jobs, labels=labels, aims=aims, kept=kept)
            break
        except CollisionError as exc:
            k = exc.job
            if not any(aims[k]):
                raise
            halved[k] += 1
            share[k] = share[k] / 2 if halved[k] <= AIM_HALVINGS else 0.0
            stopped[k] = f"the robot: {', '.join(exc.pairs)} in the {exc.phase}"
    short = tuple(ShortAim(name, aim.shift, want.shift, why) for name, aim, want, f, why
                  in zip(labels, aims, asked, share, stopped) if f < 1.0)
    return AimedTiling(execution, tiling_setups(layout, tiling, execution.trajectory, execution.robot, aims), short)


def _landing_key(p: Placement) -> tuple:
    """The key of a placement's aim in aim_tiling's landings: its approach and its plan's states."""
    return _key(p), np.asarray(p.plan.states, dtype=float).tobytes()


def _modelled_aims(tiling: Tiling, landings: dict) -> None:
    """Into landings, the aim of each piece of the tiling whose scene has robot.landing modelled
    and that has none there yet (_modelled_aim: no execution)."""
    for p in tiling.placements:
        key = _landing_key(p)
        if key not in landings and p.scene.robot.landing is Landing.MODELLED:
            landings[key] = _modelled_aim(p.scene, p.plan)


def _modelled_aim(scene: Scene, plan: Plan) -> Aim:
    """robot.pipeline.modelled_aim of the plan: from the predicted landing planning recorded in the
    plan (planning.max_landing_spread predicts it for the plan as it is, with the same object,
    contacts, robot and table), else predicted here. The record's world offset is the prediction's
    own floats, so the aim is the one modelled_aim computes, the scene's landing offset included."""
    record = plan.predicted_landing
    if isinstance(record, dict) and record.get("carried_through_p_dpsi") is True \
            and record.get("termination") == str(scene.robot.termination) and "middle_m" in record:
        return aim_along(record["middle_m"] + scene.robot.landing_offset, tuple(record["direction"]))
    return modelled_aim(scene, plan)


@dataclass
class AimingMemo:
    """What tile_aimed keeps across the tilings it makes of one layout, and across calls when
    given one: the search's (tiling.TilingMemo), the aims the pieces' landings asked for and the
    robot's trajectory parts (aim_tiling's landings and kept)."""

    search: TilingMemo = field(default_factory=TilingMemo)
    """The tiling search's scenes, screens, proofs and plans."""
    landings: dict = field(default_factory=dict)
    """Per piece, approach and plan, the aim its landing asked for."""
    kept: dict = field(default_factory=dict)
    """Per plan and aim, its part of the robot's trajectory (robot.pipeline.execute_sequence)."""


def tile_aimed(layout: Layout, options: TilingOptions = TilingOptions(),
               progress: Callable[[TilingProgress], None] | None = None,
               memo: AimingMemo | None = None,
               solved: Callable[[Tiling], None] | None = None) -> tuple[Tiling, AimedTiling | None]:
    """Tile the layout (tiling.tile) and aim it (aim_tiling), making room for the aims: for each
    piece aimed short, in order, the layout is tiled again with that piece's approach avoided
    (TilingOptions.avoid), and the new tiling is kept when less of the aims is left untaken
    (summed over the pieces). An approach whose avoidance leaves no tiling, or takes no more of
    the aims, is kept. Each tiling reuses what the ones before it worked out (AimingMemo; memo,
    when given, holds what earlier calls on this layout did). solved, when given, is called with
    each solved tiling before it is aimed (workflows.tile draws its pictures meanwhile). Returns
    the tiling and its aimed execution (None when no tiling is found).

    The pieces the model's aims find short before anything is executed are searched again in a
    forked child while this process executes the aims (_RetriesAhead); a retry whose search that
    child finds no order for is not tiled here, since tile() would fail it the same way."""
    memo = AimingMemo() if memo is None else memo
    tiling = tile(layout, options, progress, memo.search)
    if not tiling.solved:
        return tiling, None
    if solved is not None:
        solved(tiling)
    with closing(_RetriesAhead(layout, tiling, options, memo)) as ahead:
        aimed = aim_tiling(layout, tiling, memo.landings, memo.kept)
        tried: set[tuple] = set()
        while True:
            short = {a.name for a in aimed.short}
            todo = [p for p in tiling.placements if p.name in short and _key(p) not in tried]
            if not todo:
                return tiling, aimed
            tried.add(_key(todo[0]))
            retry = replace(options, avoid=options.avoid + (_key(todo[0]),))
            if ahead.no_order(retry):
                continue
            again = tile(layout, retry, progress, memo.search)
            if not again.solved:
                continue
            if solved is not None:
                solved(again)
            aimed_again = aim_tiling(layout, again, memo.landings, memo.kept)
            if _shortfall(aimed_again) < _shortfall(aimed):
                options, tiling, aimed = retry, again, aimed_again


class _RetriesAhead:
    """The first retries of tile_aimed, searched in a forked child while this process executes the
    aims: the pieces of the tiling whose modelled aim (robot.landing modelled) would take them into
    a wall or a piece down (_clear_share below 1), in order, each with its approach avoided as
    tile_aimed avoids it when no retry before it is kept. The child answers, for each in turn,
    whether tile()'s search finds an order (layout.tiler.order_exists on a copy of the memo),
    stopping at the first that does (that retry is tiled here). With one job, on a platform
    without fork, or with no such piece, nothing runs ahead."""

    def __init__(self, layout: Layout, tiling: Tiling, options: TilingOptions, memo: AimingMemo):
        self.avoids: list[tuple] = []
        self.pool: Forked | None = None
        if options.job_count() < 2 or not can_fork():
            return
        _modelled_aims(tiling, memo.landings)
        aims = [(p, memo.landings[_landing_key(p)]) for p in tiling.placements
                if p.scene.robot.landing is Landing.MODELLED]
        short = [p for p, aim in aims if any(aim) and _clear_share(p.scene, p.plan, aim)[0] < 1.0]
        if not short:
            return
        self.avoids = [options.avoid + (_key(p),) for p in short]
        self.pool = Forked(1)
        self.pool.submit("orders", _orders_exist, layout, [replace(options, avoid=a) for a in self.avoids],
                         memo.search)

    def no_order(self, retry: TilingOptions) -> bool:
        """Whether the child found that tile()'s search with retry finds no order (waiting for its
        answer); False when it did not search retry, found one, or failed."""
        if self.pool is None or retry.avoid not in self.avoids:
            return False
        ok, found = self.pool.result("orders")
        k = self.avoids.index(retry.avoid)
        return ok and k < len(found) and not found[k]

    def close(self) -> None:
        if self.pool is not None:
            self.pool.close()


def _orders_exist(layout: Layout, retries: list[TilingOptions], memo: TilingMemo) -> list[bool]:
    """In _RetriesAhead's child: whether each retry's search finds an order, in turn, up to the
    first that does."""
    found: list[bool] = []
    for retry in retries:
        found.append(order_exists(layout, retry, memo))
        if found[-1]:
            break
    return found


def _shortfall(aimed: AimedTiling) -> float:
    """How much of the aims the landings asked for the robot does not take (m, summed)."""
    return sum(a.asked - a.taken for a in aimed.short)


def _key(p: Placement) -> tuple[str, tuple[float, float], tuple[float, float]]:
    """A placement's approach as TilingOptions.avoid names it."""
    return p.name, (float(p.approach.g[0]), float(p.approach.g[1])), (float(p.approach.b[0]), float(p.approach.b[1]))


def _inside(layout: Layout, outline: NDArray, pose: NDArray, tol: float = 5e-4) -> bool:
    """The placed outline's footprint lies within the frame's inner rectangle (tol m)."""
    pts = np.column_stack([outline, np.zeros(len(outline))]) @ pose[:3, :3].T + pose[:3, 3]
    frame = layout.frame
    c, s = math.cos(frame.yaw), math.sin(frame.yaw)
    local = (pts[:, :2] - np.asarray(frame.center)) @ np.array([[c, -s], [s, c]]) + np.asarray(frame.inner) / 2
    return bool(np.all(local >= -tol) and np.all(local <= np.asarray(frame.inner) + tol))


def run_attempt(layout: Layout, setups: list[tuple[str, TrialSetup]], perturbation: Perturbation, seed: int,
                attempt: int, engine: str = "mujoco") -> TilingAttempt:
    """Attempt k: piece j draws its errors from a Generator seeded (seed, k, j); the arm's
    calibration is one per attempt (piece 0's draw), as it is one per set-up. Each piece's trial
    runs in the engine named (sim.campaign.ENGINES: run_engine_trial), the pieces down in it
    where the trials before left them (TrialResult.placed_poses)."""
    out = TilingAttempt(attempt, names=[n for n, _ in setups])
    placed: tuple = ()
    calibration = perturbation.sample(np.random.default_rng([seed, attempt, 0]))
    for j, (name, setup) in enumerate(setups):
        params = replace(perturbation.sample(np.random.default_rng([seed, attempt, j])),
                         palm_shift_mm=calibration.palm_shift_mm, palm_turn_deg=calibration.palm_turn_deg,
                         table_height_mm=calibration.table_height_mm)
        result = run_engine_trial(replace(setup, spec=replace(setup.spec, placed=placed)), params, attempt, seed,
                                  engine)
        out.pieces.append(result)
        if not result.placed:  # past a piece the strict verdict alone fails, the attempt goes on for the paper's
            return out
        obj = replace(setup.spec.obj, thickness=setup.spec.obj.thickness * params.thickness_scale)
        placed = tuple((n, o, np.array(pose)) for (n, o, _), pose in zip(placed, result.placed_poses))
        placed += ((name, obj, np.array(result.final_pose)),)
    for (name, obj, pose) in placed:
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(pose[2, 2])))))
        out.flat_inside.append(tilt <= FLAT_TILT_DEG and _inside(layout, obj.outline, pose))
    return out


def _attempt(args: tuple) -> TilingAttempt:
    return run_attempt(*args)


def simulate_tiling(layout: Layout, setups: list[tuple[str, TrialSetup]], perturbation: Perturbation,
                    attempts: int, run: RunOptions = RunOptions(jobs=1),
                    progress: Callable[[TilingAttempt], None] | None = None,
                    engine: str = "mujoco") -> list[TilingAttempt]:
    """Run attempts 0 .. attempts-1 of the whole layout, each with the errors of run.seed's
    stream, on run's worker processes (ungrasp_ompl.parallel.runner) or its Ray cluster, every
    piece's trial in the engine named (sim.campaign.ENGINES; docs/model.md 11.19)."""
    if attempts < 1:
        raise InputError("trials", f"must be at least 1, got {attempts}")
    if engine not in ENGINES:
        raise InputError("engine", f"must be one of {', '.join(ENGINES)}, got {engine!r}")
    work = [(layout, setups, perturbation, run.seed, k) if engine == "mujoco" else
            (layout, setups, perturbation, run.seed, k, engine) for k in range(attempts)]
    results: list[TilingAttempt] = []
    with trial_runner(run.workers, attempts, run.cluster) as runner, closing(runner.run(_attempt, work)) as outcomes:
        for outcome in outcomes:
            results.append(outcome.unwrap())
            if progress:
                progress(results[-1])
    return sorted(results, key=lambda a: a.attempt)
