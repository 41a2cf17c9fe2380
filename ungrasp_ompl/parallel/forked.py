"""Calls run in forked copies of this process, a few at a time, their answers collected when wanted.

A forked child starts with everything this process holds (a scene, the secure lattice built for
it, a plan), so a call that needs them costs neither pickling them nor importing the package
again (a spawned process, parallel.runner.LocalRunner, pays about a second for that); only what
the call returns comes back, pickled through a pipe. A call returns one value, or (``stream``)
an iterable whose items come back one by one as the child makes them.

:class:`Forked` keeps at most ``workers`` children running; the calls submitted beyond that wait,
and start when this process next looks (:meth:`Forked.poll`, :meth:`Forked.result`), the heaviest
first (a weight the caller gives, an estimate of the call's cost; the first submitted among equals),
so that a long call is not left to run alone at the end. A child that raises or dies gives no
answer: the caller then makes the call itself, so an answer is never other than the call's own.
A child ignores SIGINT and leaves through ``os._exit`` without flushing this process's output
buffers (it writes none of its own), so nothing is printed twice; closing the pool kills the
children. Fork is POSIX's: where this platform has none, :func:`can_fork` is False and callers
run the calls themselves.
"""

from __future__ import annotations

import gc
import os
import pickle
import select
import signal
import struct
from collections import deque
from collections.abc import Callable, Hashable, Iterable
from dataclasses import dataclass, field
from typing import Any

#: The length prefix of each pickled message a child sends (bytes).
_HEADER = struct.Struct("<Q")


def can_fork() -> bool:
    """Whether this platform forks processes (POSIX)."""
    return hasattr(os, "fork")


@dataclass
class _Call:
    """A submitted call: its function and arguments, and what came back so far."""

    fn: Callable[..., Any]
    args: tuple
    stream: bool
    weight: float = 0.0
    """How long the call is expected to take, in any unit: the heaviest waiting call starts first."""
    items: list = field(default_factory=list)
    """What the child sent: the value, or the stream's items so far."""
    finished: bool = False
    """Whether the child has ended (or the call was given up)."""
    failed: bool = False
    """Whether it raised or died before its last answer."""


@dataclass
class _Child:
    """A running child: its process id, the read end of its pipe and the bytes not yet parsed."""

    pid: int
    fd: int
    key: Hashable
    buffer: bytearray = field(default_factory=bytearray)


