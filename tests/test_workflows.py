"""The commands' workflows as library functions (ungrasp_ompl.workflows): each returns values that
agree with the floors it chains, writes what it reports, and names an options field (never a
flag) in its errors; the CLI alone names the flag."""

from __future__ import annotations

import csv
import json
import math

import pytest
from conftest import run_cli, small_landing_file

from ungrasp_ompl.errors import InputError
from ungrasp_ompl.layout.model import Layout
from ungrasp_ompl.parallel import RunOptions
from ungrasp_ompl.planning import PlannerOptions, plan
from ungrasp_ompl.planning.margins import Objective
from ungrasp_ompl.planning.plan_tolerance import tolerance
from ungrasp_ompl.scene import Scene
from ungrasp_ompl.workflows.plan import PlanOptions, plan_scene
from ungrasp_ompl.workflows.simulate import SimulateOptions, simulate_layout, simulate_scene


@pytest.mark.slow
def test_the_plan_workflow_is_the_planner_s_plan_with_its_tolerance_and_export(tmp_path):
    scene = Scene.from_file("guitar_pick")
    run = plan_scene(scene, PlanOptions(planner=PlannerOptions(planner="lattice")))
    direct = plan(scene, planner="lattice")
    assert run.solved and run.plan.states == direct.states and run.plan.cost == direct.cost
    assert run.plan.tolerance == tolerance(scene, direct).to_dict()
    written = json.loads(run.write(tmp_path / "out")["plan"].read_text())
    assert written["states"] == direct.states and "cage" not in written
    files = run.export(tmp_path / "export")
    assert {"json", "csv", "urscript", "view", "plan"} <= set(files) and all(p.is_file() for p in files.values())
    with pytest.raises(InputError) as err:
        plan_scene(Scene.from_file("reference_asymmetric"), PlanOptions(planner=PlannerOptions(planner="lattice"), cage=True))
    assert err.value.field == "cage" and "object.thickness" in err.value.reason and err.value.source is None


@pytest.mark.slow
def test_the_simulate_workflow_returns_its_trials_as_values(tmp_path):
    scene = Scene.from_file("guitar_pick")
    run = simulate_scene(scene, SimulateOptions(trials=2, perturb="none", run=RunOptions(jobs=1),
                                                planner=PlannerOptions(planner="lattice")))
    assert run.report is not None and [t.trial for t in run.report.trials] == [0, 1]
    assert not run.problems and run.plan.states == plan(scene, planner="lattice").states
    files = run.write(tmp_path)
    with open(files["trials"]) as f:
        rows = list(csv.DictReader(f))
    assert [r["outcome"] for r in rows] == [t.outcome.name.lower() for t in run.report.trials]
    summary = json.loads(files["summary"].read_text())
    assert summary["successes"] == run.report.successes
    assert all(files[k].is_file() for k in ("model", "view", "poses", "picture"))


@pytest.mark.slow
def test_the_simulate_workflow_plans_with_the_objective_asked_for(tmp_path):
    # the pick from its start before decision 0107, whose shortest and widest paths differ
    scene = Scene.from_file(small_landing_file("guitar_pick_reference_start", tmp_path))
    run = simulate_scene(scene, SimulateOptions(trials=1, perturb="none", run=RunOptions(jobs=1),
                                                planner=PlannerOptions(planner="lattice", objective="margin")))
    assert run.plan.objective is Objective.MARGIN
    assert run.plan.states == plan(scene, planner="lattice", objective="margin").states
    assert run.plan.states != plan(scene, planner="lattice").states  # the objectives choose different paths here


@pytest.mark.parametrize("options, field", [
    (SimulateOptions(trials=0), "trials"), (SimulateOptions(run=RunOptions(jobs=0)), "jobs"), (SimulateOptions(perturb="storm"), "perturb"),
    (SimulateOptions(thickness=0.2), "thickness"),
    (SimulateOptions(start_psi_offset=math.radians(100)), "start_psi_offset"),
    (SimulateOptions(planner=PlannerOptions(objective="steepest")), "objective")])
def test_simulate_options_name_their_field(options, field):
    with pytest.raises(InputError) as err:
        simulate_scene(Scene.from_file("guitar_pick"), options)
    assert err.value.field == field and err.value.source is None


def test_a_layout_refuses_the_options_of_a_single_scene():
    layout = Layout.from_file("tangram")
    for options, field in ((SimulateOptions(thickness=0.002), "thickness"), (SimulateOptions(equal_digits=True),
                                                                            "equal_digits"),
                           (SimulateOptions(planner=PlannerOptions(objective="margin")), "objective")):
        with pytest.raises(InputError) as err:
            simulate_layout(layout, options)
        assert err.value.field == field


@pytest.mark.parametrize("args, flag", [(("--trials", "0"), "--trials"), (("--world", "density=0"), "world.density"),
                                        (("--start-psi-offset-deg", "100"), "--start-psi-offset-deg")])
def test_the_cli_names_the_flag_of_an_options_field(tmp_path, args, flag):
    proc = run_cli("simulate", "guitar_pick", *args, "--out", str(tmp_path / "o"))
    assert proc.returncode == 2 and proc.stderr.startswith(f"ungrasp-ompl: error: {flag}: "), proc.stderr
    assert not (tmp_path / "o").exists()
