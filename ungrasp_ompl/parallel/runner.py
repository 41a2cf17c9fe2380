"""Run a function on tasks in child processes: the one place that starts, watches and ends them.

A :class:`Runner` takes a picklable function and its tasks and yields each task's
:class:`TaskOutcome` as it completes, with the task's index. :class:`LocalRunner` runs
them in spawned child processes on this machine, ``jobs`` at a time, either a fresh
process per task (OMPL's RNG takes its seed once per process, so every seeded planner
run needs one) or ``jobs`` workers reused from task to task (cheap tasks, where a spawn,
about a second, would cost more than the task). :class:`InlineRunner` runs them in this
process. :class:`RayRunner` runs them on a Ray cluster, behind the same :meth:`Runner.run`;
:func:`open_runner` picks one of them for a campaign.

A child process leaves through ``os._exit`` once its output is flushed, skipping
interpreter finalisation, where nanobind lists the OMPL objects still alive (noise to a
user). Children ignore SIGINT: an interrupt reaches the parent, which kills them; so does
closing the iterator of outcomes early (``contextlib.closing``).
"""

from __future__ import annotations

import enum
import logging
import multiprocessing as mp
import os
import pickle
import signal
import socket
import sys
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from contextlib import closing, contextmanager
from dataclasses import dataclass
from multiprocessing.connection import wait
from typing import Any, Generic, Protocol, TypeVar

from ..errors import InputError, ToolError

T = TypeVar("T")
R = TypeVar("R")

#: Seconds a worker that has no more tasks gets to leave by itself before it is killed.
_LEAVE_S = 5.0


class TaskStatus(enum.Enum):
    """How a task ended."""

    DONE = "done"  #: returned a value
    FAILED = "failed"  #: raised an exception
    HUNG = "hung"  #: still running at its deadline: killed
    DIED = "died"  #: its process ended without an answer


class TaskLost(RuntimeError):
    """A task gave no answer: its process was killed at the deadline or ended on its own."""


class UnsentError(RuntimeError):
    """A task's exception that could not be sent back from its child process as itself."""


@dataclass(frozen=True)
class TaskOutcome(Generic[R]):
    """One task's end."""

    index: int
    """The task's index among the tasks given (count from 0)."""
    status: TaskStatus
    """How it ended."""
    value: R | None = None
    """What fn returned (DONE)."""
    error: BaseException | None = None
    """The exception fn raised (FAILED), with a note holding the child's traceback."""
    wall_time_s: float = 0.0
    """Seconds from handing the task over to its end (s)."""

    def unwrap(self) -> R:
        """The value; raises a FAILED task's exception, TaskLost for a HUNG or DIED one."""
        if self.status is TaskStatus.DONE:
            return self.value  # type: ignore[return-value]
        if self.status is TaskStatus.FAILED:
            raise self.error  # type: ignore[misc]
        raise TaskLost(f"task {self.index} {self.status.value} after {self.wall_time_s:.1f} s without an answer")


class Runner(Protocol):
    """Runs fn on tasks; yields each task's outcome as it completes (not in task order).

    deadline: seconds a task may run, from its hand-over, before it is stopped and
    reported HUNG (None: no limit). Closing the iterator early stops the tasks still running.
    """

    def run(self, fn: Callable[[T], R], tasks: Iterable[T],
            deadline: float | None = None) -> Iterator[TaskOutcome[R]]: ...


class InlineRunner:
    """Runs the tasks in this process, one after the other, without deadline or isolation."""

    def run(self, fn: Callable[[T], R], tasks: Iterable[T],
            deadline: float | None = None) -> Iterator[TaskOutcome[R]]:
        for index, task in enumerate(tasks):
            t0 = time.perf_counter()
            try:
                value = fn(task)
            except Exception as exc:
                yield TaskOutcome(index, TaskStatus.FAILED, error=exc, wall_time_s=time.perf_counter() - t0)
            else:
                yield TaskOutcome(index, TaskStatus.DONE, value, wall_time_s=time.perf_counter() - t0)


