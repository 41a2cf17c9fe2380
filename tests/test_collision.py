"""python-fcl collision against independent oracles: 2D polygons (shapely), 3D meshes in the world.

For the 2D oracle everything is extruded through the manipulation plane with
overlapping widths, so 3D collision equals overlap of the outlines in the plane.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import shapely

from ungrasp_ompl.geometry import CollisionChecker
from ungrasp_ompl.geometry.collision import Box
from ungrasp_ompl.mechanics import digit_polygons


def oracle(scene, q):
    """Per state: does the thumb or finger outline overlap the table or an obstacle, or the
    object an obstacle (interiors, beyond touching)?"""
    l = scene.object_length
    thumb, finger = digit_polygons(q[:, 0], q[:, 1], q[:, 2], scene.digits)
    table = shapely.box(-1e3, -1e3, 1e3, 0.0)
    boxes = [shapely.box(b.lo[0], b.lo[1], b.hi[0], b.hi[1]) for b in scene.obstacles]
    out = []
    for i in range(len(q)):
        th = q[i, 0]
        obj = shapely.LineString([(0, 0), (l * math.cos(th), l * math.sin(th))])
        hit = False
        for outline in (thumb[i], finger[i]):
            poly = shapely.Polygon(outline * l)
            hit |= any(poly.intersection(t).area > 1e-14 for t in [table, *boxes])
        hit |= any(obj.intersects(b) and obj.intersection(b).length > 1e-9 for b in boxes)
        out.append(hit)
    return np.array(out)


@pytest.mark.parametrize("name", ["reference_asymmetric", "reference_upper_obstacle"])
def test_fcl_agrees_with_polygon_oracle(scenes, name):
    scene = scenes[name]
    if name == "reference_asymmetric":  # add a box obstacle in the digits' way too
        scene = dataclasses.replace(scene, obstacles=[Box("block", (0.02, 0.0), (0.05, 0.02))])
    rng = np.random.default_rng(2)
    n = 3000
    q = np.column_stack([rng.uniform(0, math.pi / 2, n), rng.uniform(0.3, 1, n), rng.uniform(0, math.radians(110), n)])
    fcl_hit = CollisionChecker(scene.collision_model()).in_collision(q)
    expected = oracle(scene, q)
    assert 0.05 < expected.mean() < 0.95
    disagree = np.flatnonzero(fcl_hit != expected)
    assert len(disagree) <= 3, q[disagree]  # at most grazing contacts, where the tolerances differ


def test_contacts_name_the_bodies(scenes):
    scene = scenes["reference_upper_obstacle"]
    # digits upright at the start's finger position: the finger reaches into the upper corner
    q = np.array([math.radians(30), 0.8, math.radians(60)])
    names = CollisionChecker(scene.collision_model()).contacts(q)
    assert "finger/upper_corner" in names
    assert CollisionChecker(scene.collision_model()).contacts(scene.start) == []


# -- solids: 3D convex bodies fixed in the world (a layout's walls and pieces) ------------------

def _mesh_object(vertices, triangles, rotation=np.eye(3), translation=np.zeros(3)):
    import fcl

    model = fcl.BVHModel()
    model.beginModel(len(vertices), len(triangles))
    model.addSubModel(np.asarray(vertices, dtype=float), np.asarray(triangles, dtype=np.int64))
    model.endModel()
    return fcl.CollisionObject(model, fcl.Transform(rotation, translation))


def _box_triangles():
    faces = [(0, 1, 2, 3), (4, 7, 6, 5), (0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0)]
    return [t for a, b, c, d in faces for t in ((a, b, c), (a, c, d))]


def _world_oracle(scene, q, down=0.0, clearance=0.0):
    """Per state: the thumb, finger or housing (boxes and prisms placed in the world through the
    plane frame, meshes built here) hits a solid (meshes of their own vertices' hulls, which are
    boxes and prisms here), or reaches below the table; with down (m), the bodies meet the solids
    that much lower in the world, and with clearance (m), reaching below that height in the plan
    is meeting the table."""
    import fcl
    from scipy.spatial import ConvexHull

    from ungrasp_ompl.mechanics.kinematics import aperture, digit_axis, thumb_normal

    l, dg = scene.object_length, scene.digits
    frame = scene.plane.frame
    rot, origin = frame[:3, :3], frame[:3, 3]
    solids = []
    for s in scene.solids:
        hull = ConvexHull(s.vertices)
        solids.append(_mesh_object(s.vertices, hull.simplices))
    thumb, finger = digit_polygons(q[:, 0], q[:, 1], q[:, 2], dg)
    e, n = digit_axis(q[:, 0], q[:, 2]), thumb_normal(q[:, 0], q[:, 2])
    half = dg.width * l / 2
    out = []
    for i in range(len(q)):
        bodies = [(thumb[i] * l, half), (finger[i] * l, half)]
        centre = thumb[i, 0] + (dg.thumb_length + dg.palm_length / 2) * -e[i] \
            + aperture(q[i, 1], q[i, 2], dg.object_thickness, dg.finger_tip_radius) / 2 * n[i]
        a, c = dg.palm_length / 2 * -e[i], dg.palm_width / 2 * n[i]
        palm = np.array([centre - a - c, centre + a - c, centre + a + c, centre - a + c]) * l
        bodies.append((palm, dg.palm_thickness * l / 2))
        hit = False
        for outline, w in bodies:
            hit |= bool(outline[:, 1].min() < clearance - 1e-9)  # the table
            plane_pts = np.vstack([np.column_stack([outline[:, 0], np.full(4, -w), outline[:, 1]]),
                                   np.column_stack([outline[:, 0], np.full(4, w), outline[:, 1]])])
            body = _mesh_object(plane_pts @ rot.T + origin - [0.0, 0.0, down], _box_triangles())
            hit |= any(fcl.collide(body, s, fcl.CollisionRequest(), fcl.CollisionResult()) > 0 for s in solids)
        out.append(hit)
    return np.array(out)


def test_solids_agree_with_a_world_frame_oracle():
    """The planar checker, which moves the solids into the plane frame, against meshes of the
    digits and housing placed in the world: same verdict on states near a layout's walls."""
    from pathlib import Path

    from ungrasp_ompl.layout.model import Layout

    layout = Layout.from_file(Path(__file__).resolve().parents[1] / "scenes" / "tangram.yaml")
    names = [p.name for p in layout.pieces]
    scene = layout.scene(names.index("medium_triangle"), placed=[names.index("square"), names.index("parallelogram")])
    rng = np.random.default_rng(5)
    n = 400
    q = np.column_stack([rng.uniform(0, math.radians(30), n), rng.uniform(0.3, 0.9, n),
                         rng.uniform(0, math.radians(110), n)])
    got = CollisionChecker(scene.collision_model()).in_collision(q)  # the object's prism too, clear of the solids here
    expected = _world_oracle(scene, q, down=scene.robot.start_press,  # the layout's own press and clearance
                             clearance=scene.digits.table_clearance * scene.object_length)
    assert 0.1 < expected.mean() < 0.9
    disagree = np.flatnonzero(got != expected)
    assert len(disagree) == 0, q[disagree]


