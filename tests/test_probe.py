"""The touch-off's probe in the simulator (sim.probe, robot.touch_off; docs/model.md 11.14).

Every probe here runs in MuJoCo, in the trial's own world: the empty hand lowered at the start
pinch of the guitar pick's lattice plan until the wrist's force reading passes the threshold.
An ideal sensor finds the table to a control period's travel; a noisy one scatters as its noise
predicts; the same draw finds the same height; a threshold under the noise stops in free air.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from conftest import SCENES
from ungrasp_ompl import Scene
from ungrasp_ompl.scene.perturbation import PRESETS, TrialParams, trial_params
from ungrasp_ompl.planning import plan
from ungrasp_ompl.robot.pipeline import execute
from ungrasp_ompl.robot.touch_off import FORCE_NOISE, FORCE_PRECISION, TouchOffOptions
from ungrasp_ompl.sim import probe as sim_probe
from ungrasp_ompl.sim.model import build_mjcf, model_ids
from ungrasp_ompl.sim.probe import (TAIL_SIGMAS, ProbeError, calibrate, descent_at, noise_sequence, periods_within,
                                    probing, stop_probabilities)
from ungrasp_ompl.sim.setup import trial_setup
from ungrasp_ompl.sim.trial import calibration_offset, touch_off_shift, trial_spec

OPTIONS = TouchOffOptions()


@pytest.fixture(scope="module")
def setup():
    """The guitar pick's lattice plan, executed, ready to simulate (its robot touches the table off)."""
    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    result = plan(scene, planner="lattice")
    assert result.solved
    ex = execute(scene, result)
    out = trial_setup(scene, result, ex.trajectory, ex.robot)
    assert out.touch_off
    return out