@dataclass(frozen=True)
class LocalRunner:
    """Runs the tasks in spawned child processes of this machine, ``jobs`` at a time.

    fn and the tasks must be picklable (fn a module-level function); fn runs in the child,
    which imports fn's module.
    """

    jobs: int = 1
    """Child processes at a time (count)."""
    fresh: bool = True
    """True: a fresh process per task; False: ``jobs`` workers, each running task after task."""

    def run(self, fn: Callable[[T], R], tasks: Iterable[T],
            deadline: float | None = None) -> Iterator[TaskOutcome[R]]:
        if isinstance(self.jobs, bool) or not isinstance(self.jobs, int) or self.jobs < 1:
            raise ValueError(f"jobs must be a positive integer, got {self.jobs!r}")
        if deadline is not None and not deadline > 0:
            raise ValueError(f"deadline must be a positive number of seconds or None, got {deadline!r}")
        return self._run(fn, list(tasks), deadline)

    def _run(self, fn: Callable[[T], R], tasks: list[T], deadline: float | None) -> Iterator[TaskOutcome[R]]:
        ctx = mp.get_context("spawn")
        pending = deque(enumerate(tasks))
        idle: list[_Worker] = []
        busy: list[_Worker] = []
        try:
            while pending or busy:
                for _ in range(min(len(pending), self.jobs - len(busy)) - len(idle)):
                    idle.append(_Worker(ctx, fn, self.fresh))
                while pending and idle:
                    index, task = pending.popleft()
                    worker = idle.pop()
                    worker.hand(index, pickle.dumps(task), deadline)
                    busy.append(worker)
                wait([w.answers for w in busy] + [w.process.sentinel for w in busy], _time_left(busy))
                for worker in list(busy):
                    outcome = worker.collect()
                    if outcome is None:
                        continue
                    busy.remove(worker)
                    if self.fresh or outcome.status in (TaskStatus.HUNG, TaskStatus.DIED):
                        worker.stop()
                    else:
                        idle.append(worker)
                    yield outcome
        finally:
            for worker in busy:
                worker.kill()
            for worker in idle + busy:
                worker.stop()


class RayRunner:
    """Runs the tasks on a Ray cluster (``pip install 'ungrasp-ompl[cluster]'``); ray is imported here only.

    Every machine of the cluster needs this package installed (the same version), as the
    tasks run its functions. A task that raises is FAILED with its exception; a task whose
    worker process dies is run again by Ray up to max_retries times, then reported DIED; a
    task given a deadline runs in a thread of its worker and is reported HUNG when it has not
    returned within the deadline from its start; that worker, its thread still busy, leaves at
    the next task it is given, which Ray runs again on another worker.
    """

    def __init__(self, address: str = "local", fresh: bool = True, max_retries: int = 3,
                 in_flight: int | None = None) -> None:
        self.address = address
        """Cluster address: "local" starts one on this machine, "auto" finds a running local one,
        HOST:PORT (or ray://HOST:PORT) joins one. A Ray already connected in this process is used as is."""
        self.fresh = fresh
        """True: a fresh worker process per task (Ray's max_calls=1): OMPL's RNG takes a seed once per process."""
        self.max_retries = max_retries
        """Times Ray runs a task again when its worker process dies (count)."""
        self.in_flight = in_flight
        """Tasks handed to Ray at a time (count); None: twice the cluster's CPUs."""
        self.started = False
        """Whether connect() started Ray in this process (close() then stops it)."""

    def connect(self) -> "RayRunner":
        """Connect to the cluster now (starting one for "local"); InputError("cluster") when no
        cluster answers at the address, ToolError when ray is not installed."""
        ray = _ray()
        if ray.is_initialized():
            return self
        quiet = dict(log_to_driver=False, logging_level=logging.ERROR)
        if self.address == "local":
            ray.init(address="local", include_dashboard=False, **quiet)
        else:
            _check_reachable(self.address)
            ray.init(address=self.address, **quiet)
        self.started = True
        return self

    def close(self) -> None:
        """Stop Ray if connect() started it in this process."""
        if self.started:
            _ray().shutdown()
            self.started = False

    def run(self, fn: Callable[[T], R], tasks: Iterable[T],
            deadline: float | None = None) -> Iterator[TaskOutcome[R]]:
        if deadline is not None and not deadline > 0:
            raise ValueError(f"deadline must be a positive number of seconds or None, got {deadline!r}")
        self.connect()
        return self._run(fn, list(tasks), deadline)

    def _run(self, fn: Callable[[T], R], tasks: list[T], deadline: float | None) -> Iterator[TaskOutcome[R]]:
        ray = _ray()
        remote = ray.remote(max_calls=1 if self.fresh else 0, max_retries=self.max_retries, num_cpus=1)(_ray_call)
        limit = self.in_flight or max(1, 2 * int(ray.cluster_resources().get("CPU", 1)))
        pending = deque(enumerate(tasks))
        running: dict[Any, tuple[int, float]] = {}  # object ref -> (task index, hand-over time)
        try:
            while pending or running:
                while pending and len(running) < limit:
                    index, task = pending.popleft()
                    running[remote.remote(fn, task, deadline)] = (index, time.monotonic())
                ready, _ = ray.wait(list(running), num_returns=1)
                for ref in ready:
                    index, t0 = running.pop(ref)
                    yield _ray_outcome(ray, ref, index, time.monotonic() - t0)
        finally:
            for ref in running:
                ray.cancel(ref, force=True)


