"""The energy-bounded cage: a hand-solved disc in a V, converging as the grid halves; poses outside
any cage; the watershed against brute force; the pinch's bodies touching where the state says."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ungrasp_ompl.errors import InputError
from ungrasp_ompl.mechanics.cage import (
    CageGrid,
    CageOutcome,
    CageProblem,
    escape_energy,
    escape_level,
    escape_level_bisection,
    grid_border,
    pinch_problem,
)
from ungrasp_ompl.mechanics.convex import ConvexShape, signed_distance
from ungrasp_ompl.mechanics.kinematics import finger_corner
from ungrasp_ompl.scene import Scene

SCENES = Path(__file__).resolve().parents[1] / "scenes"

#: A V of two fixed segments meeting at the origin, 45 deg either side of vertical; its left rim is
#: lower (0.03 m) than its right one (0.05 m).
LEFT = ConvexShape(np.array([[-0.03, 0.03], [0.0, 0.0]]))
RIGHT = ConvexShape(np.array([[0.0, 0.0], [0.05, 0.05]]))
RHO = 0.01  # the disc's radius, m
WEIGHT = 0.2  # N


def _v_problem(force: np.ndarray | None = None) -> CageProblem:
    z0 = RHO / math.sin(math.radians(45))  # resting on both sides
    centre = np.array([0.0, z0])
    return CageProblem(ConvexShape.disc(centre, RHO), centre, WEIGHT, (LEFT, RIGHT),
                       np.array([[-0.03, 0.0], [0.05, 0.05]]), table=False, force=force,
                       force_point=None if force is None else centre)


def test_disc_in_a_v_escapes_over_the_lower_rim_and_converges():
    """Hand-solved: the disc's centre rests at RHO / sin 45 deg; its lowest way out passes with the
    centre right above the lower rim's end, RHO higher: the escape energy is the weight times
    (0.03 + RHO - RHO / sin 45 deg). Within the grid's error, shrinking as the grid halves."""
    exact = WEIGHT * (0.03 + RHO - RHO / math.sin(math.radians(45)))
    length = 0.02  # the grid's steps are over this length
    errors = []
    for step in (1 / 8, 1 / 16, 1 / 32, 1 / 64):
        cage = escape_energy(_v_problem(), CageGrid(step=step, rotation_step=0.0, max_rotation=0.0), length)
        assert cage.outcome is CageOutcome.CAGED
        h = step * length
        error = cage.escape_energy - exact
        assert abs(error) <= WEIGHT * h  # a pass between two grid rows
        errors.append(abs(error))
        x, z, _ = cage.pass_pose  # over the lower (left) rim, the centre a radius above its end
        assert abs(x + 0.03) <= RHO and z == pytest.approx(0.03 + RHO - RHO / math.sin(math.radians(45)), abs=h)
    assert errors[-1] < errors[0] / 4


def test_a_constant_squeeze_adds_its_work():
    """A constant downward force F on the disc's centre makes the potential (W + F) z: the same
    pass, the escape energy scaled by (W + F) / W, exactly on the grid."""
    grid = CageGrid(step=1 / 16, rotation_step=0.0, max_rotation=0.0)
    base = escape_energy(_v_problem(), grid, 0.02).escape_energy
    pushed = escape_energy(_v_problem(np.array([0.0, -0.3])), grid, 0.02).escape_energy
    assert pushed == pytest.approx(base * (WEIGHT + 0.3) / WEIGHT, rel=1e-12)


def test_poses_outside_any_cage_give_zero_and_a_closed_box_infinity():
    centre = np.array([0.0, RHO])
    grid = CageGrid(step=1 / 16, rotation_step=0.0, max_rotation=0.0)
    wall = ConvexShape(np.array([[RHO, 0.0], [RHO, 0.04]]))
    on_table = CageProblem(ConvexShape.disc(centre, RHO), centre, WEIGHT, (wall,), np.array([[-RHO, 0], [RHO, 0.04]]))
    cage = escape_energy(on_table, grid, 0.02)
    assert cage.outcome is CageOutcome.NOT_CAGED and cage.escape_energy == 0.0
    lid = ConvexShape(np.array([[-0.02, 0.025], [0.02, 0.025]]))
    sides = (ConvexShape(np.array([[-0.02, 0.0], [-0.02, 0.025]])), ConvexShape(np.array([[0.02, 0.0], [0.02, 0.025]])))
    boxed = CageProblem(ConvexShape.disc(centre, RHO), centre, WEIGHT, (lid,) + sides, np.array([[-0.02, 0], [0.02, 0.025]]))
    cage = escape_energy(boxed, grid, 0.02)
    assert cage.outcome is CageOutcome.FULLY_CAGED and math.isinf(cage.escape_energy)


@pytest.mark.parametrize("seed", range(6))
def test_watershed_equals_brute_force_on_random_grids(seed):
    """The watershed's minimax level equals bisection on the level with ndimage.label, on random
    free cells with random energies (half of them with many ties), and its pass cell has it."""
    rng = np.random.default_rng(seed)
    for _ in range(40):
        shape = tuple(int(x) for x in rng.integers(3, 11, 3))
        free = rng.random(shape) < rng.uniform(0.3, 0.9)
        energy = rng.integers(0, 5, shape).astype(float) if rng.random() < 0.5 else rng.random(shape)
        start = tuple(int(rng.integers(0, s)) for s in shape)
        free[start] = True
        border = grid_border(shape)
        level, cell = escape_level(free, energy, start, border)
        reference = escape_level_bisection(free, energy, start, border)
        assert level == reference or (math.isinf(level) and math.isinf(reference))
        if cell is not None:
            assert energy.flat[cell] == level and free.flat[cell] and level > energy[start]


def test_pinch_bodies_touch_the_object_where_the_state_says():
    """At the state's pose the object touches the table at G, the thumb at B and the finger at A:
    zero signed distance (up to rounding), and no penetration."""
    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    l, t = scene.object_length, scene.object_thickness
    for theta, d, psi in ((math.radians(30), 0.8, 0.0), (math.radians(15), 0.7, math.radians(29)),
                          (math.radians(3), 0.615, math.radians(38))):
        p = pinch_problem(theta, d, psi, scene.digits, l, t, l / 2, 0.01)
        body = p.body.vertices
        assert body[:, 1].min() == pytest.approx(0.0, abs=1e-15)
        thumb, finger_cut, dome = p.obstacles[0], p.obstacles[1], p.obstacles[3]
        assert signed_distance(body[None], thumb.vertices)[0] == pytest.approx(0.0, abs=1e-12)
        assert signed_distance(body[None], finger_cut.vertices)[0] >= -1e-12
        gap = signed_distance(body[None], dome.vertices)[0] - dome.radius
        assert gap == pytest.approx(0.0, abs=1e-12)
        # the dome sits in the finger's tip corner
        corner = finger_corner(theta, d, psi, scene.digits.object_thickness, scene.digits.finger_tip_radius) * l
        assert np.linalg.norm(dome.vertices[0] - corner) == pytest.approx(dome.radius * math.sqrt(2), rel=1e-9)


def test_scene_cage_needs_a_weight():
    scene = Scene.from_file(SCENES / "reference_asymmetric.yaml")
    with pytest.raises(InputError, match="object.thickness"):
        scene.cage(scene.start)
