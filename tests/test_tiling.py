"""Tiling a layout: the shipped tangram put into its frame piece by piece, checked in 3D with
python-fcl against the frame and the pieces already down; a frame too tight for the thumb; bad
layouts."""

from __future__ import annotations

import functools
import json
import math
import os
import time
from dataclasses import replace

import fcl
import numpy as np
import pinocchio as pin
import pytest
import yaml

from conftest import SCENES, run_cli
from ungrasp_ompl.errors import InputError
from ungrasp_ompl.geometry.plane import flush
from ungrasp_ompl.layout.model import Layout
from ungrasp_ompl.planning.plan_tolerance import tolerance
from ungrasp_ompl.planning.setup import PlannerOptions
from ungrasp_ompl.planning.result import Plan, PlanOutcome, PrimitiveStep, Solution
from ungrasp_ompl.robot.export import read_json
from ungrasp_ompl.robot.model import configuration, load_ur5e
from ungrasp_ompl.robot.pipeline import gripper_spec
from ungrasp_ompl.robot.placement import densify
from ungrasp_ompl.scene import Scene
from ungrasp_ompl.layout.tiler import (DigitsDoNotFit, GoalStates, TilingOptions, approach_scene, approaches, screen,
                                      tile)

TANGRAM = SCENES / "tangram.yaml"
#: The tangram's pieces.
PIECES = ("large_triangle_1", "large_triangle_2", "medium_triangle", "small_triangle_1", "square",
          "small_triangle_2", "parallelogram")


# -- an independent 3D model of the table top: triangle meshes built here, not by the library ---

def _mesh(vertices: np.ndarray, triangles: list[tuple[int, int, int]]) -> fcl.BVHModel:
    model = fcl.BVHModel()
    model.beginModel(len(vertices), len(triangles))
    model.addSubModel(np.asarray(vertices, dtype=float), np.asarray(triangles, dtype=np.int64))
    model.endModel()
    return model


def _prism_mesh(polygon: np.ndarray, bottom: float, top: float) -> fcl.BVHModel:
    """A closed triangle mesh of a vertical prism over a convex polygon (N, 2)."""
    n = len(polygon)
    verts = np.vstack([np.column_stack([polygon, np.full(n, bottom)]), np.column_stack([polygon, np.full(n, top)])])
    tris = [(0, k + 1, k) for k in range(1, n - 1)] + [(n, n + k, n + k + 1) for k in range(1, n - 1)]
    for k in range(n):
        j = (k + 1) % n
        tris += [(k, j, n + j), (k, n + j, n + k)]
    return _mesh(verts, tris)


def _walls(doc: dict) -> dict[str, fcl.CollisionObject]:
    """The frame's four walls from the layout file's numbers (frame yaw 0 in the shipped layout)."""
    fr = doc["frame"]
    assert fr.get("yaw_deg", 0) == 0
    cx, cy = fr["center"]
    w = fr["inner_size"]
    t, h = fr["wall_thickness"], fr["wall_height"]
    out = {}
    for name, (x, y, sx, sy) in {"south": (cx, cy - w / 2 - t / 2, w + 2 * t, t),
                                 "north": (cx, cy + w / 2 + t / 2, w + 2 * t, t),
                                 "west": (cx - w / 2 - t / 2, cy, t, w), "east": (cx + w / 2 + t / 2, cy, t, w)}.items():
        out[name] = fcl.CollisionObject(fcl.Box(sx, sy, h), fcl.Transform(np.array([x, y, h / 2])))
    return out


@functools.lru_cache(maxsize=4)
def _spread_shifts(doc: str) -> np.ndarray:
    """The shifts (N, 2) the layout file (as JSON text) spreads its pieces by: loading a layout takes
    half a second, and the footprints are asked for piece by piece."""
    return Layout.from_dict(json.loads(doc)).spread.shifts


def _footprint(doc: dict, name: str) -> np.ndarray:
    """A piece's target outline in the world (m), from the layout file's numbers (moved by the
    spread where the file asks for one: its shifts are checked against shapely in test_spread)."""
    k, piece = next((k, p) for k, p in enumerate(doc["pieces"]) if p["name"] == name)
    fr = doc["frame"]
    corner = np.asarray(fr["center"]) - fr["inner_size"] / 2
    yaw = math.radians(piece["target"].get("yaw_deg", 0))
    rot = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    shift = _spread_shifts(json.dumps(doc))[k] if doc.get("spread") else 0.0
    return np.asarray(piece["outline"]["polygon"]) @ rot.T + np.asarray(piece["target"]["position"]) + corner + shift


def _collides(a: fcl.CollisionObject, b: fcl.CollisionObject) -> bool:
    return fcl.collide(a, b, fcl.CollisionRequest(), fcl.CollisionResult()) > 0


@pytest.fixture(scope="module")
def tiled(tmp_path_factory):
    """`ungrasp-ompl tile scenes/tangram.yaml` as a user runs it (with a seed), and what it wrote."""
    out = tmp_path_factory.mktemp("tiles")
    proc = run_cli("tile", str(TANGRAM), "--seed", "1", "--out", str(out))
    return proc, out, yaml.safe_load(TANGRAM.read_text())


@pytest.mark.slow
def test_tile_places_all_seven_pieces_and_writes_its_files(tiled):
    proc, out, doc = tiled
    assert proc.returncode == 0, proc.stderr
    result = json.loads((out / "tiling.json").read_text())
    assert result["solved"] and result["failed_piece"] is None
    assert sorted(result["order"]) == sorted(p["name"] for p in doc["pieces"])
    assert "order " + ", ".join(result["order"]) in proc.stdout
    spread = result["spread"]  # the file asks for it: the gaps and each piece's shift, as the layout has them
    assert spread["gap_m"] > spread["gap_before_m"] + 1e-3 and sorted(spread["shifts_m"]) == sorted(result["order"])
    assert f"targets spread: the narrowest gap {spread['gap_before_m'] * 1000:.1f} mm" in proc.stdout
    assert result["placed_clearance_m"] == doc["placed_clearance"] > 0
    for k, name in enumerate(result["order"], start=1):
        assert f"{k}. {name}: G (" in proc.stdout  # the per-piece summary
        assert (out / f"cspace_{k}_{name}.png").stat().st_size > 10_000
    assert (out / "layout.png").stat().st_size > 10_000
    for f in ("trajectory.csv", "trajectory.json", "trajectory_ros2_arm.yaml", "trajectory_ros2_gripper.yaml",
              "trajectory.urscript", "touch_off.urscript"):
        assert (out / f).stat().st_size > 0
    for p in result["placements"]:
        plan = p["plan"]
        assert plan["solved"] and plan["states"][-1][0] <= math.radians(doc["goal"]["theta_max_deg"]) + 1e-9  # put down
        assert plan["manipulation_plane"]["G"] == pytest.approx(p["approach"]["G"])