def _ray():
    try:
        import ray  # ray: optional (the cluster extra), loaded for --cluster
    except ImportError:
        raise ToolError("--cluster needs Ray: pip install 'ungrasp-ompl[cluster]'") from None
    return ray


def _check_reachable(address: str, timeout_s: float = 3.0, probe_s: float = 30.0) -> None:
    """InputError("cluster") unless a Ray cluster answers at the address: something must accept
    a connection on HOST:PORT within timeout_s, and a child process must connect to Ray there
    within probe_s (where Ray itself would retry for long, logging every attempt)."""
    if address != "auto":
        host, sep, port = address.removeprefix("ray://").rpartition(":")
        if not sep or not host or not port.isdigit():
            raise InputError("cluster", f"must be local, auto or HOST:PORT (e.g. 10.0.0.5:6379), got {address!r}")
        try:
            socket.create_connection((host, int(port)), timeout=timeout_s).close()
        except OSError as exc:
            raise InputError("cluster", f"no Ray cluster answers at {address} ({exc.strerror or exc})") from None
    probe = run_in_child(_probe_ray, address, deadline=probe_s)
    if probe.status is not TaskStatus.DONE:
        why = str(probe.error) if probe.error else f"no answer in {probe_s:g} s"
        raise InputError("cluster", f"no Ray cluster at {address} ({why.splitlines()[0]})")


