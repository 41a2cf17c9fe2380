"""Benchmark of the core of ungrasp_ompl; prints figures, asserts nothing.

It measures:

1. force-closure checks per second of the vectorised test
   (``ungrasp_ompl.mechanics.force_closure``), for the relaxed and the strict
   sliding model, over every contact mode (a_sign, b_sign in {-1, 0, 1});
2. force-closure checks per second of a linear-programming test on the same
   wrenches (rank 3 and a strictly positive combination summing to zero, via
   ``scipy.optimize.linprog``), and how many states the two tests disagree on;
3. the speed-up of the vectorised test over the LP (the project aims at >= 300x);
4. the cost of one lattice motion check (``SecurityAtlas.motion_secure``) and
   the planner setup time;
5. the planner itself: one ``python -m ungrasp_ompl plan`` subprocess per seed
   (OMPL's RNG can only be seeded once per process), with success rate, time to
   first solution, setup time, final cost and mode switches;
6. the exact lattice optimum (Dijkstra) at 1 deg / 0.01 and at the scene's own
   resolution, and the planner's median cost as a gap to each.

Run from the repository root:

    python tools/bench_core.py [--seeds 20] [--states 20000] [--lp-states 2000]
                               [--scene scenes/reference_asymmetric.yaml] [--time 1.0]
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parent.parent
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from scipy.optimize import linprog  # noqa: E402

from ungrasp_ompl.mechanics import Friction, contact_wrenches, force_closure  # noqa: E402
from ungrasp_ompl.scene import Scene  # noqa: E402

MODELS = ("relaxed", "strict")
SIGN_PAIRS = tuple(itertools.product((-1, 0, 1), repeat=2))
REPEATS = 3


# -- helpers -------------------------------------------------------------------------
def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=20, help="planner runs, seeds 1..N (default 20)")
    p.add_argument("--states", type=int, default=20000, help="states per vectorised call (default 20000)")
    p.add_argument("--lp-states", type=int, default=2000, help="states checked by LP per model (default 2000)")
    p.add_argument("--scene", default=str(REPO_ROOT / "scenes" / "reference_asymmetric.yaml"),
                   help="scene file (default scenes/reference_asymmetric.yaml)")
    p.add_argument("--time", type=float, default=1.0, help="planning time per seed in seconds (default 1)")
    return p.parse_args(argv)


def best_time(fn, repeats: int = REPEATS) -> float:
    """Smallest wall time of fn() over a few repeats."""
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def random_states(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n random (theta, d, psi): theta, psi in [0, pi/2], d in [0, 1]."""
    return rng.uniform(0, math.pi / 2, n), rng.uniform(0, 1, n), rng.uniform(0, math.pi / 2, n)


def percentile(values: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(values, dtype=float), q))


def header(title: str) -> None:
    print(f"\n== {title} " + "=" * max(0, 70 - len(title)))


# -- 1-3: force closure ----------------------------------------------------------------
def vectorised_rate(states, mu, model: str) -> float:
    """Checks per second of force_closure over all 9 contact modes (best of REPEATS)."""
    theta, d, psi = states

    def run():
        for a, b in SIGN_PAIRS:
            force_closure(theta, d, psi, a, b, Friction(mu, model))

    return len(SIGN_PAIRS) * len(theta) / best_time(run)


def lp_force_closure(w: np.ndarray) -> bool:
    """Force closure of the wrench columns w (3 x k) by rank and an LP."""
    k = w.shape[1]
    if k == 0 or np.linalg.matrix_rank(w) != 3:
        return False
    res = linprog(np.zeros(k), A_eq=w, b_eq=np.zeros(3), bounds=[(1, None)] * k, method="highs")
    return res.status == 0


def lp_comparison(states, mu, model: str) -> tuple[float, int, int]:
    """(LP checks per second, states where LP and vectorised disagree, LP force-closure count).

    State i is checked in contact mode SIGN_PAIRS[i % 9]; the timing covers the
    per-state LP decision only (wrenches are computed up front, in one call per mode)."""
    theta, d, psi = states
    n = len(theta)
    mode = np.arange(n) % len(SIGN_PAIRS)
    jobs = []  # (state indices, W, mask, vectorised result) per mode
    for m, (a, b) in enumerate(SIGN_PAIRS):
        idx = np.flatnonzero(mode == m)
        if idx.size == 0:
            continue
        W, mask = contact_wrenches(theta[idx], d[idx], psi[idx], a, b, Friction(mu, model))
        fc = force_closure(theta[idx], d[idx], psi[idx], a, b, Friction(mu, model))
        jobs.append((W, mask, fc))
    lp_results = []
    t0 = time.perf_counter()
    for W, mask, _ in jobs:
        lp_results.append(np.array([lp_force_closure(W[i][mask[i]].T) for i in range(len(W))], dtype=bool))
    elapsed = time.perf_counter() - t0
    disagree = sum(int(np.count_nonzero(lp != fc)) for lp, (_, _, fc) in zip(lp_results, jobs))
    closed = sum(int(lp.sum()) for lp in lp_results)
    return n / elapsed, disagree, closed


