"""How deep the contacts sink (docs/model.md 11.2): the bound tools/sinking_bound.py measured over
120 `paper` trials per object of the campaign's base plans (trial seeds 1 to 3, written to
docs/results/sinking.json and quoted by docs/results.md), held on 40 other trials per object
(seed 4) of the same plans, each run up to the release, the last tick that measures it."""

from __future__ import annotations

import pytest

from conftest import SCENES, SINKING_BOUND_MM
from ungrasp_ompl import Scene
from ungrasp_ompl.parallel import RunOptions
from ungrasp_ompl.scene.perturbation import PRESETS
from ungrasp_ompl.planning import plan
from ungrasp_ompl.sim.campaign import simulate, trial_params
from ungrasp_ompl.sim.plan_trials import placement
from ungrasp_ompl.sim.trial import run_trial



@pytest.mark.slow
@pytest.mark.parametrize("name", ["guitar_pick", "puzzle_piece", "fabric_chalk"])
def test_sinking_stays_within_its_measured_bound(name):
    """40 `paper` trials of the object's base plan (RRT*, seed 1, as the campaign plans it) drawn
    with seed 4, which the bound's measurement did not draw: every control tick of the primitives
    sinks no deeper than the bound, and the contacts do sink (a trial that measured nothing would
    pass any bound)."""
    scene = Scene.from_file(SCENES / f"{name}.yaml")
    result = plan(scene, planner="RRTstar", time=1.0, seed=1)
    assert result.solved
    setup = placement(scene, result)[1].to_release()  # the ticks that measure the sinking, and no more
    report = simulate(setup, PRESETS["paper"], 40, RunOptions(seed=4, jobs=1), scene=name)
    depths = [t.max_penetration_mm for t in report.trials]
    assert max(depths) <= SINKING_BOUND_MM, sorted(depths)[-5:]
    assert sum(d > 0.0 for d in depths) >= 30


@pytest.mark.slow
def test_a_trial_cut_at_the_release_sinks_as_the_whole_trial():
    """TrialSetup.to_release, which the sinking's test and tool run: a trial cut at the release
    measures what the whole trial measures up to it, bit for bit (the pick's base plan, two
    `paper` trials of seed 4), and stops at the release's tick."""
    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    setup = placement(scene, plan(scene, planner="RRTstar", time=1.0, seed=1))[1]
    cut = setup.to_release()
    release = setup.drive.phase_start("termination")
    assert cut.drive.times[-2] < release <= cut.drive.times[-1] < setup.drive.times[-1]
    for k, params in enumerate(trial_params(PRESETS["paper"], 4, 2)):
        whole, part = run_trial(setup, params, k, 4), run_trial(cut, params, k, 4)
        assert (part.max_penetration_mm, part.a_off_dome_share) == (whole.max_penetration_mm, whole.a_off_dome_share)
        assert part.max_penetration_mm > 0.0
