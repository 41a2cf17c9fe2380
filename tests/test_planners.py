"""Planners that need care with Python callbacks: PRM and PRM* (their two solver threads take
turns, planning/turns.py), AORRTC (a loop that never checks its time limit), and the planners
that cannot solve these problems (a known limitation reported by bench)."""

from __future__ import annotations

import faulthandler
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT, SCENES
from ungrasp_ompl import Scene
from ungrasp_ompl.benchmark.options import validate_planners
from ungrasp_ompl.benchmark.statistics import SUMMARY_COLUMNS, limitation_notes, summarise
from ungrasp_ompl.benchmark.tasks import RunResult, RunStatus
from ungrasp_ompl.planning.atlas import FORWARD
from ungrasp_ompl.planning.setup import (KNOWN_LIMITATIONS, PLANNER_ITERATIONS_PER_SECOND, PLANNERS, PlannerOptions,
                                         UngraspSetup)
from ungrasp_ompl.planning.verify import verify_leg

REFERENCE = SCENES / "reference_asymmetric.yaml"
MOVES = {"P_theta": (0,), "P_psi": (2,), "P_dpsi": (1, 2)}
TIMING = ("time_to_first_solution_s", "planning_time_s", "setup_time_s")
HANG_S = 60  # seconds after which a planning run counts as hung


def plan_cli(tmp_path, planner: str, seed: int, time: float, scene=REFERENCE) -> dict:
    """A seeded `ungrasp-ompl plan` run in its own process, stopped (a failure) if it hangs."""
    out = tmp_path / f"{planner}-{seed}-{len(list(tmp_path.iterdir()))}"
    cmd = [sys.executable, "-m", "ungrasp_ompl", "plan", str(scene), "--planner", planner, "--seed", str(seed),
           "--time", str(time), "--out", str(out)]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=HANG_S)
    assert proc.returncode in (0, 3), proc.stdout + proc.stderr
    return json.loads((out / "plan.json").read_text())


def assert_secure_forward_path(scene: Scene, plan: dict) -> None:
    """Independent re-validation: every leg of every primitive passes the exact mechanics and FCL
    (planning/verify.py) at a quarter of the planning resolution in its travel direction, moves
    only its primitive's coordinates, and only forward (theta down, d down, psi up); the path
    starts at the start and ends in the goal."""
    res = np.array(plan["resolution"]) / 4
    for p in plan["primitives"]:
        pts = np.array(p["waypoints"])
        for a, b in zip(pts[:-1], pts[1:]):
            assert verify_leg(scene, p["type"], a, b, res) is None, (p["type"], a, b)
            still = [k for k in range(3) if k not in MOVES[p["type"]]]
            assert np.allclose(a[still], b[still])
            assert np.all((b - a) * FORWARD >= -1e-12), f"{p['type']} leg runs backward: {a} -> {b}"
    states = np.array(plan["states"])
    assert np.allclose(states[0], scene.start)
    assert scene.goal.contains(states[-1])[0]


def test_prm_planners_are_offered():
    assert {"PRM", "PRMstar"} <= set(PLANNERS)
    for name in ("PRM", "PRMstar"):
        PlannerOptions(planner=name).validated()
    assert validate_planners(["PRMstar", "PRM", "lattice"]) == ["PRMstar", "PRM", "lattice"]


@pytest.fixture(scope="module")
def prm_star_runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("prmstar")
    return [plan_cli(tmp, "PRMstar", seed=1, time=1.0) for _ in range(2)]


@pytest.mark.slow
def test_seeded_prm_star_solves_the_reference_case(prm_star_runs):
    plan = prm_star_runs[0]
    assert plan["solved"] and plan["planner"] == "PRMstar"
    budget = PLANNER_ITERATIONS_PER_SECOND["PRMstar"] * 1  # a fixed budget, not wall time
    assert plan["stopped_by"] == "iterations" and plan["iterations"] == budget
    assert_secure_forward_path(Scene.from_file(REFERENCE), plan)
    assert 0 < plan["time_to_first_solution_s"] <= plan["planning_time_s"]


@pytest.mark.slow
def test_seeded_prm_star_is_reproducible(prm_star_runs):
    a, b = ({k: v for k, v in p.items() if k not in TIMING} for p in prm_star_runs)
    assert a == b


def test_seeded_prm_solves_the_reference_case(tmp_path):
    plan = plan_cli(tmp_path, "PRM", seed=1, time=1.0)
    assert plan["solved"] and plan["planner"] == "PRM"
    assert_secure_forward_path(Scene.from_file(REFERENCE), plan)


