"""The touch-off's probe, simulated (robot.touch_off; docs/model.md 11.14).

The probe runs in the trial's own world (its table, where the trial's calibration error puts it,
its digits and contacts), the object taken out of it: the empty hand, at the start pinch's
orientation and opening, starts TouchOffOptions.lift above the start pinch and is lowered straight
down along the arm's z at TouchOffOptions.speed, as the arm is told to move it; a miscalibrated arm
moves it where its calibration error takes every command (sim.trial.calibration_offset). Each
control period the wrist's force sensor is read, and the descent stops at the first period whose
vertical reading passes TouchOffOptions.threshold; what the probe finds comes from the commanded
descent at that period alone.

The reading: the vertical (world z) component of every contact force on the hand's geoms (the
palm, the thumb, the finger and its dome) from anything in the world, averaged over the control
period (the period's impulse over its length: what a sensor sampled once a period behind its
anti-alias filter reads), plus the sensor's noise, one Gaussian draw per period (standard
deviation TrialParams.probe_noise_n) from a sequence seeded by the trial's probe_seed.

The give: when the reading passes the threshold the hand has gone on past the first touch by the
digits' and the contacts' give at that force. A cell calibrates it once, with its own sensor,
over a surface of known height (Calibration): here the scene's own world (the table at z = 0, no
calibration error, the nominal contacts), the same probe from the same start; with a noisy sensor
it is the descent's mean over the noise (stop_probabilities), as a cell averages repeated touches.
The table then stands higher than the plan has it by the calibration's descent less the trial's.

Free air: while no geom of the hand is within reach of anything, the simulated force is zero and
the hand rides on the arm, so the descent is not stepped there: after SETTLE_PERIODS periods the
hand is moved at once to GUARD above the nearest thing it can meet (MuJoCo's geom distances), its
velocity and its joints as they are; the readings of the periods passed over are the noise alone.
"""

from __future__ import annotations

import functools
import math
import pickle
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr

from ..errors import ToolError
from ..robot.touch_off import TouchOffOptions
from .model import ModelIds, build_mjcf, model_ids
from .spec import SimModelSpec

#: Control periods of the descent that are stepped from its start before the hand skips the free
#: air: the hand, put at rest at its start, takes up the arm's speed (20 ms).
SETTLE_PERIODS = 10
#: How far (m) above the nearest thing it can meet the hand's skip through free air ends: the last
#: 20 control periods before a touch at 5 mm/s are stepped.
GUARD = 2e-4
#: A calibration with a noisy sensor traces the force until it passes the threshold by this many
#: standard deviations of the noise, beyond which the chance that no reading has stopped the
#: descent is below 1e-15.
TAIL_SIGMAS = 8.0


class ProbeError(ToolError):
    """The probe went its whole reach (reach, m of commanded descent from its start) without the
    force reading passing stop_at (N): nothing was found under the hand."""

    def __init__(self, reach: float, stop_at: float):
        super().__init__(f"the touch-off's probe went down {reach * 1000:.2f} mm without the force reading "
                         f"passing {stop_at:g} N: nothing under the hand")
        self.reach, self.stop_at = reach, stop_at


def descent_at(period: int | NDArray, options: TouchOffOptions) -> float | NDArray:
    """How far (m) the hand's target has gone down, commanded, at the end of control period period
    (from 0, the descent's first)."""
    return (np.asarray(period) + 1) * options.step if isinstance(period, np.ndarray) else (period + 1) * options.step


def periods_within(reach: float, options: TouchOffOptions) -> int:
    """How many control periods of descent stay within reach (m)."""
    return int(math.floor(reach / options.step + 1e-9))


def noise_sequence(sigma: float, seed: int, periods: int) -> NDArray[np.float64] | None:
    """The sensor's noise (N) on the readings of periods 0 .. periods - 1: sigma times standard
    normal draws from a Generator seeded by seed (a negative sigma: the same draws turned the
    other way); None for sigma 0 (an ideal sensor)."""
    if sigma == 0.0:
        return None
    return sigma * np.random.default_rng(seed).standard_normal(periods)


def stop_probabilities(forces: NDArray, threshold: float, sigma: float) -> NDArray[np.float64]:
    """The chance (K,) that a descent whose force without noise is forces (N, (K,), one a period)
    stops at each period: the first whose reading, force plus Gaussian noise of standard deviation
    sigma (N), reaches threshold (N) in magnitude; for sigma 0, 1 at the first period whose force
    does. What is left of 1 is the chance of going on past the last period."""
    forces = np.asarray(forces, dtype=float)
    if sigma == 0.0:
        below = (np.abs(forces) < threshold).astype(float)
    else:
        below = ndtr((threshold - forces) / sigma) - ndtr((-threshold - forces) / sigma)
    going = np.concatenate([[1.0], np.cumprod(below)[:-1]])
    return going * (1.0 - below)


