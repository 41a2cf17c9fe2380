"""The secure lattice as SecurityAtlas builds it (axis by axis, force closure from triple
products, the table and bounding boxes in closed form) against the same checks state by state
(kinematic_validity, force_closure_margin > FC_TOLERANCE, CollisionChecker.in_collision) on every
shipped scene and on tangram pieces among the frame's walls and placed pieces."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ungrasp_ompl import Scene
from ungrasp_ompl.geometry.collision import CollisionChecker
from ungrasp_ompl.layout.model import Layout
from ungrasp_ompl.mechanics import Friction, force_closure, force_closure_margin, kinematic_validity
from ungrasp_ompl.mechanics.force_closure import FC_TOLERANCE
from ungrasp_ompl.planning.atlas import SecurityAtlas, planning_box
from ungrasp_ompl.shipped import shipped_scenes

SCENES = [s for s in shipped_scenes() if s.kind == "scene"]
#: (piece, pieces placed before it) of the tangram: a piece among walls alone, and one among pieces.
TANGRAM_CASES = [(0, ()), (4, (0, 1, 2, 3))]


def _per_state(scene: Scene, atlas: SecurityAtlas) -> None:
    """Every table of atlas equals the state-by-state checks at its lattice states."""
    q = np.stack(np.meshgrid(*atlas.axes, indexing="ij"), axis=-1).reshape(-1, 3)
    th, d, ps = q.T
    kin = kinematic_validity(th, d, ps, scene.digits)
    assert np.array_equal(atlas.kinematic.ravel(), kin)

    def fc(sa: int, sb: int, where: np.ndarray) -> np.ndarray:
        """Force closure in mode (sa, sb) where asked (False elsewhere: the tables require it too)."""
        out = np.zeros(len(q), dtype=bool)
        out[where] = force_closure_margin(th[where], d[where], ps[where], sa, sb, scene.friction) > FC_TOLERANCE
        return out

    check = fc(0, 0, kin)
    collision = np.zeros(len(q), dtype=bool)
    collision[check] = CollisionChecker(scene.collision_model()).in_collision(q[check])
    assert np.array_equal(atlas.collision.ravel(), collision)
    holdable = check & ~collision
    assert np.array_equal(atlas.holdable.ravel(), holdable)
    atlas.prepare()
    for (sa, sb), table in atlas._mode_ok.items():
        where = holdable.copy()
        if sa != 0 and sb != sa:  # computed only where a primitive makes that mode
            where &= ps >= math.pi / 2 - 1e-9
        expected = fc(sa, sb, where)
        assert np.array_equal(table.ravel(), expected), (sa, sb)


@pytest.mark.slow
@pytest.mark.parametrize("shipped", SCENES, ids=lambda s: s.name)
def test_lattice_equals_state_by_state_checks_on_shipped_scenes(shipped):
    scene = Scene.from_file(shipped.path)
    _per_state(scene, SecurityAtlas(scene, planning_box(scene)))


@pytest.mark.slow
@pytest.mark.parametrize("piece, placed", TANGRAM_CASES)
def test_lattice_equals_state_by_state_checks_among_solids(piece, placed):
    layout = Layout.from_file(next(s.path for s in shipped_scenes() if s.name == "tangram"))
    scene = layout.scene(piece, placed=placed)
    atlas = SecurityAtlas(scene, planning_box(scene))
    assert atlas.collision.any()  # the walls and pieces do stop some states
    _per_state(scene, atlas)


@pytest.mark.parametrize("model", ["relaxed", "strict"])
def test_force_closure_on_broadcast_axes_equals_the_margin_test(model):
    """force_closure over axes that broadcast (and signs that vary per state) equals the margin's
    test state by state, also at degenerate states (theta 0, psi 0 or 90 deg) where triple products
    vanish and the margin itself decides."""
    rng = np.random.default_rng(7)
    th = np.concatenate([[0.0, math.pi / 2], rng.uniform(0, math.pi / 2, 9)])[:, None, None]
    d = np.concatenate([[0.0, 1.0], rng.uniform(0, 1, 8)])[None, :, None]
    ps = np.concatenate([[0.0, math.pi / 2], rng.uniform(0, math.radians(120), 10)])[None, None, :]
    mu = (0.2, 0.3, 0.35)
    signs = rng.integers(-1, 2, size=(2,) + np.broadcast_shapes(th.shape, d.shape, ps.shape))
    flat = [np.ravel(np.broadcast_to(x, signs.shape[1:])) for x in (th, d, ps)]
    for sa, sb in [(0, 0), (0, -1), (-1, -1), (1, 0), (signs[0], signs[1])]:
        got = force_closure(th, d, ps, sa, sb, Friction(mu, model))
        ref = force_closure_margin(*flat, np.ravel(np.broadcast_to(sa, got.shape)),
                                   np.ravel(np.broadcast_to(sb, got.shape)), Friction(mu, model)) > FC_TOLERANCE
        assert got.shape == signs.shape[1:]
        assert np.array_equal(got.ravel(), ref)
        assert 0 < ref.sum() < ref.size  # both outcomes occur
