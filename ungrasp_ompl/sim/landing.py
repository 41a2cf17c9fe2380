"""Where the object lands when a placement's release is simulated, and the aim that corrects the
hand for it: with no error drawn (robot.landing: simulated; docs/model.md 11.12), or on average
under the `paper` errors (robot.landing: expected; docs/model.md 11.12).

The plan ends with the object pinched at a small theta, its end G on the table; the termination
lets go and the object falls flat. The plan takes the object to turn flat about G, but a falling
object's end rides down the thumb's face as the thumb backs away, and the object comes to rest a
millimetre or so toward G, and an object held off its centre of mass turns a little about the
vertical as it falls. The table is flat and the same everywhere, so the same release run a few
millimetres away, or turned a few degrees about the vertical, lands the same way, moved by as
much: moving the hand's whole motion by the inverse of the landing's move puts the object on its
target, at its heading. The trial that measures it is the
placement's own, with no error drawn (TrialParams()), so that nothing of the errors a campaign
draws enters it.

The errors do not move the landing evenly, though (friction, for one, is only ever lower than
the scene's), and the mean landing under the `paper` errors can lie a millimetre and more from the
no-error one (docs/model.md 11.12); nor is the world the one modelled: the landing moves with the
friction, which a real cell knows to about +-30 %, and with the friction cone's model. The expected
landing averages antithetic pairs of releases (a draw and its mirror through the box's middle,
Perturbation.mirrored), whose errors cancel to first order in each pair's mean, so that a few
pairs measure the mean more closely than as many plain draws; each pair also runs in a world of
its own (landing_world): every friction scaled by a factor drawn over +-LANDING_FRICTION_RANGE
(the pair's mirror by the factor reflected about 1), and the pairs' cones alternately elliptic and
pyramidal, so that the aim is fitted to no one world (docs/model.md 11.12). Its draws come from a
seed stream of their own (LANDING_ENTROPY, spawned per pair), apart from every trial's.

A landing is a function of the unaimed placement alone, and the expected one costs nine simulated
placements; with the environment variable UNGRASP_OMPL_CACHE naming a directory, robot_landing
keeps each landing it computes there, under a digest of everything it was computed from, and
answers the same placement again from it (plan --export then simulate --plan, a campaign run
twice, the test suite).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import pickle
from dataclasses import dataclass, replace
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..io import write_text_atomic
from ..parallel import RunOptions
from ..robot.pipeline import Aim
from ..scene.options import Landing, RobotOptions
from ..scene.perturbation import PRESETS, TrialParams
from .campaign import run_each
from .outcome import Outcome
from .trial import TrialSetup, _rot_z, placement_offset, placement_turn, run_trial
from .world import Cone, World


@dataclass(frozen=True)
class LandingPrediction:
    """One release simulated with no error: where the object came to rest against its target."""

    offset: tuple[float, float]
    """World (x, y) of the object's outline centroid at rest less its target's (m)."""
    outcome: Outcome
    """How that trial ended, by the strict verdict."""
    turn: float = 0.0
    """The object's turn about the vertical at rest against its target (rad, counter-clockwise)."""
    correction: Aim = Aim()
    """The aim that undoes the landing's move (offset and turn), whether or not it landed."""
    pairs: int = 0
    """Antithetic pairs of drawn releases whose landings the offset, turn and correction average
    (0: the release with no error alone)."""

    @property
    def landed(self) -> bool:
        """The object was let go flat with nothing gone wrong before, whatever the error (the strict
        verdict placed it: no digit on the table, no turn out of the plane), so its offset says where
        the release lands it; an object that turned out of the plane first lands where that took it."""
        return self.outcome.placed

    @property
    def aim(self) -> Aim:
        """How to move the hand's motion to put the object on its target at its heading: the
        correction where it landed, none where it did not."""
        return self.correction if self.landed else Aim()


