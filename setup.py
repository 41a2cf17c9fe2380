"""Package layout that pyproject.toml cannot express; the project's metadata is in pyproject.toml.

Besides the ``ungrasp_ompl`` packages, the repository's top-level ``scenes/`` directory is shipped
as the package ``ungrasp_ompl.shipped_scenes`` (its ``*.yaml`` as package data), so commands take
a shipped scene by name (``ungrasp-ompl plan guitar_pick``) from a wheel and from an editable
install alike; ``ungrasp_ompl.shipped`` finds them. ``scenes/__init__.py`` makes that directory a
regular package, which editable installs need to map it. The UR5e URDF ships as package data of
``ungrasp_ompl.robots``.
"""

from setuptools import find_packages, setup

setup(
    packages=find_packages(include=["ungrasp_ompl", "ungrasp_ompl.*"]) + ["ungrasp_ompl.shipped_scenes"],
    package_dir={"ungrasp_ompl.shipped_scenes": "scenes"},
    package_data={"ungrasp_ompl.robots": ["*.urdf"], "ungrasp_ompl.shipped_scenes": ["*.yaml"]},
)
