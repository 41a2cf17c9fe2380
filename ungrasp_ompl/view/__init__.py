"""The 3D view of an exported trajectory: the UR5e, its gripper, the objects, the table.

``make_view(DIR)`` reads what ``plan --export DIR``, ``tile --out DIR`` or ``simulate --out DIR``
wrote (trajectory.json, view_scene.json, and trial_poses.json after a simulation) and writes one
self-contained HTML page (meshcat's viewer, animated) and, on request, a PNG strip of key frames.

Modules: ``record`` (view_scene.json: what the view needs besides the trajectory), ``geometry``
(triangle meshes), ``scene`` (bodies and their poses over time), ``html`` (the meshcat page),
``frames`` (the key-frame strip, matplotlib). A simulated trial's object poses are what
``sim.poses`` wrote (trial_poses.json): the view reads them and never runs the simulator.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..robot.export import read_json
from ..robot.trajectory import JOINT_NAMES, PINCER_JOINT_NAMES
from ..sim.poses import POSES_FILE, read_trial_poses
from .html import write_page
from .record import RECORD_FILE, default_record, read_view_record
from .scene import build_scene

TRAJECTORY_FILE = "trajectory.json"
VIEW_FILE = "view.html"
FRAMES_FILE = "view_frames.png"
#: The longest trajectory the view animates (s): an hour, some 100,000 frames.
MAX_DURATION_S = 3600.0

PathLike = str | os.PathLike[str]


@dataclass
class ViewFiles:
    """What make_view wrote: the page, the strip (or None) and its key times (s); what it read."""

    page: Path
    frames: Path | None
    key_times: list[float]
    sources: list[Path]
    notes: list[str]


def load_scene(directory: PathLike):
    """The ViewScene (view.scene) of what DIR holds; InputError naming DIR when it holds no
    trajectory.json, or naming the field of a malformed file."""
    d = Path(directory)
    if not d.is_dir():
        raise InputError("DIR", f"{d} is not a directory (give what plan --export DIR, tile --out DIR or "
                         "simulate --out DIR wrote)")
    traj_path = d / TRAJECTORY_FILE
    if not traj_path.is_file():
        raise InputError("DIR", f"{d} holds no {TRAJECTORY_FILE} (write one with plan --export DIR, tile --out DIR "
                         "or simulate --out DIR)")
    traj = _named(read_json(traj_path), str(traj_path))
    sources = [traj_path]
    record_path = d / RECORD_FILE
    if record_path.is_file():
        record = read_view_record(record_path)
        sources.append(record_path)
    else:
        record = default_record(pincer=_is_pincer(traj))
    traj = _viewable(traj, str(traj_path), record)
    trial = None
    if (d / POSES_FILE).is_file() and record.kind == "simulation":
        trial = read_trial_poses(d / POSES_FILE)
        sources.append(d / POSES_FILE)
    scene = build_scene(traj, record, trial)
    if not record_path.is_file():
        scene.notes.append(f"no {RECORD_FILE} beside the trajectory: the robot only, its base at the origin")
    return scene, sources


def _is_pincer(traj) -> bool:
    """Whether traj's gripper is a pincer: its last joint is the pincer's joint angle (rad)."""
    return tuple(traj.joint_names) == PINCER_JOINT_NAMES


def _named(traj, source: str):
    """traj once its joints are the UR5e's six and a gripper's, in that order: the parallel jaws'
    opening (m) or a pincer's joint angle (rad); InputError naming joint_names otherwise."""
    if tuple(traj.joint_names) not in (JOINT_NAMES, PINCER_JOINT_NAMES):
        raise InputError("joint_names", f"must be {', '.join(JOINT_NAMES)} (the UR5e and its gripper), or the same "
                         f"ending in {PINCER_JOINT_NAMES[-1]} (a pincer), got {', '.join(traj.joint_names)}", source)
    return traj


def _viewable(traj, source: str, record=None):
    """traj (robot.trajectory.JointTrajectory) once it holds what the view animates: the UR5e's six
    joints and the gripper opening (m; a pincer's joint angle, rad, when record's gripper is a
    pincer), in that order, at angles the arm can take and openings the gripper can, for at most
    MAX_DURATION_S; InputError naming the field otherwise."""
    _named(traj, source)
    pincer = None if record is None else record.pincer
    wanted = JOINT_NAMES if pincer is None else PINCER_JOINT_NAMES
    if tuple(traj.joint_names) != wanted:
        raise InputError("joint_names", f"must end in {wanted[-1]}: {RECORD_FILE} describes "
                         f"{'a pincer' if pincer is not None else 'parallel jaws'}, got {traj.joint_names[-1]}",
                         source)
    arm, opening = traj.positions[:, :-1], traj.positions[:, -1]
    if np.abs(arm).max() > 2 * math.pi + 1e-9:
        raise InputError("points.positions", f"the arm's joint angles must lie within [-2 pi, 2 pi] rad, got "
                         f"{float(arm.flat[np.abs(arm).argmax()]):.4g}", source)
    if pincer is None and not 0.0 <= opening.min() <= opening.max() <= 1.0:
        raise InputError("points.positions", f"the gripper opening (the last joint) must lie within [0, 1] m, got "
                         f"{float(opening.min() if opening.min() < 0 else opening.max()):.4g}", source)
    if pincer is not None and not -1e-9 <= opening.min() <= opening.max() <= pincer.max_angle + 1e-9:
        raise InputError("points.positions", f"the pincer's joint angle (the last joint) must lie within [0, "
                         f"{pincer.max_angle:.4g}] rad, got "
                         f"{float(opening.min() if opening.min() < 0 else opening.max()):.4g}", source)
    duration = float(traj.times[-1] - traj.times[0])
    if duration > MAX_DURATION_S:
        raise InputError("points.time_s", f"span {duration:.4g} s; the view animates at most {MAX_DURATION_S:g} s",
                         source)
    n = len(traj.times)
    for name, a, b in traj.segments:
        if not 0 <= a <= b < n:
            raise InputError("segments", f"{name}: start {a} and end {b} must be sample indices in order, 0..{n - 1}",
                             source)
    return traj


def make_view(directory: PathLike, out: PathLike | None = None, frames: int | None = None) -> ViewFiles:
    """Write the view page of DIR to out (default DIR/view.html) and, with frames = K, the strip of
    K key frames beside it (view_frames.png)."""
    from .frames import MAX_FRAMES, draw_frames  # matplotlib: loaded when key frames are drawn

    if frames is not None and not 1 <= frames <= MAX_FRAMES:
        raise InputError("frames", f"must be a count of key frames in 1..{MAX_FRAMES}, got {frames}")
    page = Path(out) if out is not None else Path(directory) / VIEW_FILE
    if page.suffix.lower() not in (".html", ".htm"):
        raise InputError("out", f"must name an .html file, got {page}")
    if page.is_dir():
        raise InputError("out", f"{page} is a directory")
    scene, sources = load_scene(directory)
    write_page(scene, page)
    strip, times = None, []
    if frames is not None:
        strip = page.with_name(page.stem + "_frames.png")  # view.html -> view_frames.png
        times = [float(t) for t in draw_frames(scene, frames, strip)]
    return ViewFiles(page, strip, times, sources, scene.notes)


__all__ = ["ViewFiles", "make_view"]
