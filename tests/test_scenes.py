"""The shipped scenes: those `scenes` calls robot-ready are executed by the robot without a collision;
the others say why not; every obstacle is bounded."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

from conftest import SCENES, leaf, paths, run_cli
from ungrasp_ompl.geometry import CollisionChecker
from ungrasp_ompl.io import parse_yaml
from ungrasp_ompl.mechanics import kinematic_validity
from ungrasp_ompl.planning.atlas import lattice_axes
from ungrasp_ompl.scene import Scene
from ungrasp_ompl.scene.options import Landing, Release
from ungrasp_ompl.shipped import shipped_scenes

SHIPPED = [s for s in shipped_scenes() if s.kind == "scene"]
READY = [s.name for s in SHIPPED if not s.planar_only]


def test_the_object_scenes_are_robot_ready_and_the_planar_ones_say_why():
    assert sorted(READY) == ["coin", "fabric_chalk", "fabric_chalk_designed", "go_stone", "guitar_pick", "guitar_pick_1_5mm",
                             "guitar_pick_designed", "guitar_pick_reference_start", "pincer_guitar_pick", "pincer_puzzle_piece", "puzzle_piece",
                             "puzzle_piece_designed"]
    for s in SHIPPED:
        assert Scene.from_file(s.name).planar_only == s.planar_only
        assert s.planar_only is None or len(s.planar_only.split()) > 8  # a reason, not a flag


@pytest.mark.slow
@pytest.mark.parametrize("planner", ["RRTstar", "lattice"])
@pytest.mark.parametrize("name", READY)
def test_robot_ready_scenes_export_without_collision(tmp_path, name, planner):
    """Each robot-ready scene's plan, by either planner, is executed and exported within the arm's
    limits and clear of the table and obstacles, the hand aimed by the model of its fall
    (robot.landing: modelled). RRT* gets 3 s: at its friction's +-30 % (docs/model.md 4.7) the
    1.5 mm pick's seed 2 finds no path within 2 s (12,000 iterations). The pincer's fall is
    modelled with its digits turning about the joint; the curved objects, whose fall is modelled
    as a slab's, aim as planned."""
    scene = Scene.from_file(name)
    curved = scene.digits.section is not None  # the fall is modelled for a slab only
    modelled = not curved
    assert scene.robot.landing is (Landing.PLANNED if curved else Landing.MODELLED)
    out = tmp_path / "out"
    proc = run_cli("plan", name, "--planner", planner, "--seed", "2", "--time", "3", "--export", str(out))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert (out / "trajectory.json").is_file() and (out / "plan.json").is_file()
    assert "planar-only" not in proc.stdout
    if modelled:
        assert json.loads((out / "plan.json").read_text())["predicted_landing"]["spread_m"] > 0.0


def test_the_c_parser_reads_every_shipped_file_as_pure_python_yaml_does():
    """io.parse_yaml (libyaml's parser where PyYAML has it) gives each shipped scene and layout the
    values PyYAML's pure-Python parser gives it, and refuses what that parser refuses."""
    assert yaml.__with_libyaml__  # PyYAML's wheels carry libyaml: otherwise this compares a parser with itself
    files = sorted(SCENES.glob("*.yaml"))
    assert len(files) >= 10
    for path in files:
        text = path.read_text()
        assert parse_yaml(text) == yaml.load(text, Loader=yaml.SafeLoader), path.name
    for broken in ("object: [1, 2\n  length: :\n", "a: b: c\n", "\tkey: 1\n"):
        with pytest.raises(yaml.YAMLError):
            yaml.load(broken, Loader=yaml.SafeLoader)
        with pytest.raises(yaml.YAMLError):
            parse_yaml(broken)


def test_every_shipped_obstacle_is_bounded():
    """Within a metre of G: a robot's arm can pass above or beside it (the reference planner's
    quadrants reached 100 m)."""
    for s in SHIPPED:
        for box in Scene.from_file(s.name).obstacles:
            assert max(map(abs, (*box.lo, *box.hi))) < 1.0, (s.name, box)


def _collisions(scene: Scene) -> np.ndarray:
    """In collision, per kinematically valid state of the planning lattice over the scene's bounds."""
    _, axes = lattice_axes(scene.start, np.asarray(scene.options.resolution), scene.bounds)
    th, d, ps = (np.reshape(ax, s) for ax, s in zip(axes, ((-1, 1, 1), (1, -1, 1), (1, 1, -1))))
    kin = np.broadcast_to(kinematic_validity(th, d, ps, scene.digits), tuple(len(a) for a in axes)).copy()
    return CollisionChecker(scene.collision_model()).in_collision_lattice(axes, where=kin)


