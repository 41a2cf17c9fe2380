"""The child-process runner, with real processes: answers, deadlines, deaths, exceptions, interrupts."""

from __future__ import annotations

import os
import signal
import threading
import time
from contextlib import closing
from pathlib import Path

import pytest

from ungrasp_ompl.parallel.runner import (InlineRunner, LocalRunner, TaskLost, TaskOutcome, TaskStatus, UnsentError,
                                 run_in_child)


class _Picky(Exception):
    """An exception that pickles but does not unpickle (its __init__ wants two arguments)."""

    def __init__(self, a: str, b: str) -> None:
        super().__init__(f"{a} and {b}")


def _work(task: tuple) -> object:
    """What the tests run in the children: (kind, argument)."""
    kind, arg = task
    if kind == "square":
        return arg * arg, os.getpid()
    if kind == "nap":  # arg: (pid file, seconds)
        Path(arg[0]).write_text(str(os.getpid()))
        time.sleep(arg[1])
        return os.getpid()
    if kind == "exit":
        os._exit(arg)
    if kind == "raise":
        raise ValueError(f"boom {arg}")
    if kind == "picky":
        raise _Picky("a", arg)
    raise AssertionError(kind)


def _add(a: int, b: int) -> int:
    return a + b


def _all(outcomes) -> dict[int, TaskOutcome]:
    """The outcomes by task index, checking that every index comes once."""
    out = {}
    for o in outcomes:
        assert o.index not in out
        out[o.index] = o
    return out


def _gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


@pytest.mark.parametrize("fresh", [True, False])
def test_results_equal_running_inline_and_the_processes_are_fresh_or_reused(fresh):
    n = 3 if fresh else 5
    tasks = [("square", k) for k in range(n)]
    inline = _all(InlineRunner().run(_work, tasks))
    done = _all(LocalRunner(2, fresh=fresh).run(_work, tasks))
    assert sorted(done) == list(range(n))
    assert all(o.status is TaskStatus.DONE for o in done.values())
    assert [done[k].value[0] for k in range(n)] == [inline[k].value[0] for k in range(n)] == [k * k for k in range(n)]
    pids = [done[k].value[1] for k in range(n)]
    assert os.getpid() not in pids
    if fresh:
        assert len(set(pids)) == n
    else:
        assert len(set(pids)) <= 2


@pytest.mark.slow
def test_a_task_past_its_deadline_is_hung_and_killed_and_the_run_goes_on(tmp_path):
    pid_file = tmp_path / "pid"
    t0 = time.monotonic()
    done = _all(LocalRunner(1, fresh=False).run(_work, [("nap", (pid_file, 60)), ("square", 3)], deadline=4.0))
    assert time.monotonic() - t0 < 30
    assert done[0].status is TaskStatus.HUNG and done[0].wall_time_s >= 4.0
    assert _gone(int(pid_file.read_text()))
    assert done[1].status is TaskStatus.DONE and done[1].value[0] == 9
    with pytest.raises(TaskLost):
        done[0].unwrap()


def test_a_process_that_ends_without_answering_died_and_the_run_goes_on():
    done = _all(LocalRunner(1, fresh=False).run(_work, [("exit", 0), ("square", 2)]))
    assert done[0].status is TaskStatus.DIED and done[0].value is None
    assert done[1].status is TaskStatus.DONE and done[1].value[0] == 4


def test_an_exception_comes_back_typed_and_the_worker_goes_on():
    tasks = [("raise", 7), ("picky", "b"), ("square", 5), ("square", 6)]
    done = _all(LocalRunner(1, fresh=False).run(_work, tasks))
    failed = done[0]
    assert failed.status is TaskStatus.FAILED and isinstance(failed.error, ValueError)
    assert str(failed.error) == "boom 7" and "in the child process" in failed.error.__notes__[-1]
    with pytest.raises(ValueError, match="boom 7"):
        failed.unwrap()
    assert done[1].status is TaskStatus.FAILED and isinstance(done[1].error, UnsentError)
    assert str(done[1].error) == "_Picky: a and b"
    assert done[2].unwrap()[0] == 25 and done[2].value[1] == done[3].value[1]  # the same worker


def test_run_in_child():
    outcome = run_in_child(_add, 2, 3)
    assert outcome.status is TaskStatus.DONE and outcome.unwrap() == 5
    assert run_in_child(time.sleep, 60, deadline=1.0).status is TaskStatus.HUNG


def test_an_interrupt_in_the_parent_kills_the_children(tmp_path):
    files = [tmp_path / f"pid{k}" for k in range(2)]
    # Ctrl-C as a terminal sends it: Python's own handler, the signal at the main thread (a signal
    # sent to the process may land on this test's other thread, which leaves the main thread
    # asleep in its wait until the children answer)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    main = threading.main_thread().ident

    def interrupt() -> None:
        end = time.monotonic() + 20
        while not all(f.exists() and f.read_text() for f in files) and time.monotonic() < end:
            time.sleep(0.05)
        signal.pthread_kill(main, signal.SIGINT)

    thread = threading.Thread(target=interrupt)
    thread.start()
    t0 = time.monotonic()
    try:
        with pytest.raises(KeyboardInterrupt):
            list(LocalRunner(2, fresh=False).run(_work, [("nap", (f, 60)) for f in files]))
    finally:
        thread.join()
        signal.signal(signal.SIGINT, previous)
    assert time.monotonic() - t0 < 30
    assert all(_gone(int(f.read_text())) for f in files)


def test_closing_the_outcomes_early_kills_the_children(tmp_path):
    pid_file = tmp_path / "pid"
    with closing(LocalRunner(2).run(_work, [("square", 1), ("nap", (pid_file, 60))])) as outcomes:
        first = next(outcomes)
        while not (pid_file.exists() and pid_file.read_text()):
            time.sleep(0.05)
    assert first.index == 0 and first.value[0] == 1
    assert _gone(int(pid_file.read_text()))
