"""Statistics of a planner's runs on one scene: success, failures by kind, times, cost, the gap
to the exact lattice optimum (times in seconds, costs in reference units)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..planning.setup import KNOWN_LIMITATIONS
from .table import Column
from .tasks import RunResult, RunStatus


def median(xs: Sequence[float]) -> float | None:
    """The median, None for no values."""
    return float(np.median(xs)) if len(xs) else None


def p90(xs: Sequence[float]) -> float | None:
    """The 90th percentile, None for no values."""
    return float(np.percentile(xs, 90)) if len(xs) else None


def gap_percent(cost: float | None, optimum: float | None) -> float | None:
    """(cost / optimum - 1) in percent; None without both (or with a zero optimum and a cost)."""
    if cost is None or optimum is None:
        return None
    if optimum <= 0:
        return 0.0 if cost <= 0 else None
    return 100.0 * (cost / optimum - 1.0)


@dataclass(frozen=True)
class SummaryRow:
    """Statistics of one planner on one scene."""

    scene: str
    """The scene's key."""
    planner: str
    """The planner's name."""
    runs: int
    """Runs (count)."""
    success_rate: float
    """Share of runs with a re-validated path (0-1)."""
    invalid_paths: int
    """Runs whose path failed re-validation (count)."""
    timeouts: int
    """Runs that found nothing in time though a path exists (count)."""
    hung: int
    """Runs killed after ignoring their termination condition, or whose process died (count)."""
    proved_unsolvable: int
    """Runs that proved no path exists: start, goal or the exact search (count)."""
    first_solution_median_s: float | None
    """Median time to the first solution over the solved runs (s)."""
    first_solution_p90_s: float | None
    """90th percentile of the time to the first solution over the solved runs (s)."""
    cost_median: float | None
    """Median final cost over the solved runs (reference units)."""
    gap_percent: float | None
    """(median cost / lattice optimum - 1) * 100 (percent)."""
    mode_changes_median: float | None
    """Median count of primitive changes over the solved runs."""
    lattice_optimum: float | None
    """The exact optimum on the scene's lattice (reference units); None: no secure path."""
    margin_median: float | None = None
    """Median over the solved runs of the path's smallest friction margin (deg)."""
    lattice_margin: float | None = None
    """The smallest friction margin of the lattice optimum's path (deg): with the margin
    objective, the most any secure lattice path keeps."""
    limitation: str | None = None
    """0% success where a path exists: the code of the planner's known limitation."""
    tolerance_median: float | None = None
    """Median over the solved runs of the path's tolerance of the `paper` errors (scale of their
    box), under the tolerance objective; None otherwise."""
    lattice_tolerance: float | None = None
    """The tolerance of the lattice optimum's path under the tolerance objective (scale)."""


def summarise(scene: str, planner: str, runs: Sequence[RunResult], optimum: float | None,
              optimum_margin: float | None = None, optimum_tolerance: float | None = None) -> SummaryRow:
    """The summary row of one planner's runs on one scene; optimum_margin: the smallest friction
    margin (deg) of the lattice optimum's path; optimum_tolerance: its tolerance (tolerance
    objective)."""
    solved = [r for r in runs if r.solved]
    cost = median([r.cost for r in solved])
    return SummaryRow(
        scene=scene, planner=planner, runs=len(runs),
        success_rate=len(solved) / len(runs) if runs else 0.0,
        invalid_paths=sum(r.status is RunStatus.INVALID for r in runs),
        timeouts=sum(r.status is RunStatus.TIMEOUT for r in runs),
        hung=sum(r.status is RunStatus.HUNG for r in runs),
        proved_unsolvable=sum(r.status in (RunStatus.UNSOLVABLE_START_OR_GOAL, RunStatus.INFEASIBLE) for r in runs),
        first_solution_median_s=median([r.time_to_first_solution_s for r in solved]),
        first_solution_p90_s=p90([r.time_to_first_solution_s for r in solved]),
        cost_median=cost, gap_percent=gap_percent(cost, optimum),
        mode_changes_median=median([r.mode_switches for r in solved]),
        lattice_optimum=optimum,
        margin_median=median([r.min_margin_deg for r in solved if r.min_margin_deg is not None]),
        lattice_margin=optimum_margin,
        tolerance_median=median([r.tolerance for r in solved if r.tolerance is not None]),
        lattice_tolerance=optimum_tolerance,
        limitation=KNOWN_LIMITATIONS[planner].code
        if planner in KNOWN_LIMITATIONS and not solved and optimum is not None else None)


def limitation_notes(rows: Sequence[SummaryRow]) -> list[str]:
    """One line per planner reported with a known limitation: why it cannot succeed here."""
    named = dict.fromkeys(r.planner for r in rows if r.limitation)
    return [f"{p}: {KNOWN_LIMITATIONS[p].code}: {KNOWN_LIMITATIONS[p].value}" for p in named]


#: The summary's columns, in the printed table and summary.csv.
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
    Column("margin median deg", "smallest_margin_median_deg", lambda r: r.margin_median, ".3f"),
    Column("lattice margin deg", "lattice_smallest_margin_deg", lambda r: r.lattice_margin, ".3f"),
    Column("tolerance median", "tolerance_median", lambda r: r.tolerance_median, ".3f"),
    Column("lattice tolerance", "lattice_tolerance", lambda r: r.lattice_tolerance, ".3f"),
    Column("known limitation", "known_limitation", lambda r: r.limitation),
)
