"""Plans certified in simulation: several candidate plans, each executed and simulated, the one
with the highest Wilson 95 % lower bound on success kept.

Which candidates (a fixed rule, reproducible from the seed s; :func:`candidate_sources`): the
objectives are taken in turn, the plan's own first, then the others of
:data:`~ungrasp_ompl.planning.margins.OBJECTIVES` in their order (cost, margin, balanced, tolerance). First,
for each objective in turn, the planner with seed s under it, then the exact lattice search under
it; after that the planner with seed s + 1 under each objective in turn, then s + 2, and so on,
until there are K. A planner that optimises the cost only (PRM, PRM*) is run under the cost only;
the lattice planner itself gives one candidate per objective.

Each solved candidate is turned into a robot trajectory (robot.pipeline), and simulated N trials
(sim.campaign.run_trials, all candidates' trials in one pool); trial k of every candidate meets
the same seeded perturbation, so that candidates are compared on the same errors. A candidate
whose path is that of an earlier one is not simulated again: it has that one's trials. The kept
candidate has the highest Wilson 95 % lower bound on its success rate; among equal bounds, the
lowest cost, then the first.
"""

from __future__ import annotations

import enum
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from ..errors import InputError, UngraspError
from ..planning import plan
from ..planning.atlas import SecurityAtlas, planning_box
from ..planning.margins import OBJECTIVES, Objective
from ..planning.names import LATTICE, PLANNERS
from ..planning.result import Plan
from ..parallel.options import RunOptions, check_seed
from ..planning.setup import KNOWN_LIMITATIONS, UNUSABLE_PLANNERS, PlannerOptions, check_objective, scene_objective
from ..scene import Scene
from ..scene.perturbation import preset
from .campaign import failure_causes, run_trials, wilson_interval
from .outcome import TrialResult
from .plan_trials import placement