@pytest.mark.slow
def test_each_piece_misses_the_frame_and_earlier_pieces_in_3d(tiled):
    """Along every planned path, the piece (its outline's prism, tilted about the plane's normal
    through G) stays clear of the walls, and the layout's placed_clearance off the pieces put down
    before it (fcl meshes and distances)."""
    proc, out, doc = tiled
    assert proc.returncode == 0, proc.stderr
    result = json.loads((out / "tiling.json").read_text())
    layout = Layout.from_file(TANGRAM)
    walls = _walls(doc)
    thickness = {p["name"]: p["thickness"] for p in doc["pieces"]}
    down: dict[str, fcl.CollisionObject] = {}
    checked = 0
    for p in result["placements"]:
        name, plan = p["piece"], p["plan"]
        frame = np.asarray(plan["manipulation_plane"]["frame"])
        g = frame[:3, 3]
        outline = _footprint(doc, name)
        local = np.column_stack([(outline - g[:2]) @ frame[:2, :2], np.zeros(len(outline))])  # plane coordinates
        body = _prism_mesh(local[:, :2], 0.0, thickness[name])
        obj = fcl.CollisionObject(body)
        scene = layout.scene([q.name for q in layout.pieces].index(name), (p["approach"]["G"], p["approach"]["B"]))
        steps = [PrimitiveStep(**s) for s in plan["primitives"]]
        states, _ = densify(Plan(outcome=PlanOutcome.SOLVED, scene=name, planner="", seed=None, sliding_model="",
                                 solution=Solution(plan["states"], steps)), angle_step=math.radians(0.5))
        for theta in np.unique(states[:, 0]):
            # tilt by theta about the plane's y axis through G (x toward z), then into the world
            c, s = math.cos(theta), math.sin(theta)
            tilt = np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])
            obj.setTransform(fcl.Transform(frame[:3, :3] @ tilt, g))
            for other, target in walls.items():
                assert not _collides(obj, target), f"{name} hits {other} at theta {math.degrees(theta):.1f} deg"
            for other, target in down.items():
                gap = fcl.distance(obj, target, fcl.DistanceRequest(), fcl.DistanceResult())
                assert gap >= layout.placed_clearance - 1e-6, f"{name} {gap * 1000:.3f} mm from {other}"
                checked += 1
        assert scene.object_length == pytest.approx(np.linalg.norm(np.subtract(p["approach"]["B"], p["approach"]["G"])))
        down[name] = fcl.CollisionObject(_prism_mesh(outline, 0.0, thickness[name]))
    assert checked > 100


@pytest.mark.slow
def test_robot_misses_the_frame_and_earlier_pieces_in_3d(tiled):
    """Every sample of the exported trajectory: the gripper and wrist (forward kinematics of the
    URDF's collision geometry) clear the walls and the pieces down at that time (fcl meshes)."""
    proc, out, doc = tiled
    assert proc.returncode == 0, proc.stderr
    result = json.loads((out / "tiling.json").read_text())
    traj = read_json(out / "trajectory.json")
    layout = Layout.from_file(TANGRAM)
    robot = load_ur5e(gripper_spec(layout.scene(0)), np.array(layout.scene(0).robot.base))
    gdata = pin.GeometryData(robot.collision_model)
    shapes = {}
    for k, g in enumerate(robot.collision_model.geometryObjects):
        geo = g.geometry
        kind = type(geo).__name__
        if kind == "Box":
            shapes[k] = fcl.CollisionObject(fcl.Box(*(2 * np.asarray(geo.halfSide))))
        elif kind == "Cylinder":
            shapes[k] = fcl.CollisionObject(fcl.Cylinder(geo.radius, 2 * geo.halfLength))
    names = {k: robot.collision_model.geometryObjects[k].name for k in shapes}
    near = [k for k in shapes if names[k].startswith(("gripper", "wrist"))]
    assert len(near) >= 3
    walls = _walls(doc)
    order = result["order"]
    checked = 0
    for seg, a, b in traj.segments:
        piece = seg.split("/")[0]
        targets = dict(walls)
        for earlier in order[:order.index(piece)]:
            thick = next(p["thickness"] for p in doc["pieces"] if p["name"] == earlier)
            targets[earlier] = fcl.CollisionObject(_prism_mesh(_footprint(doc, earlier), 0.0, thick))
        for i in range(a, b + 1, 2):
            pin.forwardKinematics(robot.model, robot.data, configuration(robot, traj.positions[i]))
            pin.updateGeometryPlacements(robot.model, robot.data, robot.collision_model, gdata)
            for k in near:
                m = gdata.oMg[k]
                shapes[k].setTransform(fcl.Transform(m.rotation, m.translation))
                for tname, target in targets.items():
                    assert not _collides(shapes[k], target), f"{names[k]} hits {tname} in {seg} at sample {i}"
                    checked += 1
    assert checked > 10_000


# -- a frame too tight for the thumb ---------------------------------------------------------

def _square_in_frame(tmp_path, clearance: float) -> str:
    """One tangram square alone in a square frame that leaves clearance (m) on every side."""
    doc = yaml.safe_load(TANGRAM.read_text())
    square = next(p for p in doc["pieces"] if p["name"] == "square")
    poly = np.asarray(square["outline"]["polygon"])
    half = float(np.max(np.abs(poly))) + clearance
    square["target"] = {"position": [half, half], "yaw_deg": 0}
    doc["pieces"] = [square]
    doc["frame"]["inner_size"] = 2 * half
    path = tmp_path / f"square_{clearance}.yaml"
    path.write_text(yaml.safe_dump(doc))
    return str(path)


def test_frame_too_tight_for_the_thumb_names_the_piece_and_exits_3(tmp_path):
    proc = run_cli("tile", _square_in_frame(tmp_path, 0.0005), "--out", str(tmp_path / "out"))
    assert proc.returncode == 3, proc.stdout + proc.stderr
    assert "piece 'square' cannot be placed" in proc.stdout
    assert "wall_" in proc.stdout  # the reasons name the walls the digits would hit
    assert (tmp_path / "out" / "layout.png").exists() and not (tmp_path / "out" / "trajectory.csv").exists()
    written = json.loads((tmp_path / "out" / "tiling.json").read_text())
    assert written["failed_piece"] == "square" and written["down_before"] == [] and written["reasons"]
    assert {r["kind"] for r in written["reasons"]} <= {"ends", "digits_do_not_fit"}  # values, not sentences


def test_a_tiling_that_fails_gives_its_reasons_as_values(tmp_path):
    """The same square, through the library: every reason is a Rejection with the value behind it,
    and the screen's evidence says which check failed with which solid."""
    from ungrasp_ompl.planning.setup import EndsProblem
    from ungrasp_ompl.layout.tiler import Rejection

    result = tile(Layout.from_file(_square_in_frame(tmp_path, 0.0005)),
                  TilingOptions(planner=PlannerOptions(planner="lattice")))
    assert not result.solved and result.failed_piece == "square" and result.down_before == []
    ends = [r for r in result.reasons if r.kind is Rejection.ENDS]
    assert ends and all(isinstance(r.evidence, EndsProblem) and r.approach is not None for r in ends)
    assert any("wall_" in json.dumps(r.evidence.evidence) for r in ends)


@pytest.mark.slow
def test_the_same_square_with_room_is_placed(tmp_path):
    """The control: with 15 mm around it the square goes in."""
    proc = run_cli("tile", _square_in_frame(tmp_path, 0.015), "--planner", "lattice", "--out", str(tmp_path / "out"))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "1. square: G (" in proc.stdout



