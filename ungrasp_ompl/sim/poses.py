"""The simulated object's pose over time in one trial: ``trial_poses.json``, which the 3D view reads.

``simulate --out DIR`` runs its first trial once more in the main process with pose recording on
(MuJoCo is deterministic: it is the campaign's trial 0 again; ``final_pose_difference_m`` says how
far the campaign's last pose, at the end or at the failure where its trial stopped, lies from the
recorded pose at the same time) and writes the object's world pose every RECORD_PERIOD_S
of trajectory time. Units: s (trajectory time, as in trajectory.json), m; poses are 4x4 world
poses of the object's body frame (the manipulation plane's frame at the target: origin at G, x
toward B, z up; the prism spans z in [0, thickness]).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..io import read_versioned_json, write_text_atomic
from ..scene.perturbation import TrialParams
from .drive import UNDRIVEN
from .outcome import TrialResult
from .trial import TrialSetup, run_trial, trial_spec

POSES_FILE = "trial_poses.json"
FORMAT = "ungrasp-ompl trial poses"
SCHEMA_VERSION = 1
#: Poses are kept every this many seconds (the simulator records every 2 ms control tick).
RECORD_PERIOD_S = 0.02

PathLike = str | os.PathLike[str]


@dataclass
class TrialPoses:
    """One simulated trial's object poses: times (N,) s of trajectory time, poses (N, 4, 4);
    outline (M, 2) m and thickness m of the simulated prism; the trial's outcome for the legend."""

    times: NDArray[np.float64]
    poses: NDArray[np.float64]
    outline: NDArray[np.float64]
    thickness: float
    trial: int = 0
    outcome: str = ""
    position_error_mm: float = float("nan")
    final_pose_difference_m: float | None = None


def record_trial(setup: TrialSetup, params: TrialParams, start_time: float, trial: int = 0, seed: int | None = None,
                 campaign: TrialResult | None = None) -> TrialPoses:
    """Run one trial (sim.trial.run_trial) with recording on. setup: its TrialSetup; params: its
    TrialParams; start_time: trajectory time (s) of the drive's start (its first primitive);
    campaign: the campaign's TrialResult of the same trial, whose final pose is compared with the
    recorded pose at the same simulated time (a campaign's trial stops at its failure)."""
    record: list[tuple[float, NDArray]] = []
    result = run_trial(setup, params, trial, seed, record=record)
    times = np.array([t for t, _ in record]) + start_time
    poses = np.array([p for _, p in record])
    keep = _thinned(times)
    spec = trial_spec(setup, params)
    diff = None
    if campaign is not None:
        same_time = np.asarray(result.final_pose)
        if campaign.sim_time_s < result.sim_time_s:  # the campaign stopped at the failure: its pose then
            drive_time = campaign.sim_time_s - setup.sim.settle_time  # the record's times start after the settling
            same_time = poses[int(np.argmin(np.abs(times - start_time - drive_time)))]
        diff = float(np.max(np.abs(np.asarray(campaign.final_pose, dtype=float)[:3, 3] - same_time[:3, 3])))
    return TrialPoses(times[keep], poses[keep], np.asarray(spec.obj.outline, dtype=float), float(spec.obj.thickness),
                      trial, result.cause(), float(result.position_error_mm), diff)


def _thinned(times: NDArray) -> NDArray[np.int64]:
    """Indices of samples at least RECORD_PERIOD_S apart, keeping the first and the last."""
    keep, last = [], -np.inf
    for i, t in enumerate(times):
        if t - last >= RECORD_PERIOD_S - 1e-9:
            keep.append(i)
            last = t
    if keep[-1] != len(times) - 1:
        keep.append(len(times) - 1)
    return np.array(keep)


def write_trial_poses(directory: PathLike, poses: TrialPoses) -> Path:
    """Write directory/trial_poses.json atomically; returns its path."""
    doc = {"format": FORMAT, "schema_version": SCHEMA_VERSION,
           "units": {"time": "s (trajectory time)", "length": "m"},
           "trial": poses.trial, "outcome": poses.outcome,
           "position_error_mm": None if np.isnan(poses.position_error_mm) else poses.position_error_mm,
           "final_pose_difference_m": poses.final_pose_difference_m,
           "outline": np.round(poses.outline, 9).tolist(), "thickness": poses.thickness,
           "times_s": np.round(poses.times, 6).tolist(), "poses": np.round(poses.poses, 9).tolist()}
    path = Path(directory) / POSES_FILE
    write_text_atomic(path, json.dumps(doc) + "\n")
    return path


def read_trial_poses(path: PathLike) -> TrialPoses:
    """Read a trial_poses.json; InputError naming the field for malformed content."""
    source = str(path)
    doc = read_versioned_json(path, "trial_poses.json", FORMAT, SCHEMA_VERSION)
    try:
        times = np.asarray(doc["times_s"], dtype=float)
        poses = np.asarray(doc["poses"], dtype=float)
        outline = np.asarray(doc["outline"], dtype=float)
        thickness = float(doc["thickness"])
    except KeyError as e:
        raise InputError(str(e.args[0]), "missing", source) from None
    except (TypeError, ValueError) as e:
        raise InputError("poses", f"not numbers ({e})", source) from None
    if times.ndim != 1 or poses.shape != (len(times), 4, 4) or len(times) == 0 or np.any(np.diff(times) <= 0):
        raise InputError("poses", "needs one 4x4 pose per time, times increasing", source)
    if outline.ndim != 2 or outline.shape[1] != 2 or len(outline) < 3 or not thickness > 0:
        raise InputError("outline", "needs (N >= 3, 2) points and a positive thickness", source)
    err = doc.get("position_error_mm")
    return TrialPoses(times, poses, outline, thickness, int(doc.get("trial", 0)), str(doc.get("outcome", "")),
                      float("nan") if err is None else float(err), doc.get("final_pose_difference_m"))


def trial_start_time(trajectory: Any) -> float:
    """Trajectory time (s) at which a placement's drive starts: its first primitive (the
    approach and the return before it are not simulated, and a start press is the settling's)."""
    return next(float(trajectory.times[a]) for name, a, _ in trajectory.segments if name not in UNDRIVEN)