@pytest.mark.slow
def test_upper_obstacle_block_acts_as_the_reference_quadrant():
    """The block of reference_upper_obstacle puts every lattice state in collision or not exactly as
    the reference planner's quadrant (everything left of and above its corner) does."""
    doc = yaml.safe_load((SCENES / "reference_upper_obstacle.yaml").read_text())
    (block,) = doc["obstacles"]
    corner = [block["center"][0] + block["size"][0] / 2, block["center"][1] - block["size"][1] / 2]
    assert np.allclose(corner, [0.3 * 0.06, 0.7 * 0.06])
    quadrant = dict(doc, obstacles=[{"name": "quadrant", "corner": corner, "extends": [-1, 1]}])
    assert Scene.from_dict(quadrant).obstacles[0].hi[1] >= 100.0
    blocked = _collisions(Scene.from_dict(doc))
    assert blocked.sum() > 10**5
    assert np.array_equal(blocked, _collisions(Scene.from_dict(quadrant)))


@pytest.mark.parametrize("name", ["guitar_pick", "puzzle_piece", "fabric_chalk"])
def test_object_plans_keep_their_clearances_between_lattice_states(name):
    """Each object's lattice plan, sampled ten times finer than its lattice, keeps the digits and
    the housing planning.table_clearance above the table and B planning.thumb_tip_margin from the
    thumb's tip all along (the kinematic margins, 0 where a check flips), B that far from the tip
    and A planning.across_margin inside the supports across the plane, as planned and where the
    start press puts the object (mechanics.pressed_state), and the plan ends lower than the
    scene's theta_max: the plan to the scene's release and the plan to anywhere in the goal region
    (planning.release objective), on one of which the table's clearance binds."""
    from ungrasp_ompl.mechanics import across_support, s_b
    from ungrasp_ompl.mechanics.kinematics import pressed_state
    from ungrasp_ompl.mechanics.path import plan_samples
    from ungrasp_ompl.planning import plan

    scene = Scene.from_file(SCENES / f"{name}.yaml")
    assert scene.digits.table_clearance > 0 and scene.digits.thumb_tip_margin > 0
    dg = scene.digits
    assert dg.press == pytest.approx(scene.robot.start_press / scene.object_length) and dg.press > 0
    assert dg.across_margin == pytest.approx(0.001 / scene.object_length)
    anywhere = scene.with_options(release=Release.OBJECTIVE)
    nearest = math.inf
    for planned in (scene, anywhere):
        result = plan(planned, planner="lattice")
        assert result.solved
        states = plan_samples(result, np.asarray(scene.options.resolution) / 10).states
        margins = scene.margin(states).kinematic
        assert margins["table"].min() >= -1e-9 and margins["thumb_tip"].min() >= -1e-9
        nearest = min(nearest, margins["table"].min())
        _, d, psi, found = pressed_state(states[:, 0], states[:, 1], states[:, 2], dg.press, dg)
        assert found.all()
        assert s_b(d, psi, dg.alpha, dg.object_thickness, dg.finger_tip_radius).min() >= dg.thumb_tip_margin - 1e-9
        for dd, ps in ((states[:, 1], states[:, 2]), (d, psi)):
            assert across_support(dd, ps, dg).min() >= dg.across_margin - 1e-9
        assert result.states[-1][0] <= scene.goal.theta_max + 1e-12
    assert nearest < 2.5e-4  # the clearance binds somewhere: the check is not idle


def test_docs_scene_format_names_every_field_the_loader_takes():
    """Every mapping of every shipped scene and layout, given a field the loader does not know, is
    refused (UnknownFieldError) with that field's name and the fields it does know; docs/scene-format.md
    names each."""
    import copy
    import re

    from ungrasp_ompl.errors import UnknownFieldError
    from ungrasp_ompl.layout.model import Layout
    from ungrasp_ompl.shipped import resolve

    words = set(re.findall(r"\w+", (SCENES.parent / "docs" / "scene-format.md").read_text()))
    sections = 0
    for shipped in shipped_scenes():
        doc = yaml.safe_load(resolve(shipped.name, shipped.kind).read_text())
        load = Layout.from_dict if shipped.kind == "layout" else Scene.from_dict
        for path in [p for p in [(), *paths(doc)] if isinstance(leaf(doc, p), dict)]:
            bad = copy.deepcopy(doc)
            leaf(bad, path)["not_a_field"] = 1
            with pytest.raises(UnknownFieldError) as err:
                load(bad)
            assert err.value.field.endswith("not_a_field"), (shipped.name, path, err.value)
            sections += 1
            missing = sorted(set(err.value.expected) - words)
            assert not missing, (shipped.name, path, missing)
    assert sections > 100, sections


def test_docs_scene_format_example_is_a_scene_with_the_default_sim_section():
    """The format page's example scene loads as it stands, and its sim section, which the page
    gives as the defaults, is SimOptions' defaults."""
    from ungrasp_ompl.scene.options import SimOptions

    text = (SCENES.parent / "docs" / "scene-format.md").read_text()
    doc = yaml.safe_load(text.split("```yaml\n", 1)[1].split("```", 1)[0])
    assert doc["sim"] and Scene.from_dict(doc, source="docs/scene-format.md").sim == SimOptions()
