"""Benchmarks: the planners on scenes (OMPL's benchmark log and database), and a sweep over alpha.

Every run happens in a fresh worker process (a spawn pool with one task per
process): OMPL's RNG can be seeded only once per process, before any planner
exists. A worker seeds it with ``seed + run``, builds the scene's
:class:`~ungrasp_ompl.planning.UngraspSetup` with the planner by name and
solves on wall time, like OMPL's ``tools::Benchmark`` does.

The planner ``lattice`` is the exact Dijkstra search over the primitive
lattice (:func:`~ungrasp_ompl.planning.lattice.lattice_search`) at the scene's
own resolution, the lattice the OMPL planners plan on: its cost is the optimum
those planners can reach, so a planner's cost over it is a true optimality gap.

Units: times in seconds; costs in the reference units (degrees of theta and
psi + 100 d + 1 per primitive change, with the scene's ``d_weight`` and
``mode_change_penalty``). The times of the OMPL planners run from the start of
``solve()`` (their setup, which builds the same secure lattice, is logged
apart); the lattice planner's time is building that lattice plus the search.

Outputs of :func:`run_benchmark` in ``out_dir``: ``<scene>.log`` per scene in
OMPL's benchmark log format (its parser reads one experiment per file),
``benchmark.db`` made from the logs by the ``ompl_benchmark_statistics.py``
script shipped with ompl, ``summary.csv``, ``success_vs_time.png`` and
``cost_vs_time.png``. Of :func:`run_sweep`: ``sweep.csv`` and ``sweep.png``.
"""

from __future__ import annotations

import csv
import dataclasses
import importlib.util
import io
import math
import multiprocessing as mp
import os
import platform
import re
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

import numpy as np

from .errors import InputError
from .planning.setup import HANG_GRACE_S
from .io import write_atomic, write_text_atomic
from .planning.setup import KNOWN_LIMITATIONS, PLANNERS, UNUSABLE_PLANNERS, PlannerOptions
from .scene import Scene

#: The exact search over the primitive lattice, benchmarked like a planner.
LATTICE = "lattice"
#: Outcome of a run: a verified path; none found within the time; a path that failed
#: re-validation; the start cannot be held or the goal region holds no valid state;
#: (lattice only) the exhaustive search reaches no goal state.
STATUSES = ("exact", "timeout", "invalid", "unsolvable_start_or_goal", "infeasible", "hung")

# A run may take HANG_GRACE_S seconds beyond its time limit (setup, re-validation) before its
# worker is killed and the run counted as hung: a planner that stops checking its termination
# condition (AORRTC, see planning.setup.UNRULY_PLANNERS) must not stall the benchmark.
#: Prefix of Plan.reason when the returned path fails re-validation.
_INVALID_PREFIX = "the returned path fails re-validation"
#: OMPL version written into the logs when the package does not say.
_OMPL_VERSION_FALLBACK = "2.0.1"
#: The benchmark log format's run count and planner prefix.
_PLANNER_PREFIX = "geometric_"


# -- runs ---------------------------------------------------------------------------

@dataclass(frozen=True)
class Task:
    """One run: a planner on a scene, in its own worker process.

    group: the scene's key (benchmark) or the alpha's index (sweep); run: the
    run index (-1: a lattice yardstick run, not reported as a planner run);
    seed: OMPL's RNG seed; time_limit: seconds of planning.
    """

    group: str
    scene: Scene
    planner: str
    run: int
    seed: int
    time_limit: float


@dataclass(frozen=True)
class RunResult:
    """What one run measured. Times in seconds, cost in reference units (None: no path).

    time_s is the benchmark log's ``time``: an OMPL planner's planning time
    (solve() only), or the lattice planner's wall time to build the lattice
    and search it. wall_time_s: the whole task in the worker, setup included.
    """

    group: str
    planner: str
    run: int
    seed: int
    status: str
    cost: float | None
    mode_switches: int | None
    time_to_first_solution_s: float | None
    planning_time_s: float
    setup_time_s: float
    iterations: int | None
    wall_time_s: float

    @property
    def solved(self) -> bool:
        """A path was found and passed re-validation."""
        return self.status == "exact"

    @property
    def time_s(self) -> float:
        return self.planning_time_s


def _plan_status(plan) -> str:
    """The STATUSES entry of an OMPL planner's Plan."""
    if plan.solved:
        return "exact"
    if plan.stopped_by == "not started":
        return "unsolvable_start_or_goal"
    if (plan.reason or "").startswith(_INVALID_PREFIX):
        return "invalid"
    return "timeout"