def landing_offset(setup: TrialSetup, final_pose: NDArray[np.float64]) -> NDArray[np.float64]:
    """World (x, y) of the outline centroid of the object at final_pose (4 x 4) less its target's
    (m, shape (2,)): the offset whose length a trial's placement error is."""
    return placement_offset(np.asarray(final_pose, dtype=float), setup.target_pose, setup.spec.obj.outline)


def landing_correction(setup: TrialSetup, final_pose: NDArray[np.float64]) -> tuple[float, Aim]:
    """The object's turn about the vertical at final_pose (4 x 4) against its target (rad), and the
    aim (robot.pipeline.Aim, about the target frame's origin G) that moves a landing there back onto
    the target: the landing maps the target's planar pose to the final one, p -> R(turn) (p - g) + o
    (g, o: the target's and the final pose's origins), and the aim is its inverse, the turn undone
    about g and the shift R(-turn) (g - o)."""
    final, target = np.asarray(final_pose, dtype=float), setup.target_pose
    turn = placement_turn(final, target)
    c, s = math.cos(turn), math.sin(turn)
    gx, gy = target[:2, 3] - final[:2, 3]
    return turn, Aim(float(c * gx + s * gy), float(-s * gx + c * gy), -turn)


def _prediction(setup: TrialSetup, final: NDArray[np.float64], outcome: Outcome, pairs: int = 0) -> LandingPrediction:
    x, y = landing_offset(setup, final)
    turn, correction = landing_correction(setup, final)
    return LandingPrediction((float(x), float(y)), outcome, turn, correction, pairs)


def predict_landing(setup: TrialSetup) -> LandingPrediction:
    """Simulate the placement, as setup has it unaimed, once with no error drawn and say where the
    object landed."""
    result = run_trial(setup, TrialParams())
    return _prediction(setup, np.array(result.final_pose), result.outcome)


#: The entropy of the expected landing's draws; pair k draws from SeedSequence(LANDING_ENTROPY,
#: spawn_key=(k,)), a stream no trial's seed (seed, k) or (seed, attempt, piece) reaches.
LANDING_ENTROPY = 0x1A4D


#: How far (a fraction either way) the expected landing's worlds scale every friction coefficient:
#: the uncertainty of dry friction between the shipped objects' materials (docs/model.md 11.12).
LANDING_FRICTION_RANGE = 0.3


def landing_draw(k: int) -> tuple[tuple[TrialParams, World], tuple[TrialParams, World]]:
    """The expected landing's pair k: a draw of the `paper` errors in a world of its own, and its
    mirror: friction scaled by a factor f drawn uniformly over 1 +- LANDING_FRICTION_RANGE and by
    2 - f, both with elliptic cones for even k and pyramidal ones for odd k."""
    box = PRESETS["paper"]
    rng = np.random.default_rng(np.random.SeedSequence(LANDING_ENTROPY, spawn_key=(k,)))
    params = box.sample(rng)
    f = float(rng.uniform(1.0 - LANDING_FRICTION_RANGE, 1.0 + LANDING_FRICTION_RANGE))
    cone = Cone.ELLIPTIC if k % 2 == 0 else Cone.PYRAMIDAL
    return (params, World(friction=f, cone=cone)), (box.mirrored(params), World(friction=2.0 - f, cone=cone))