def _probe_ray(address: str) -> None:
    """Connect to the Ray cluster at the address and leave (in a child process, its stderr silenced)."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), 2)
    ray = _ray()
    try:
        ray.init(address=address, log_to_driver=False, logging_level=logging.ERROR)
    except Exception as exc:  # Ray's reason is at the chain's root (a missing token, a refused connection)
        root = exc
        while root.__cause__ or root.__context__:
            root = root.__cause__ or root.__context__
        lines = [line.strip() for line in str(root).splitlines() if line.strip()] or [type(root).__name__]
        raise RuntimeError(lines[-1]) from None  # the last line: a traceback's own reason
    ray.shutdown()


#: In a Ray worker: whether a task of this worker hung (its thread may still run).
_HUNG_HERE = False


def _ray_call(fn: Callable[[T], R], task: T, deadline: float | None) -> tuple[bool, Any]:
    """In a Ray worker: (True, fn(task)); with a deadline, fn runs in a thread and the answer is
    (False, seconds) when it has not returned by then. fn's exception is raised. A worker one of
    whose tasks hung ends when given the next (Ray counts it dead and runs that task elsewhere)."""
    global _HUNG_HERE
    if _HUNG_HERE:
        os._exit(1)
    if deadline is None:
        return True, fn(task)
    answer: list = []

    def target() -> None:
        try:
            answer.append((True, fn(task)))
        except BaseException as exc:
            answer.append((None, exc))

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(deadline)
    if not answer:
        _HUNG_HERE = True
        return False, deadline
    ok, value = answer[0]
    if ok is None:
        raise value
    return True, value


def _ray_outcome(ray, ref, index: int, wall: float) -> TaskOutcome:
    """The outcome of a finished Ray task."""
    try:
        ok, value = ray.get(ref)
    except ray.exceptions.RayTaskError as exc:  # fn raised: the exception itself when it came back
        cause = getattr(exc, "cause", None)
        return TaskOutcome(index, TaskStatus.FAILED, error=cause if isinstance(cause, BaseException) else exc,
                           wall_time_s=wall)
    except ray.exceptions.TaskCancelledError:
        return TaskOutcome(index, TaskStatus.HUNG, wall_time_s=wall)
    except ray.exceptions.RayError as exc:  # the worker (or its node) died, retries spent
        return TaskOutcome(index, TaskStatus.DIED, error=exc, wall_time_s=wall)
    if ok:
        return TaskOutcome(index, TaskStatus.DONE, value, wall_time_s=wall)
    return TaskOutcome(index, TaskStatus.HUNG, wall_time_s=wall)


@contextmanager
def open_runner(jobs: int, cluster: str | None = None, fresh: bool = True) -> Iterator[Runner]:
    """The runner for a campaign: ``jobs`` child processes here, or the Ray cluster at the address
    (connected now; a cluster started here is stopped at the end). fresh: a new process per task."""
    if cluster is None:
        yield LocalRunner(jobs, fresh=fresh)
        return
    runner = RayRunner(cluster, fresh=fresh).connect()
    try:
        yield runner
    finally:
        runner.close()


def default_jobs() -> int:
    """The worker processes a command runs when not told (--jobs): all cores (count)."""
    return max(1, os.cpu_count() or 1)


def resolve_jobs(jobs: int | None) -> int | None:
    """jobs as given, or all cores (default_jobs) for None; the caller checks a given value."""
    return default_jobs() if jobs is None else jobs


def run_in_child(fn: Callable[..., R], *args: Any, deadline: float | None = None) -> TaskOutcome[R]:
    """Call fn(*args) in a fresh child process, stopped after deadline seconds if given.
    Returns its outcome: DONE with the value, FAILED with the exception, HUNG or DIED."""
    with closing(LocalRunner(1).run(_call, [(fn, args)], deadline)) as outcomes:
        return next(outcomes)


def _call(item: tuple[Callable[..., R], tuple]) -> R:
    fn, args = item
    return fn(*args)


def _time_left(busy: list[_Worker]) -> float | None:
    """Seconds until the nearest deadline of the busy workers (None: none has one)."""
    deadlines = [w.deadline for w in busy if w.deadline is not None]
    return max(0.0, min(deadlines) - time.monotonic()) if deadlines else None


class _Worker:
    """A child process with the pipe its tasks go down and the pipe its answers come up."""

    def __init__(self, ctx, fn: Callable, once: bool) -> None:
        receiver, self.tasks = ctx.Pipe(duplex=False)
        self.answers, sender = ctx.Pipe(duplex=False)
        self.process = ctx.Process(target=_serve, args=(fn, receiver, sender, once), daemon=True)
        self.process.start()
        receiver.close()
        sender.close()
        self.index = -1
        self.started = 0.0
        self.deadline: float | None = None

    def hand(self, index: int, payload: bytes, deadline: float | None) -> None:
        """Send a pickled task; a thread sends it, as a child that is still starting reads it late."""
        self.index = index
        self.started = time.monotonic()
        self.deadline = None if deadline is None else self.started + deadline
        threading.Thread(target=_send_quietly, args=(self.tasks, payload), daemon=True).start()

    def collect(self) -> TaskOutcome | None:
        """The task's outcome if it has ended (killing it past its deadline); None while it runs."""
        alive = self.process.is_alive()
        now = time.monotonic()
        wall = now - self.started
        if self.answers.poll():
            try:
                ok, value = pickle.loads(self.answers.recv_bytes())
            except EOFError:
                return TaskOutcome(self.index, TaskStatus.DIED, wall_time_s=wall)
            except Exception as exc:  # the answer does not unpickle here
                return TaskOutcome(self.index, TaskStatus.FAILED, error=exc, wall_time_s=wall)
            if ok:
                return TaskOutcome(self.index, TaskStatus.DONE, value, wall_time_s=wall)
            return TaskOutcome(self.index, TaskStatus.FAILED, error=value, wall_time_s=wall)
        if not alive:
            return TaskOutcome(self.index, TaskStatus.DIED, wall_time_s=wall)
        if self.deadline is not None and now >= self.deadline:
            self.kill()
            return TaskOutcome(self.index, TaskStatus.HUNG, wall_time_s=wall)
        return None

    def kill(self) -> None:
        if self.process.is_alive():
            self.process.kill()

    def stop(self) -> None:
        """End the worker: its task pipe closed, it leaves by itself or is killed."""
        self.tasks.close()
        self.process.join(_LEAVE_S)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self.answers.close()
        self.process.close()


def _send_quietly(conn, payload: bytes) -> None:
    try:
        conn.send_bytes(payload)
    except (OSError, ValueError):  # the worker was stopped first
        pass


def _serve(fn: Callable, tasks, answers, once: bool) -> None:
    """A child's loop: answer tasks until the task pipe closes (or after one task, once)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        while True:
            try:
                payload = tasks.recv_bytes()
            except EOFError:
                break
            answers.send_bytes(_answer(fn, payload))
            if once:
                break
    except OSError:  # the parent is gone
        pass
    finally:
        _leave()


def _answer(fn: Callable, payload: bytes) -> bytes:
    """Pickled (True, value) or (False, exception): what fn gives for the pickled task."""
    try:
        return pickle.dumps((True, fn(pickle.loads(payload))))
    except BaseException as exc:
        exc.add_note("in the child process:\n" + "".join(traceback.format_exception(exc)).rstrip())
        try:
            answer = pickle.dumps((False, exc))
            pickle.loads(answer)
            return answer
        except Exception:
            unsent = UnsentError(f"{type(exc).__name__}: {exc}")
            unsent.add_note(exc.__notes__[-1])
            return pickle.dumps((False, unsent))


def _leave() -> None:
    """End the child process now, its output flushed, without interpreter finalisation."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError, AttributeError):
            pass
    os._exit(0)
