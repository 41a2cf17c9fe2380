"""Calls in forked children (parallel.forked.Forked): each answer is the call's own, made in another
process from this one's memory; a call that raises or dies gives none; a stream's items come back in
order; a call given up or a pool closed leaves no child running; a child's copy of the pool starts
nothing."""

from __future__ import annotations

import os
import signal
import time

import pytest

from ungrasp_ompl.parallel.forked import Forked, can_fork

pytestmark = pytest.mark.skipif(not can_fork(), reason="this platform does not fork")


class Unpicklable:
    """State a spawned process could not be sent (a lambda inside): a forked child has it already."""

    def __init__(self, base: int):
        self.base = base
        self.scale = lambda x: 3 * x

    def value(self, k: int) -> tuple[int, int]:
        return self.base + self.scale(k), os.getpid()


def _mark(path, text: str) -> None:
    """Write a file whole in one step, so a reader that sees it exist never reads it half written."""
    part = path.with_name(path.name + ".part")
    part.write_text(text)
    os.replace(part, path)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie still answers kill(0): it has ended when /proc says so
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_each_answer_is_the_calls_own_made_in_another_process():
    state = Unpicklable(100)
    with Forked(2) as pool:
        for k in range(5):
            pool.submit(k, state.value, k)
        answers = [pool.result(k) for k in range(5)]
    assert [ok for ok, _ in answers] == [True] * 5
    assert [value for _, (value, _) in answers] == [100 + 3 * k for k in range(5)]
    pids = {pid for _, (_, pid) in answers}
    assert os.getpid() not in pids and len(pids) == 5  # a fresh child per call


def test_no_more_children_run_than_workers(tmp_path):
    def stamp(k: int) -> None:
        (tmp_path / f"{k}.start").write_text(str(time.monotonic()))
        time.sleep(0.3)
        (tmp_path / f"{k}.end").write_text(str(time.monotonic()))

    with Forked(2) as pool:
        for k in range(4):
            pool.submit(k, stamp, k)
        for k in range(4):
            pool.result(k)
    spans = [(float((tmp_path / f"{k}.start").read_text()), float((tmp_path / f"{k}.end").read_text()))
             for k in range(4)]
    for t, _ in spans:  # at any start, how many calls were running
        assert sum(a <= t < b for a, b in spans) <= 2


def test_the_heaviest_waiting_call_starts_first(tmp_path):
    go, order = tmp_path / "go", tmp_path / "order"

    def blocker() -> None:
        while not go.exists():
            time.sleep(0.01)

    def note(name: str) -> None:
        with order.open("a") as f:
            f.write(name + "\n")

    with Forked(1) as pool:
        pool.submit("blocker", blocker)  # holds the one worker while the others are submitted
        for name, weight in (("light", 1.0), ("heavy", 5.0), ("medium", 3.0), ("medium again", 3.0)):
            pool.submit(name, note, name, weight=weight)
        go.write_text("")
        for name in ("light", "heavy", "medium", "medium again"):
            assert pool.result(name) == (True, None)
    assert order.read_text().split("\n")[:-1] == ["heavy", "medium", "medium again", "light"]


def _raises() -> None:
    raise RuntimeError("no answer")


def test_a_call_that_raises_or_dies_gives_no_answer():
    with Forked(2) as pool:
        pool.submit("raises", _raises)
        pool.submit("dies", os._exit, 3)
        pool.submit("none", lambda: None)
        assert pool.result("raises") == (False, None)
        assert pool.result("dies") == (False, None)
        assert pool.result("none") == (True, None)  # None is an answer
        assert pool.result("never submitted") == (False, None)


def test_a_streams_items_come_back_in_order_as_they_are_made(tmp_path):
    go = tmp_path / "go"

    def items():
        yield "first"
        while not go.exists():  # the second waits for this process
            time.sleep(0.01)
        yield "second"

    with Forked(1) as pool:
        pool.submit("s", items, stream=True)
        deadline = time.monotonic() + 30
        while not pool.items("s") and time.monotonic() < deadline:
            pool.poll(0.05)
        assert pool.items("s") == ["first"] and not pool.finished("s")
        go.write_text("")
        assert pool.result("s") == (True, ["first", "second"]) and pool.finished("s")


def test_a_call_given_up_or_a_pool_closed_leaves_no_child(tmp_path):
    def sleeper(name: str) -> None:
        _mark(tmp_path / name, str(os.getpid()))
        time.sleep(60)

    pool = Forked(2)
    pool.submit("a", sleeper, "a")
    pool.submit("b", sleeper, "b")
    pool.submit("c", sleeper, "c")  # waits: two workers
    deadline = time.monotonic() + 30
    while not ((tmp_path / "a").exists() and (tmp_path / "b").exists()) and time.monotonic() < deadline:
        time.sleep(0.01)
    a, b = (int((tmp_path / n).read_text()) for n in "ab")
    assert _alive(a) and _alive(b)
    pool.discard("a")  # killed; c starts in its place
    assert not _alive(a) and "a" not in pool.keys()
    while not (tmp_path / "c").exists() and time.monotonic() < deadline:
        pool.poll(0.01)
    c = int((tmp_path / "c").read_text())
    pool.submit("d", sleeper, "d")  # waits: never runs
    pool.close()
    assert not _alive(b) and not _alive(c) and not (tmp_path / "d").exists()
    assert pool.result("b") == (False, None) and pool.result("d") == (False, None)


def test_a_childs_copy_of_the_pool_starts_nothing():
    pool = Forked(2)

    def uses_the_pool() -> tuple:
        pool.submit("inner", os.getpid)
        pool.poll(None)
        return pool.result("inner"), pool.keys()

    with pool:
        pool.submit("outer", uses_the_pool)
        ok, (inner, keys) = pool.result("outer")
    assert ok and inner == (False, None) and "inner" in keys  # queued in the copy, never forked


def test_workers_must_be_a_positive_integer():
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ValueError):
            Forked(bad)


def test_an_interrupt_does_not_reach_the_children(tmp_path):
    def waits() -> str:
        (tmp_path / "ready").write_text("")
        time.sleep(0.5)
        return "finished"

    with Forked(1) as pool:
        pool.submit("w", waits)
        deadline = time.monotonic() + 30
        while not (tmp_path / "ready").exists() and time.monotonic() < deadline:
            time.sleep(0.01)
        child = next(iter(pool._running.values())).pid
        os.kill(child, signal.SIGINT)  # as a terminal's Ctrl-C reaches the whole process group
        assert pool.result("w") == (True, "finished")
