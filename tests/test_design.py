"""``design``: a grid of digits planned exactly, the most tolerant chosen, its scene file written."""

from __future__ import annotations

import csv

import pytest

from conftest import assert_picture, run_cli
from figure_marks import unexplained_marks
from ungrasp_ompl.benchmark.design import DesignOptions, design_figure, run_design
from ungrasp_ompl.cli.exits import EXIT_BAD_INPUT
from ungrasp_ompl.parallel import RunOptions
from ungrasp_ompl.planning.plan_tolerance import tolerance
from ungrasp_ompl.planning.setup import lattice_plan
from ungrasp_ompl.scene import Scene
from ungrasp_ompl.shipped import resolve
from test_cli import assert_one_line_error

GRID = DesignOptions(alphas=(0.42, 0.47), tip_radii=(0.0005, 0.001), run=RunOptions(jobs=2))


@pytest.fixture(scope="module")
def designed(tmp_path_factory):
    out = tmp_path_factory.mktemp("design")
    result = run_design("guitar_pick", GRID)
    return result, result.write(out)


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.slow
def test_the_chosen_design_is_the_most_tolerant_of_the_grid(designed):
    result, files = designed
    rows = _rows(files["csv"])
    assert len(rows) == 4 and [(float(r["alpha"]), float(r["tip_radius_mm"])) for r in rows] == \
        [(a, r * 1000) for r in GRID.tip_radii for a in GRID.alphas]
    planned = [r for r in rows if r["outcome"] == "solved"]
    assert planned, rows
    best = max(planned, key=lambda r: (float(r["tolerance"]), -float(r["cost"])))
    assert [r["chosen"] for r in rows].count("1") == 1 and best["chosen"] == "1"


def test_a_designs_tolerance_is_its_scenes_own(designed):
    """Each row is the design's scene planned exactly and its tolerance as
    planning.plan_tolerance.tolerance gives it."""
    result, files = designed
    row = next(r for r in _rows(files["csv"]) if r["outcome"] == "solved")
    scene = Scene.from_file("guitar_pick").with_free_goal().with_digits(
        alpha=float(row["alpha"]), finger_tip_radius=float(row["tip_radius_mm"]) / 1000)
    plan = lattice_plan(scene, 1)
    assert plan.cost == pytest.approx(float(row["cost"]), abs=1e-9)
    assert tolerance(scene, plan).scale == pytest.approx(float(row["tolerance"]), rel=1e-9)


def test_the_recommended_scene_file_has_the_chosen_digits_and_plans(designed):
    result, files = designed
    scene = Scene.from_file(files["scene"])
    best = result.best
    assert scene.digits.alpha == pytest.approx(best.alpha)
    assert scene.digits.finger_tip_radius * scene.object_length == pytest.approx(best.tip_radius)
    plan = lattice_plan(scene, 1)  # the goal it was designed to comes with it
    assert plan.solved and plan.cost == pytest.approx(best.cost, abs=1e-9)
    assert tolerance(scene, plan).scale == pytest.approx(best.tolerance, rel=1e-9)
    comments = [s for s in resolve("guitar_pick", "scene").read_text().splitlines() if s.lstrip().startswith("#")]
    assert [s for s in files["scene"].read_text().splitlines()[2:] if s.lstrip().startswith("#")] == comments


@pytest.mark.slow
def test_a_design_search_reproduces(designed, tmp_path):
    result, files = designed
    again = run_design("guitar_pick", GRID).write(tmp_path)
    assert again["csv"].read_text() == files["csv"].read_text()
    assert again["scene"].read_text() == files["scene"].read_text()


def test_the_design_picture_explains_every_mark(designed):
    result, files = designed
    assert_picture(files["plot"])
    assert unexplained_marks(design_figure(result)) == []


def test_digits_that_cannot_be_built_are_a_designs_verdict_not_an_error():
    result = run_design("guitar_pick", DesignOptions(alphas=(1.0, 0.47), tip_radii=(0.001,), goal="scene",
                                                     run=RunOptions(jobs=1)))
    bad, good = result.designs
    assert bad.outcome is None and not bad.digits_valid and "digits.alpha" in bad.error
    assert good.cost is not None and result.chosen == 1


@pytest.mark.parametrize("args, flag", [
    (("--tip-radius", "-1"), "--tip-radius"),
    (("--finger-tip", "flat", "--tip-radius", "1"), "--tip-radius"),
    (("--simulate", "-1"), "--simulate"),
    (("--alpha", "x"), "--alpha"),
    (("--goal", "anywhere"), "--goal"),
])
def test_bad_design_options_exit_2_naming_the_flag(tmp_path, args, flag):
    proc = run_cli("design", "guitar_pick", *args, "--out", str(tmp_path / "d"))
    assert proc.returncode == EXIT_BAD_INPUT
    assert_one_line_error(proc, flag)
    assert not (tmp_path / "d").exists()