def test_a_start_press_meets_the_solids_where_the_hand_runs():
    """With robot.start_press p the hand runs p lower than planned: the checker meets the solids
    with the digits and housing p lower in the world (the oracle's meshes moved down) and the table
    with the planned digits above the scene's clearance, near a layout's walls and a placed piece;
    the press decides some of the states."""
    from pathlib import Path

    import yaml

    from ungrasp_ompl.layout.model import Layout

    doc = yaml.safe_load((Path(__file__).resolve().parents[1] / "scenes" / "tangram.yaml").read_text())
    p, c = 0.002, 0.003
    doc["planning"] = {"table_clearance": c}
    doc["robot"]["start_press"] = p
    layout = Layout.from_dict(doc)
    names = [piece.name for piece in layout.pieces]
    scene = layout.scene(names.index("small_triangle_1"), placed=[names.index("medium_triangle")])
    rng = np.random.default_rng(7)
    n = 400
    q = np.column_stack([rng.uniform(0, math.radians(30), n), rng.uniform(0.3, 0.9, n),
                         rng.uniform(0, math.radians(110), n)])
    got = CollisionChecker(scene.collision_model()).in_collision(q)
    expected = _world_oracle(scene, q, down=p, clearance=c)
    assert (expected != _world_oracle(scene, q, clearance=c)).sum() >= 5
    disagree = np.flatnonzero(got != expected)
    assert len(disagree) == 0, q[disagree]


def test_opening_sweeps_the_finger_into_a_block_beside_it(scenes):
    """A small block 3 mm beyond the finger tip's back corner, along n_B: clear at rest, hit when
    the gripper opens by 5 mm (the finger moves along n_B), clear when it opens by 2 mm; opened
    about the palm (open_symmetric, the finger moving half as far), hit at 6 mm, clear at 4 mm."""
    from ungrasp_ompl.mechanics.kinematics import finger_tip, thumb_normal

    scene = scenes["reference_asymmetric"]
    l = scene.object_length
    q = np.array([math.radians(20), 0.7, math.radians(40)])
    a = finger_tip(q[0], q[1]) * l
    spot = a + (scene.digits.finger_tip_thickness * l + 0.003) * thumb_normal(q[0], q[2])
    block = Box("block", tuple(spot - 0.0005), tuple(spot + 0.0005))
    scene = dataclasses.replace(scene, obstacles=[block])
    checker = CollisionChecker(scene.collision_model())
    assert not checker.in_collision(q)[0]
    assert checker.termination_collides(q, "open", 0.005)[0]
    assert not checker.termination_collides(q, "open", 0.002)[0]
    # the gripper's own opening moves the finger by half of it
    assert checker.termination_collides(q, "open_symmetric", 0.006)[0]
    assert not checker.termination_collides(q, "open_symmetric", 0.004)[0]


