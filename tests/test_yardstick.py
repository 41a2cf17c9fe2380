"""The exact lattice search is a true yardstick: no planner's re-validated path costs less
(docs/model.md, section 8.2), and the lattice planner's own plan attains it."""

from __future__ import annotations

import pytest

from conftest import SCENES
from ungrasp_ompl import Scene
from ungrasp_ompl.planning.atlas import SecurityAtlas, planning_box
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
    below = {run: cost for run, cost in costs.items() if cost < exact.lattice_optimum - 1e-9}
    assert not below, f"cheaper than the yardstick {exact.lattice_optimum}: {below}"
    assert len(costs) > len(SEEDS) * 6  # most runs solve, so the bound is tested
