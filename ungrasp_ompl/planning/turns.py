"""PRM and PRM* with Python callbacks: their two solver threads take turns.

OMPL's ``PRM::solve()`` grows the roadmap in the calling thread and, in a
second C++ thread, adds goal milestones and searches the roadmap for a path.
Both threads call back into Python (validity, motions, costs, the goal), and
the wheel's bindings keep the GIL while the calling thread runs C++. Left to
themselves the threads deadlock: the search thread waits for the GIL while it
holds the roadmap's mutex, and the calling thread waits for that mutex while
it holds the GIL (ompl 2.0.1 wheel; measured: every run hangs).

:class:`TakeTurns` is the termination condition that avoids it. solve() starts
the search thread, then consults the condition at the head of its roadmap
loop, where it holds no lock. That first call does the whole run: it grows
the roadmap through the planner's own single-threaded calls
(``growRoadmapPtc``, then ``expandRoadmapPtc`` for half as long, as
``constructRoadmap`` does), and between phases waits in Python (the GIL
released) while the search thread runs one round at the head of its own loop
(a goal milestone, then a search from the start to every goal milestone).
Only one thread is in the planner at a time, so the roadmap's mutex is never
contended, and every phase ends after a count of calls, not on wall time (as
``constructRoadmap``'s phases do), so a seeded run is reproducible.

PRM's roadmap is undirected and it checks each edge once, from the older
milestone to the newer: with one-way motions that would lose every edge
whose secure direction points the other way. While the roadmap grows, the
validator and the objective here (RoadmapMotionValidator,
RoadmapCostObjective, ``either_way``) take an edge that is secure in either
direction, at the cost of that direction; the search then costs a path in
its travel direction and keeps it only if every edge is secure that way.

A round searches from the start to every goal milestone, so rounds grow
dearer as the roadmap does. They share the time with growing, as PRM's two
threads would on one core: a round runs only when the calls of growing so
far, weighed WORK_PER_CALL each, outweigh the search work done so far
(counted in cost-heuristic calls, which the searches make per vertex).

When the run is over, the search thread runs a last round over the final
roadmap and is stopped, and the call returns ``True`` only once that thread
has left the interpreter for good (its Python thread state is gone): solve()
then joins it while holding the GIL, and returns the best path found.
"""

from __future__ import annotations

import ctypes
import math
import threading
import time
from collections.abc import Callable

from ompl import base as ob

from .objective import PrimitiveCostObjective
from .validity import PrimitiveMotionValidator

#: Planners whose solve() runs a second, solution-checking thread (see the module docstring).
ROADMAP_PLANNERS = ("PRM", "PRMstar")
#: Condition calls (about two per milestone) of a growing phase; expanding phases get half.
GROW_CALLS = 100
#: One growing call's weight in search work (cost-heuristic calls). Measured on reference_asymmetric
#: and guitar_pick: a growing call takes 0.45-0.9 ms, a heuristic call of a round 16-17 us, so
#: rounds take about a fifth of the time (success in 1 s runs was the same with 40: a half).
WORK_PER_CALL = 15
#: Seconds to wait for the search thread to show up; it does within microseconds once solve()
#: has started it, so this only bounds a wait for a thread that was never started.
CONTACT_TIMEOUT_S = 2.0