def test_open_lift_meets_the_table_where_the_gripper_s_own_opening_does(scenes):
    """open_lift lowers the thumb as far as open_symmetric does and the housing not at all, so
    against a flat table the two releases collide at the same states (a grid over the planning
    box of the pick, whose housing and digits are drawn to scale; the thumb's tip is near the table
    in some of them)."""
    from conftest import SCENES
    from ungrasp_ompl import Scene

    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    checker = CollisionChecker(scene.collision_model())
    th, d, ps = np.meshgrid(np.radians(np.linspace(2, 30, 15)), np.linspace(0.4, 0.95, 12),
                            np.radians(np.linspace(0, 60, 13)), indexing="ij")
    q = np.column_stack([th.ravel(), d.ravel(), ps.ravel()])
    q = q[~checker.in_collision(q)]
    for amount in (0.004, 0.008, 0.016):
        lift = checker.termination_collides(q, "open_lift", amount)
        assert np.array_equal(lift, checker.termination_collides(q, "open_symmetric", amount))
        assert 0 < lift.sum() < len(q)


def test_planar_hull_agrees_with_qhull():
    """The planar hull (monotone chain) against scipy's Qhull on random point sets, with collinear
    and repeated points: the same vertices, counter-clockwise."""
    from scipy.spatial import ConvexHull

    from ungrasp_ompl.geometry.solids import convex_hull_2d

    rng = np.random.default_rng(7)
    for n in range(3, 60):
        p = rng.normal(size=(n, 2))
        p = np.vstack([p, p[:3], 0.5 * (p[0] + p[1])[None]])  # repeats and a midpoint
        hull = convex_hull_2d(p)
        qhull = p[ConvexHull(p).vertices]
        assert {tuple(v) for v in hull} == {tuple(v) for v in qhull}
        signed_area = np.sum(hull[:, 0] * np.roll(hull[:, 1], -1) - np.roll(hull[:, 0], -1) * hull[:, 1])
        assert signed_area > 0


def test_prism_shape_collides_like_the_hull_of_its_corners():
    """An extruded planar hull and the 3D hull of the same corners (Qhull) give FCL the same body:
    the same answers against boxes placed at random."""
    import fcl

    from ungrasp_ompl.geometry.solids import convex_shape, prism_shape

    rng = np.random.default_rng(3)
    poly = rng.normal(size=(12, 2))
    a = fcl.CollisionObject(prism_shape(poly, 0.0, 0.3))
    corners = np.vstack([np.column_stack([poly, np.zeros(12)]), np.column_stack([poly, np.full(12, 0.3)])])
    b = fcl.CollisionObject(convex_shape(corners))
    hits = 0
    for _ in range(300):
        box = fcl.CollisionObject(fcl.Box(0.2, 0.2, 0.2), fcl.Transform(rng.uniform([-2.5, -2.5, -0.2], [2.5, 2.5, 0.5])))
        ra = fcl.collide(a, box, fcl.CollisionRequest(), fcl.CollisionResult()) > 0
        rb = fcl.collide(b, box, fcl.CollisionRequest(), fcl.CollisionResult()) > 0
        assert ra == rb
        hits += ra
    assert 20 < hits < 280  # both outcomes were tried