@dataclass(frozen=True)
class Descent:
    """One probe's descent: where it stopped, and the force on the hand on the way."""

    stop: int
    """The control period (from 0, the descent's first) at whose end the reading passed the threshold."""
    forces: NDArray[np.float64]
    """(stop + 1,) the contact force (N, upward on the hand) over each period up to the stop, without
    the sensor's noise (0 over the periods passed in free air)."""
    options: TouchOffOptions

    @property
    def descent(self) -> float:
        """How far (m) the hand's target went down, commanded, from the probe's start to the stop."""
        return descent_at(self.stop, self.options)


class _Hand:
    """The empty hand in a world, at the probe's start: its own MjData; the world's object out of
    it (its contacts off in the model, put back by probing)."""

    def __init__(self, model, ids: ModelIds, start: NDArray, opening: float, options: TouchOffOptions,
                 error: NDArray | None):
        import mujoco  # mujoco: loaded when the probe runs

        self.model, self.ids, self.options = model, ids, options
        top = np.array(start, dtype=float)
        top[2, 3] += options.lift  # the arm's frame: lift along its z
        if error is not None:
            top = error @ top
        self.origin = top[:3, 3].copy()
        self.down = -(np.array([0.0, 0.0, 1.0]) if error is None else error[:3, 2])  # the arm's -z in the world
        data = self.data = mujoco.MjData(model)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(top[:3, :3]).ravel())
        self.palm_q = model.jnt_qposadr[model.body_jntadr[ids.palm_body]]
        data.qpos[self.palm_q:self.palm_q + 3], data.qpos[self.palm_q + 3:self.palm_q + 7] = self.origin, quat
        for jaw, side in ((ids.thumb_jaw, -1.0), (ids.finger_jaw, 1.0)):
            data.qpos[model.jnt_qposadr[model.body_jntadr[jaw]]] = side * opening / 2
        data.mocap_pos[ids.palm_mocap], data.mocap_quat[ids.palm_mocap] = self.origin, quat
        data.ctrl[ids.actuator] = opening  # the hand is empty: the servo holds the opening itself
        mujoco.mj_forward(model, data)
        mine = ids.thumb_geoms | ids.finger_geoms | {ids.palm_geom}
        self.hand = [g in mine for g in range(model.ngeom)]
        self.others = sorted({ids.table_geom} | ids.solid_geoms)
        self.substeps = max(1, round(options.period / model.opt.timestep))

    def gap(self, geoms) -> float:
        """The least distance (m) from a geom of the hand to one of geoms, as the hand is now."""
        import mujoco  # mujoco: loaded when the probe runs

        mujoco.mj_kinematics(self.model, self.data)
        fromto = np.zeros(6)
        reach = 1.0
        return min(mujoco.mj_geomDistance(self.model, self.data, h, int(g), reach, fromto)
                   for h in range(self.model.ngeom) if self.hand[h] for g in geoms)

    def _push(self, force6: NDArray) -> float:
        """The vertical (world z) component of the contact forces on the hand now (N, upward). A
        plain loop over the step's few contacts: numpy's per-call overhead would cost more."""
        import mujoco  # mujoco: loaded when the probe runs

        hand, contact = self.hand, self.data.contact
        total = 0.0
        for i, (g1, g2) in enumerate(contact.geom[:self.data.ncon].tolist()):
            if hand[g1] == hand[g2]:
                continue
            mujoco.mj_contactForce(self.model, self.data, i, force6)  # geom1 on geom2, in the contact's frame
            _, _, nz, _, _, t1z, _, _, t2z = contact.frame[i].tolist()
            up = force6[0] * nz + force6[1] * t1z + force6[2] * t2z
            total += up if hand[g2] else -up
        return total

    def descend(self, noise: NDArray | None, stop_at: float, reach: float) -> Descent:
        """Lower the hand's target by the options' step a control period, moved a step of the way
        per simulation step, and read the force each period; stop at the first period whose
        reading (force plus noise[period]) reaches stop_at (N) in magnitude. ProbeError once the
        descent would pass reach (m) without it."""
        import mujoco  # mujoco: loaded when the probe runs

        model, data, ids = self.model, self.data, self.ids
        periods = periods_within(reach, self.options)
        if noise is not None and len(noise) < periods:
            raise ValueError(f"{len(noise)} noise draws for {periods} control periods")
        forces = np.zeros(periods)
        per_step = self.options.step / self.substeps
        within = np.arange(1, self.substeps + 1)  # the steps of a period
        mocap = ids.palm_mocap
        force6 = np.zeros(6)
        k = 0
        while k < periods:
            if k == SETTLE_PERIODS:  # free air: nothing to step until the hand is GUARD from anything
                skip = min(periods - k, max(0, int(math.floor((self.gap(self.others) - GUARD) / self.options.step))))
                if skip:
                    if noise is not None and (hit := np.flatnonzero(np.abs(noise[k:k + skip]) >= stop_at)).size:
                        stop = k + int(hit[0])
                        return Descent(stop, forces[:stop + 1].copy(), self.options)
                    moved = self.down * (skip * self.options.step)
                    data.qpos[self.palm_q:self.palm_q + 3] += moved
                    k += skip
                    continue
            push = 0.0
            for target in self.origin + self.down * ((k * self.substeps + within) * per_step)[:, None]:
                data.mocap_pos[mocap] = target
                mujoco.mj_step(model, data)
                if data.ncon:
                    push += self._push(force6)
            forces[k] = push / self.substeps
            reading = forces[k] + (noise[k] if noise is not None else 0.0)
            if abs(reading) >= stop_at:
                return Descent(k, forces[:k + 1].copy(), self.options)
            k += 1
        raise ProbeError(descent_at(periods - 1, self.options), stop_at)