def _world(setup, params: TrialParams):
    """The trial's compiled world (the table where params put it), its ids and the arm's error."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(build_mjcf(trial_spec(setup, params)))
    return model, model_ids(model), calibration_offset(setup.drive, params)


def _pinch(setup):
    drive = setup.drive
    return (drive.palm[0] if drive.press_from is None else drive.press_from), float(drive.opening[0])


def test_the_sensor_model_comes_from_the_data_sheet():
    """The noise is the UR5e's precision read as two sigmas, the `paper` and `calibration` presets
    draw it, the threshold stands over five sigmas above it, and the touch-off's draw is the last
    of a trial's: with it or without it, every other error is drawn the same, and what a caller
    draws after a trial's errors (sim.landing's worlds) finds the generator as a uniform draw left it."""
    assert FORCE_NOISE == FORCE_PRECISION / 2 == 1.75
    assert PRESETS["paper"].probe_noise_n == PRESETS["calibration"].probe_noise_n == FORCE_NOISE
    assert OPTIONS.threshold >= 5 * FORCE_NOISE and OPTIONS.step == pytest.approx(1e-5)
    ideal = replace(PRESETS["paper"], probe_noise_n=0.0)
    for k in range(20):
        noisy, quiet = PRESETS["paper"].sample(np.random.default_rng([5, k])), ideal.sample(np.random.default_rng([5, k]))
        assert replace(noisy, probe_noise_n=0.0, probe_seed=0) == quiet
        assert noisy.probe_noise_n == FORCE_NOISE and quiet.probe_seed == 0
    assert len({p.probe_seed for p in trial_params(PRESETS["paper"], 1, 20)}) == 20
    noisy, quiet = np.random.default_rng(9), np.random.default_rng(9)
    PRESETS["paper"].sample(noisy), ideal.sample(quiet), quiet.uniform()  # the seed takes one word, as one uniform
    assert noisy.uniform() == quiet.uniform() and noisy.integers(2**32) == quiet.integers(2**32)


@pytest.mark.parametrize("table_mm", [-0.5, 0.0, 0.237, 0.5])
def test_an_ideal_probe_finds_the_table_to_a_control_periods_travel(setup, table_mm):
    """No calibration error, no noise: the table where the trial puts it is found within the
    overshoot bound, one control period's travel (0.01 mm; the give at the threshold is the
    calibration's, the same digits at the same orientation: its model error is nil here), and
    the record's error is the found height less the truth. The table where the plan has it is
    found there bit for bit."""
    params = TrialParams(table_height_mm=table_mm)
    model, ids, error = _world(setup, params)
    probe = touch_off_shift(setup, model, ids, error, params)
    assert abs(probe.found - table_mm / 1000) <= OPTIONS.step + 1e-12
    assert probe.error == pytest.approx(probe.found - table_mm / 1000, abs=1e-12)
    if table_mm == 0.0:
        assert probe.found == 0.0
    assert probe.calibration.sigma == 0.0 and 0.5e-3 < probe.calibration.deflection < 1.5e-3
    assert probe.descent.forces[-1] >= OPTIONS.threshold > probe.descent.forces[-2]


@pytest.mark.slow
def test_the_probes_height_error_follows_the_sensor(setup):
    """With the UR5e's noise, over 150 draws, the found height's error (against the table 0.3 mm
    above the plan's) has the mean and the spread the sensor model predicts from the same world's
    force trace without noise (stop_probabilities; the rare stop in free air, some 1e-5 a probe,
    left out of the prediction as out of 150 draws): the mean within three standard errors and
    half a control period's travel, the standard deviation within 20 % (its sampling spread over
    150 draws of this distribution is some 8 %, 1 % of sets of seeds fall outside 15 %). The
    calibration takes out the mean stop's lead over the noise-free one, and the spread is the
    sensor's, over five control periods' travel."""
    draws, truth = 150, 0.3e-3
    params = TrialParams(table_height_mm=truth * 1000, probe_noise_n=FORCE_NOISE)
    model, ids, error = _world(setup, params)
    pinch, opening = _pinch(setup)
    calibration = calibrate(setup.spec, pinch, opening, OPTIONS, FORCE_NOISE)
    with probing(model, ids, pinch, opening, OPTIONS, error) as hand:
        trace = hand.descend(None, OPTIONS.threshold + TAIL_SIGMAS * FORCE_NOISE, calibration.reach)
    stops = stop_probabilities(trace.forces, OPTIONS.threshold, FORCE_NOISE)
    touched = np.arange(len(stops)) >= np.flatnonzero(trace.forces > 0)[0]
    chance = stops * touched / (stops * touched).sum()
    predicted = calibration.descent - descent_at(np.arange(len(stops)), OPTIONS) - truth
    mean = float(chance @ predicted)
    sd = float(np.sqrt(chance @ (predicted - mean) ** 2))
    assert abs(mean) < OPTIONS.step and sd > 5 * OPTIONS.step
    found = np.array([touch_off_shift(setup, model, ids, error, replace(params, probe_seed=k)).error
                      for k in range(draws)])
    assert abs(found.mean() - mean) <= 3 * sd / np.sqrt(draws) + OPTIONS.step / 2
    assert abs(found.std(ddof=1) / sd - 1) <= 0.2
    assert model.geom_contype[ids.object_geom] == model.geom_conaffinity[ids.object_geom] == 1  # the object put back


def test_the_same_trial_finds_the_same_height_bit_for_bit(setup):
    """A trial's draw (its sensor noise's seed with the rest) gives the same found height and the
    same force trace every time, whether its calibration is computed again or kept."""
    params = trial_params(PRESETS["paper"], seed=7, trials=1)[0]
    assert params == trial_params(PRESETS["paper"], seed=7, trials=1)[0] and params.probe_seed
    first = touch_off_shift(setup, *_world(setup, params), params)
    sim_probe._calibrate.cache_clear()
    again = touch_off_shift(setup, *_world(setup, params), params)
    assert again.found == first.found and again.error == first.error
    assert again.calibration == first.calibration and np.array_equal(again.descent.forces, first.descent.forces)
    others = [replace(params, probe_seed=params.probe_seed + k) for k in (1, 2, 3)]
    stops = {touch_off_shift(setup, *_world(setup, other), other).descent.stop for other in others}
    assert stops != {first.descent.stop}  # the noise, not the world alone, sets the stop


def test_a_threshold_under_the_noise_stops_in_free_air(setup):
    """Negative control: a threshold under the sensor's noise floor (half a sigma) stops the descent
    in free air within the first periods, before any force, and the table is found higher than it
    is by more than the lift: far outside the ideal probe's bound, which the same check holds it
    to. A probe with no reach past its start finds nothing (ProbeError)."""
    params = TrialParams(table_height_mm=0.5, probe_noise_n=FORCE_NOISE, probe_seed=3)
    model, ids, error = _world(setup, params)
    pinch, opening = _pinch(setup)
    calibration = calibrate(setup.spec, pinch, opening, OPTIONS)
    noise = noise_sequence(FORCE_NOISE, params.probe_seed, periods_within(calibration.reach, OPTIONS))
    with probing(model, ids, pinch, opening, OPTIONS, error) as hand:
        low = hand.descend(noise, FORCE_NOISE / 2, calibration.reach)
    assert low.stop < 10 and not low.forces.any()
    found = calibration.descent - low.descent
    assert found - 0.5e-3 > OPTIONS.lift
    assert not abs(found - 0.5e-3) <= OPTIONS.step + 1e-12
    with probing(model, ids, pinch, opening, OPTIONS, error) as hand, pytest.raises(ProbeError) as caught:
        hand.descend(None, OPTIONS.threshold, OPTIONS.lift)
    assert caught.value.reach <= OPTIONS.lift and caught.value.stop_at == OPTIONS.threshold