@dataclass(frozen=True)
class CertifyOptions:
    """How to choose and certify candidate plans (see the module for the rule)."""

    trials: int = 10
    """Simulated trials per candidate (count)."""
    candidates: int = 4
    """Candidate plans (count)."""
    planner: PlannerOptions = PlannerOptions(seed=1)
    """The planner of the seeded candidates (an OMPL planner by name, or ``lattice``: one candidate per
    objective), its time per candidate (s: a seeded run's iteration budget, as for ``plan --seed``) and
    iterations; its objective is taken first, the others follow in turn; its seed s: the planner's
    candidates use s, s + 1, ... (None: 1)."""
    perturb: str = "paper"
    """The trials' perturbation preset (see ``simulate --perturb``)."""
    run: RunOptions = RunOptions(jobs=1)
    """How the trials run: every candidate's trials use run.seed; run.jobs trials at a time (worker
    processes; None: all cores; unused on a cluster); on the Ray cluster at run.cluster ("local"
    starts one here; None: this machine)."""

    def validated(self, scene: Scene) -> "CertifyOptions":
        """These options checked for scene (jobs None as all cores, the planner's seed None as 1,
        its objective None as the scene's); InputError naming the field otherwise."""
        for name, value in (("trials", self.trials), ("candidates", self.candidates)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise InputError(name, f"must be at least 1, got {value!r}")
        run = self.run.validated()
        p = self.planner if self.planner.seed is not None else replace(self.planner, seed=1)
        if p.planner != LATTICE and p.planner not in PLANNERS:
            raise InputError("planner", f"unknown planner {p.planner!r} (known: {', '.join(PLANNERS)}, "
                             f"{LATTICE})")
        why = UNUSABLE_PLANNERS.get(p.planner) or (
            KNOWN_LIMITATIONS[p.planner].value if p.planner in KNOWN_LIMITATIONS else "")
        if why:
            raise InputError("planner", f"{p.planner} cannot produce candidates: {why.split(';')[0]}")
        try:
            objective = scene_objective(p.objective, scene, p.planner)
        except InputError as exc:
            raise InputError("objective", exc.reason) from None
        check_seed(p.seed)
        preset(self.perturb)  # InputError("perturb") for an unknown preset
        candidate_sources(p.planner, objective, p.seed, self.candidates)  # candidates beyond the rule
        return replace(self, planner=replace(p, objective=objective), run=replace(run, jobs=run.workers))


@dataclass(frozen=True)
class CandidateSource:
    """Where a candidate plan comes from: a planner, an objective and a seed."""

    planner: str
    """The planner (an OMPL planner's name, or ``lattice``)."""
    objective: Objective
    """What it optimised (cost, margin, balanced, tolerance)."""
    seed: int | None
    """The planner's seed; None for the lattice search (it draws no random numbers)."""

    def label(self) -> str:
        """'RRTstar margin seed 2', 'lattice cost'."""
        return f"{self.planner} {self.objective}" + ("" if self.seed is None else f" seed {self.seed}")


def candidate_sources(planner: str, objective: Objective, seed: int, count: int) -> list[CandidateSource]:
    """The first count candidates of the rule (see the module); InputError("candidates") when the
    rule gives fewer (the lattice planner gives one per objective)."""
    objectives = [objective] + [o for o in OBJECTIVES if o != objective]
    if planner == LATTICE:
        if count > len(objectives):
            raise InputError("candidates", f"the lattice planner gives at most {len(objectives)} candidates (one per "
                             f"objective), got {count}; use an OMPL planner (e.g. RRTstar) for more")
        return [CandidateSource(LATTICE, o, None) for o in objectives[:count]]

    def optimises(o: Objective) -> bool:
        try:
            check_objective(o, planner)
        except InputError:
            return False
        return True

    own = [o for o in objectives if optimises(o)]
    out: list[CandidateSource] = []
    for o in objectives:
        if o in own:
            out.append(CandidateSource(planner, o, seed))
        out.append(CandidateSource(LATTICE, o, None))
    r = 1
    while len(out) < count:
        out.extend(CandidateSource(planner, o, seed + r) for o in own)
        r += 1
    return out[:count]


class CandidateStatus(enum.Enum):
    """What became of a candidate. Candidate.why holds the evidence where there are no trials."""

    SIMULATED = "simulated"  #: executed and simulated: successes of trials
    SAME_PATH = "same_path"  #: the path of an earlier candidate (same_as): its trials
    NOT_SOLVED = "not_solved"  #: the planner found no plan: why is the plan's reason
    NOT_EXECUTABLE = "not_executable"  #: the robot cannot execute the plan: why is the robot's reason


@dataclass
class Candidate:
    """One candidate plan and its simulated trials."""

    index: int
    """Its place in the rule's order (count from 0)."""
    source: CandidateSource
    """Where it comes from."""
    plan: Plan
    """The plan (solved or not)."""
    status: CandidateStatus
    """What became of it."""
    why: str = ""
    """Why it has no trials (NOT_SOLVED, NOT_EXECUTABLE); empty otherwise."""
    same_as: int | None = None
    """The earlier candidate with the same path (SAME_PATH)."""
    results: list[TrialResult] = field(default_factory=list, repr=False)
    """Its trials, in trial order (empty without trials)."""
    planning_time_s: float = 0.0
    """Wall time to plan it and turn it into a robot trajectory (s)."""

    @property
    def simulated(self) -> bool:
        """It has trials (its own or those of an earlier candidate with the same path)."""
        return bool(self.results)

    @property
    def successes(self) -> int | None:
        """Trials placed within the scene's sim.max_error of the target (count); None: no trials."""
        return sum(t.success for t in self.results) if self.results else None

    @property
    def interval(self) -> tuple[float, float] | None:
        """Wilson's 95 % interval of its success rate (fractions); None: no trials."""
        return wilson_interval(self.successes, len(self.results)) if self.results else None

    @property
    def causes(self) -> dict[str, int]:
        """Its failed trials counted by outcome and phase ('B past the thumb tip in P_theta': 3)."""
        return failure_causes(self.results)

    def to_dict(self) -> dict:
        """Its row of plan.json's certification.candidates."""
        low, high = self.interval or (None, None)
        return {"index": self.index, "source": self.source.label(), "planner": self.source.planner,
                "objective": self.source.objective, "seed": self.source.seed, "status": self.status.value,
                "cost": self.plan.cost, "successes": self.successes, "trials": len(self.results) or None,
                "wilson_low": low, "wilson_high": high, "causes": self.causes, "same_as": self.same_as,
                "why": self.why, "planning_time_s": self.planning_time_s}


@dataclass
class CertifyResult:
    """The candidates in the rule's order and the one kept."""

    scene: str
    """The scene's name."""
    options: CertifyOptions
    """What it ran with."""
    candidates: list[Candidate]
    """Every candidate, in the rule's order."""
    kept: int | None
    """The index of the kept candidate; None: none could be simulated (see the candidates' why)."""
    wall_time_s: float = 0.0
    """Wall time of the whole certification (s)."""

    @property
    def certified(self) -> bool:
        """A candidate was simulated and kept."""
        return self.kept is not None

    @property
    def plan(self) -> Plan | None:
        """The kept candidate's plan."""
        return None if self.kept is None else self.candidates[self.kept].plan

    def to_dict(self) -> dict:
        """plan.json's certification: the kept candidate's counts and bound, and every candidate."""
        kept = self.candidates[self.kept] if self.kept is not None else None
        return {"kept": self.kept, "source": kept.source.label() if kept else None,
                "successes": kept.successes if kept else None, "trials": self.options.trials,
                "wilson_low": kept.interval[0] if kept else None, "wilson_high": kept.interval[1] if kept else None,
                "perturbation": self.options.perturb, "seed": self.options.run.seed, "wall_time_s": self.wall_time_s,
                "candidates": [c.to_dict() for c in self.candidates]}


@dataclass(frozen=True)
class CertifyProgress:
    """How far a certification has got."""

    stage: str
    """'planning' (candidates planned and executed) or 'simulating' (trials run)."""
    done: int
    """Units done in this stage (candidates, or trials)."""
    total: int
    """Units in this stage (count)."""


def certify(scene: Scene, options: CertifyOptions,
            progress: Callable[[CertifyProgress], None] | None = None) -> CertifyResult:
    """Plan the candidates of the rule (see the module), execute each solved one on the robot,
    simulate N trials of each executable one, and keep the one with the highest Wilson 95 %
    lower bound. Raises InputError naming the flag for bad options or a scene the simulator cannot
    take (no thickness); a candidate that is not solved or not executable is recorded as such."""
    options = options.validated(scene)
    if scene.object_thickness <= 0.0:
        raise InputError("trials", "the simulator needs an object with a thickness (object.thickness)")
    t0 = time.perf_counter()
    planner = options.planner
    sources = candidate_sources(planner.planner, planner.objective, planner.seed, options.candidates)
    atlas = SecurityAtlas(scene, planning_box(scene))  # one secure lattice for every candidate
    candidates: list[Candidate] = []
    setups = []  # (candidate index, trial setup) of the candidates to simulate
    for k, source in enumerate(sources):
        t1 = time.perf_counter()
        result = plan(scene, replace(planner, planner=source.planner, objective=source.objective,
                                     seed=planner.seed if source.seed is None else source.seed), atlas=atlas)
        cand = Candidate(k, source, result, CandidateStatus.NOT_SOLVED, why=result.reason or "")
        if result.solved:
            same = next((c for c in candidates if c.status is CandidateStatus.SIMULATED
                         and _same_path(c.plan, result)), None)
            if same is not None:
                cand.status, cand.why, cand.same_as = CandidateStatus.SAME_PATH, "", same.index
            else:
                try:
                    _, setup = placement(scene, result)
                except UngraspError as exc:  # out of reach, a collision of the arm, beyond the joint limits
                    cand.status, cand.why = CandidateStatus.NOT_EXECUTABLE, str(exc)
                else:
                    cand.status, cand.why = CandidateStatus.SIMULATED, ""
                    setups.append((k, setup))
        cand.planning_time_s = time.perf_counter() - t1
        candidates.append(cand)
        if progress:
            progress(CertifyProgress("planning", k + 1, len(sources)))
    if setups:
        total, done = len(setups) * options.trials, [0]

        def step(_: TrialResult) -> None:
            done[0] += 1
            if progress:
                progress(CertifyProgress("simulating", done[0], total))

        runs = run_trials([s for _, s in setups], preset(options.perturb), options.trials, options.run, progress=step)
        for (k, _), results in zip(setups, runs):
            candidates[k].results = results
        for c in candidates:
            if c.status is CandidateStatus.SAME_PATH:
                c.results = candidates[c.same_as].results
    kept = best_candidate([(c.successes, len(c.results), c.plan.cost) if c.simulated else None for c in candidates])
    return CertifyResult(scene.name, options, candidates, kept, time.perf_counter() - t0)


def best_candidate(rows: list[tuple[int, int, float] | None]) -> int | None:
    """The index of the row (successes, trials, cost) with the highest Wilson 95 % lower bound on
    the success rate; among equal bounds the lowest cost, then the first. Rows that are None (no
    trials) are passed over; None when every row is."""
    scored = [(wilson_interval(s, n)[0], -cost, -k) for k, row in enumerate(rows) if row is not None
              for s, n, cost in [row]]
    return -max(scored)[2] if scored else None


def _same_path(a: Plan, b: Plan) -> bool:
    """The two plans move through the same primitives and waypoints (to 1e-12)."""
    if len(a.primitives) != len(b.primitives):
        return False
    for p, q in zip(a.primitives, b.primitives):
        if p.type != q.type or len(p.waypoints) != len(q.waypoints):
            return False
        if any(not math.isclose(x, y, abs_tol=1e-12) for u, v in zip(p.waypoints, q.waypoints) for x, y in zip(u, v)):
            return False
    return True
