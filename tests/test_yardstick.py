"""The exact lattice search is a true yardstick: no planner's re-validated path costs less
(docs/model.md, section 8.2), and the lattice planner's own plan attains it."""

from __future__ import annotations

import pytest

from conftest import SCENES
from ungrasp_ompl import Scene
from ungrasp_ompl.planning.atlas import SecurityAtlas, planning_box
from ungrasp_ompl.planning.result import StoppedBy
from ungrasp_ompl.planning.setup import KNOWN_LIMITATIONS, PLANNERS, lattice_plan, plan

SEEDS = range(1, 11)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["reference_asymmetric", "guitar_pick"])
def test_no_planner_beats_the_yardstick(name):
    """Every planner that can solve these problems (FMT* and BFMT* cannot, setup.KNOWN_LIMITATIONS),
    seeds 1-10: every solved plan (its legs re-validated with the exact mechanics) costs at least
    the lattice optimum, counted as plans count it."""
    scene = Scene.from_file(SCENES / f"{name}.yaml")
    atlas = SecurityAtlas(scene, planning_box(scene))
    exact = lattice_plan(scene, atlas=atlas)
    assert exact.solved and exact.cost == pytest.approx(exact.lattice_optimum, abs=1e-9)
    costs = {}
    for planner in (p for p in PLANNERS if p not in KNOWN_LIMITATIONS):
        for seed in SEEDS:
            result = plan(scene, planner, time=0.2, seed=seed, atlas=atlas)
            if result.solved:
                costs[planner, seed] = result.cost
            if result.stopped_by == StoppedBy.OPTIMUM:  # it stops there only on reaching it
                assert result.cost == pytest.approx(exact.lattice_optimum, abs=1e-9), (planner, seed)
    below = {run: cost for run, cost in costs.items() if cost < exact.lattice_optimum - 1e-9}
    assert not below, f"cheaper than the yardstick {exact.lattice_optimum}: {below}"
    assert len(costs) > len(SEEDS) * 6  # most runs solve, so the bound is tested


def test_rrt_star_stops_at_the_optimum_reproducibly():
    """Seeded RRT* on guitar_pick reaches the lattice optimum within its budget: it stops there
    (stopped_by says so, long before the budget), and the same seed stops at the same iteration
    with the same plan."""
    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    atlas = SecurityAtlas(scene, planning_box(scene))
    optimum = lattice_plan(scene, atlas=atlas).lattice_optimum
    runs = [plan(scene, "RRTstar", time=1.0, seed=1, atlas=atlas) for _ in range(2)]
    for run in runs:
        assert run.stopped_by == StoppedBy.OPTIMUM and run.iterations < 6000
        assert run.cost == pytest.approx(optimum, abs=1e-9)
        assert "stopped at the lattice optimum" in run.summary()
    assert runs[0].iterations == runs[1].iterations and runs[0].states == runs[1].states
