"""What planning a layout's pieces shares between them, and between a plan and its replan without
P_dpsi, gives what computing it afresh gives: the friction margins of lattice states
(planning.margin_table), the predicted landings (planning.predicted_landing), the secure lattice of
the scene without P_dpsi (SecurityAtlas.with_options) and the re-validation of a path's legs at
once (planning.verify.first_failing_leg)."""

from __future__ import annotations

import os
from dataclasses import replace

import numpy as np
import pytest

from conftest import SCENES
from ungrasp_ompl.layout.model import Layout
from ungrasp_ompl.mechanics.margin import friction_margin
from ungrasp_ompl.parallel.forked import can_fork
from ungrasp_ompl.planning import predicted_landing
from ungrasp_ompl.planning.atlas import SecurityAtlas, planning_box
from ungrasp_ompl.planning.margin_table import MarginTable
from ungrasp_ompl.planning.verify import first_failing_leg, verify_leg


@pytest.fixture(scope="module")
def tangram():
    """The shipped tangram, and the lattices of two pieces of different shape and size (the
    square and a large triangle) with their own approaches."""
    layout = Layout.from_file(SCENES / "tangram.yaml")
    names = [p.name for p in layout.pieces]
    scenes = [layout.scene(names.index(n)) for n in ("square", "large_triangle_1")]
    return layout, [SecurityAtlas(s, planning_box(s)) for s in scenes]


def _bits(x: np.ndarray) -> np.ndarray:
    return np.asarray(x, dtype=np.float64).view(np.uint64)


def _some(atlas: SecurityAtlas, count: int, offset: int = 0) -> tuple[np.ndarray, ...]:
    """count holdable lattice states of atlas (index arrays), from the offset-th on."""
    idx = np.nonzero(atlas.holdable)
    return tuple(i[offset:offset + count] for i in idx)


def test_pieces_of_another_shape_share_their_states_margins_bit_for_bit(tangram):
    """The square's and a large triangle's lattices have the same axes and friction: the triangle's
    margins come from the square's where their states meet, and every margin is friction_margin's
    own, bit for bit."""
    _, (square, triangle) = tangram
    assert all(np.array_equal(a, b) for a, b in zip(square.axes, triangle.axes))
    table = MarginTable()
    for mode in ((0, 0), (0, -1), (-1, -1)):
        first = _some(square, 1500)
        got = table.margins(square.axes, first, *mode, square.scene.friction)
        want = friction_margin(*(ax[i] for ax, i in zip(square.axes, first)), *mode, square.scene.friction)
        assert np.array_equal(_bits(got), _bits(want))
        before = table.computed_states
        second = _some(triangle, 1500, offset=700)  # half of them the square's
        got = table.margins(triangle.axes, second, *mode, triangle.scene.friction)
        want = friction_margin(*(ax[i] for ax, i in zip(triangle.axes, second)), *mode, triangle.scene.friction)
        assert np.array_equal(_bits(got), _bits(want))
        fresh = {tuple(s) for s in np.column_stack(second)} - {tuple(s) for s in np.column_stack(first)}
        assert table.computed_states - before == len(fresh) < 1500


def test_another_friction_or_lattice_does_not_hit_the_table(tangram):
    """What a margin depends on keys the table: a narrower friction, or a lattice shifted by a
    step, computes every state anew, and gets friction_margin's values for them."""
    _, (square, _) = tangram
    table = MarginTable()
    idx = _some(square, 400)
    table.margins(square.axes, idx, 0, 0, square.scene.friction)
    narrower = replace(square.scene.friction, mu=tuple(0.9 * m for m in square.scene.friction.mu),
                       low=tuple(0.9 * m for m in square.scene.friction.low),
                       high=tuple(0.9 * m for m in square.scene.friction.high))
    shifted = [ax + step for ax, step in zip(square.axes, square.res)]
    for axes, friction in ((square.axes, narrower), (shifted, square.scene.friction)):
        before = table.computed_states
        got = table.margins(axes, idx, 0, 0, friction)
        assert table.computed_states - before == 400
        want = friction_margin(*(ax[i] for ax, i in zip(axes, idx)), 0, 0, friction)
        assert np.array_equal(_bits(got), _bits(want))


@pytest.mark.skipif(not can_fork(), reason="no fork on this platform")
def test_a_shared_table_serves_margins_a_forked_child_computed(tangram):
    """share() before a fork: the margins the child computes are the parent's too."""
    _, (square, _) = tangram
    table = MarginTable()
    table.share(square.axes, square.scene.friction)
    idx = _some(square, 800)
    pid = os.fork()
    if pid == 0:  # the child: compute, then leave at once
        try:
            table.margins(square.axes, idx, 0, -1, square.scene.friction)
        finally:
            os._exit(0)
    os.waitpid(pid, 0)
    got = table.margins(square.axes, idx, 0, -1, square.scene.friction)
    assert table.computed_states == 0
    want = friction_margin(*(ax[i] for ax, i in zip(square.axes, idx)), 0, -1, square.scene.friction)
    assert np.array_equal(_bits(got), _bits(want))