@pytest.mark.slow
def test_a_piece_unprovable_after_two_others_goes_before_them(monkeypatch):
    """The proof of large_triangle_2 made to fail whenever the square and large_triangle_1 are
    both down (NO_SECURE_PATH, as the lattice search answers where no secure path exists): the
    search backs out of every order that puts both before it, meets the same set of pieces again
    in another order, and finds one that puts large_triangle_2 down earlier. Each (pieces down,
    piece) is proved once. (A set met again used to end the command with a TypeError.)"""
    import ungrasp_ompl.layout.tiler as tiling

    real, proved = tiling.prove, []

    def prove(scene):
        down = frozenset(s.name for s in scene.solids if s.name in PIECES)
        proved.append((scene.name, down))
        if "large_triangle_2" in scene.name and {"square", "large_triangle_1"} <= down:
            return PlanOutcome.NO_SECURE_PATH, real(scene)[1]
        return real(scene)

    monkeypatch.setattr(tiling, "prove", prove)
    result = tile(Layout.from_file(TANGRAM), TilingOptions(planner=PlannerOptions(planner="lattice"), approaches=1))
    order = [p.name for p in result.placements]
    assert result.solved and sorted(order) == sorted(PIECES)
    assert order.index("large_triangle_2") < max(order.index("square"), order.index("large_triangle_1"))
    assert len(proved) == len(set(proved))
    assert any("large_triangle_2" in name and {"square", "large_triangle_1"} <= down for name, down in proved)


@pytest.mark.slow
def test_each_piece_takes_the_approach_whose_plan_tolerates_most(tmp_path):
    """Ranked by tolerance, a piece's approach is the one whose exact lattice plan has the largest
    tolerance among its approaches that pass the screen and the proof, recomputed here approach by
    approach through the public steps; ranked first, the search's choice, which tolerates no more."""
    from ungrasp_ompl.planning import plan
    from ungrasp_ompl.layout.tiler import Rank, prove

    layout = Layout.from_file(_square_in_frame(tmp_path, 0.015))
    best = -math.inf
    for a in approaches(layout, 0, [], TilingOptions().approaches):
        scene = approach_scene(layout, 0, a, [])
        if isinstance(scene, DigitsDoNotFit) or screen(scene) is not None or prove(scene)[0] is not None:
            continue
        best = max(best, tolerance(scene, plan(scene, planner="lattice")).scale)
    ranked = tile(layout, TilingOptions(planner=PlannerOptions(planner="lattice"), rank="tolerance"))
    first = tile(layout, TilingOptions(planner=PlannerOptions(planner="lattice")))  # the default: the search's choice
    (chosen,), (searched,) = ranked.placements, first.placements
    assert chosen.tolerance == pytest.approx(best, rel=1e-12) and chosen.ranked > 1
    assert chosen.tolerance == tolerance(chosen.scene, chosen.plan).scale
    assert searched.tolerance <= chosen.tolerance and searched.ranked == 1
    assert ranked.to_dict()["placements"][0]["tolerance"] == chosen.tolerance
    with pytest.raises(InputError) as err:
        tile(layout, TilingOptions(rank="loosest"))
    assert err.value.field == "rank" and Rank("first") is Rank.FIRST


# -- the approaches -------------------------------------------------------------------------
def test_an_approach_whose_plane_the_digits_do_not_fit_is_a_reason_not_an_error():
    """With a grippy thumb (friction B 1.2, known exactly) some pairs G, B are so short that the
    finger's extra length over |GB| (digits.alpha) leaves (-1, 1): such an approach is ruled out
    with the scene's own words, and every other one still gives the scene."""
    doc = yaml.safe_load(TANGRAM.read_text())
    doc["friction"].update(B=1.2, uncertainty=0)
    layout = Layout.from_dict(doc)
    names = [p.name for p in layout.pieces]
    i, placed = names.index("small_triangle_1"), []
    answers = [approach_scene(layout, i, a, placed) for a in approaches(layout, i, placed, 6)]
    refused = [a for a in answers if isinstance(a, DigitsDoNotFit)]
    assert refused and all(r.field == "digits.alpha" for r in refused)
    assert any(isinstance(a, Scene) for a in answers)



def test_room_beyond_b_is_the_gap_to_the_wall(tmp_path):
    """A square 4 mm from every wall: an approach whose GB points straight at a wall measures
    4 mm of room beyond B (and behind G), the digits' width included."""
    doc = yaml.safe_load(TANGRAM.read_text())
    side = 0.03
    doc["pieces"] = [{"name": "block", "thickness": 0.003,
                      "outline": {"polygon": [[0, 0], [side, 0], [side, side], [0, side]]},
                      "target": {"position": [0.004, 0.004]}}]
    doc["frame"]["inner_size"] = side + 0.008
    path = tmp_path / "block.yaml"
    path.write_text(yaml.safe_dump(doc))
    layout = Layout.from_file(path)
    found = approaches(layout, 0, [], 50)
    straight = [a for a in found if abs(math.sin(2 * a.yaw)) < 1e-9]  # along a wall normal
    assert straight
    for a in straight:
        assert a.room_b == pytest.approx(0.004) and a.room_g == pytest.approx(0.004)
    # at a contact inside a side, GB lies inside that side's friction cone (G: 0.35, B: 0.45)
    for a in found:
        chord = (a.b - a.g) / np.linalg.norm(a.b - a.g)
        for point, direction, mu in ((a.g, chord, 0.35), (a.b, -chord, 0.45)):
            on = [k for k in range(2) for v in (0.0, side) if abs(point[k] - v) < 1e-9]
            if len(on) == 1:  # inside a side (not a corner): its inward normal
                k = on[0]
                normal = np.zeros(2)
                normal[k] = 1.0 if point[k] < side / 2 else -1.0
                assert math.acos(np.clip(direction @ normal, -1, 1)) < math.atan(mu) + 1e-9


def _inside_a_side_square_to(point: np.ndarray, u: np.ndarray, vertices: np.ndarray) -> bool:
    """Oracle from the sides: point lies inside a side (not at its ends) whose direction is square
    to u."""
    for a, b in zip(vertices, np.roll(vertices, -1, axis=0)):
        e = b - a
        t = float((point - a) @ e / (e @ e))
        off = np.linalg.norm(a + t * e - point)
        if off < 1e-9 and 1e-6 < t < 1 - 1e-6 and abs(e @ u) / np.linalg.norm(e) < 1e-9:
            return True
    return False


def test_an_edge_contact_is_one_inside_a_side_square_to_gb():
    """geometry.plane.flush against the oracle from the sides, over every ordered pair of contact
    candidates (vertices, and the feet of the double normals) of the tangram's pieces: the table's
    and the thumb's faces contain the plane's normal, so a side holds the object across the plane
    only when it is square to GB and the contact lies inside it."""
    layout = Layout.from_file(TANGRAM)
    checked = flushed = 0
    for piece in layout.pieces:
        outline = piece.object3d.outline
        cand = outline.candidates().joined(outline.double_normals())
        i, j = np.nonzero(~np.eye(len(cand.points), dtype=bool))
        g, b = cand.points[i], cand.points[j]
        far = np.linalg.norm(b - g, axis=1) > 1e-9
        g, b = g[far], b[far]
        on_g, on_b = flush(outline.vertices, g, b)
        for k in range(len(g)):
            u = (b[k] - g[k]) / np.linalg.norm(b[k] - g[k])
            assert on_g[k] == _inside_a_side_square_to(g[k], u, outline.vertices)
            assert on_b[k] == _inside_a_side_square_to(b[k], u, outline.vertices)
            checked += 1
            flushed += bool(on_g[k] or on_b[k])
    assert checked > 200 and 0 < flushed < checked