class TakeTurns:
    """The termination condition for a PRM/PRM* planner's solve(): grows its roadmap in phases
    and lets the search thread run a round between them (see WORK_PER_CALL), until done() (the
    run's own condition, consulted once per growing call) says stop.

    work: the search work so far (cost-heuristic calls); either_way: objects whose either_way is
    set while the roadmap grows. After solve(): rounds (search rounds run), interrupt (an
    exception raised while it ran, such as KeyboardInterrupt, that ended the run early; re-raise it).
    """

    def __init__(self, planner, done: Callable[[], bool], work: Callable[[], int] = lambda: 0,
                 either_way: tuple = (), grow_calls: int = GROW_CALLS):
        self._planner = planner
        self._either_way = either_way  # objects whose either_way is set while the roadmap grows
        self._done = done
        self._work = work  # search work done so far (see WORK_PER_CALL)
        self._grow_calls = max(2, int(grow_calls))
        self._grown = 0  # growing calls so far
        self._owner = threading.get_ident()  # the thread that calls solve()
        self._cond = threading.Condition(threading.Lock())
        self._turn = "grow"  # or "search"
        self._search = "new"  # the search thread: new, waiting, searching, leaving, gone
        self._search_tstate: int | None = None
        self._started = False
        self._stop = False
        self._left = 0  # calls left in the current phase
        self.rounds = 0
        self.interrupt: BaseException | None = None

    def __call__(self) -> bool:
        if threading.get_ident() != self._owner:
            return self._search_thread()
        try:
            if not self._started:  # the head of PRM's roadmap loop: run it all from here
                self._started = True
                self._run()
        except BaseException as exc:  # e.g. KeyboardInterrupt in a callback: end cleanly, re-raised after solve()
            self.interrupt = self.interrupt or exc
        self._stop = True
        while True:  # an exception escaping here would abort the process (solve()'s thread is joinable)
            try:
                self._finish()
                return True
            except BaseException as exc:
                self.interrupt = self.interrupt or exc

    # -- the thread that called solve(): grows the roadmap --------------------------------
    def _run(self) -> None:
        phase = ob.PlannerTerminationCondition(self._phase)
        while not self._stop:
            self._grow(self._planner.growRoadmapPtc, phase, self._grow_calls)
            if not self._stop:
                self._grow(self._planner.expandRoadmapPtc, phase, self._grow_calls // 2)
            if self.interrupt is None and (self._stop or self._grown * WORK_PER_CALL >= self._work()):
                self._hand_over()  # after the last phase too: the final roadmap is searched

    def _grow(self, method, phase, calls: int) -> None:
        self._left = calls
        for part in self._either_way:
            part.either_way = True
        try:
            method(phase)
        finally:
            for part in self._either_way:
                part.either_way = False

    def _phase(self) -> bool:
        """The condition of one phase: ends it after its count of calls, or the run."""
        if not self._stop:
            try:
                self._stop = bool(self._done())
            except BaseException as exc:  # e.g. KeyboardInterrupt: end cleanly, re-raised after solve()
                self.interrupt = exc
                self._stop = True
        self._left -= 1
        self._grown += 1
        return self._stop or self._left < 0

    def _hand_over(self) -> None:
        """Let the search thread run one round; return when it is back at its loop's head."""
        with self._cond:
            self._turn = "search"
            self._cond.notify_all()
            if not self._cond.wait_for(lambda: self._search != "new", timeout=CONTACT_TIMEOUT_S):
                self._turn = "grow"  # no search thread: nothing to wait for
                return
            self._cond.wait_for(lambda: self._turn == "grow")

    def _finish(self) -> None:
        """Stop the search thread and wait until it has left the interpreter."""
        if self._search == "gone":
            return
        with self._cond:
            self._cond.notify_all()
            if not self._cond.wait_for(lambda: self._search != "new", timeout=CONTACT_TIMEOUT_S):
                return  # never started
            self._cond.wait_for(lambda: self._search == "leaving")  # after a round it may be in
        while _thread_state_alive(self._search_tstate):
            time.sleep(0.0002)  # releases the GIL
        self._search = "gone"

    # -- PRM's solution-checking thread: never raises (an exception there aborts the process) --
    def _search_thread(self) -> bool:
        with self._cond:
            if self._search == "searching":  # a round has ended: the roadmap's turn
                self._turn = "grow"
            self._search = "waiting"
            self._cond.notify_all()
            self._cond.wait_for(lambda: self._turn == "search" or self._stop)
            if self._turn != "search":  # stopped
                self._search_tstate = _thread_state_id()
                self._search = "leaving"
                self._cond.notify_all()
                return True
            self._search = "searching"
            self.rounds += 1
            return False


class RoadmapMotionValidator(PrimitiveMotionValidator):
    """The motion validator for PRM/PRM*: while the roadmap grows (either_way), a motion is an
    edge if it is secure in either direction; otherwise (the search thread, and everything
    after solve()) only in its own."""

    either_way = False

    def checkMotion(self, s1, s2, *last_valid) -> bool:
        if super().checkMotion(s1, s2, *last_valid):
            return True
        if not self.either_way:
            return False
        index = self.atlas.index
        a, b = index((s2[0], s2[1], s2[2])), index((s1[0], s1[1], s1[2]))
        return a is not None and b is not None and self.atlas.motion_secure(a, b)


class RoadmapCostObjective(PrimitiveCostObjective):
    """The planners' objective for PRM/PRM*.

    PRM's roadmap is undirected: its search may travel an edge against the direction it was
    checked in, and keeps a path only if the path's cost, summed in travel direction, is finite.
    So a motion costs infinity unless it is secure in its own direction; while the roadmap
    grows (either_way), an edge secure only the other way costs that way's cost, so it weighs
    what the search may use it for.

    It records when the search thread first costs a finite path (first_solution, a
    time.perf_counter(), or None), and is never satisfied, so the search thread stops only
    when told to (see TakeTurns). heuristic_calls: cost-heuristic calls so far (the searches
    make one per vertex they reach).
    """

    def __init__(self, si, atlas):
        super().__init__(si, atlas)
        self.first_solution: float | None = None
        self.heuristic_calls = 0

    either_way = False

    def motionCost(self, s1, s2):
        index = self.atlas.index
        a = index((s1[0], s1[1], s1[2]))
        b = index((s2[0], s2[1], s2[2]))
        if a is None or b is None:
            return self.infiniteCost()
        if self.atlas.motion_secure(a, b):
            return super().motionCost(s1, s2)
        if self.either_way and self.atlas.motion_secure(b, a):
            return super().motionCost(s2, s1)
        return self.infiniteCost()

    def motionCostHeuristic(self, s1, s2):
        self.heuristic_calls += 1
        return super().motionCostHeuristic(s1, s2)

    def isSatisfied(self, cost) -> bool:
        if self.first_solution is None and math.isfinite(cost.value()):
            self.first_solution = time.perf_counter()
        return False


# -- Python thread states (CPython C API; called with the GIL held) --------------------------
_api = ctypes.pythonapi
_api.PyThreadState_Get.restype = ctypes.c_void_p
_api.PyThreadState_GetID.restype = ctypes.c_uint64
_api.PyThreadState_GetID.argtypes = [ctypes.c_void_p]
_api.PyInterpreterState_Get.restype = ctypes.c_void_p
_api.PyInterpreterState_ThreadHead.restype = ctypes.c_void_p
_api.PyInterpreterState_ThreadHead.argtypes = [ctypes.c_void_p]
_api.PyThreadState_Next.restype = ctypes.c_void_p
_api.PyThreadState_Next.argtypes = [ctypes.c_void_p]


def _thread_state_id() -> int:
    """The unique id of the calling thread's Python thread state (never reused)."""
    return int(_api.PyThreadState_GetID(_api.PyThreadState_Get()))


def _thread_state_alive(ident: int | None) -> bool:
    """Whether a thread state of that id still exists in this interpreter."""
    if ident is None:
        return False
    ts = _api.PyInterpreterState_ThreadHead(_api.PyInterpreterState_Get())
    while ts:
        if _api.PyThreadState_GetID(ts) == ident:
            return True
        ts = _api.PyThreadState_Next(ts)
    return False