def test_the_lattice_margins_are_the_tables(tangram):
    """LatticeMargins takes its friction margins from the process's table: the same values as
    friction_margin at the states it computes."""
    from ungrasp_ompl.planning.margins import LatticeMargins, Objective

    _, (square, _) = tangram
    margins = LatticeMargins(square, Objective.MARGIN)
    got = margins.mode(0, 0)
    idx = np.nonzero(np.isfinite(got))
    assert len(idx[0]) > 0
    want = friction_margin(*(ax[i] for ax, i in zip(square.axes, idx)), 0, 0, square.scene.friction)
    assert np.array_equal(_bits(got[idx]), _bits(want))


def test_the_scene_without_p_dpsi_shares_the_lattice_and_answers_as_its_own(tangram):
    """SecurityAtlas.with_options: the atlas of the scene without P_dpsi (with_landing_spread's
    replan) has the tables an atlas built for that scene has, refuses the D and X legs, and is made
    once; options that change the tables are refused."""
    _, (square, _) = tangram
    square.prepare()
    options = replace(square.scene.options, forbid_partial=True, max_landing_spread=None)
    twin = square.with_options(options)
    assert twin is square.with_options(options) and twin.scene.options == options
    fresh = SecurityAtlas(twin.scene, planning_box(twin.scene))
    fresh.prepare()
    assert np.array_equal(twin.holdable, fresh.holdable) and np.array_equal(twin.collision, fresh.collision)
    for kind, direction in (("T", -1), ("P", 1), ("D", -1)):
        assert np.array_equal(twin.runs(kind, direction), fresh.runs(kind, direction))
    rng = np.random.default_rng(1)
    held = np.argwhere(square.holdable)
    pairs = [(tuple(int(x) for x in held[i]), tuple(int(x) for x in held[j]))
             for i, j in rng.integers(0, len(held), (3000, 2))]
    assert [twin.motion_secure(a, b) for a, b in pairs] == [fresh.motion_secure(a, b) for a, b in pairs]
    moves = [(a, (a[0], a[1] - 2, a[2])) for a, _ in pairs if a[1] >= 2]  # d alone: a P_dpsi
    assert any(square.leg_secure("D", a, b) for a, b in moves)
    assert not any(twin.leg_secure("D", a, b) for a, b in moves)
    assert square.with_options(square.scene.options) is square
    with pytest.raises(ValueError, match="resolution"):
        square.with_options(replace(options, resolution=(0.01, 0.01, 0.01)))


def test_a_landing_predicted_again_is_the_first_one(tangram):
    """predict_landing keeps its predictions by the fall's exact inputs: the same plan's landing
    in the scene without P_dpsi (another Scene object) is the first prediction, and it is
    mechanics.release.predict_release's own."""
    from ungrasp_ompl.mechanics.release import predict_release
    from ungrasp_ompl.planning import plan

    _, (square, _) = tangram
    scene = square.scene
    result = plan(scene, planner="lattice", atlas=square, objective="cost")
    assert result.solved
    first = predicted_landing.predict_landing(scene, result)
    strict = replace(scene, options=replace(scene.options, forbid_partial=True, max_landing_spread=None))
    assert predicted_landing.predict_landing(strict, result) is first
    setup = predicted_landing.release_setup(scene, tuple(result.states[-1]))
    setup = replace(setup, start=predicted_landing.carried_start(scene, result, setup))
    mu_g, _, mu_b = scene.mu_contacts
    assert predict_release(setup, mu_g, mu_b, str(scene.robot.termination), True) == first
    assert predicted_landing._exact((0.0,)) != predicted_landing._exact((-0.0,))


@pytest.mark.parametrize("theta_deg, slide, failing", [
    (2, 0.05, (2, "force_closure")),  # the finger slid a little: the grip is lost
    (2, 0.2, (2, "kinematics")),  # slid far: B leaves the thumb
    (4, 0.05, (0, "collision")),  # turned down too far at once: the palm meets the table
])
def test_legs_checked_at_once_fail_where_they_fail_alone(theta_deg, slide, failing):
    """first_failing_leg: the first leg verify_leg refuses, with verify_leg's reason; None when
    every leg passes (the guitar pick from d 0.65, its start before decision 0121: turned down, the
    thumb turned, then the finger slid toward B)."""
    from ungrasp_ompl import Scene

    scene = Scene.from_file("guitar_pick")
    res = np.asarray(scene.options.resolution) / 2
    q = np.array([scene.start[0], 0.65, scene.start[2]])
    down = q + [-np.radians(theta_deg), 0.0, 0.0]
    up = down + [0.0, 0.0, np.radians(20)]
    slid = up + [0.0, -slide, 0.0]
    legs = [("P_theta", q, down), ("P_psi", down, up), ("P_dpsi", up, slid), ("P_theta", slid, slid - [0.05, 0, 0])]
    alone = [verify_leg(scene, p, a, b, res) for p, a, b in legs]
    k = next(k for k, why in enumerate(alone) if why is not None)
    assert (k, alone[k].check.value) == failing
    assert first_failing_leg(scene, legs, res) == (k, alone[k])
    assert first_failing_leg(scene, legs[:k], res) is None