def _ompl_run(scene: Scene, planner: str, time_limit: float, seed: int) -> dict:
    """Solve scene with an OMPL planner for time_limit seconds of wall time, OMPL seeded with seed."""
    from ompl import util as ou

    from .planning.setup import UngraspSetup

    ou.RNG.setSeed(seed)
    ou.setLogLevel(ou.LogLevel.LOG_ERROR)
    plan = UngraspSetup(scene, PlannerOptions(planner=planner, time=time_limit, seed=None, iterations=None)).solve()
    return dict(status=_plan_status(plan), cost=plan.cost, mode_switches=plan.mode_switches,
                time_to_first_solution_s=plan.time_to_first_solution_s, planning_time_s=plan.planning_time_s,
                setup_time_s=plan.setup_time_s, iterations=plan.iterations)


def _lattice_run(scene: Scene) -> dict:
    """The exact optimum on the scene's lattice; its time is building the lattice plus the search."""
    from .planning.atlas import SecurityAtlas, planning_box
    from .planning.setup import lattice_plan

    plan = lattice_plan(scene)
    elapsed = plan.setup_time_s + plan.planning_time_s
    if plan.solved:
        status = "exact"
    elif plan.lattice_optimum is not None:
        status = "invalid"  # the optimum's legs failed re-validation
    elif not _lattice_ends_hold(SecurityAtlas(scene, planning_box(scene)), scene.start, scene.goal.box()):
        status = "unsolvable_start_or_goal"
    else:
        status = "infeasible"
    return dict(status=status, cost=plan.lattice_optimum, mode_switches=plan.mode_switches,
                time_to_first_solution_s=elapsed if plan.solved else None, planning_time_s=elapsed,
                setup_time_s=0.0, iterations=None)


def _lattice_ends_hold(atlas, start: np.ndarray, goal_box: np.ndarray) -> bool:
    """Whether the start and some lattice state in the goal box can be held."""
    i = atlas.index(start)
    if i is None or not atlas.holdable[i]:
        return False
    return bool(atlas.releasable_in(goal_box).any())


def run_task(task: Task) -> RunResult:
    """Run one task (in a fresh worker process: OMPL's RNG is seeded here)."""
    t0 = time.perf_counter()
    if task.planner == LATTICE:
        measured = _lattice_run(task.scene)
    else:
        measured = _ompl_run(task.scene, task.planner, task.time_limit, task.seed)
    return RunResult(group=task.group, planner=task.planner, run=task.run, seed=task.seed,
                     wall_time_s=time.perf_counter() - t0, **measured)


def _progress_bar(done: int, total: int, width: int = 30) -> str:
    filled = width * done // total if total else width
    return f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total}"


def run_tasks(tasks: Sequence[Task], jobs: int, progress: bool = True) -> list[RunResult]:
    """Run tasks in a spawn pool of jobs workers, one fresh process per task; results in task order.
    With progress, a text bar on stderr."""
    total = len(tasks)

    def show(done: int) -> None:
        if progress:
            sys.stderr.write(_progress_bar(done, total))
            sys.stderr.flush()

    show(0)
    out: list[RunResult | None] = [None] * total
    ctx = mp.get_context("spawn")
    pending = list(enumerate(tasks))
    running: dict[int, tuple] = {}  # task index -> (process, pipe end, deadline)
    done = 0
    while pending or running:
        while pending and len(running) < max(1, jobs):
            k, task = pending.pop(0)
            receiver, sender = ctx.Pipe(duplex=False)
            proc = ctx.Process(target=_run_in_worker, args=(task, sender), daemon=True)
            proc.start()
            sender.close()
            running[k] = (proc, receiver, time.monotonic() + task.time_limit + HANG_GRACE_S)
        for k, (proc, receiver, deadline) in list(running.items()):
            if receiver.poll():
                result = receiver.recv()
                proc.join()
                if isinstance(result, BaseException):
                    raise result
                out[k] = result
            elif not proc.is_alive():
                proc.join()
                out[k] = _failed(tasks[k], "hung", 0.0)  # the worker died without an answer
            elif time.monotonic() > deadline:
                proc.kill()
                proc.join()
                out[k] = _failed(tasks[k], "hung", tasks[k].time_limit + HANG_GRACE_S)
            else:
                continue
            del running[k]
            done += 1
            show(done)
        time.sleep(0.02)
    if progress:
        sys.stderr.write("\n")
        sys.stderr.flush()
    return out  # type: ignore[return-value]


def _run_in_worker(task: Task, sender) -> None:
    try:
        sender.send(run_task(task))
    except BaseException as exc:  # handed back to the parent
        sender.send(exc)
    finally:
        sender.close()
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)  # skip interpreter finalisation, where nanobind lists OMPL objects still alive


def _failed(task: Task, status: str, wall: float) -> RunResult:
    return RunResult(group=task.group, planner=task.planner, run=task.run, seed=task.seed, status=status, cost=None,
                     mode_switches=None, time_to_first_solution_s=None, planning_time_s=task.time_limit,
                     setup_time_s=0.0, iterations=None, wall_time_s=wall)


