"""The SQLite benchmark database that Planner Arena opens, made from the logs by the
``ompl_benchmark_statistics.py`` script shipped with the ompl package."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from ..errors import ToolError
from ..io import write_atomic


def statistics_script() -> Path:
    """ompl_benchmark_statistics.py of the installed ompl package; ToolError (exit 1) without it."""
    spec = importlib.util.find_spec("ompl")
    for location in (spec.submodule_search_locations or []) if spec else []:
        path = Path(location) / "ompl_benchmark_statistics.py"
        if path.is_file():
            return path
    raise ToolError("ompl_benchmark_statistics.py is not in the installed ompl package (reinstall ompl)")


def logs_to_database(logs: Sequence[Path], db: Path) -> None:
    """Convert benchmark logs into an SQLite database with OMPL's script (atomically);
    ToolError (exit 1, one line) when the script fails: OMPL's script, not the input."""

    def convert(tmp: str) -> None:
        cmd = [sys.executable, str(statistics_script()), *map(str, logs), "-d", tmp]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
            raise ToolError(f"ompl_benchmark_statistics.py failed on {', '.join(map(str, logs))}: "
                            + " | ".join(tail))

    write_atomic(db, convert)