def expected_landing(setup: TrialSetup, pairs: int, run: RunOptions = RunOptions(jobs=1)) -> LandingPrediction:
    """Where the placement, as setup has it unaimed, lands the object on average under the `paper`
    errors and over the worlds of landing_draw: the release simulated with no error first (an
    object that does not land so gets no aim, as in predict_landing), then pairs antithetic pairs
    of drawn releases (landing_draw), on run's workers or cluster (sim.campaign.run_each; the draws
    are landing_draw's, not seeded by run.seed). The mean landing (mean position of the body frame,
    mean turn) of the pairs whose both releases placed the object by the paper's criterion (let
    go flat, wherever: where it lands is what is measured) gives the offset, turn and correction;
    with fewer than half the pairs so, the no-error landing does."""
    nominal = run_trial(setup, TrialParams())
    if not nominal.outcome.placed:
        return _prediction(setup, np.array(nominal.final_pose), nominal.outcome)
    draws = [draw for k in range(pairs) for draw in landing_draw(k)]
    landed = run_each([(replace(setup, world=world), params, k, None) for k, (params, world) in enumerate(draws)],
                      run.workers, cluster=run.cluster)
    finals = [np.array(r.final_pose) for pair in zip(landed[::2], landed[1::2])
              if all(r.placed for r in pair) for r in pair]
    if len(finals) < pairs:  # fewer than half the pairs placed both
        return _prediction(setup, np.array(nominal.final_pose), nominal.outcome)
    target = setup.target_pose
    heading = math.atan2(target[1, 0], target[0, 0]) + float(np.mean([placement_turn(f, target) for f in finals]))
    mean = np.eye(4)
    mean[:3, :3] = _rot_z(heading)
    mean[:3, 3] = np.mean([f[:3, 3] for f in finals], axis=0)
    return _prediction(setup, mean, nominal.outcome, len(finals) // 2)


#: The environment variable naming the directory in which robot_landing keeps its landings (unset
#: or empty: none kept).
CACHE_VARIABLE = "UNGRASP_OMPL_CACHE"


def _cache_file(setup: TrialSetup, robot: RobotOptions) -> Path | None:
    """Where the landing of setup under robot's landing settings is kept: a file named by the
    SHA-256 of the pickled setup, the settings and the versions of this package and of MuJoCo (so
    that another release never answers for this one); None without a cache directory."""
    root = os.environ.get(CACHE_VARIABLE)
    if not root:
        return None
    import mujoco  # mujoco: loaded when a landing is simulated

    try:
        ours = version("ungrasp-ompl")
    except PackageNotFoundError:  # run from a source tree that was never installed
        ours = "source"
    worlds = [world for k in range(robot.landing_pairs) for _, world in landing_draw(k)]
    key = pickle.dumps((ours, mujoco.__version__, str(robot.landing), robot.landing_pairs, worlds, setup), protocol=5)
    return Path(root) / "landing" / f"{hashlib.sha256(key).hexdigest()}.json"


def _read_kept(path: Path) -> LandingPrediction | None:
    """The landing kept in path, or None where there is none or it cannot be read as one."""
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        x, y = map(float, doc["offset"])
        return LandingPrediction((x, y), Outcome(doc["outcome"]), float(doc["turn"]),
                                 Aim(*map(float, doc["correction"])), int(doc["pairs"]))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _keep(path: Path, landing: LandingPrediction) -> None:
    """Keep landing in path (atomically: a reader sees the whole file or none); a cache that cannot
    be written costs the next run the simulation, nothing more."""
    doc = {"offset": list(landing.offset), "outcome": landing.outcome.value, "turn": landing.turn,
           "correction": list(landing.correction), "pairs": landing.pairs}
    try:
        write_text_atomic(path, json.dumps(doc))
    except OSError:
        pass


def robot_landing(setup: TrialSetup, robot: RobotOptions, run: RunOptions = RunOptions(jobs=1)) -> LandingPrediction | None:
    """The landing the scene's robot.landing aims the hand by: None where it is planned, the
    release with no error where simulated, the expected landing of robot.landing_pairs pairs where
    expected (its pairs on run's workers or cluster). With
    UNGRASP_OMPL_CACHE set, a landing kept there for the same setup and settings is returned as
    it was computed, and one computed is kept."""
    if robot.landing is Landing.PLANNED:
        return None
    path = _cache_file(setup, robot)
    if path is not None and (kept := _read_kept(path)) is not None:
        return kept
    if robot.landing is Landing.SIMULATED:
        landing = predict_landing(setup)
    else:
        landing = expected_landing(setup, robot.landing_pairs, run)
    if path is not None:
        _keep(path, landing)
    return landing