def test_every_approach_of_a_polygon_has_an_edge_contact():
    """A polygon's contacts are corners or straight sides, so an approach holds x-moments only by a
    side square to GB at G or B (oracle from the sides), whatever pieces are down. The large
    triangle's plane from a corner at G to a side 6 deg off square at B, which the simulator
    turned 36 deg out of the plane (docs/model.md 11.14), is not among them."""
    layout = Layout.from_file(TANGRAM)
    names = [p.name for p in layout.pieces]
    for i, piece in enumerate(layout.pieces):
        for placed in ([], [j for j in range(len(names)) if j != i][:3]):
            found = approaches(layout, i, placed, 12)
            assert found, piece.name
            v = piece.object3d.outline.vertices
            for a in found:
                u = (a.b - a.g) / np.linalg.norm(a.b - a.g)
                assert _inside_a_side_square_to(a.g, u, v) or _inside_a_side_square_to(a.b, u, v), \
                    (piece.name, a.describe())
    big = layout.pieces[names.index("large_triangle_1")].object3d.outline.vertices
    corner = big[np.argmin(big[:, 0])]
    assert not any(np.allclose(a.g, corner) and abs(math.degrees(a.yaw) - 39) < 2
                   for a in approaches(layout, names.index("large_triangle_1"), [], 12))


# -- what the search reuses ----------------------------------------------------------------

@pytest.mark.slow
def test_screens_reusing_what_earlier_screens_learnt_answer_as_fresh_ones():
    """tile() keeps one GoalStates per piece and approach over every set of pieces down (the
    goal states' kinematics and force closure, a witness state where the gripper let go, the
    sets of solids where none could) and reads a piece's scene from the file once: each answer
    equals a screen from scratch of the scene a freshly loaded layout builds, with the sets of
    pieces down one order puts down (their solids only grow) and the same sets the other way."""
    layout = Layout.from_file(TANGRAM)
    n = len(layout.pieces)
    order = [int(k) for k in np.random.default_rng(5).permutation(n)]
    fresh: dict[tuple, str | None] = {}  # the answers from scratch, by piece, approach and pieces down
    seen = {"pass by witness": 0, "pass by search": 0, "fail among fewer solids": 0, "fail by search": 0}
    for sizes in (range(n), range(n - 1, -1, -1)):
        goals: dict[tuple, GoalStates] = {}
        for placed in (order[:k] for k in sizes):
            fresh_layout = Layout.from_file(TANGRAM)
            for i in sorted(set(range(n)) - set(placed)):
                for a in approaches(layout, i, placed, 6):
                    scene = layout.scene(i, (a.g, a.b), placed)
                    key = (i, a.g.tobytes(), a.b.tobytes())
                    if key + (len(placed),) not in fresh:
                        other = fresh_layout.scene(i, (a.g, a.b), placed)
                        assert [s.name for s in scene.solids] == [s.name for s in other.solids]
                        assert all(np.array_equal(s.vertices, t.vertices) for s, t in zip(scene.solids, other.solids))
                        fresh[key + (len(placed),)] = screen(other)
                    if key not in goals:
                        goals[key] = GoalStates(scene)
                    goal = goals[key]
                    witness, failed = goal.witness, len(goal.failed)
                    answer = screen(scene, goal)
                    assert answer == fresh[key + (len(placed),)], (layout.pieces[i].name, placed, a.describe())
                    names = {s.name for s in scene.solids}
                    if answer is None:
                        by_witness = witness is not None and goal.witness is witness
                        seen["pass by witness" if by_witness else "pass by search"] += 1
                    elif any(solids <= names for solids, _ in goal.failed[:failed]):
                        seen["fail among fewer solids"] += 1
                    else:
                        seen["fail by search"] += 1
    assert min(seen.values()) >= 3, seen  # every way through screen() was taken


def _placements(tiling) -> list:
    return [(p.name, p.approach.g.tolist(), p.approach.b.tolist(), p.plan.states, p.tolerance)
            for p in tiling.placements]


def test_a_memo_answers_a_later_tiling_as_a_fresh_search_would():
    """tile() with a TilingMemo of earlier calls on the layout finds what a search from scratch
    finds, with the same checks: the same tiling again computes nothing new, and with the second
    piece's approach avoided (the two large triangles then go down the other way round) it adds
    only what the new approaches need. A memo serves one layout."""
    from ungrasp_ompl.layout.tiler import TilingMemo

    two = {**AS_CUT, "pieces": AS_CUT["pieces"][:2]}
    layout = Layout.from_dict(two)
    options = TilingOptions(planner=PlannerOptions(planner="lattice", seed=1))
    memo = TilingMemo()
    first = tile(layout, options, memo=memo)
    kept = {name: dict(getattr(memo, name)) for name in ("scenes", "screens", "proofs", "plans")}
    again = tile(layout, options, memo=memo)
    assert first.solved and _placements(again) == _placements(first) and again.checks == first.checks

    def unchanged(name, exactly):  # every answer kept is the same object; exactly: and no new one
        now = getattr(memo, name)
        return all(now[k] is v for k, v in kept[name].items()) and (not exactly or now.keys() == kept[name].keys())

    assert all(unchanged(name, True) for name in kept)  # nothing new computed
    p = first.placements[1]
    avoid = replace(options, avoid=((p.name, tuple(p.approach.g), tuple(p.approach.b)),))
    other = tile(layout, avoid, memo=memo)
    fresh = tile(Layout.from_dict(two), avoid)
    assert other.solved and _placements(other) == _placements(fresh) and other.checks == fresh.checks
    assert [q.name for q in other.placements] == [q.name for q in first.placements][::-1]
    assert all(unchanged(name, False) for name in kept) and len(memo.proofs) > len(kept["proofs"])
    with pytest.raises(ValueError, match="TilingMemo"):
        tile(Layout.from_dict(two), options, memo=memo)


def test_order_exists_answers_whether_tile_gets_past_its_search():
    """layout.tiler.order_exists, tile()'s search alone (what sim.tiling.tile_aimed's child answers
    for a retry): on the first two pieces as cut it finds an order, and tile() tiles them; with
    every approach of the first piece avoided it finds none, and tile() fails for want of one of
    that piece's approaches, the other piece down or not."""
    from ungrasp_ompl.layout.tiler import order_exists

    layout = Layout.from_dict({**AS_CUT, "pieces": AS_CUT["pieces"][:2]})
    options = TilingOptions(planner=PlannerOptions(planner="lattice", seed=1))
    assert order_exists(layout, options) and tile(layout, options).solved
    every = approaches(layout, 0, [], options.approaches)
    name = layout.pieces[0].name
    none = replace(options, avoid=tuple((name, tuple(map(float, a.g)), tuple(map(float, a.b))) for a in every))
    assert every and not order_exists(layout, none)
    failed = tile(layout, none)
    assert not failed.solved and failed.failed_piece == name and not failed.placements


