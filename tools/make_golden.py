"""Regenerate the golden plans of the shipped reference scenes (tests/golden/*.json).

Run after a deliberate change of planning behaviour, then review the diff:

    python tools/make_golden.py

Each golden plan is `ungrasp-ompl plan SCENE --seed 1 --time 1` run in a fresh
process (the CLI the tests run too), timing fields removed.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENES = ("reference_asymmetric", "reference_upper_obstacle", "reference_equal_digits")
GOLDEN_ARGS = ("--seed", "1", "--time", "1")
TIMING_FIELDS = ("time_to_first_solution_s", "planning_time_s", "setup_time_s")


def golden_plan(scene: str) -> dict:
    """Plan a shipped scene as the golden tests do; the plan without its timing fields."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([sys.executable, "-m", "ungrasp_ompl", "plan", str(ROOT / "scenes" / f"{scene}.yaml"),
                        *GOLDEN_ARGS, "--out", out], env=env, capture_output=True, text=True, timeout=600)
        data = json.loads((Path(out) / "plan.json").read_text())
    for key in TIMING_FIELDS:
        data.pop(key, None)
    return data


def main() -> None:
    for scene in SCENES:
        path = ROOT / "tests" / "golden" / f"{scene}.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        data = golden_plan(scene)
        path.write_text(json.dumps(data, indent=2) + "\n")
        print(f"{path.relative_to(ROOT)}: solved={data['solved']} cost={data.get('cost')}")


if __name__ == "__main__":
    main()
