"""Progress of long commands on stderr: a bar on a terminal, a line at each tenth in a log."""

from __future__ import annotations

import shutil
import sys
import threading
import time

from tqdm import tqdm


class Progress:
    """How far a long command has got, on stderr: on a terminal a tqdm bar (count, rate, time left)
    redrawn in place; in a pipe or a log a plain line at each tenth (never a carriage return). A
    new stage starts a new bar. A bar ends when done reaches total, and is wiped when the command
    ends with an error (run() closes it), so that the error's line is the one left."""

    open: list["Progress"] = []  #: bars on the terminal now

    def __init__(self, unit: str, stage: str = "") -> None:
        self.unit = unit
        """What is counted (runs, trials, cells, pieces)."""
        self.stage = stage
        """What is being done, shown before the count."""
        self.bar = None
        self.tenth = 0  # tenths reported in a log (none at the start)
        self.started = time.monotonic()

    def show(self, done: int, total: int, status: str = "", stage: str | None = None) -> None:
        """done of total units so far; status: a few words on the latest one."""
        if stage is not None and stage != self.stage:
            self.close()
            self.stage, self.tenth, self.started = stage, 0, time.monotonic()
        if sys.stderr.isatty():
            if self.bar is None:
                cols, rows = shutil.get_terminal_size()  # 80 x 24 where a terminal says 0 x 0 (tqdm would hide)
                self.bar = tqdm(total=total, desc=self.stage or None, unit=f" {self.unit}", file=sys.stderr,
                                ncols=cols, nrows=rows)
                Progress.open.append(self)
            self.bar.total = total
            self.bar.set_postfix_str(status, refresh=False)
            self.bar.update(done - self.bar.n)
        elif total and 10 * done // total > self.tenth:
            self.tenth = 10 * done // total
            spent = time.monotonic() - self.started
            left = f", about {spent * (total - done) / done:.0f} s left" if 0 < done < total else ""
            print(f"{self.stage + ': ' if self.stage else ''}{done}/{total} {self.unit} after {spent:.0f} s{left}"
                  + (f"; {status}" if status else ""), file=sys.stderr, flush=True)
        if done >= total:
            self.close()

    def close(self, ok: bool = True) -> None:
        """End the bar: kept on its line (ok) or wiped (the command ends with an error)."""
        if self.bar is not None:
            self.bar.leave = ok
            self.bar.close()
            self.bar = None
            Progress.open.remove(self)


#: A planning budget above this (s) shows a bar of its seconds (Ticker): a planner reports no
#: progress of its own, and a silent minute looks like a hang.
TICK_ABOVE_S = 10.0


class Ticker:
    """A bar of seconds for work that reports no progress of its own (a planner's time budget): a
    thread advances it once a second while the work runs, never to its end (the work may take longer
    than its budget, or stop early); stop() (or leaving the with block) wipes it. Starts only for a
    budget above TICK_ABOVE_S seconds."""

    def __init__(self, stage: str, seconds: float) -> None:
        self.total = max(1, int(round(seconds)))
        """The budget in whole seconds."""
        self.bar = Progress("s", stage)
        self.done = threading.Event()
        self.thread = None if seconds <= TICK_ABOVE_S else threading.Thread(target=self._tick, daemon=True)

    def _tick(self) -> None:
        started = time.monotonic()
        while not self.done.wait(1.0):
            self.bar.show(min(int(time.monotonic() - started), self.total - 1), self.total)

    def __enter__(self) -> "Ticker":
        if self.thread is not None:
            self.thread.start()
        return self

    def stop(self) -> None:
        """End the bar (again: nothing)."""
        self.done.set()
        if self.thread is not None and self.thread.is_alive():
            self.thread.join()
        self.bar.close(ok=False)

    def __exit__(self, *exc) -> None:
        self.stop()


class Steps:
    """A bar of the named steps of a command (plan --export: executing on the arm, writing the
    files), each shown as it starts; in a log a line as each ends (with the next one's name)."""

    def __init__(self, stage: str, steps: tuple[str, ...]) -> None:
        self.steps = steps
        self.bar = Progress("steps", stage)
        self.at = 0

    def start(self, step: str) -> None:
        """step (one of the steps) begins: the steps before it are done."""
        self.at = self.steps.index(step)
        self.bar.show(self.at, len(self.steps), step)

    def finish(self) -> None:
        """Every step is done."""
        self.bar.show(len(self.steps), len(self.steps), "done")


def map_status(p) -> str:
    """How a map stands, beside its count (p: benchmark.map.MapProgress)."""
    words = []
    if p.resumed:
        words.append(f"{p.resumed} from an earlier run")
    if p.failed:
        words.append(f"{p.failed} failed")
    if p.last is not None:
        verdict = ("failed" if p.last.secure_path is None else
                   "secure path" if p.last.secure_path else "no secure path")
        words.append(f"last alpha {p.last.alpha:g}, friction x{p.last.friction_scale:g}: {verdict}")
    return "; ".join(words)


def tile_progress(bar: Progress):
    """tile()'s progress (p: tiling.TilingProgress) on the bar: a stage for the search, one for the plans."""
    def show(p) -> None:
        if p.stage == "search":
            bar.show(p.done, p.total, f"{p.checks} approaches checked ({p.piece})", "searching an order")
        else:
            bar.show(p.done, p.total, p.piece, "planning")
    return show


def trial_progress(total: int):
    """A progress bar of total trials (or attempts), advanced by each call."""
    bar, done = Progress("trials", "simulate"), [0]

    def step(_) -> None:
        done[0] += 1
        bar.show(done[0], total)

    return step