def bench_force_closure(scene: Scene, n_states: int, n_lp: int, rng: np.random.Generator) -> None:
    header("force closure")
    states = random_states(n_states, rng)
    lp_states = tuple(x[:n_lp] for x in random_states(max(n_lp, 1), rng))
    print(f"mu (G, A, B) = ({', '.join(f'{m:.4f}' for m in scene.mu)}); "
          f"vectorised: {n_states} states x 9 contact modes, best of {REPEATS}; LP: {n_lp} states, modes cycled")
    for model in MODELS:
        vec = vectorised_rate(states, scene.mu, model)
        lp, disagree, closed = lp_comparison(lp_states, scene.mu, model)
        print(f"  [{model:7s}] vectorised {vec:12,.0f} checks/s | LP {lp:8,.0f} checks/s | "
              f"ratio vectorised/LP {vec / lp:7.0f}x (aim >= 300x) | "
              f"disagreements {disagree}/{n_lp} (LP force closure in {closed})")


# -- motion check ---------------------------------------------------------------------
def random_index_pairs(shape: tuple[int, ...], n: int, rng: np.random.Generator):
    """n pairs of lattice indices (tuples of ints): the first half near (offsets in [-6, 6]), the rest anywhere."""
    hi = np.asarray(shape) - 1
    a = rng.integers(0, np.asarray(shape), size=(n, 3))
    near = np.clip(a + rng.integers(-6, 7, size=(n, 3)), 0, hi)
    far = rng.integers(0, np.asarray(shape), size=(n, 3))
    b = np.where((np.arange(n) < n // 2)[:, None], near, far)
    to_tuples = lambda m: [tuple(int(x) for x in row) for row in m]  # noqa: E731
    return list(zip(to_tuples(a), to_tuples(b)))


def time_motion_checks(atlas, pairs) -> tuple[float, int]:
    """(microseconds per motion_secure check, number found secure)."""
    t0 = time.perf_counter()
    secure = sum(atlas.motion_secure(a, b) for a, b in pairs)
    return (time.perf_counter() - t0) / len(pairs) * 1e6, secure


def bench_motion_check(scene: Scene, rng: np.random.Generator, n_pairs: int = 20000) -> None:
    from ungrasp_ompl.planning.setup import PlannerOptions, UngraspSetup

    header("motion check (SecurityAtlas.motion_secure)")
    s = UngraspSetup(scene, PlannerOptions())
    print(f"setup time (UngraspSetup, in process): {s.setup_time:.3f} s; lattice shape {s.atlas.shape}")
    pairs = random_index_pairs(s.atlas.shape, n_pairs, rng)
    half = n_pairs // 2
    us_all, ok_all = time_motion_checks(s.atlas, pairs)
    us_near, ok_near = time_motion_checks(s.atlas, pairs[:half])
    us_far, ok_far = time_motion_checks(s.atlas, pairs[half:])
    print(f"  all  {n_pairs:6d} pairs: {us_all:8.2f} us/check ({ok_all} secure)")
    print(f"  near {half:6d} pairs: {us_near:8.2f} us/check ({ok_near} secure)")
    print(f"  far  {n_pairs - half:6d} pairs: {us_far:8.2f} us/check ({ok_far} secure)")


# -- planner ------------------------------------------------------------------------------
def run_plan(scene_path: str, seed: int, plan_time: float) -> dict:
    """One CLI plan in a fresh process; its plan.json, or a dict with 'error'."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO_ROOT), env.get("PYTHONPATH")) if p)
    with tempfile.TemporaryDirectory(prefix="bench_core_") as tmp:
        cmd = [sys.executable, "-m", "ungrasp_ompl", "plan", scene_path, "--seed", str(seed),
               "--time", str(plan_time), "--out", tmp]
        t0 = time.perf_counter()
        try:
            proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=plan_time + 300)
        except subprocess.TimeoutExpired:
            return {"error": "timeout"}
        wall = time.perf_counter() - t0
        path = Path(tmp) / "plan.json"
        if not path.exists():
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or [""]
            return {"error": f"exit {proc.returncode}: {tail[0]}"}
        data = json.loads(path.read_text())
    data["wall_s"] = wall
    return data


def fmt(x, spec: str) -> str:
    return "-" if x is None else format(x, spec)


def bench_planner(scene_path: str, seeds: int, plan_time: float) -> float | None:
    """Run the planner per seed, print per-seed lines and a summary; return the median final cost."""
    header(f"planner (CLI subprocess per seed, --time {plan_time}, sequential)")
    runs = []
    for seed in range(1, seeds + 1):
        r = run_plan(scene_path, seed, plan_time)
        runs.append(r)
        if "error" in r:
            print(f"  seed {seed:3d}: ERROR {r['error']}")
            continue
        print(f"  seed {seed:3d}: solved={str(r['solved']):5s} cost={fmt(r['cost'], '8.2f')} "
              f"first={fmt(r['time_to_first_solution_s'], '7.3f')} s plan={r['planning_time_s']:6.3f} s "
              f"setup={r['setup_time_s']:6.3f} s switches={fmt(r['mode_switches'], '2')} "
              f"iterations={r['iterations']} wall={r['wall_s']:5.2f} s")
    solved = [r for r in runs if r.get("solved")]
    print(f"success rate: {len(solved)}/{seeds} ({100 * len(solved) / max(seeds, 1):.0f}%)")
    if not solved:
        return None
    first = [r["time_to_first_solution_s"] for r in solved if r["time_to_first_solution_s"] is not None]
    costs = [r["cost"] for r in solved]
    setups = [r["setup_time_s"] for r in runs if "setup_time_s" in r]
    switches = [r["mode_switches"] for r in solved if r["mode_switches"] is not None]
    if first:
        print(f"time to first solution: median {statistics.median(first):.4f} s, p90 {percentile(first, 90):.4f} s")
    print(f"setup time: median {statistics.median(setups):.3f} s")
    print(f"final cost: median {statistics.median(costs):.2f}, max {max(costs):.2f}")
    if switches:
        print(f"mode switches: median {statistics.median(switches):g}")
    return float(statistics.median(costs))


# -- lattice optimum ---------------------------------------------------------------------
def lattice_optimum(scene: Scene, resolution) -> tuple[float | None, tuple[int, ...], float]:
    """(optimal cost or None, lattice shape, seconds) of the Dijkstra search at a resolution."""
    from ungrasp_ompl.planning.atlas import SecurityAtlas, planning_box
    from ungrasp_ompl.planning.lattice import lattice_search

    t0 = time.perf_counter()
    atlas = SecurityAtlas(scene, planning_box(scene), resolution=resolution)
    r = lattice_search(atlas, scene.goal.box())
    return r.cost, atlas.shape, time.perf_counter() - t0


def bench_lattice(scene: Scene, planner_median: float | None) -> None:
    header("exact lattice optimum (yardstick)")
    coarse = (math.radians(1), 0.01, math.radians(1))
    own = tuple(scene.options.resolution)
    for label, res in (("1 deg / 0.01 / 1 deg", coarse),
                       (f"scene's own ({math.degrees(own[0]):g} deg / {own[1]:g} / {math.degrees(own[2]):g} deg)", own)):
        cost, shape, secs = lattice_optimum(scene, res)
        gap = ("-" if cost is None or planner_median is None
               else f"{100 * (planner_median - cost) / cost:+.2f}%")
        print(f"  {label}: optimum {fmt(cost, '.2f')} (lattice {shape}, {secs:.2f} s); "
              f"planner median cost gap {gap}")


# -- main ---------------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    scene_path = str(Path(args.scene).resolve())
    scene = Scene.from_file(scene_path)
    rng = np.random.default_rng(12345)
    print(f"scene {scene.name} ({scene_path}); python {sys.version.split()[0]}, numpy {np.__version__}, "
          f"{os.cpu_count()} CPUs")
    bench_force_closure(scene, args.states, args.lp_states, rng)
    bench_motion_check(scene, rng)
    median_cost = bench_planner(scene_path, args.seeds, args.time)
    bench_lattice(scene, median_cost)
    sys.stdout.flush()
    os._exit(0)


if __name__ == "__main__":
    main()
