"""A plan's files in a directory: a plan read back for the scene it was made for, and the files an
earlier plan left in a directory cleared before another plan's are written there.

A directory the commands write a plan into (plan --out and --export, simulate --out, tile --out)
must never hold two plans' files side by side: a picture of one plan beside the trajectory of
another, or an earlier simulation's trial beside a new export (view shows them together).
"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import InputError
from ..planning.result import Plan, read_plan
from ..scene import Scene

#: The files the commands write for one plan (or one tiling) into a directory: plan.json and its
#: pictures, certify.csv, the exported trajectory and the touch-off program (robot.export), the
#: view's record and page, a simulation's files (simulate) and a tiling's (tile).
PLAN_FILES = ("plan.json", "cspace.png", "certify.csv",
              "trajectory.csv", "trajectory.json", "trajectory_ros2_arm.yaml", "trajectory_ros2_gripper.yaml",
              "trajectory.urscript", "touch_off.urscript", "view_scene.json", "view.html", "view_frames.png",
              "trials.csv", "summary.json", "trials.png", "model.xml", "trial_poses.json",
              "tiling.json", "layout.png")
#: Per-piece pictures of a tiling (tile: cspace_K_NAME.png).
PLAN_FILE_PATTERNS = ("cspace_*.png",)


def read_plan_for(scene: Scene, path: str | os.PathLike[str], force: bool = False) -> Plan:
    """The plan at path (a plan.json, or a directory holding one), made for the scene: plan.json
    records the name of the scene it was planned for. InputError naming `plan` when that is
    another scene's name, unless force (the caller then warns: plan_made_for)."""
    plan = read_plan(str(path))
    if not force and plan_made_for(scene, plan) is not None:
        raise InputError("plan", f"{path} was made for scene {plan.scene!r}, not {scene.name!r} "
                         "(--force runs it anyway)")
    return plan


def plan_made_for(scene: Scene, plan: Plan) -> str | None:
    """The name of the other scene the plan was made for; None when it was made for this scene."""
    return None if plan.scene == scene.name else str(plan.scene)


def clear_plan_files(directory: str | os.PathLike[str]) -> list[Path]:
    """Remove the files of PLAN_FILES (and PLAN_FILE_PATTERNS) that directory holds, before another
    plan's are written there; other files (and subdirectories) stay. Returns the paths removed
    (none when the directory does not exist)."""
    directory = Path(directory)
    if not directory.is_dir():
        return []
    found = [directory / name for name in PLAN_FILES]
    found += sorted(p for pattern in PLAN_FILE_PATTERNS for p in directory.glob(pattern))
    removed = []
    for path in found:
        if path.is_file() or path.is_symlink():
            path.unlink()
            removed.append(path)
    return removed