def test_a_secure_path_among_more_pieces_is_one_among_fewer():
    """What lets the search take a proof among fewer pieces from one among more without building
    its lattice (TilingMemo.secure_among): after the shipped tangram's search, approaches proven
    with two or more pieces down are proven again, by prove() itself, with one of those pieces
    taken away."""
    from ungrasp_ompl.layout.tiler import TilingMemo, approach_scene, order_exists, prove

    layout = Layout.from_file(TANGRAM)
    options = TilingOptions(planner=PlannerOptions(planner="lattice", seed=1))
    memo = TilingMemo()
    assert order_exists(layout, options, memo)
    wide = [(key, down) for key, sets in memo.secure_among.items() for down in sets if len(down) >= 2]
    assert len(wide) >= 3
    for (i, g, b), down in wide[:6]:
        a = next(a for a in approaches(layout, i, [], 1000) if (a.g.tobytes(), a.b.tobytes()) == (g, b))
        for j in sorted(down)[:2]:
            assert prove(approach_scene(layout, i, a, sorted(down - {j})))[0] is None, (i, down, j)


# -- bad layouts ----------------------------------------------------------------------------

def _bad(tmp_path, change) -> tuple[int, str]:
    doc = yaml.safe_load(TANGRAM.read_text())
    change(doc)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(doc))
    proc = run_cli("tile", str(path), "--out", str(tmp_path / "out"))
    return proc.returncode, proc.stderr


def _overlap(doc):
    doc["pieces"][1]["target"]["position"] = doc["pieces"][0]["target"]["position"]


def _outside(doc):
    doc["pieces"][2]["target"]["position"] = [0.2, 0.02]


def _twice(doc):
    doc["pieces"][3]["name"] = doc["pieces"][0]["name"]


def _no_size(doc):
    del doc["frame"]["inner_size"]


def _unknown(doc):
    doc["pieces"][4]["colour"] = "red"


def _thin(doc):
    doc["pieces"][5]["thickness"] = -0.003


def _degenerate(doc):
    doc["pieces"][6]["outline"] = {"polygon": [[0, 0], [0.01, 0], [0.02, 0]]}


def _offset_unaimed(doc):  # a piece's landing offset where the hand is not aimed by the model
    doc["robot"]["landing"] = "planned"
    for piece in doc["pieces"]:
        piece.pop("landing_offset", None)
    doc["pieces"][2]["landing_offset"] = 0.0005


def _offset_in_mm(doc):
    doc["pieces"][3]["landing_offset"] = 0.5


@pytest.mark.parametrize("change, field", [
    (_overlap, "pieces[1].target"), (_outside, "pieces[2].target"), (_twice, "pieces[3].name"),
    (_no_size, "frame.inner_size"), (_unknown, "pieces[4].colour"), (_thin, "pieces[5].thickness"),
    (_degenerate, "pieces[6].outline.polygon"), (_offset_unaimed, "pieces[2].landing_offset"),
    (_offset_in_mm, "pieces[3].landing_offset"),
])
def test_bad_layout_exits_2_naming_the_field(tmp_path, change, field):
    code, err = _bad(tmp_path, change)
    assert code == 2
    assert field in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "out").exists()  # nothing written


def test_a_piece_s_landing_offset_is_its_scene_s_and_the_shared_one_the_others():
    """pieces[i].landing_offset is piece i's robot.landing_offset; the pieces without one take the
    shared robot section's."""
    doc = yaml.safe_load(TANGRAM.read_text())
    doc["robot"]["landing_offset"] = -0.0002
    for piece in doc["pieces"]:
        piece.pop("landing_offset", None)
    doc["pieces"][1]["landing_offset"] = 0.0007
    layout = Layout.from_dict(doc)
    assert [layout.scene(i).robot.landing_offset for i in range(3)] == [-0.0002, 0.0007, -0.0002]


def test_layout_api_rejects_a_scene_file():
    with pytest.raises(InputError, match="frame"):
        Layout.from_file(SCENES / "puzzle_piece.yaml")


@pytest.mark.parametrize("args, word", [(["--planner", "LazyPRM"], "planner"), (["--planner", "Nope"], "planner"),
                                        (["--time", "0"], "time"), (["--approaches", "0"], "approaches"),
                                        (["--range", "-1"], "range")])
def test_bad_tile_options_exit_2(tmp_path, args, word):
    proc = run_cli("tile", str(TANGRAM), *args, "--out", str(tmp_path / "out"))
    assert proc.returncode == 2 and word in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "out").exists()


# -- aiming each piece by its landing -------------------------------------------------------

#: The shipped tangram as cut, its pieces not spread (2 mm between neighbours) and its plans kept no
#: further from the pieces down than touching, each piece's plan the shortest with its landing's
#: spread unbounded, and aimed by its own simulated release (robot.landing simulated, the aim that
#: carries a turn; the pieces' landing offsets, the model's, dropped): tight enough that some aims do not fit and a piece held off in its grasp starts
#: inside its neighbour.
_SHIPPED = yaml.safe_load(TANGRAM.read_text())
AS_CUT = {**_SHIPPED, "spread": False, "placed_clearance": 0.0, "robot": {**_SHIPPED["robot"], "landing": "simulated"},
          "planning": {k: v for k, v in _SHIPPED["planning"].items() if k not in ("max_landing_spread", "objective")},
          "pieces": [{k: v for k, v in p.items() if k != "landing_offset"} for p in _SHIPPED["pieces"]]}


@pytest.fixture(scope="module")
def aimed():
    """The tangram as cut (AS_CUT) tiled with lattice plans and aimed (robot.landing simulated),
    and the memo of what that worked out (sim.tiling.AimingMemo, which tile_aimed takes)."""
    from ungrasp_ompl.sim.tiling import AimingMemo, aim_tiling

    layout = Layout.from_dict(AS_CUT)
    memo = AimingMemo()
    tiling = tile(layout, TilingOptions(planner=PlannerOptions(planner="lattice", seed=1)), memo=memo.search)
    assert tiling.solved
    return layout, tiling, aim_tiling(layout, tiling, memo.landings, memo.kept), memo


