"""No silent surprises (issue 61): a plan for another scene is refused, what a long command finds is
kept and said where, long phases show progress, outputs go beside their inputs, a directory never
mixes two plans' files, default outputs are git-ignored, and --jobs means the same on every command."""

from __future__ import annotations

import csv
import json
import os
import re
import shlex
import shutil
import subprocess

import pytest

from conftest import ROOT, command_parsers, run_cli


def one_line_error(proc) -> str:
    """The one line of a bad input's error (exit 2, no traceback)."""
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    return lines[0]


def lattice_plan(tmp_path_factory, scene: str):
    """A directory holding what `plan SCENE --planner lattice --out DIR` wrote."""
    out = tmp_path_factory.mktemp(scene) / "plan"
    proc = run_cli("plan", scene, "--planner", "lattice", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.fixture(scope="module")
def puzzle_plan(tmp_path_factory):
    return lattice_plan(tmp_path_factory, "puzzle_piece")


@pytest.fixture(scope="module")
def pick_plan(tmp_path_factory):
    return lattice_plan(tmp_path_factory, "guitar_pick")


# --- a: a plan made for another scene ---

@pytest.mark.parametrize("command", ["simulate", "cage"])
def test_a_plan_made_for_another_scene_is_refused_naming_both(pick_plan, tmp_path, monkeypatch, command):
    """simulate and cage refuse a plan.json whose scene is another (the issue's: the card's plan run
    on the puzzle piece, which simulate reported a success): exit 2, one line naming both scenes,
    before any work, and nothing written."""
    monkeypatch.chdir(tmp_path)
    for plan in (pick_plan, pick_plan / "plan.json"):
        line = one_line_error(run_cli(command, "puzzle_piece", "--plan", str(plan), "--trials" if command == "simulate"
                                      else "--refine", "1", "--out", str(tmp_path / "out")))
        assert "puzzle_piece" in line and "guitar_pick" in line and "--plan" in line, line
    assert list(tmp_path.iterdir()) == []
    assert sorted(p.name for p in pick_plan.iterdir() if p.name != "simulation") == ["cspace.png", "plan.json"]


def test_regions_refuses_to_draw_another_scenes_plan(pick_plan, tmp_path):
    """regions --plan draws a plan on its own scene's map only: another scene's plan is refused
    (exit 2, one line naming both) and no picture is written."""
    line = one_line_error(run_cli("regions", "puzzle_piece", "--plan", str(pick_plan), "--out", str(tmp_path / "r.png")))
    assert "puzzle_piece" in line and "guitar_pick" in line, line
    assert not (tmp_path / "r.png").exists()


def test_a_force_runs_another_scenes_plan_with_a_warning(pick_plan, tmp_path):
    """--force examines it, with a warning naming both scenes; --force without --plan is refused."""
    proc = run_cli("cage", "puzzle_piece", "--plan", str(pick_plan), "--force", "--refine", "0.5", "--jobs", "1",
                   "--out", str(tmp_path / "cage"))
    assert proc.returncode == 0, proc.stderr
    assert json.loads((tmp_path / "cage" / "cage.json").read_text())["scene"] == "puzzle_piece"
    warned = [line for line in proc.stdout.splitlines() if "puzzle_piece" in line and "guitar_pick" in line]
    assert len(warned) == 1, proc.stdout
    assert "--force" in one_line_error(run_cli("simulate", "guitar_pick", "--force"))


# --- b: plan --certify keeps what it found ---

@pytest.mark.slow
def test_b_certify_without_out_keeps_the_plan_and_every_candidate(tmp_path, monkeypatch):
    """plan --certify without --out writes the kept plan and certify.csv to ./plan, and says so."""
    monkeypatch.chdir(tmp_path)
    proc = run_cli("plan", "guitar_pick", "--planner", "lattice", "--certify", "1", "--candidates", "1",
                   "--jobs", "1", "--seed", "1")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((tmp_path / "plan" / "plan.json").read_text())
    assert doc["scene"] == "guitar_pick" and doc["certification"]["kept"] == 0
    with open(tmp_path / "plan" / "certify.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 1 and rows[0]["kept"] == "1" and rows[0]["status"] == "simulated"
    assert int(rows[0]["successes"]) == doc["certification"]["successes"]
    assert str(os.path.join("plan", "certify.csv")) in proc.stdout


# --- c: progress of long phases, and a bound on the budget ---

def test_c_an_absurd_time_budget_is_refused_naming_the_flag():
    """--time 1e12 (a typo: 31,700 years) is refused before anything runs."""
    proc = run_cli("plan", "guitar_pick", "--time", "1e12", "--iterations", "1")
    assert one_line_error(proc).startswith("ungrasp-ompl: error: --time:")
    assert proc.stdout == ""


@pytest.mark.slow
def test_c_planning_with_a_budget_over_ten_seconds_shows_progress():
    """A planner's budget above 10 s shows its seconds on stderr (a line per tenth in a pipe)."""
    proc = run_cli("plan", "reference_asymmetric", "--time", "11", "--seed", "1", "--iterations", "40000")
    assert proc.returncode == 0, proc.stderr
    ticks = [line for line in proc.stderr.splitlines() if re.search(r"\b\d+/11 s\b", line)]
    assert ticks and "\r" not in proc.stderr, proc.stderr


# --- d and e: outputs beside their inputs; a directory never mixes two plans' files ---

@pytest.mark.slow
def test_d_simulate_writes_beside_the_plan(pick_plan, tmp_path, monkeypatch):
    """simulate --plan DIR writes DIR/simulation (not ./simulation) unless --out is given."""
    monkeypatch.chdir(tmp_path)
    proc = run_cli("simulate", "guitar_pick", "--plan", str(pick_plan), "--trials", "1", "--perturb", "none",
                   "--jobs", "1")
    assert proc.returncode == 0, proc.stderr
    summary = json.loads((pick_plan / "simulation" / "summary.json").read_text())
    assert summary["scene"] == "guitar_pick" and summary["trials"] == 1
    assert not (tmp_path / "simulation").exists()


@pytest.fixture(scope="module")
def export_over_another_plan(puzzle_plan, tmp_path_factory):
    """`plan guitar_pick --export DIR` into a copy of the puzzle piece's plan directory holding a
    file of the user's: (the process, DIR)."""
    out = tmp_path_factory.mktemp("export") / "dir"
    shutil.copytree(puzzle_plan, out)
    (out / "notes.txt").write_text("the user's\n")
    return run_cli("plan", "guitar_pick", "--seed", "1", "--export", str(out)), out


def test_e_export_replaces_an_earlier_plans_files(export_over_another_plan, tmp_path):
    """--export into a directory holding another scene's plan.json and cspace.png leaves only this
    plan's files (and the user's own): no picture of the other plan beside this trajectory. With
    --out DIR --export DIR, the picture --out draws stays beside the trajectory (one clearing)."""
    proc, out = export_over_another_plan
    assert proc.returncode == 0, proc.stderr
    assert json.loads((out / "plan.json").read_text())["scene"] == "guitar_pick"
    assert not (out / "cspace.png").exists()
    assert (out / "notes.txt").read_text() == "the user's\n"
    from ungrasp_ompl.workflows.plan_files import PLAN_FILES

    assert (out / "trajectory.csv").is_file() and {p.name for p in out.iterdir()} <= set(PLAN_FILES) | {"notes.txt"}
    proc = run_cli("plan", "guitar_pick", "--planner", "lattice", "--out", str(tmp_path), "--export", str(tmp_path))
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "cspace.png").is_file() and (tmp_path / "trajectory.csv").is_file()


def test_c_export_shows_its_steps(export_over_another_plan):
    """plan --export shows its steps (executing on the arm, writing the trajectory) on stderr."""
    proc, _ = export_over_another_plan
    assert proc.returncode == 0, proc.stderr
    assert len(re.findall(r"\b\d/2 steps\b", proc.stderr)) == 2 and "\r" not in proc.stderr, proc.stderr


# --- f: default outputs are git-ignored ---

def test_f_default_outputs_are_git_ignored(tmp_path):
    """Every command's default output directory, and every output the README's examples name, is
    ignored by git in a clone."""
    git = shutil.which("git")
    if git is None or subprocess.run([git, "-C", str(ROOT), "rev-parse"], capture_output=True).returncode:
        pytest.skip("not a git checkout")
    outputs = {"plan/plan.json", "simulation/summary.json"}  # plan --certify's and simulate's defaults
    for name, parser in command_parsers().items():
        out = next((a for a in parser._actions if "--out" in a.option_strings), None)
        if out is not None and out.default:
            outputs.add(f"{out.default}/x")
    section = (ROOT / "README.md").read_text().split("## The commands, one example each", 1)[1]
    for line in section.split("```bash\n", 1)[1].split("```", 1)[0].splitlines():
        words = shlex.split(line, comments=True)
        for flag, value in zip(words, words[1:]):
            if flag in ("--out", "--export"):
                outputs.add(value if value.endswith(".png") else f"{value}/x")
    assert {"design/x", "regions.png", "tiling/x", "map/x", "benchmark/x", "sweep/x"} <= outputs
    proc = subprocess.run([git, "-C", str(ROOT), "check-ignore", "--no-index", *sorted(outputs)],
                          capture_output=True, text=True)
    assert set(proc.stdout.split()) == outputs, sorted(outputs - set(proc.stdout.split()))


# --- item 7: one --jobs, one default ---

def test_jobs_on_every_parallel_command_defaults_to_all_cores(monkeypatch):
    """Every command that runs work in parallel takes --jobs, defaulting (None) to all cores, and
    the library's options take None as all cores too."""
    from ungrasp_ompl import Scene
    from ungrasp_ompl.benchmark import BenchmarkOptions, SweepOptions
    from ungrasp_ompl.benchmark.design import DesignOptions
    from ungrasp_ompl.benchmark.map import MapOptions
    from ungrasp_ompl.parallel import RunOptions
    from ungrasp_ompl.shipped import resolve

    parsers = command_parsers()
    jobs = {name: next((a for a in p._actions if "--jobs" in a.option_strings), None) for name, p in parsers.items()}
    assert {"plan", "simulate", "bench", "sweep", "map", "design", "cage"} <= {n for n, a in jobs.items() if a}
    assert all(a.default is None for a in jobs.values() if a is not None)
    monkeypatch.setattr(os, "cpu_count", lambda: 7)
    assert BenchmarkOptions().validated().run.jobs == 7
    assert SweepOptions(alphas=(0.4,)).validated().run.jobs == 7
    assert MapOptions(alphas=(0.4,)).validated().run.jobs == 7
    assert DesignOptions().validated(Scene.from_file(resolve("guitar_pick", "scene"))).run.jobs == 7
    assert BenchmarkOptions(run=RunOptions(jobs=3)).validated().run.jobs == 3
    assert RunOptions().workers == 7


@pytest.mark.slow
def test_map_simulate_prints_its_successes(tmp_path):
    """map --simulate N prints how many simulated trials placed the object, as map.csv counts them."""
    proc = run_cli("map", "guitar_pick", "--alpha", "0.47:0.47:0.1", "--planner", "lattice", "--simulate", "1",
                   "--jobs", "1", "--out", str(tmp_path))
    assert proc.returncode == 0, proc.stderr
    with open(tmp_path / "map.csv", newline="") as f:
        (row,) = list(csv.DictReader(f))
    assert row["sim_trials"] == "1" and row["sim_successes"] in ("0", "1")
    assert re.search(rf"\b{row['sim_successes']}/1\b", proc.stdout), proc.stdout
