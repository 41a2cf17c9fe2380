"""Robot description files shipped with the package, and their loaders.

``ur5e.urdf`` (the UR5e arm, no gripper) is written by the repository's
``robots/make_ur5e_urdf.py`` from the published DH table; do not edit it by hand. The model built
from it (with the gripper) is ``ungrasp_ompl.robot.model.load_ur5e``.
"""

from __future__ import annotations

from pathlib import Path

from ..shipped import package_file

#: The file name of the UR5e URDF in this package.
UR5E_URDF_NAME = "ur5e.urdf"


def ur5e_urdf() -> Path:
    """Returns the filesystem path of the shipped UR5e URDF (loaded with importlib.resources).
    Raises FileNotFoundError when the installation lacks it."""
    return package_file(__name__, UR5E_URDF_NAME)


__all__: list[str] = []  # nothing public: robot.model loads the shipped URDF
