"""OMPL's benchmark log format: one scene's runs as one experiment, as ``ompl::tools::Benchmark``
writes it, so that ``ompl_benchmark_statistics.py`` and Planner Arena read it.

Units: times in seconds; costs in the reference units (degrees of theta and psi + d_weight d
+ mode_change_penalty per primitive change).
"""

from __future__ import annotations

import math
import os
import platform
import socket
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import numpy as np
import ompl

from ..planning.setup import LATTICE, PlannerOptions
from ..scene import Scene
from .tasks import STATUSES, RunResult, RunStatus

#: OMPL version written into the logs when the package does not say.
_OMPL_VERSION_FALLBACK = "2.0.1"
#: The benchmark log format's planner prefix.
_PLANNER_PREFIX = "geometric_"


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
    ("correct solution BOOLEAN", lambda r: r.solved if r.status in (RunStatus.EXACT, RunStatus.INVALID) else None),
    ("time to first solution REAL", lambda r: r.time_to_first_solution_s),
    ("mode switches INTEGER", lambda r: r.mode_switches if r.solved else None),
    ("invalid path BOOLEAN", lambda r: r.status is RunStatus.INVALID),
    ("timeout BOOLEAN", lambda r: r.status is RunStatus.TIMEOUT),
    ("ungrasp status ENUM", lambda r: STATUSES.index(r.status.value)),
    ("setup time REAL", lambda r: r.setup_time_s),
    ("iterations INTEGER", lambda r: r.iterations),
    ("seed INTEGER", lambda r: r.seed if r.planner != LATTICE else None),
)


def _ompl_version() -> str:
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
    """The scene's key: the experiment's name and the log's file name."""
    scene: Scene
    """The scene."""
    planners: list[str]
    """The planners, in table order."""
    runs: dict[str, list[RunResult]]
    """Each planner's runs, in run order."""
    optimum: float | None
    """The lattice optimum (reference units); None: no secure path."""
    lattice_status: RunStatus
    """How the lattice search ended."""
    seed: int
    """Seed of run 0."""
    time_limit: float
    """Planning time per run (s)."""
    runs_per_planner: int
    """Runs per planner (count)."""
    started: datetime
    """When the benchmark started."""
    jobs: int
    """Runs at a time (count)."""

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
            f"OMPL seeded afresh per run with {self.seed} + run index; {self.jobs} parallel jobs",
            "memory limit: none enforced (0)",
        ])

    def total_time(self) -> float:
        return sum(r.wall_time_s for runs in self.runs.values() for r in runs)

    def planner_settings(self, planner: str) -> list[str]:
        if planner == LATTICE:
            res = self.scene.options.resolution
            return [f"resolution TEXT = {math.degrees(res[0]):g} deg / {res[1]:g} / {math.degrees(res[2]):g} deg"]
        opts = PlannerOptions(planner=planner, time=self.time_limit).for_scene(self.scene)
        return [f"range REAL = {opts.range!r}", f"goal_bias REAL = {opts.goal_bias!r}",
                f"simplify BOOLEAN = {int(opts.simplify)}"]

    def properties(self) -> list[str]:
        props = [f"scene_file TEXT = {self.scene.source or ''}",
                 f"lattice_reachable BOOLEAN = {int(self.optimum is not None)}",
                 f"lattice_status TEXT = {self.lattice_status.value}"]
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