class Forked:
    """Calls run in forked children of this process, ``workers`` at a time, by key."""

    def __init__(self, workers: int):
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise ValueError(f"workers must be a positive integer, got {workers!r}")
        self.workers = workers
        self._owner = os.getpid()  # a forked child holds a copy of this pool: it must not use it
        self._calls: dict[Hashable, _Call] = {}
        self._pending: deque[Hashable] = deque()
        self._running: dict[int, _Child] = {}  # by pipe descriptor

    def __enter__(self) -> "Forked":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- submitting ------------------------------------------------------------------------------
    def submit(self, key: Hashable, fn: Callable[..., Any], *args: Any, stream: bool = False,
               weight: float = 0.0) -> None:
        """Run fn(*args) in a child (now if a worker is free, else once one is, the heaviest waiting
        call first: weight); stream: fn returns an iterable whose items come back one by one. A key
        submitted already is left as it is."""
        if key in self._calls:
            return
        self._calls[key] = _Call(fn, args, stream, weight)
        self._pending.append(key)
        self._start()

    def __contains__(self, key: Hashable) -> bool:
        return key in self._calls

    def keys(self) -> list[Hashable]:
        """The calls' keys (waiting, running or ended, until discarded), in the order submitted."""
        return list(self._calls)

    def withdraw(self, key: Hashable) -> bool:
        """Give up a call that has not started: True when it was waiting (it never runs now)."""
        if key in self._pending:
            self._pending.remove(key)
            del self._calls[key]
            return True
        return False

    def discard(self, key: Hashable) -> None:
        """Forget a call: withdrawn if waiting, its child killed if running."""
        if self.withdraw(key):
            return
        for child in list(self._running.values()):
            if child.key == key:
                self._end(child, kill=True)
        self._calls.pop(key, None)
        self._start()

    # -- answers ---------------------------------------------------------------------------------
    def poll(self, timeout: float | None = 0.0) -> None:
        """Read what the running children sent (waiting up to timeout s for something to arrive;
        None: until something does), reap those that ended and start waiting calls in their place."""
        self._start()
        if not self._running or os.getpid() != self._owner:
            return
        ready, _, _ = select.select(list(self._running), [], [], timeout)
        for fd in ready:
            child = self._running[fd]
            try:
                data = os.read(fd, 1 << 20)
            except BlockingIOError:
                continue
            if data:
                child.buffer += data
                self._parse(child)
            else:  # the child closed its pipe: it has ended
                self._end(child, kill=False)
        self._start()

    def items(self, key: Hashable) -> list:
        """What the call sent back so far: its value, or its stream's items, in order ([] for an
        unknown key)."""
        call = self._calls.get(key)
        return [] if call is None else call.items

    def finished(self, key: Hashable) -> bool:
        """Whether the call has ended (or is unknown)."""
        call = self._calls.get(key)
        return call is None or call.finished

    def result(self, key: Hashable) -> tuple[bool, Any]:
        """Wait for the call: (True, its value, or its stream's items as a list), or (False, None)
        when it raised, its child died, or no such call was submitted."""
        call = self._calls.get(key)
        while call is not None and not call.finished and os.getpid() == self._owner:
            self.poll(None)
        if call is None or not call.finished or call.failed or not (call.stream or call.items):
            return False, None
        return True, (call.items if call.stream else call.items[0])

    def close(self) -> None:
        """Kill the running children and give up the waiting calls (each then fails)."""
        while self._pending:
            call = self._calls[self._pending.popleft()]
            call.finished = call.failed = True
        if os.getpid() != self._owner:
            return
        for child in list(self._running.values()):
            self._end(child, kill=True)

    # -- the children ----------------------------------------------------------------------------
    def _start(self) -> None:
        while os.getpid() == self._owner and self._pending and len(self._running) < self.workers:
            key = max(self._pending, key=lambda k: self._calls[k].weight)  # the first of the heaviest
            self._pending.remove(key)
            call = self._calls[key]
            read, write = os.pipe()
            gc.freeze()  # the child's collections then leave this process's objects (and their pages) alone
            pid = os.fork()
            if pid == 0:  # the child: it never returns from here
                os.close(read)
                _serve(call.fn, call.args, call.stream, write)
            gc.unfreeze()
            os.close(write)
            os.set_blocking(read, False)
            self._running[read] = _Child(pid, read, key)

    def _parse(self, child: _Child) -> None:
        """Take the whole messages off the child's buffer into its call's answers."""
        call = self._calls.get(child.key)
        buf = child.buffer
        while len(buf) >= _HEADER.size:
            (size,) = _HEADER.unpack_from(buf)
            if len(buf) < _HEADER.size + size:
                break
            ok, item = pickle.loads(bytes(buf[_HEADER.size:_HEADER.size + size]))
            del buf[:_HEADER.size + size]
            if call is None:
                continue
            if ok:
                call.items.append(item)
            else:
                call.failed = True

    def _end(self, child: _Child, kill: bool) -> None:
        """Reap the child (killed first when kill) and close its pipe; its call is finished, failed
        unless it sent its whole answer."""
        if kill:
            try:
                os.kill(child.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        os.close(child.fd)
        del self._running[child.fd]
        _, status = os.waitpid(child.pid, 0)
        call = self._calls.get(child.key)
        if call is not None:
            call.finished = True
            call.failed = call.failed or kill or status != 0 or bool(child.buffer)


def _serve(fn: Callable[..., Any], args: tuple, stream: bool, fd: int) -> None:
    """In the child: send fn(*args) (or each item of it, stream) down the pipe fd, pickled, then
    leave; after an exception, a failure mark. Exits 0 when everything was sent."""
    status = 1
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            values: Iterable = fn(*args) if stream else (fn(*args),)
            for value in values:
                _send(fd, (True, value))
            status = 0
        except BaseException:  # the parent makes the call itself and sees the exception there
            _send(fd, (False, None))
    except BaseException:  # the pipe is gone: the parent has left or given up this call
        pass
    finally:
        os._exit(status)


def _send(fd: int, message: tuple[bool, Any]) -> None:
    payload = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    view = memoryview(_HEADER.pack(len(payload)) + payload)
    while view:
        view = view[os.write(fd, view):]
