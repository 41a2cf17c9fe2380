"""What a result records of where it was produced (ungrasp_ompl.provenance): the versions the
packages report of themselves, and no version for a distribution that is not installed."""

from __future__ import annotations

import mujoco
import numpy as np

from ungrasp_ompl import __version__
from ungrasp_ompl.provenance import PACKAGES, _version, describe, environment


def test_the_environment_names_the_versions_the_packages_report():
    env = environment()
    assert set(env["packages"]) == set(PACKAGES)
    assert env["packages"]["mujoco"] == mujoco.__version__
    assert env["packages"]["numpy"] == np.__version__
    assert env["packages"]["ungrasp-ompl"] == __version__
    assert env["cores"] >= 1 and env["processor"] and env["machine"]
    assert f"mujoco {mujoco.__version__}" in describe(env)


def test_a_distribution_not_installed_has_no_version():
    assert _version("no-such-distribution-ungrasp") is None
    env = {**environment(), "packages": {**environment()["packages"], "drake": None}}
    assert "drake" not in describe(env)