@pytest.mark.slow
def test_each_piece_aimed_by_its_landing_lands_on_its_target(aimed):
    """Each piece's release, simulated with no error drawn and the pieces before it absent, lands
    within 0.2 mm and 0.3 deg of its target when it is aimed by its whole landing, the shift and the
    turn (the square, held off its centre of mass, turns over 2 deg unaimed; the 0.2 mm is the
    release's own repeatability: the medium triangle's aim, 2 mm and 0.04 deg, lands it 0.17 mm
    off). A piece aimed short is one
    whose whole aim would run its object into a piece or wall (checked here with an independent
    fcl mesh of the start, tilted about G and moved by the aim) or its robot into one (the
    trajectory's check); its aim is a share of the whole, its start moved by it is clear, and it
    lands where its unaimed release, moved by the share taken, puts it (within 0.3 mm: the square,
    aimed short, lands 0.26 mm from its unaimed release moved by its share)."""
    from ungrasp_ompl.scene.perturbation import TrialParams
    from ungrasp_ompl.robot.pipeline import CollisionError, execute_sequence
    from ungrasp_ompl.robot.pipeline import Aim
    from ungrasp_ompl.sim.landing import landing_correction, landing_offset, robot_landing
    from ungrasp_ompl.sim.tiling import tiling_setups
    from ungrasp_ompl.sim.trial import run_trial

    layout, tiling, result, memo = aimed
    names = [p.name for p in tiling.placements]
    short = {a.name: (a.taken, a.asked) for a in result.short}
    assert short and set(short) < set(names)
    plain = execute_sequence([(p.scene, p.plan) for p in tiling.placements], labels=names, kept=memo.kept)
    planned = dict(tiling_setups(layout, tiling, plain.trajectory, plain.robot))
    robots = {p.name: p.scene.robot for p in tiling.placements}

    def landing(name):  # the unaimed release as aim_tiling simulated it (kept in the run's landing cache)
        return robot_landing(planned[name], robots[name])

    doc = AS_CUT
    assert abs(landing("square").turn) > math.radians(2)
    for k, (p, (name, setup)) in enumerate(zip(tiling.placements, result.setups)):
        aim = result.execution.aims[k]
        final = np.array(run_trial(setup, TrialParams()).final_pose)
        offset = landing_offset(setup, final)
        landed = np.hypot(*offset)
        if name not in short:
            turn, _ = landing_correction(setup, final)
            assert aim.shift > 0 and landed < 2e-4 and abs(turn) < math.radians(0.3), (name, landed, turn)
            continue
        taken, asked = short[name]
        want = landing(name).aim
        assert want.shift == pytest.approx(asked) and aim.shift == pytest.approx(taken) and taken < asked
        assert np.allclose(aim, want.scaled(taken / asked), atol=1e-12)  # a share of the whole
        aims = [want if j == k else Aim() for j in range(len(names))]
        try:
            execute_sequence([(q.scene, q.plan) for q in tiling.placements], labels=names, aims=aims,
                             kept=memo.kept)
            robot_hits = False
        except CollisionError as exc:
            assert exc.job == k
            robot_hits = True
        assert robot_hits or _start_hits(doc, p, names[:k], want), name
        assert not _start_hits(doc, p, names[:k], aim), name
        # where the unaimed release put the piece, flat: its landing's planar move, the correction's inverse
        target = planned[name].target_pose
        unaimed = np.linalg.inv(landing(name).correction.transform(target[:3, 3])) @ target
        moved = landing_offset(setup, aim.transform(setup.target_pose[:3, 3]) @ unaimed)
        assert np.hypot(*(offset - moved)) < 3e-4, name  # the same release, moved by the aim



@pytest.mark.slow
def test_the_shipped_tangram_aims_each_piece_by_its_modelled_landing():
    """The shipped tangram (robot.landing modelled, planning.max_landing_spread 4 mm): every piece's
    plan keeps its predicted landing within the bound over the friction range and both cones, and
    every piece takes its modelled aim (the hand moved back by the middle of the predicted landings
    and by the piece's landing offset, no turn), whole, or where the whole aim would take the piece
    into a wall or a piece down, the share of it that fits (named in AimedTiling.short), with
    lattice plans and with RRT*. The retries of the pieces aimed short, searched ahead in a forked
    child with two jobs, change nothing: with one job (no child) the lattice's tiling and aims are
    the same to the bit."""
    from ungrasp_ompl.planning.predicted_landing import predict_landing
    from ungrasp_ompl.robot.pipeline import modelled_aim
    from ungrasp_ompl.sim.tiling import _clear_share, tile_aimed

    layout = Layout.from_file(TANGRAM)
    for planner in ("lattice", "RRTstar"):
        tiling, result = tile_aimed(layout, TilingOptions(planner=PlannerOptions(planner=planner, seed=1), jobs=2))
        assert tiling.solved, planner
        if planner == "lattice":
            alone, unforked = tile_aimed(layout, TilingOptions(planner=PlannerOptions(planner=planner, seed=1), jobs=1))
            assert result.short and unforked.short == result.short
            assert [(p.name, p.plan.states) for p in alone.placements] == [(p.name, p.plan.states) for p in tiling.placements]
            assert [tuple(a) for a in unforked.execution.aims] == [tuple(a) for a in result.execution.aims]
        short = {a.name: a.taken / a.asked for a in result.short}
        for a in result.short:  # what stops it: a wall or a piece down before it, met by the piece or the hand
            solids = {s.name for s in next(p for p in tiling.placements if p.name == a.name).scene.solids}
            assert any(f"meets {name} at theta" in a.stopped_by for name in solids), (planner, a)
        for k, p in enumerate(tiling.placements):
            assert p.scene.options.max_landing_spread == pytest.approx(0.004)
            assert predict_landing(p.scene, p.plan).spread <= 0.004 + 1e-12, (planner, p.name)
            aim, want = result.execution.aims[k], modelled_aim(p.scene, p.plan)
            share = short.get(p.name, 1.0)
            assert 0.0 < share <= 1.0 and (share == 1.0) == (_clear_share(p.scene, p.plan, want)[0] == 1.0), p.name
            assert np.allclose(tuple(aim), tuple(want.scaled(share)), atol=1e-12) and aim.turn == 0.0, (planner, p.name)
            assert 0.0 < aim.shift < 0.003, (planner, p.name)

@pytest.fixture(scope="module")
def two_shipped():
    """The shipped tangram's first two pieces (robot.landing modelled, planning.max_landing_spread
    4 mm, so that each plan carries its predicted landing) tiled with lattice plans, with no
    clearance from the piece down (alone, the two large triangles go down side by side, and the
    second's whole aim would take the housing within 1 mm of the first)."""
    layout = Layout.from_dict({**_SHIPPED, "placed_clearance": 0.0, "pieces": _SHIPPED["pieces"][:2]})
    tiling = tile(layout, TilingOptions(planner=PlannerOptions(planner="lattice", seed=1)))
    assert tiling.solved and len(tiling.placements) == 2
    return layout, tiling


def test_a_placements_tolerance_is_the_scale_its_plans_tolerance_finds(two_shipped):
    """The tiling keeps each plan's tolerance scale alone (plan_tolerance.tolerance_scale, without the
    binding component's own scales): to the bit the scale of planning.plan_tolerance.tolerance,
    on two plans of different pieces whose scales differ."""
    _, tiling = two_shipped
    scales = [tolerance(p.scene, p.plan).scale for p in tiling.placements]
    assert [p.tolerance for p in tiling.placements] == scales
    assert len(set(scales)) == 2 and min(scales) > 0


