"""Campaigns of planning tasks: benchmarks of the planners on scenes (OMPL's benchmark log and
database), a sweep over alpha, and a feasibility map over alpha and friction.

Every run is a task of worker processes (:mod:`ungrasp_ompl.parallel.runner`), on this machine or
on a Ray cluster, with OMPL's random numbers seeded afresh for it (planning.setup.seed_ompl).
Results stream to a CSV file as they arrive (:mod:`ungrasp_ompl.parallel.stream`), so a campaign
resumes. The planner ``lattice`` is the exact
Dijkstra search over the primitive lattice at the scene's own resolution, the lattice the OMPL
planners plan on: its cost is the optimum those planners can reach, so a planner's cost over it
is a true optimality gap.

Units: times in seconds; costs in the reference units (degrees of theta and psi + 100 d + 1 per
primitive change, with the scene's ``d_weight`` and ``mode_change_penalty``).

One concern per module:

* :mod:`.options` -- :class:`BenchmarkOptions`, :class:`SweepOptions` and their checks;
* :mod:`.ranges` -- ``START:STOP:STEP`` ranges of the command line;
* :mod:`.tasks` -- one run of a planner on a scene, its typed status, running many;
* :mod:`.statistics` -- per planner and scene: success, failures, times, cost, gap;
* :mod:`.table` -- columns for text tables and CSV;
* :mod:`.ompl_log` -- OMPL's benchmark log format;
* :mod:`.database` -- the SQLite database made from the logs by OMPL's script;
* :mod:`.bench` -- :func:`run_benchmark` and its pictures;
* :mod:`.sweep` -- :func:`run_sweep` and its picture;
* :mod:`.map` -- :func:`run_map`, the feasibility map, and its picture;
* :mod:`.design` -- :func:`run_design`, the search over digit designs, and its picture;
* :mod:`.starts` -- :func:`choose_start`, the search over the start's d for the one from which B
  slides least along the thumb.

Nothing here prints: the CLI does.
"""

from __future__ import annotations

from .bench import BenchmarkResult, run_benchmark
from .design import DesignOptions, DesignResult, run_design
from .map import MapOptions, MapResult, run_map
from .options import BenchmarkOptions, SweepOptions
from .starts import StartChoice, StartOptions, b_slide, choose_start, search_starts
from .sweep import SweepResult, run_sweep

__all__ = ["BenchmarkOptions", "BenchmarkResult", "DesignOptions", "DesignResult", "MapOptions", "MapResult",
           "StartChoice", "StartOptions", "SweepOptions", "SweepResult", "b_slide", "choose_start", "run_benchmark",
           "run_design", "run_map", "run_sweep", "search_starts"]