def test_prm_star_in_process_stops_on_its_budget():
    """In the test process itself (threads already started by other tests): PRM*'s solve()
    returns, after exactly its iteration budget, with a path that re-validates. A deadlock
    would hang with the GIL held, so a C-level watchdog ends the process instead."""
    setup = UngraspSetup(Scene.from_file(REFERENCE), PlannerOptions(planner="PRMstar", time=5.0, iterations=600))
    faulthandler.dump_traceback_later(HANG_S, exit=True)
    try:
        plan = setup.solve()
    finally:
        faulthandler.cancel_dump_traceback_later()
    assert plan.iterations == 600 and plan.stopped_by == "iterations"
    assert plan.planning_time_s < 5.0
    assert plan.solved, plan.reason
    assert_secure_forward_path(setup.scene, json.loads(plan.to_json()))


def test_motion_asked_for_over_and_over_is_refused():
    """AORRTC's connect loop checks one motion forever without checking its time limit; the
    validator refuses a motion asked for REPEAT_LIMIT times in a row, and only that one."""
    setup = UngraspSetup(Scene.from_file(REFERENCE), PlannerOptions(planner="RRT"))
    mv, space = setup.motion_validator, setup.space

    def state(q):
        s = space.allocState()
        s[0], s[1], s[2] = (float(x) for x in q)
        return s

    a = state(setup.scene.start)
    b = state(setup.scene.start + np.array([-math.radians(5), 0, 0]))
    c = state(setup.scene.start + np.array([-math.radians(4), 0, 0]))
    answers = [mv.checkMotion(a, b) for _ in range(mv.REPEAT_LIMIT + 5)]
    assert answers[:mv.REPEAT_LIMIT] == [True] * mv.REPEAT_LIMIT
    assert answers[mv.REPEAT_LIMIT:] == [False] * 5
    assert mv.checkMotion(a, c) and mv.checkMotion(a, b)  # another motion in between: asked afresh


def _runs(planner: str, status: str, n: int = 3) -> list[RunResult]:
    solved = status == "exact"
    return [RunResult(group="s", planner=planner, run=k, seed=k, status=RunStatus(status), cost=86.0 if solved else None,
                      mode_switches=3 if solved else None, time_to_first_solution_s=0.1 if solved else None,
                      planning_time_s=1.0, setup_time_s=0.5, iterations=100, wall_time_s=1.6) for k in range(n)]


def test_bench_says_why_a_planner_cannot_succeed():
    assert set(KNOWN_LIMITATIONS) == {"FMT", "BFMT"}
    fmt = summarise("s", "FMT", _runs("FMT", "timeout"), optimum=85.5)
    assert fmt.success_rate == 0.0 and fmt.limitation == KNOWN_LIMITATIONS["FMT"].code == "lazy-roadmap"
    bfmt = summarise("s", "BFMT", _runs("BFMT", "timeout"), optimum=85.5)
    assert bfmt.limitation == "backward-goal-tree"
    # no claim where the planner did solve, where no path exists at all, or for other planners
    assert summarise("s", "FMT", _runs("FMT", "exact"), optimum=85.5).limitation is None
    assert summarise("s", "FMT", _runs("FMT", "timeout"), optimum=None).limitation is None
    assert summarise("s", "RRTstar", _runs("RRTstar", "timeout"), optimum=85.5).limitation is None
    notes = limitation_notes([fmt, bfmt])
    assert len(notes) == 2 and notes[0].startswith("FMT: lazy-roadmap: ") and "goal tree" in notes[1]
    column = next(c for c in SUMMARY_COLUMNS if c.csv_name == "known_limitation")
    assert column.value(fmt) == "lazy-roadmap"


def test_a_seeded_run_stops_at_its_time_cap_only_beyond_its_budget_and_records_it():
    """A seeded run stops on its iteration budget; only a budget it cannot reach in SEEDED_TIME_CAP
    times its --time stops it on time, and then the plan records it (stopped_by "time", fewer
    iterations than the budget)."""
    from ungrasp_ompl.planning.setup import SEEDED_TIME_CAP

    time = 0.002
    setup = UngraspSetup(Scene.from_file(REFERENCE), PlannerOptions(time=time, seed=1, iterations=10**8))
    plan = setup.solve()
    assert plan.stopped_by == "time" and plan.iterations < 10**8
    assert SEEDED_TIME_CAP * time <= plan.planning_time_s < SEEDED_TIME_CAP * time + 1.0