def test_modelled_aims_are_executed_once_and_as_modelled(two_shipped, monkeypatch):
    """robot.landing modelled: aim_tiling moves each piece by robot.pipeline.modelled_aim (the
    model of the fall run again here), whether the plan's record of its predicted landing gives
    it or, without one, the model is run; the layout is executed once, aimed, as `plan` executes
    one modelled object, and its trajectory is to the bit the one execute_sequence makes from
    scratch with those aims."""
    import ungrasp_ompl.sim.tiling as sim_tiling
    from ungrasp_ompl.robot.pipeline import execute_sequence, modelled_aim

    layout, tiling = two_shipped
    assert all(p.plan.predicted_landing is not None for p in tiling.placements)
    want = [modelled_aim(p.scene, p.plan) for p in tiling.placements]
    assert all(a.shift > 0 for a in want) and want[0] != want[1]
    calls = []
    monkeypatch.setattr(sim_tiling, "execute_sequence", lambda *a, **k: calls.append(k) or execute_sequence(*a, **k))
    bare = replace(tiling, placements=[replace(p, plan=replace(p.plan, predicted_landing=None))
                                       for p in tiling.placements])
    jobs = [(p.scene, p.plan) for p in tiling.placements]
    fresh = execute_sequence(jobs, labels=[p.name for p in tiling.placements], aims=want)
    for tiled in (tiling, bare):
        calls.clear()
        aimed = sim_tiling.aim_tiling(layout, tiled)
        assert [tuple(a) for a in aimed.execution.aims] == [tuple(a) for a in want] and aimed.short == ()
        assert len(calls) == 1 and calls[0]["aims"] is not None
        for name in ("times", "positions", "velocities", "accelerations"):
            assert np.array_equal(getattr(aimed.execution.trajectory, name), getattr(fresh.trajectory, name)), name
    # a scene's landing offset moves the aim alike whether it is made from the plan's record or not
    for p in tiling.placements:
        kept = replace(p.scene, robot=replace(p.scene.robot, landing_offset=4e-4))
        bare_plan = replace(p.plan, predicted_landing=None)
        assert tuple(sim_tiling._modelled_aim(kept, p.plan)) == tuple(modelled_aim(kept, bare_plan))
        assert tuple(modelled_aim(kept, bare_plan)) != tuple(modelled_aim(p.scene, bare_plan))


_TIMINGS = {"time_to_first_solution_s", "planning_time_s", "setup_time_s", "time_s"}


def _untimed(doc):
    """A tiling.json document without its wall-clock fields."""
    if isinstance(doc, dict):
        return {k: _untimed(v) for k, v in doc.items() if k not in _TIMINGS}
    if isinstance(doc, list):
        return [_untimed(v) for v in doc]
    return doc


@pytest.mark.slow
def test_pieces_planned_ahead_in_forked_processes_get_the_plans_planned_here(tmp_path, monkeypatch):
    """With worker processes (TilingOptions.jobs) the pieces are planned in forked children, some
    while the search goes on, and the tiling is the one planned in this process alone, to the
    bit: a seeded OMPL planner's plans (each piece's own seed), their tolerances and the checks."""
    from ungrasp_ompl.layout import tiler

    made = tmp_path / "made_by"
    plan_piece = tiler._plan_piece

    def recorded(scene, atlas, piece):
        with made.open("a") as f:
            f.write(f"{os.getpid()}\n")
        return plan_piece(scene, atlas, piece)

    monkeypatch.setattr(tiler, "_plan_piece", recorded)
    layout = Layout.from_dict({**_SHIPPED, "pieces": _SHIPPED["pieces"][:3]})
    planner = PlannerOptions(planner="RRTstar", time=0.1, seed=3)
    here = tile(layout, TilingOptions(planner=planner, jobs=1))
    assert set(made.read_text().split()) == {str(os.getpid())}
    made.unlink()
    forked = tile(layout, TilingOptions(planner=planner, jobs=2))
    assert str(os.getpid()) not in made.read_text().split()
    assert here.solved and len(here.placements) == 3
    assert _untimed(forked.to_dict()) == _untimed(here.to_dict())
    assert [p.plan.states for p in forked.placements] == [p.plan.states for p in here.placements]


def test_the_pictures_drawn_in_a_forked_process_are_the_ones_drawn_here(two_shipped, tmp_path, monkeypatch):
    """TiledLayout.write's pictures are the same files whether a forked process drew them ahead
    (PictureDrawing, as tile_layout starts it), shares them with this one at write, or this
    process draws them all (no fork)."""
    import ungrasp_ompl.workflows.tile as workflow
    from ungrasp_ompl.plots.cspace import draw_plan
    from ungrasp_ompl.plots.layout import draw_layout

    layout, tiling = two_shipped
    names = ["layout.png"] + [f"cspace_{p.order}_{p.name}.png" for p in tiling.placements]
    draw_layout(layout, tiling, tmp_path / "here" / names[0])
    for p, name in zip(tiling.placements, names[1:]):
        draw_plan(p.scene, p.plan, tmp_path / "here" / name)
    ahead = workflow.PictureDrawing(layout, tiling)
    deadline = time.monotonic() + 60
    while not ahead._pool.items("pictures") and time.monotonic() < deadline:  # drawn there before write
        ahead._pool.poll(0.05)
    assert ahead._pool.items("pictures")[:1] == [0]
    doc, picture, cspaces = workflow.TiledLayout(layout, tiling, drawing=ahead).write(tmp_path / "ahead")
    assert [picture] + cspaces == [tmp_path / "ahead" / n for n in names]
    assert not ahead._spare.exists()
    workflow.TiledLayout(layout, tiling).write(tmp_path / "shared")
    monkeypatch.setattr(workflow, "can_fork", lambda: False)
    workflow.TiledLayout(layout, tiling).write(tmp_path / "alone")
    for name in names:
        want = (tmp_path / "here" / name).read_bytes()
        assert len(want) > 10_000
        for way in ("ahead", "shared", "alone"):
            assert (tmp_path / way / name).read_bytes() == want, (way, name)


def test_the_files_exported_in_a_forked_process_are_the_ones_exported_here(two_shipped, tmp_path):
    """TiledLayout.export's files are the same, by kind, name and bytes, whether a forked process
    wrote them ahead (ExportAhead, as tile_layout starts it) or this process writes them."""
    import ungrasp_ompl.workflows.tile as workflow
    from ungrasp_ompl.sim.tiling import aim_tiling

    layout, tiling = two_shipped
    execution = aim_tiling(layout, tiling).execution
    here = workflow.export_files(tiling, execution, tmp_path / "here")
    ahead = workflow.ExportAhead(tiling, execution)
    moved = workflow.TiledLayout(layout, tiling, execution, exporting=ahead).export(tmp_path / "ahead")
    assert list(moved) == list(here) and {"json", "touch_off", "view"} <= set(here)
    assert not ahead._spare.exists()
    for kind, path in here.items():
        assert moved[kind] == tmp_path / "ahead" / path.name
        assert moved[kind].read_bytes() == path.read_bytes(), kind
        assert moved[kind].stat().st_mode == path.stat().st_mode, kind


def _start_hits(doc: dict, placement, down: list[str], aim) -> bool:
    """Whether the piece's object at its plan's start, moved by aim (robot.pipeline.Aim: turned
    about the vertical through G, then shifted), overlaps a wall or a piece down (fcl meshes built
    from the layout file)."""
    frame = placement.scene.plane.frame
    theta = placement.plan.states[0][0]
    outline = _footprint(doc, placement.name)
    g = frame[:3, 3]
    local = (outline - g[:2]) @ frame[:2, :2]
    thickness = next(p["thickness"] for p in doc["pieces"] if p["name"] == placement.name)
    obj = fcl.CollisionObject(_prism_mesh(local, 0.0, thickness))
    c, s = math.cos(theta), math.sin(theta)
    tilt = np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])
    c, s = math.cos(aim.turn), math.sin(aim.turn)
    turn = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    obj.setTransform(fcl.Transform(turn @ frame[:3, :3] @ tilt, g + np.array([aim.x, aim.y, 0.0])))
    targets = list(_walls(doc).values())
    for other in down:
        thick = next(p["thickness"] for p in doc["pieces"] if p["name"] == other)
        targets.append(fcl.CollisionObject(_prism_mesh(_footprint(doc, other), 0.0, thick)))
    return any(_collides(obj, t) for t in targets)