@contextmanager
def probing(model, ids: ModelIds, start: NDArray, opening: float, options: TouchOffOptions = TouchOffOptions(),
            error: NDArray | None = None):
    """The empty hand in model's world, ready to descend (yields _Hand): start, the commanded palm
    pose (4x4, the arm's frame) at the start pinch, the probe starting options.lift above it along
    the arm's z; opening (m) the start pinch's; error, the world transform the arm applies to every
    command (sim.trial.calibration_offset; None: none). The world's object is out of the world
    (its contacts off) until the block ends; the hand has its own MjData."""
    geom = ids.object_geom
    kept = int(model.geom_contype[geom]), int(model.geom_conaffinity[geom])
    model.geom_contype[geom] = model.geom_conaffinity[geom] = 0
    try:
        yield _Hand(model, ids, start, opening, options, error)
    finally:
        model.geom_contype[geom], model.geom_conaffinity[geom] = kept


@dataclass(frozen=True)
class Calibration:
    """A cell's calibration of its probe, made once over a surface of known height: the scene's
    own world (the table at z = 0, no calibration error, the nominal contacts), the probe from the
    start pinch."""

    gap: float
    """How far (m) the hand's lowest point is above the surface at the probe's start: lift plus the
    clearance the simulated digits have at the start pinch."""
    descent: float
    """The commanded descent (m) from the probe's start to its stop: with a noisy sensor its mean
    over the noise, as over many touches (stop_probabilities)."""
    sigma: float
    """The sensor noise (N, one standard deviation of a reading) it was made with."""
    options: TouchOffOptions

    @property
    def deflection(self) -> float:
        """How far (m) the hand goes on past the first touch before the reading passes the
        threshold: the give of the digits and the contacts (TouchOff.deflection)."""
        return self.descent - self.gap

    @property
    def reach(self) -> float:
        """How far (m) the probe may go down from its start: the gap and options.overtravel."""
        return self.gap + self.options.overtravel


def calibrate(spec: SimModelSpec, start: NDArray, opening: float, options: TouchOffOptions = TouchOffOptions(),
              sigma: float = 0.0) -> Calibration:
    """The calibration (Calibration) of the probe from the start pinch start (palm pose, 4x4) at
    opening (m) in the world spec describes, as planned (spec itself, the trial's errors not
    applied), with a sensor of noise sigma (N). Kept per process for the same arguments."""
    return _calibrate(pickle.dumps((spec, np.array(start, dtype=float), float(opening), options, abs(float(sigma)))))


@functools.lru_cache(maxsize=32)
def _calibrate(arguments: bytes) -> Calibration:
    """calibrate's work, on its arguments pickled (the key under which it is kept)."""
    import mujoco  # mujoco: loaded when the probe runs

    spec, pinch, opening, options, sigma = pickle.loads(arguments)
    model = mujoco.MjModel.from_xml_string(build_mjcf(spec))
    ids = model_ids(model)
    with probing(model, ids, pinch, opening, options) as hand:
        gap = hand.gap([ids.table_geom])
        reach = gap + options.overtravel
        if sigma == 0.0:
            return Calibration(gap, hand.descend(None, options.threshold, reach).descent, 0.0, options)
        trace = hand.descend(None, options.threshold + TAIL_SIGMAS * sigma, reach)
    stops = stop_probabilities(trace.forces, options.threshold, sigma)
    descent = float(stops @ descent_at(np.arange(len(stops)), options) / stops.sum())
    return Calibration(gap, descent, sigma, options)


@dataclass(frozen=True)
class TouchOffProbe:
    """A trial's touch-off: what its probe found, and how far from the truth (the record)."""

    found: float
    """How much higher (m, along the arm's z) than the plan has it the probe found the table: the
    calibration's descent less the trial's. Every command of the trial is moved up by it."""
    error: float
    """found less what an exact probe would have found (m): computed after the fact from the trial's
    calibration error and table height, for the record; the trial never reads it."""
    descent: Descent
    """The trial's descent."""
    calibration: Calibration

    def result_fields(self) -> dict[str, float]:
        """The trial result's fields (sim.outcome.TrialResult): table_found_mm, probe_error_mm."""
        return {"table_found_mm": self.found * 1000, "probe_error_mm": self.error * 1000}