def test_exact_planar_narrow_phase_agrees_with_fcl():
    """Against the frame's walls and placed pieces (upright prisms) the digits and housing are
    checked in numpy; FCL is the oracle (exact_planar=False): the same answers on states spread
    over the planning box of several pieces of the tangram, collisions and letting go alike."""
    from ungrasp_ompl.layout.model import Layout
    from ungrasp_ompl.planning.atlas import planning_box
    from ungrasp_ompl.shipped import resolve
    from ungrasp_ompl.layout.tiler import approaches

    layout = Layout.from_file(resolve("tangram", "layout"))
    n = len(layout.pieces)
    rng = np.random.default_rng(11)
    hits = solid_hits = states = 0
    for i in range(n):
        placed = [j for j in range(n) if j != i][: (2 * i) % n]
        for a in approaches(layout, i, placed, 2):
            scene = layout.scene(i, (a.g, a.b), placed)
            model = scene.collision_model()
            exact, oracle = CollisionChecker(model), CollisionChecker(model, exact_planar=False)
            box = planning_box(scene)
            q = rng.uniform(box[0], box[1], size=(3000, 3))
            q[:, 0] = np.round(q[:, 0], 1)  # few distinct theta, as on a lattice (the object goes to FCL)
            got = exact.in_collision(q)
            assert np.array_equal(got, oracle.in_collision(q))
            assert np.array_equal(exact.termination_collides(q[:500], "rotate", 0.3),
                                  oracle.termination_collides(q[:500], "rotate", 0.3))
            bare = CollisionChecker(dataclasses.replace(model, solids=())).in_collision(q)
            hits += int(got.sum())
            solid_hits += int((got & ~bare).sum())  # decided against the walls and pieces
            states += len(q)
    assert 0 < solid_hits and hits < states


def test_table_clearance_keeps_every_body_that_far_above_the_table():
    """planning.table_clearance c: a state is valid with it exactly when it is valid without it
    and no digit nor the housing reaches below the height c (shapely on their outlines); the
    lattice's collision check, the kinematic margin and the loader agree."""
    import yaml

    from ungrasp_ompl import Scene
    from ungrasp_ompl.errors import InputError
    from ungrasp_ompl.mechanics.kinematics import housing_centre, housing_offsets

    from conftest import SCENES

    doc = yaml.safe_load((SCENES / "guitar_pick.yaml").read_text())
    doc.setdefault("planning", {})["table_clearance"] = 0.0
    doc["planning"]["across_margin"] = 0.0  # the table alone: A's supports across the plane aside
    doc.setdefault("robot", {})["start_press"] = 0.0
    doc["robot"].pop("end_press")
    base = Scene.from_dict(doc)
    c = 0.0015
    doc["planning"]["table_clearance"] = c
    scene = Scene.from_dict(doc)
    l, dg = scene.object_length, scene.digits
    rng = np.random.default_rng(5)
    n = 2000
    q = np.column_stack([rng.uniform(0.0, math.radians(40), n), rng.uniform(0.3, 1.0, n),
                         rng.uniform(0.0, math.radians(80), n)])
    thumb, finger = digit_polygons(q[:, 0], q[:, 1], q[:, 2], dg)
    housing = housing_centre(q[:, 0], q[:, 1], q[:, 2], dg)[:, None, :] + housing_offsets(q[:, 0], q[:, 2], dg)
    raised = shapely.box(-1e3, -1e3, 1e3, c)
    below = np.array([any(shapely.Polygon(p[i] * l).intersection(raised).area > 1e-14 for p in (thumb, finger, housing))
                      for i in range(n)])
    valid, valid0 = scene.is_valid(q), base.is_valid(q)
    assert 0.02 < (valid0 & below).mean() < 0.5  # the clearance matters on a fair share of the states
    disagree = np.flatnonzero(valid != (valid0 & ~below))
    assert len(disagree) <= 2, q[disagree]  # at most states grazing the height c
    margin = scene.margin(q).kinematic["table"]
    assert np.allclose(margin, base.margin(q).kinematic["table"] - c)
    # the lattice's check, state by state, as in_collision's
    axes = (np.linspace(0.05, 0.6, 12), np.linspace(0.4, 1.0, 7), np.linspace(0.0, 1.2, 13))
    checker = CollisionChecker(scene.collision_model())
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    lattice = checker.in_collision_lattice(axes)
    assert lattice.any() and not lattice.all()
    assert np.array_equal(lattice.ravel(), checker.in_collision(grid))
    doc["planning"]["table_clearance"] = -0.001
    with pytest.raises(InputError, match="planning.table_clearance"):
        Scene.from_dict(doc)
    # a start press runs the digits that much lower: no deeper than the clearance
    doc["planning"]["table_clearance"] = c
    doc["robot"]["start_press"] = c
    assert Scene.from_dict(doc).robot.start_press == c
    doc["robot"]["start_press"] = 1.5 * c
    with pytest.raises(InputError) as err:
        Scene.from_dict(doc)
    assert err.value.field == "robot.start_press"
    # the last P_theta only lets the press out: robot.end_press no deeper than the start press
    doc["robot"]["start_press"] = c
    doc["robot"]["end_press"] = c / 2
    assert Scene.from_dict(doc).robot.final_press == c / 2
    doc["robot"]["end_press"] = 2 * c
    with pytest.raises(InputError) as err:
        Scene.from_dict(doc)
    assert err.value.field == "robot.end_press"
    del doc["robot"]["end_press"]
    assert Scene.from_dict(doc).robot.final_press == c  # nothing let out