@pytest.mark.slow
def test_a_simulated_layout_exports_what_tile_exports_with_the_first_pieces_touch_off(aimed, tmp_path):
    """`simulate LAYOUT --out` writes the trajectory the attempts ran as `tile` exports it, the
    touch-off under the first piece's start pinch included (the layout's robot makes one)."""
    from ungrasp_ompl.workflows.simulate import LayoutSimulation, SimulateOptions
    from ungrasp_ompl.workflows.tile import TiledLayout

    layout, tiling, result, _ = aimed
    assert tiling.placements[0].scene.robot.touch_off
    simulated = LayoutSimulation(layout, tiling, SimulateOptions(), result.execution, [], result.short)
    written = simulated.write(tmp_path / "simulated")
    exported = TiledLayout(layout, tiling, result.execution, result.short).export(tmp_path / "tiled")
    for name in ("trajectory.urscript", "touch_off.urscript", "trajectory.csv"):
        assert (tmp_path / "simulated" / name).read_bytes() == (tmp_path / "tiled" / name).read_bytes(), name
    assert json.loads(written["summary"].read_text())["attempts"] == 0 and "view" in exported


@pytest.mark.slow
def test_a_piece_whose_aim_does_not_fit_is_tiled_again_by_another_approach(aimed):
    """tile_aimed avoids the approach of a piece aimed short and tiles again: on the tangram
    large_triangle_1's aim from its first approach (B at the south wall) would take the thumb into
    the wall; tiled again it comes B first toward the middle and takes its whole aim, and less of
    the aims is left untaken. (It starts from what the fixture's tiling and aiming worked out.)"""
    from ungrasp_ompl.sim.tiling import tile_aimed

    layout, tiling, first, memo = aimed
    assert "large_triangle_1" in {a.name for a in first.short}
    again, result = tile_aimed(layout, TilingOptions(planner=PlannerOptions(planner="lattice", seed=1)),
                               memo=memo)  # layout: AS_CUT
    assert again.solved and "large_triangle_1" not in {a.name for a in result.short}
    untaken = [sum(a.asked - a.taken for a in r.short) for r in (first, result)]
    assert untaken[1] < untaken[0]
    before = {p.name: p.approach for p in tiling.placements}
    after = {p.name: p.approach for p in again.placements}
    moved = before["large_triangle_1"], after["large_triangle_1"]
    assert not np.allclose(moved[0].b, moved[1].b)
    assert abs(math.cos(moved[0].yaw - moved[1].yaw) + 1) < 1e-9  # the same plane, the other way round


@pytest.mark.slow
def test_a_kept_part_of_the_robots_trajectory_is_the_part_computed_again(aimed):
    """execute_sequence's kept parts (what aim_tiling and tile_aimed reuse): the same pieces again
    take their parts from it, a piece with another aim gets a part of its own (the aim is in the
    digest), and each trajectory is, to the last bit, the one computed without keeping."""
    from ungrasp_ompl.robot.pipeline import execute_sequence

    _, tiling, result, _ = aimed
    jobs = [(p.scene, p.plan) for p in tiling.placements[:2]]
    aims = list(result.execution.aims[:2])
    assert any(aims[1])
    kept: dict = {}
    plain = execute_sequence(jobs, kept=kept)
    assert len(kept) == 2
    both = execute_sequence(jobs, aims=aims, kept=kept)
    assert len(kept) == 2 + sum(map(any, aims))
    for got, fresh in ((both, execute_sequence(jobs, aims=aims)), (execute_sequence(jobs, kept=kept), plain)):
        assert got.trajectory.segments == fresh.trajectory.segments
        for name in ("times", "positions", "velocities", "accelerations"):
            assert np.array_equal(getattr(got.trajectory, name), getattr(fresh.trajectory, name)), name


@pytest.mark.slow
def test_a_piece_held_into_a_piece_down_starts_above_it(aimed):
    """A trial's world never starts with two bodies inside each other: small_triangle_2, held 1 mm
    off along GB toward G, would start with its edge behind G inside the parallelogram beside it; the hand and the piece then start higher, clear of it (MuJoCo's own contacts, read
    from the trial's MJCF keyframe), and the settling lowers them onto it. With nothing beside it
    they start where the grasp puts them, as before."""
    import mujoco

    from ungrasp_ompl.scene.perturbation import TrialParams
    from ungrasp_ompl.sim.trial import trial_mjcf

    _, _, result, _ = aimed
    setups = dict(result.setups)
    piece, beside = setups["small_triangle_2"], setups["parallelogram"]
    params = TrialParams(shift_along_mm=-1.0)

    def first_state(setup):
        model = mujoco.MjModel.from_xml_string(trial_mjcf(setup, params))
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, 0)
        mujoco.mj_forward(model, data)
        names = {i: mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i) or "" for i in range(model.ngeom)}
        deepest = min((c.dist for c in data.contact[:data.ncon]
                       if {names[int(c.geom[0])], names[int(c.geom[1])]} & {"object"}
                       and any(names[int(g)].startswith("placed") for g in c.geom)), default=0.0)
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "object")
        return float(data.xpos[body][2]), deepest

    alone_z, _ = first_state(piece)
    beside_z, deepest = first_state(replace(piece, spec=replace(
        piece.spec, placed=(("parallelogram", beside.spec.obj, beside.target_pose),))))
    assert deepest > -1e-5  # not inside the parallelogram
    assert beside_z > alone_z + 2e-4


@pytest.mark.slow
def test_curved_pieces_are_tiled_each_on_its_own_section():
    """The shipped go_stones layout: both stones placed, each planned as a curved (semi-elliptical)
    piece of the go_stone scene's size, the second with the first down as a solid, every leg of
    both plans secure again under the exact mechanics at a quarter of the lattice step."""
    from ungrasp_ompl.planning.verify import verify_leg

    layout = Layout.from_file("go_stones")
    result = tile(layout, TilingOptions(planner=PlannerOptions(planner="lattice")))
    assert [p.name for p in result.placements] == ["stone_1", "stone_2"] or \
        [p.name for p in result.placements] == ["stone_2", "stone_1"]
    stone = Scene.from_file("go_stone")
    for k, placement in enumerate(result.placements):
        scene = placement.scene
        assert scene.digits.section is not None and not scene.digits.section.is_slab
        assert scene.object_length == pytest.approx(stone.object_length, abs=1e-9)
        assert len(scene.solids) == 4 + k  # the frame's walls and the stones down before it
        assert placement.plan.solved
        res = np.asarray(scene.options.resolution) / 4
        for p in placement.plan.primitives:
            for a, b in zip(p.waypoints[:-1], p.waypoints[1:]):
                assert verify_leg(scene, p.type, a, b, res) is None
