"""Shared fixtures. OMPL's RNG is seeded once per pytest process, before any planning."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"
REFERENCE_SCENES = ("reference_asymmetric", "reference_upper_obstacle", "reference_equal_digits")


@pytest.fixture(scope="session")
def scenes():
    from ungrasp_ompl import Scene

    return {name: Scene.from_file(SCENES / f"{name}.yaml") for name in REFERENCE_SCENES}


def run_cli(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    """Run `python -m ungrasp_ompl ARGS` as a new process, as a user would."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.run([sys.executable, "-m", "ungrasp_ompl", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    """Leave without interpreter finalisation, where nanobind (OMPL's bindings) lists the
    objects still alive: noise after pytest's summary. pytest has finished by now."""
    status = getattr(config, "_ungrasp_exitstatus", None)
    if status is not None:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(int(status))


def pytest_sessionfinish(session, exitstatus):
    session.config._ungrasp_exitstatus = exitstatus
