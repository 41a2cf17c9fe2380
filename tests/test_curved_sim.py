"""The simulated object of a curved section is the solid the planner collides with
(geometry.collision.object_solid, docs/model.md 2.7 and 11.1): its mass is the density times the
solid's volume in both engines, its facets keep to the true surface, it rests where it is put, and
a slab's prism is untouched.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from conftest import SCENES, mujoco_drop
from ungrasp_ompl import Scene
from ungrasp_ompl.geometry.collision import object_solid
from ungrasp_ompl.robot.model import load_ur5e
from ungrasp_ompl.robot.pipeline import gripper_links, gripper_spec
from ungrasp_ompl.sim.model import build_mjcf, model_ids
from ungrasp_ompl.sim.setup import OUTLINE_SAGITTA, gripper_geometry, object_outline
from ungrasp_ompl.sim.spec import PairFriction, SimModelSpec, SimObject, curved_solid
from ungrasp_ompl.sim.world_description import describe

mujoco = pytest.importorskip("mujoco")


def _solid(scene: Scene) -> np.ndarray | None:
    """The simulated solid of scene's object, as sim.setup.trial_setup asks for it."""
    l = scene.object_length
    return curved_solid(scene.digits.section, l, scene.digits.width * l,
                        scene.object3d is not None and scene.plane is not None)


def _spec(name: str) -> SimModelSpec:
    """The simulated world of a shipped scene, its object built as sim.setup.trial_setup builds it."""
    scene = Scene.from_file(SCENES / f"{name}.yaml")
    robot = load_ur5e(gripper_spec(scene), np.array(scene.robot.base), pincer=gripper_links(scene))
    return SimModelSpec(obj=SimObject(object_outline(scene), scene.object_thickness, scene.sim.density, _solid(scene)),
                        gripper=gripper_geometry(scene, robot), friction=PairFriction.from_contacts(scene.mu_contacts),
                        timestep=scene.sim.timestep, grip_force=scene.sim.grip_force,
                        servo_stiffness=2 * scene.sim.grip_force / scene.sim.squeeze)


@pytest.mark.parametrize("name", ["guitar_pick", "puzzle_piece", "pincer_puzzle_piece", "reference_asymmetric"])
def test_a_slabs_simulated_object_is_its_outlines_prism_as_before(name):
    """A slab has no curved solid: its mesh is its outline at z = 0 and again at the thickness,
    vertex for vertex, in that order."""
    scene = Scene.from_file(SCENES / f"{name}.yaml")
    assert _solid(scene) is None
    spec = _spec(name)
    outline, t = spec.obj.outline, spec.obj.thickness
    expected = np.vstack([np.column_stack([outline, np.zeros(len(outline))]),
                          np.column_stack([outline, np.full(len(outline), t)])])
    mesh = describe(spec).object.geom.shape
    assert np.array_equal(mesh.vertices, expected)
    assert np.array_equal(mesh.centre, np.zeros(3))


def test_the_go_stones_mass_is_its_density_times_the_semi_ellipsoids_volume_in_both_engines():
    """The Go stone is a semi-ellipsoid of half-axes a = l/2 and c = t: the simulated solid's hull
    holds 2/3 pi a^2 c less at most its area times the 2 um its facets may stray (its vertices lie
    on the surface, so never more), and MuJoCo's and Drake's object masses are the density times
    that hull's volume."""
    spec = _spec("go_stone")
    scene = Scene.from_file(SCENES / "go_stone.yaml")
    a, c = scene.object_length / 2, scene.object_thickness
    hull = ConvexHull(describe(spec).object.geom.shape.vertices)
    closed = 2 / 3 * math.pi * a * a * c
    assert 0.0 < closed - hull.volume <= hull.area * OUTLINE_SAGITTA
    mass = spec.obj.density * hull.volume
    model = mujoco.MjModel.from_xml_string(build_mjcf(spec))
    ids = model_ids(model)
    assert model.body_mass[ids.object_body] == pytest.approx(mass, rel=1e-6)
    # the centre of mass 3c/8 above the flat face, on the axis through the outline's centre
    assert model.body_ipos[ids.object_body] == pytest.approx([a, 0.0, 3 * c / 8], abs=2 * OUTLINE_SAGITTA)
    drake = pytest.importorskip("pydrake.all")
    from ungrasp_ompl.sim import drake_world

    world = describe(spec)
    dw = drake_world.build(world, drake.PiecewisePolynomial.FirstOrderHold([0.0, 1.0], np.zeros((6, 2))),
                           drake.PiecewisePolynomial.ZeroOrderHold([0.0, 1.0], np.zeros((1, 2))), np.eye(3))
    assert dw.bodies["object"].get_mass(dw.plant_context) == pytest.approx(mass, rel=1e-6)


@pytest.mark.parametrize("name", ["go_stone", "coin"])
def test_the_simulated_solids_facets_stray_at_most_the_outline_sagitta_from_the_true_surface(name):
    """Points of the section's solid sampled two and a half times finer than the simulator's lie within
    OUTLINE_SAGITTA of the simulated hull (inside it or outside by at most that); the planner's
    own coarser solid strays further, so the bound is the finer sampling's."""
    scene = Scene.from_file(SCENES / f"{name}.yaml")
    l, width = scene.object_length, scene.digits.width * scene.object_length
    fine = object_solid(scene.digits.section, l, width, True, 320)
    points = fine[np.random.default_rng(0).choice(len(fine), 4000, replace=False)]

    def stray(vertices: np.ndarray) -> float:
        eq = ConvexHull(vertices).equations
        return max(float((chunk @ eq[:, :3].T + eq[:, 3]).max()) for chunk in np.array_split(points, 20))

    assert stray(_solid(scene)) <= OUTLINE_SAGITTA
    assert stray(object_solid(scene.digits.section, l, width, True)) > OUTLINE_SAGITTA


def test_a_drawn_or_variant_thickness_scales_the_solids_heights_alone_and_keeps_its_mass():
    """The stone 1.05 times as thick, its density over 1.05 (as a trial draws a thickness error,
    sim.trial): the same outline on the table, its heights times 1.05, its mass unchanged."""
    spec = _spec("go_stone")
    own = describe(spec).object.geom.shape.vertices
    thick = replace(spec.obj, thickness=1.05 * spec.obj.thickness, density=spec.obj.density / 1.05)
    scaled = describe(replace(spec, obj=thick)).object.geom.shape.vertices
    assert np.array_equal(scaled[:, :2], own[:, :2])
    assert scaled[:, 2] == pytest.approx(1.05 * own[:, 2], rel=1e-12)
    assert np.ptp(scaled[:, 2]) == pytest.approx(thick.thickness, rel=1e-12)
    assert ConvexHull(scaled).volume * thick.density == pytest.approx(ConvexHull(own).volume * spec.obj.density,
                                                                      rel=1e-9)


def test_the_go_stone_dropped_on_its_flat_face_from_a_millimetre_rests_where_it_fell():
    """Flat face down, 1 mm above the table, let go: after 0.3 s it lies within 0.05 mm of below
    its drop point, flat (the positive control of tests/test_drake.py, on the curved solid)."""
    spec = _spec("go_stone")
    pose = np.eye(4)
    pose[:3, 3] = [0.45, 0.10, 0.001]
    final = mujoco_drop(spec, pose, 0.3)
    assert np.linalg.norm(final[:2, 3] - pose[:2, 3]) < 5e-5
    assert abs(final[2, 3]) < 5e-5
    assert math.degrees(math.acos(min(1.0, final[2, 2]))) < 0.05
