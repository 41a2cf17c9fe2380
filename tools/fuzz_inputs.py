"""The long profile of tests/test_bad_input.py: many more mutated scenes and layouts, with a seed.

    python tools/fuzz_inputs.py [--examples N] [--seed S]

Every shipped scene and layout has one value replaced (nan, -1, an absurd number, a string,
null, a list, ...) and every command that reads it runs; so do the files read back (plan.json
through simulate --plan and cage --plan, trajectory.json and view_scene.json through view), a
value replaced or the file cut short. A failure prints the smallest mutation Hypothesis finds.
Prints how many runs ended with each exit code.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--examples", type=int, default=400, help="mutations per scene test (layouts get a quarter)")
    ap.add_argument("--seed", type=int, default=0, help="Hypothesis seed")
    args = ap.parse_args()
    env = dict(os.environ, UNGRASP_FUZZ_EXAMPLES=str(max(args.examples, 4)))
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(ROOT / "tests" / "test_bad_input.py"),
           "-k", "mutated or read_back", f"--hypothesis-seed={args.seed}", "--hypothesis-show-statistics"]
    return subprocess.call(cmd, cwd=ROOT, env=env)


if __name__ == "__main__":
    sys.exit(main())
