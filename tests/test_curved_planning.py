"""The secure lattice on a curved section (go_stone): a lattice step is secure only when force
closure holds all the way between its two states, as the re-validation checks it, so that the
motion validator and the re-validation agree. The oracle: force closure sampled at 1/64 of a
step along every lattice step, independent of the atlas's own check."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import SCENES
from ungrasp_ompl import Scene
from ungrasp_ompl.mechanics import force_closure, primitive_sliding_signs
from ungrasp_ompl.planning.atlas import D, FORWARD, LEG_AXES, PSI, THETA, SecurityAtlas, planning_box
from ungrasp_ompl.planning.verify import first_loss_along, verify_leg

ORACLE_SAMPLES = 64  # force closure checked at this many points per lattice step


@pytest.fixture(scope="module")
def go_stone():
    scene = Scene.from_file(SCENES / "go_stone.yaml")
    atlas = SecurityAtlas(scene, planning_box(scene))
    atlas.prepare()
    return scene, atlas


def _oracle(scene: Scene, atlas: SecurityAtlas, kind: str, direction: int, idx: np.ndarray) -> np.ndarray:
    """Per lattice step from the states idx (k, 3) along the leg's axis: force closure at
    ORACLE_SAMPLES + 1 evenly spaced points, in the leg's mode, all hold."""
    axis = LEG_AXES[kind][0]
    q0 = atlas.state(idx)
    ok = np.ones(len(idx), dtype=bool)
    for j in range(ORACLE_SAMPLES + 1):
        q = q0.copy()
        q[:, axis] += direction * atlas.res[axis] * j / ORACLE_SAMPLES
        if kind == "T":
            sa, sb = 0, 0
        elif kind == "P":
            sa, sb = primitive_sliding_signs("P_psi", 1.0, 0.0, 0.0, direction)
        else:
            sa, sb = primitive_sliding_signs("P_dpsi", q[:, D], q[:, PSI], direction, 0.0)
        ok &= force_closure(q[:, 0], q[:, 1], q[:, 2], sa, sb, scene.friction)
    return ok


@pytest.mark.parametrize("kind", [pytest.param("T", marks=pytest.mark.slow), "P", "D"])
def test_steps_the_lattice_accepts_hold_all_the_way(go_stone, kind):
    """Every lattice step the atlas finds secure holds force closure at 1/64 of a step throughout;
    the steps whose two states hold but which lose the grip between them are refused."""
    scene, atlas = go_stone
    direction = int(FORWARD[LEG_AXES[kind][0]])
    steps = atlas.step_ok(kind, direction)
    idx = np.argwhere(steps)
    assert len(idx) > 500
    assert _oracle(scene, atlas, kind, direction, idx).all()


def test_the_thin_band_between_two_held_states_is_refused(go_stone):
    """At theta 21.5 deg, d 0.8 the P_psi leg's mode holds at psi 11.0 and 11.5 deg but not in a
    band near 11.2 deg (the finger's contact passes from its face to its rounded tip there): the
    atlas refuses the step, the leg over it and the motion, and the re-validation names the band."""
    scene, atlas = go_stone
    a = atlas.index((math.radians(21.5), 0.8, math.radians(11.0)))
    b = (a[0], a[1], a[2] + 1)
    ok = atlas.leg_ok("P", 1)
    assert ok[a] and ok[b]  # both states hold in the leg's mode: a check of states alone passes
    assert not _oracle(scene, atlas, "P", 1, np.array([a]))[0]
    assert not atlas.step_ok("P", 1)[a]
    start = (a[0], a[1], a[2] - 4)
    assert not atlas.leg_secure("P", start, (a[0], a[1], a[2] + 4))
    assert not atlas.motion_secure(start, (a[0], a[1], a[2] + 4))
    why = verify_leg(scene, "P_psi", atlas.state(start), atlas.state((a[0], a[1], a[2] + 4)), atlas.res / 2)
    assert why is not None and 11.0 < math.degrees(why.state[2]) < 11.5


def test_first_loss_along_matches_fine_sampling(go_stone):
    """first_loss_along against sampling at 1/1000 of a segment: it reports a loss exactly on the
    segments where sampling finds one, at a point that is not force-closed."""
    scene, atlas = go_stone
    rng = np.random.default_rng(7)
    r = math.radians
    q0 = np.column_stack([rng.uniform(r(15), r(30), 300), rng.uniform(0.7, 0.8, 300), rng.uniform(0, r(20), 300)])
    q0[:40] = [r(21.5), 0.8, r(10.5)]  # through the band above, with others at random
    q1 = q0.copy()
    q1[:, PSI] += rng.uniform(r(0.2), r(2.0), len(q0))
    q1[:40, PSI] = r(11.5)
    lost = first_loss_along(q0, q1, 0, -1, scene.friction)
    t = np.linspace(0.0, 1.0, 1001)
    q = q0[:, None, :] + t[None, :, None] * (q1 - q0)[:, None, :]
    fc = force_closure(q[..., 0], q[..., 1], q[..., 2], 0, -1, scene.friction)
    sampled = ~fc.all(axis=1)
    assert sampled[:40].all() and (~sampled).sum() > 50
    assert np.array_equal(~np.isnan(lost), sampled)
    at = q0[sampled] + lost[sampled, None] * (q1 - q0)[sampled]
    assert not force_closure(at[:, 0], at[:, 1], at[:, 2], 0, -1, scene.friction).any()


@pytest.mark.slow
def test_legs_that_the_validator_accepts_re_validate(go_stone):
    """Motions the planner's validator accepts between seeded random holdable lattice states of
    go_stone are realised by legs that the re-validation passes."""
    scene, atlas = go_stone
    rng = np.random.default_rng(3)
    held = np.argwhere(atlas.holdable)
    checked = 0
    for _ in range(4000):
        a = tuple(int(x) for x in held[rng.integers(len(held))])
        b = tuple(int(x) for x in np.array(a) + rng.integers(0, 12, 3) * (FORWARD < 0) * -1
                  + rng.integers(0, 12, 3) * (FORWARD > 0))
        if atlas.index(atlas.state(b)) is None or not atlas.motion_secure(a, b):
            continue
        for legs in atlas.realise(a, b)[:1]:
            for leg in legs:
                why = verify_leg(scene, leg.primitive, atlas.state(leg.start), atlas.state(leg.end), atlas.res / 2)
                assert why is None, (leg, why)
        checked += 1
        if checked >= 40:
            break
    assert checked >= 40
