"""What a result was produced with: the versions of the packages a plan or a simulation depends
on, and the processor it ran on, for summary.json and the results files.

A seed reproduces a plan and a trial exactly where these agree. Simulated trials are chaotic: a
trial in which the object grazes a wall, a piece or the edge of its friction cone can end otherwise
under another release of the engine, or on another processor, whose floating-point rounding
differs, so a result's record says where it was produced.
"""

from __future__ import annotations

import os
import platform
import sys
from functools import cache
from importlib import metadata

#: The distributions whose versions decide a result: this package, the planner's, the numerics',
#: the robot pipeline's and the two simulators'.
PACKAGES = ("ungrasp-ompl", "ompl", "numpy", "scipy", "pin", "python-fcl", "toppra", "ruckig", "mujoco", "drake")


def _version(name: str) -> str | None:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return None


def _processor() -> str:
    """The processor's model name (Linux: /proc/cpuinfo's first "model name"), else what the
    platform module says, else "unknown"."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


@cache
def environment() -> dict:
    """Where this process produces its results: {"python": its version, "packages": {name: version,
    None where not installed} over PACKAGES, "machine": the architecture (x86_64, arm64),
    "processor": the processor's model name, "cores": how many this process may use}. Read once
    per process, from the installed distributions' metadata (nothing is imported)."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {"python": ".".join(str(v) for v in sys.version_info[:3]),
            "packages": {name: _version(name) for name in PACKAGES},
            "machine": platform.machine(), "processor": _processor(), "cores": cores}


def describe(env: dict) -> str:
    """One line naming an environment() record: the engines' and the planner's versions, the
    processor and its cores (a package not installed is left out)."""
    packages = env.get("packages", {})
    named = ", ".join(f"{name} {packages[name]}" for name in ("mujoco", "drake", "ompl", "numpy") if packages.get(name))
    return f"{named}; Python {env.get('python')} on {env.get('processor')} ({env.get('cores')} cores)"