# -- validation ---------------------------------------------------------------------

def validate_planners(planners: Iterable[str]) -> list[str]:
    """The planner names, duplicates dropped; InputError("--planners") for an unknown or refused one."""
    names = list(dict.fromkeys(planners))
    if not names:
        raise InputError("--planners", "names no planner")
    for name in names:
        if name == LATTICE:
            continue
        if name not in PLANNERS and name not in UNUSABLE_PLANNERS:
            raise InputError("--planners", f"unknown planner {name!r} (known: {', '.join(PLANNERS + (LATTICE,))})")
        try:
            PlannerOptions(planner=name).validated()
        except InputError as exc:  # PRM, PRMstar: refused with the reason
            raise InputError("--planners", exc.reason) from None
    return names


def _validate_run_options(runs: int, time_limit: float, jobs: int, seed: int, out_dir) -> Path:
    """Check the common options; returns out_dir as a Path."""
    if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
        raise InputError("--runs", f"must be a positive integer, got {runs!r}")
    if isinstance(time_limit, bool) or not isinstance(time_limit, (int, float)) or not (
            math.isfinite(time_limit) and time_limit > 0):
        raise InputError("--time", f"must be a positive number of seconds, got {time_limit!r}")
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise InputError("--jobs", f"must be a positive integer, got {jobs!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0 or seed + runs > 2**32:
        raise InputError("--seed", f"must be an integer with seed + runs <= 2^32, got {seed!r}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a directory")
    return out


def _scene_key(name: str, taken: set[str]) -> str:
    """A file-name-safe, unique key for a scene (its log's name and experiment name)."""
    base = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "scene"
    key, k = base, 2
    while key in taken:
        key, k = f"{base}_{k}", k + 1
    taken.add(key)
    return key


# -- statistics ---------------------------------------------------------------------

def _median(xs: Sequence[float]) -> float | None:
    return float(np.median(xs)) if len(xs) else None


def _p90(xs: Sequence[float]) -> float | None:
    return float(np.percentile(xs, 90)) if len(xs) else None


def _gap_percent(cost: float | None, optimum: float | None) -> float | None:
    """(cost / optimum - 1) in percent; None without both (or with a zero optimum and a cost)."""
    if cost is None or optimum is None:
        return None
    if optimum <= 0:
        return 0.0 if cost <= 0 else None
    return 100.0 * (cost / optimum - 1.0)


@dataclass(frozen=True)
class SummaryRow:
    """Statistics of one planner on one scene. Times in seconds over the solved runs, costs in
    reference units; gap_percent: (median cost / lattice optimum - 1) * 100."""

    scene: str
    planner: str
    runs: int
    success_rate: float
    invalid_paths: int
    timeouts: int
    hung: int  # runs whose planner ignored its termination condition and was killed
    proved_unsolvable: int
    first_solution_median_s: float | None
    first_solution_p90_s: float | None
    cost_median: float | None
    gap_percent: float | None
    mode_changes_median: float | None
    lattice_optimum: float | None
    limitation: str | None = None  # 0% success where a path exists: the planner's known limitation's code


def summarise(scene: str, planner: str, runs: Sequence[RunResult], optimum: float | None) -> SummaryRow:
    """The summary row of one planner's runs on one scene."""
    solved = [r for r in runs if r.solved]
    cost = _median([r.cost for r in solved])
    return SummaryRow(
        scene=scene, planner=planner, runs=len(runs),
        success_rate=len(solved) / len(runs) if runs else 0.0,
        invalid_paths=sum(r.status == "invalid" for r in runs),
        timeouts=sum(r.status == "timeout" for r in runs),
        hung=sum(r.status == "hung" for r in runs),
        proved_unsolvable=sum(r.status in ("unsolvable_start_or_goal", "infeasible") for r in runs),
        first_solution_median_s=_median([r.time_to_first_solution_s for r in solved]),
        first_solution_p90_s=_p90([r.time_to_first_solution_s for r in solved]),
        cost_median=cost, gap_percent=_gap_percent(cost, optimum),
        mode_changes_median=_median([r.mode_switches for r in solved]),
        lattice_optimum=optimum,
        limitation=KNOWN_LIMITATIONS[planner].code
        if planner in KNOWN_LIMITATIONS and not solved and optimum is not None else None)


def limitation_notes(rows: Sequence[SummaryRow]) -> list[str]:
    """One line per planner reported with a known limitation: why it cannot succeed here."""
    named = dict.fromkeys(r.planner for r in rows if r.limitation)
    return [f"{p}: {KNOWN_LIMITATIONS[p].code}: {KNOWN_LIMITATIONS[p].value}" for p in named]


# -- tables and CSV -----------------------------------------------------------------

@dataclass(frozen=True)
class Column:
    """A column of a printed table and of a CSV file: header, CSV name, value, text format."""

    header: str
    csv_name: str
    value: Callable[[object], object]
    fmt: str = ""


def _cell(value: object, fmt: str, missing: str) -> str:
    if value is None:
        return missing
    if isinstance(value, bool):
        return "yes" if value else "no"
    return format(value, fmt)


def format_table(columns: Sequence[Column], rows: Sequence[object]) -> str:
    """Fixed-width text table; text columns left-aligned, numbers right-aligned, '-' for missing."""
    cells = [[_cell(c.value(r), c.fmt, "-") for c in columns] for r in rows]
    widths = [max([len(c.header)] + [len(row[k]) for row in cells]) for k, c in enumerate(columns)]
    values = [[c.value(r) for r in rows] for c in columns]
    left = [any(isinstance(v, str) for v in vs) and all(v is None or isinstance(v, str) for v in vs) for vs in values]

    def line(items: Sequence[str]) -> str:
        return "  ".join(s.ljust(w) if lft else s.rjust(w) for s, w, lft in zip(items, widths, left)).rstrip()

    return "\n".join([line([c.header for c in columns])] + [line(row) for row in cells])


def write_csv(path: Path, columns: Sequence[Column], rows: Sequence[object]) -> None:
    """Write rows atomically as CSV (full precision; empty for missing)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([c.csv_name for c in columns])
    for r in rows:
        values = [c.value(r) for c in columns]
        writer.writerow(["" if v is None else int(v) if isinstance(v, bool) else v for v in values])
    write_text_atomic(path, buf.getvalue())


SUMMARY_COLUMNS = (
    Column("scene", "scene", lambda r: r.scene),
    Column("planner", "planner", lambda r: r.planner),
    Column("runs", "runs", lambda r: r.runs, "d"),
    Column("success", "success_rate", lambda r: r.success_rate, ".0%"),
    Column("invalid", "invalid_paths", lambda r: r.invalid_paths, "d"),
    Column("timeouts", "timeouts", lambda r: r.timeouts, "d"),
    Column("hung", "hung", lambda r: r.hung, "d"),
    Column("unsolvable", "proved_unsolvable", lambda r: r.proved_unsolvable, "d"),
    Column("first sol. median s", "time_to_first_solution_median_s", lambda r: r.first_solution_median_s, ".3f"),
    Column("p90 s", "time_to_first_solution_p90_s", lambda r: r.first_solution_p90_s, ".3f"),
    Column("cost median", "final_cost_median", lambda r: r.cost_median, ".2f"),
    Column("gap %", "gap_to_optimum_percent", lambda r: r.gap_percent, ".2f"),
    Column("mode changes", "mode_changes_median", lambda r: r.mode_changes_median, "g"),
    Column("lattice optimum", "lattice_optimum", lambda r: r.lattice_optimum, ".2f"),
    Column("known limitation", "known_limitation", lambda r: r.limitation),
)


# -- OMPL benchmark log -------------------------------------------------------------

def cost_units(scene: Scene) -> str:
    """The cost's units for a person, with the scene's weights."""
    o = scene.options
    return f"deg + {o.d_weight:g} d + {o.mode_change_penalty:g} per primitive change"


def _log_value(x: object) -> str:
    """A value as the log parser takes it: booleans 0/1; 'nan' (stored as NULL) for missing."""
    if x is None:
        return "nan"
    if isinstance(x, bool):
        return str(int(x))
    if isinstance(x, float):
        return repr(x)
    return str(x)


#: Per-run properties of the log: (name with type, value of a RunResult).
RUN_PROPERTIES: tuple[tuple[str, Callable[[RunResult], object]], ...] = (
    ("time REAL", lambda r: r.time_s),
    ("solved BOOLEAN", lambda r: r.solved),
    ("best cost REAL", lambda r: r.cost if r.solved else math.inf),
    ("approximate solution BOOLEAN", lambda r: False),
    ("correct solution BOOLEAN", lambda r: r.solved if r.status in ("exact", "invalid") else None),
    ("time to first solution REAL", lambda r: r.time_to_first_solution_s),
    ("mode switches INTEGER", lambda r: r.mode_switches if r.solved else None),
    ("invalid path BOOLEAN", lambda r: r.status == "invalid"),
    ("timeout BOOLEAN", lambda r: r.status == "timeout"),
    ("ungrasp status ENUM", lambda r: STATUSES.index(r.status)),
    ("setup time REAL", lambda r: r.setup_time_s),
    ("iterations INTEGER", lambda r: r.iterations),
    ("seed INTEGER", lambda r: r.seed if r.planner != LATTICE else None),
)


def _ompl_version() -> str:
    import ompl

    return str(getattr(ompl, "__version__", None) or _OMPL_VERSION_FALLBACK)


def _cpu_info() -> str:
    """CPU model and count, for the log's optional cpuinfo block."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}\n{os.cpu_count()} logical CPUs"


@dataclass(frozen=True)
class Experiment:
    """One scene's runs, written as one experiment of OMPL's benchmark log."""

    key: str
    scene: Scene
    planners: list[str]
    runs: dict[str, list[RunResult]]  # planner -> its runs in run order
    optimum: float | None
    lattice_status: str
    seed: int
    time_limit: float
    runs_per_planner: int
    started: datetime
    jobs: int

    def setup_info(self) -> str:
        s = self.scene
        res = s.options.resolution
        return "\n".join([
            f"ungrasp-ompl benchmark of scene {s.name} ({s.source or 'in memory'})",
            f"start (theta rad, d, psi rad): {[round(float(x), 6) for x in s.start]}",
            f"goal box: {np.round(s.goal.box(), 6).tolist()}",
            f"lattice resolution: {math.degrees(res[0]):g} deg / {res[1]:g} / {math.degrees(res[2]):g} deg; "
            f"sliding model {s.options.sliding_model}; digits alpha {s.digits.alpha:g}",
            f"cost: {cost_units(s)} (degrees of theta and psi)",
            "OMPL planners stop on wall time; time = planning time of solve(), setup time apart; "
            "solved = a path that passed re-validation",
            "geometric_lattice = the exact Dijkstra search on the same lattice (not an OMPL planner); "
            "its time is building the lattice plus the search",
            f"one fresh process per run, OMPL seeded with {self.seed} + run index; {self.jobs} parallel jobs",
            "memory limit: none enforced (0)",
        ])

    def total_time(self) -> float:
        return sum(r.wall_time_s for runs in self.runs.values() for r in runs)

    def planner_settings(self, planner: str) -> list[str]:
        if planner == LATTICE:
            res = self.scene.options.resolution
            return [f"resolution TEXT = {math.degrees(res[0]):g} deg / {res[1]:g} / {math.degrees(res[2]):g} deg"]
        opts = PlannerOptions(planner=planner, time=self.time_limit)
        return [f"range REAL = {opts.range!r}", f"goal_bias REAL = {opts.goal_bias!r}",
                f"simplify BOOLEAN = {int(opts.simplify)}"]

    def properties(self) -> list[str]:
        props = [f"scene_file TEXT = {self.scene.source or ''}",
                 f"lattice_reachable BOOLEAN = {int(self.optimum is not None)}",
                 f"lattice_status TEXT = {self.lattice_status}"]
        if self.optimum is not None:
            props.append(f"lattice_optimum REAL = {self.optimum!r}")
        return props

    def log_text(self) -> str:
        """The experiment in OMPL's benchmark log format (as ompl::tools::Benchmark writes it)."""
        props = self.properties()
        lines = [f"OMPL version {_ompl_version()}",
                 f"Experiment {self.key}",
                 f"{len(props)} experiment properties", *props,
                 f"Running on {socket.gethostname() or 'unknown'}",
                 f"Starting at {self.started:%Y-%m-%d %H:%M:%S}",
                 "<<<|", self.setup_info(), "|>>>",
                 "<<<|", _cpu_info(), "|>>>",
                 f"{self.seed} is the random seed",
                 f"{self.time_limit!r} seconds per run",
                 "0 MB per run",
                 f"{self.runs_per_planner} runs per planner",
                 f"{self.total_time()!r} seconds spent to collect the data",
                 "1 enum type",
                 "ungrasp_status|" + "|".join(STATUSES),
                 f"{len(self.planners)} planners"]
        for planner in self.planners:
            settings = self.planner_settings(planner)
            runs = self.runs[planner]
            lines += [f"{_PLANNER_PREFIX}{planner}", f"{len(settings)} common properties", *settings,
                      f"{len(RUN_PROPERTIES)} properties for each run", *(name for name, _ in RUN_PROPERTIES),
                      f"{len(runs)} runs"]
            lines += ["".join(f"{_log_value(value(r))}; " for _, value in RUN_PROPERTIES) for r in runs]
            lines.append(".")
        return "\n".join(lines) + "\n"


def statistics_script() -> Path:
    """ompl_benchmark_statistics.py of the installed ompl package."""
    spec = importlib.util.find_spec("ompl")
    for location in (spec.submodule_search_locations or []) if spec else []:
        path = Path(location) / "ompl_benchmark_statistics.py"
        if path.is_file():
            return path
    from .errors import ToolError  # exit 1, one line: an installation problem, not the input

    raise ToolError("ompl_benchmark_statistics.py is not in the installed ompl package (reinstall ompl)")


def logs_to_database(logs: Sequence[Path], db: Path) -> None:
    """Convert benchmark logs into an SQLite database with OMPL's script (atomically)."""

    def convert(tmp: str) -> None:
        cmd = [sys.executable, str(statistics_script()), *map(str, logs), "-d", tmp]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
            from .errors import ToolError  # exit 1, one line: OMPL's script failed, not the input

            raise ToolError(f"ompl_benchmark_statistics.py failed on {', '.join(map(str, logs))}: "
                            + " | ".join(tail))

    write_atomic(db, convert)


# -- plots ----------------------------------------------------------------------------

def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save_png(fig, path: Path) -> None:
    write_atomic(path, lambda tmp: fig.savefig(tmp, format="png", dpi=110))
    _pyplot().close(fig)


def _panels(n: int, width: float = 6.0, height: float = 4.0):
    plt = _pyplot()
    fig, axes = plt.subplots(1, n, figsize=(width * n, height), squeeze=False, constrained_layout=True)
    return fig, list(axes[0])


def plot_success_vs_time(experiments: Sequence[Experiment], path: Path) -> None:
    """Per scene and planner: the fraction of runs whose first solution came by time t (s)."""
    fig, axes = _panels(len(experiments))
    for ax, exp in zip(axes, experiments):
        times = [r.time_to_first_solution_s for runs in exp.runs.values() for r in runs if r.solved]
        t_max = max([exp.time_limit] + times) * 1.02
        t = np.linspace(0.0, t_max, 400)
        for planner in exp.planners:
            runs = exp.runs[planner]
            first = np.array([r.time_to_first_solution_s for r in runs if r.solved])
            frac = (first[None, :] <= t[:, None]).sum(axis=1) / len(runs)
            style = dict(color="black", linestyle="--", label="lattice (exact; builds the lattice too)") \
                if planner == LATTICE else dict(label=planner)
            ax.step(t, frac, where="post", **style)
        ax.axvline(exp.time_limit, color="grey", linestyle=":", label=f"time limit {exp.time_limit:g} s")
        ax.set(xlim=(0, t_max), ylim=(-0.02, 1.02), xlabel="time t (s)", ylabel="fraction of runs solved by t",
               title=f"{exp.key}: first solution by time t")
        ax.legend(fontsize=8, loc="lower right")
    _save_png(fig, path)


def plot_final_cost(experiments: Sequence[Experiment], path: Path) -> None:
    """Per scene: the final cost (reference units) of each planner's solved runs, with the
    lattice optimum as a line. Costs over time are not recorded; this is the cost at the end."""
    fig, axes = _panels(len(experiments))
    rng = np.random.default_rng(0)
    for ax, exp in zip(axes, experiments):
        labels = []
        for k, planner in enumerate(exp.planners):
            runs = exp.runs[planner]
            costs = np.array([r.cost for r in runs if r.solved])
            labels.append(f"{planner}\n{len(costs)}/{len(runs)} solved")
            if len(costs):
                ax.boxplot([costs], positions=[k], widths=0.5, showfliers=False)
                ax.scatter(k + rng.uniform(-0.12, 0.12, len(costs)), costs, s=14, alpha=0.7, zorder=3)
        if exp.optimum is not None:
            ax.axhline(exp.optimum, color="black", linestyle="--", label=f"lattice optimum {exp.optimum:.2f}")
            ax.legend(fontsize=8)
        ax.set_xticks(range(len(labels)), labels, fontsize=8)
        ax.set(xlim=(-0.6, len(labels) - 0.4), ylabel=f"final cost ({cost_units(exp.scene)})",
               title=f"{exp.key}: final cost after {exp.time_limit:g} s\n(cost over time is not recorded)")
    _save_png(fig, path)


# -- benchmark ----------------------------------------------------------------------

@dataclass
class BenchmarkResult:
    """Runs, per-scene lattice optima (reference units, None: no secure path), summary rows,
    the printed table and the files written."""

    runs: list[RunResult]
    optima: dict[str, float | None]
    summary: list[SummaryRow]
    table: str
    files: dict[str, Path] = field(default_factory=dict)


def _lattice_yardstick(results: Sequence[RunResult], group: str) -> RunResult:
    """The first lattice run of a group (all are the same search)."""
    return next(r for r in results if r.group == group and r.planner == LATTICE)


def run_benchmark(scene_paths: Sequence[str | os.PathLike[str]], planners: Sequence[str], runs: int,
                  time_limit: float, jobs: int, out_dir: str | os.PathLike[str], seed: int = 1,
                  progress: bool = True) -> BenchmarkResult:
    """Benchmark planners on scenes: `runs` runs of `time_limit` seconds each per scene and
    planner, `jobs` at a time, each in a fresh process with OMPL seeded with seed + run index.

    Writes to out_dir the OMPL benchmark logs (one ``<scene>.log`` per scene),
    ``benchmark.db``, ``summary.csv``, ``success_vs_time.png`` and ``cost_vs_time.png``;
    prints the summary table and returns it with the runs. ``lattice`` among the planners
    is the exact search; the optimum it finds (reference cost units) is also the yardstick
    of the gap column, computed once per scene when ``lattice`` is not benchmarked.
    Raises InputError naming the option (``--planners``, ``--runs``, ...) or the scene.
    """
    names = validate_planners(planners)
    out = _validate_run_options(runs, time_limit, jobs, seed, out_dir)
    if not scene_paths:
        raise InputError("scene", "no scene given")
    taken: set[str] = set()
    scenes = {}
    for p in scene_paths:
        scene = Scene.from_file(p)
        scenes[_scene_key(scene.name, taken)] = scene
    tasks = [Task(key, scene, name, k, seed + k, float(time_limit))
             for key, scene in scenes.items() for name in names for k in range(runs)]
    if LATTICE not in names:
        tasks += [Task(key, scene, LATTICE, -1, seed, float(time_limit)) for key, scene in scenes.items()]
    started = datetime.now()
    results = run_tasks(tasks, jobs, progress)

    experiments = []
    for key, scene in scenes.items():
        lattice = _lattice_yardstick(results, key)
        by_planner = {name: [r for r in results if r.group == key and r.planner == name and r.run >= 0]
                      for name in names}
        experiments.append(Experiment(key, scene, names, by_planner, lattice.cost, lattice.status, seed,
                                      float(time_limit), runs, started, jobs))
    files: dict[str, Path] = {}
    for exp in experiments:
        files[f"log:{exp.key}"] = out / f"{exp.key}.log"
        write_text_atomic(files[f"log:{exp.key}"], exp.log_text())
    files["db"] = out / "benchmark.db"
    logs_to_database([p for k, p in files.items() if k.startswith("log:")], files["db"])

    summary = [summarise(exp.key, name, exp.runs[name], exp.optimum) for exp in experiments for name in names]
    files["summary"] = out / "summary.csv"
    write_csv(files["summary"], SUMMARY_COLUMNS, summary)
    files["success_plot"] = out / "success_vs_time.png"
    plot_success_vs_time(experiments, files["success_plot"])
    files["cost_plot"] = out / "cost_vs_time.png"
    plot_final_cost(experiments, files["cost_plot"])

    table = format_table(SUMMARY_COLUMNS, summary)
    units = sorted({cost_units(scene) for scene in scenes.values()})
    table += ("\ntimes in s over the solved runs: OMPL planners from the start of solve(); lattice: building "
              f"the lattice plus the exact search.\ncosts: {' or '.join(units)}; gap = median cost / lattice "
              "optimum - 1 (the optimum on the planners' own lattice).")
    notes = limitation_notes(summary)
    if notes:
        table += "\nknown limitations (why these planners solve nothing here):\n" + "\n".join(f"  {n}" for n in notes)
    print(table)
    print(f"wrote {', '.join(p.name for p in files.values())} to {out}")
    optima = {exp.key: exp.optimum for exp in experiments}
    return BenchmarkResult([r for r in results if r.run >= 0], optima, summary, table, files)


# -- alpha sweep --------------------------------------------------------------------

def parse_alpha_range(text: str) -> list[float]:
    """Alphas (over the object length) from ``START:STOP:STEP`` (STOP included within rounding)
    or a single number. Raises InputError("--alpha") on bad text."""
    parts = [p.strip() for p in str(text).split(":")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise InputError("--alpha", f"must be START:STOP:STEP or a number, got {text!r}") from None
    if len(values) not in (1, 3):
        raise InputError("--alpha", f"must be START:STOP:STEP or a number, got {text!r}")
    if not all(math.isfinite(v) for v in values):
        raise InputError("--alpha", f"must be finite numbers, got {text!r}")
    if len(values) == 1:
        return values
    start, stop, step = values
    if step <= 0:
        raise InputError("--alpha", f"step must be positive, got {step:g}")
    if stop < start:
        raise InputError("--alpha", f"stop {stop:g} lies below start {start:g}")
    n = int(math.floor((stop - start) / step + 1e-9))
    if n >= 10000:
        raise InputError("--alpha", f"gives {n + 1} values; at most 10000")
    return [round(start + k * step, 10) for k in range(n + 1)]


def scene_with_alpha(scene: Scene, alpha: float) -> Scene:
    """The scene with digits.alpha replaced (over the object length); InputError("--alpha") if invalid."""
    if not (math.isfinite(alpha) and -1.0 < alpha < 1.0):
        raise InputError("--alpha", f"{alpha:g} must lie in (-1, 1) (over the object length)")
    if scene.digits.thumb_length + alpha <= 0:
        raise InputError("--alpha", f"{alpha:g} makes the finger length thumb_length + alpha non-positive")
    return dataclasses.replace(scene, digits=dataclasses.replace(scene.digits, alpha=float(alpha)))


@dataclass(frozen=True)
class SweepPoint:
    """One alpha: the planner's runs and the lattice search's run (costs in reference units)."""

    alpha: float
    runs: list[RunResult]
    lattice: RunResult

    @property
    def success_rate(self) -> float:
        return sum(r.solved for r in self.runs) / len(self.runs)

    @property
    def median_cost(self) -> float | None:
        return _median([r.cost for r in self.runs if r.solved])

    @property
    def lattice_optimum(self) -> float | None:
        return self.lattice.cost

    @property
    def lattice_reachable(self) -> bool:
        return self.lattice.cost is not None


@dataclass
class SweepResult:
    """The sweep over alpha: one point per alpha, the printed table and the files written."""

    scene: str
    planner: str
    points: list[SweepPoint]
    table: str
    units: str  # of the costs
    files: dict[str, Path] = field(default_factory=dict)


SWEEP_COLUMNS = (
    Column("alpha", "alpha", lambda p: p.alpha, "g"),
    Column("success", "success_rate", lambda p: p.success_rate, ".0%"),
    Column("median cost", "median_cost", lambda p: p.median_cost, ".2f"),
    Column("lattice optimum", "lattice_optimum", lambda p: p.lattice_optimum, ".2f"),
    Column("secure path exists", "lattice_reachable", lambda p: p.lattice_reachable),
)


def plot_sweep(result: SweepResult, time_limit: float, path: Path) -> None:
    """Success rate and cost (reference units) against alpha."""
    plt = _pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(6.5, 6.0), sharex=True, constrained_layout=True)
    alphas = [p.alpha for p in result.points]
    nan = float("nan")
    top.plot(alphas, [p.success_rate for p in result.points], "o-", label=result.planner)
    top.set(ylim=(-0.05, 1.05), ylabel=f"success rate ({time_limit:g} s)",
            title=f"{result.scene}: sweep over alpha")
    top.legend(fontsize=8)
    bottom.plot(alphas, [nan if p.median_cost is None else p.median_cost for p in result.points], "o-",
                label=f"{result.planner} median cost")
    bottom.plot(alphas, [nan if p.lattice_optimum is None else p.lattice_optimum for p in result.points], "k--x",
                label="lattice optimum")
    blocked = [p.alpha for p in result.points if not p.lattice_reachable]
    for k, a in enumerate(blocked):
        bottom.axvline(a, color="0.8", linewidth=3, zorder=0, label="no secure path" if k == 0 else None)
    bottom.set(xlabel="alpha (finger - thumb length, over l)", ylabel=f"cost ({result.units})")
    bottom.legend(fontsize=8)
    _save_png(fig, path)


def run_sweep(scene_path: str | os.PathLike[str], alphas: Sequence[float], runs: int, time_limit: float, jobs: int,
              out_dir: str | os.PathLike[str], planner: str = "RRTstar", seed: int = 1,
              progress: bool = True) -> SweepResult:
    """For each alpha (over the object length): `runs` runs of the planner for `time_limit`
    seconds each (fresh processes, OMPL seeded with seed + run index) and the exact lattice
    search once. Writes ``sweep.csv`` and ``sweep.png`` to out_dir, prints a table and
    returns it. Raises InputError naming the option or the scene."""
    (name,) = validate_planners([planner])
    out = _validate_run_options(runs, time_limit, jobs, seed, out_dir)
    alphas = [float(a) for a in alphas]
    if not alphas:
        raise InputError("--alpha", "gives no value")
    base = Scene.from_file(scene_path)
    scenes = [scene_with_alpha(base, a) for a in alphas]
    tasks = [Task(str(i), scene, LATTICE, -1, seed, float(time_limit)) for i, scene in enumerate(scenes)]
    tasks += [Task(str(i), scene, name, k, seed + k, float(time_limit))
              for i, scene in enumerate(scenes) for k in range(runs)]
    results = run_tasks(tasks, jobs, progress)
    points = [SweepPoint(a, [r for r in results if r.group == str(i) and r.run >= 0],
                         _lattice_yardstick(results, str(i))) for i, a in enumerate(alphas)]
    table = format_table(SWEEP_COLUMNS, points)
    result = SweepResult(base.name, name, points, table, cost_units(base))
    result.files["csv"] = out / "sweep.csv"
    write_csv(result.files["csv"], SWEEP_COLUMNS, points)
    result.files["plot"] = out / "sweep.png"
    plot_sweep(result, float(time_limit), result.files["plot"])
    print(f"{base.name}: {name}, {runs} run(s) of {time_limit:g} s per alpha; costs in {result.units}")
    print(table)
    print(f"wrote {', '.join(p.name for p in result.files.values())} to {out}")
    return result


__all__ = ["LATTICE", "STATUSES", "BenchmarkResult", "RunResult", "SummaryRow", "SweepPoint", "SweepResult",
           "parse_alpha_range", "run_benchmark", "run_sweep", "scene_with_alpha", "validate_planners"]
