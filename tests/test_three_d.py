"""3D ungrasping: antipodal pairs, effective friction, prism roll, stability classes, bad outlines."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
import yaml

from conftest import PREVIOUS_PAIRS, ROOT, SCENES, pick_before_0107, run_cli, with_previous_pair
from ungrasp_ompl.geometry.outline import ellipse, polygon, rounded_polygon
from ungrasp_ompl.mechanics.antipodal import antipodal_pairs, effective_friction
from ungrasp_ompl.mechanics.roll import roll_simulation

SHIPPED_3D = ("guitar_pick", "guitar_pick_1_5mm", "puzzle_piece", "fabric_chalk")


def brute_force_pairs(cand, vertices, phi_g, phi_b):
    """Ordered pairs that are antipodal and supported, by an explicit double loop."""
    def angle_to_cone(c, lo, hi):
        a_lo = math.atan2(lo[1], lo[0])
        width = (math.atan2(hi[1], hi[0]) - a_lo) % (2 * math.pi)
        rel = (math.atan2(c[1], c[0]) - a_lo) % (2 * math.pi)
        if rel <= width + 1e-12:
            return 0.0, c
        to_lo = 2 * math.pi - rel
        to_hi = rel - width
        return (to_lo, lo) if to_lo <= to_hi else (to_hi, hi)

    found = {}
    pts = cand.points
    for i in range(len(pts)):
        for j in range(len(pts)):
            chord = pts[j] - pts[i]
            if i == j or np.linalg.norm(chord) < 1e-9:
                continue
            chord = chord / np.linalg.norm(chord)
            bg, ng = angle_to_cone(chord, cand.normal_lo[i], cand.normal_hi[i])
            bb, nb = angle_to_cone(-chord, cand.normal_lo[j], cand.normal_hi[j])
            if not (bg < phi_g and bb < phi_b):
                continue
            scale = np.max(np.ptp(vertices, axis=0))
            if all(np.dot(v - pts[i], ng) >= -1e-9 * scale and np.dot(v - pts[j], nb) >= -1e-9 * scale for v in vertices):
                found[i, j] = min(phi_g - bg, phi_b - bb)
    return found


@pytest.mark.parametrize("outline", [
    polygon([[0, 0], [0.05, 0], [0, 0.05]]),
    rounded_polygon([[-0.018, 0], [0.018, 0], [0, 0.036]], [0.008, 0.008, 0.003], arc_samples=8),
    ellipse(0.02, 0.012, samples=48),
    polygon([[0, 0], [0.04, 0], [0.04, 0.01], [0.02, 0.004], [0, 0.01]]),  # not convex
], ids=["triangle", "pick", "ellipse", "notched"])
def test_antipodal_search_equals_brute_force(outline):
    cand = outline.candidates(edge_samples=5)
    phi_g, phi_b = math.atan(0.3), math.atan(0.4)
    gi, bi, margin = antipodal_pairs(cand.points, cand.normal_lo, cand.normal_hi, outline.vertices, phi_g, phi_b)
    got = {(int(i), int(j)): float(m) for i, j, m in zip(gi, bi, margin)}
    want = brute_force_pairs(cand, outline.vertices, phi_g, phi_b)
    assert got.keys() == want.keys() and len(got) > 0
    for k in got:
        assert got[k] == pytest.approx(want[k], abs=1e-9)


@pytest.mark.parametrize("phi_deg,gamma_deg", [(17, 0), (17, 5), (17, 12), (30, 20), (11, 10.9)])
def test_effective_friction_equals_numerical_cone_plane_cut(phi_deg, gamma_deg):
    """Intersect a friction cone whose axis makes gamma with a plane by sampling directions
    in the plane; the widest angle inside the cone is atan(mu')."""
    phi, gamma = math.radians(phi_deg), math.radians(gamma_deg)
    axis = np.array([0.0, math.sin(gamma), math.cos(gamma)])  # the plane is y = 0
    t = np.linspace(-math.pi / 2, math.pi / 2, 200001)
    dirs = np.stack([np.sin(t), np.zeros_like(t), np.cos(t)], axis=1)
    inside = dirs @ axis >= math.cos(phi)
    half = np.max(np.abs(t[inside]))
    assert float(effective_friction(math.tan(phi), gamma)) == pytest.approx(math.tan(half), rel=2e-4)


def test_assumption_2_fails_when_the_plane_misses_the_cone():
    assert np.isnan(effective_friction(math.tan(math.radians(17)), math.radians(17)))
    assert np.isnan(effective_friction(0.3, math.radians(40)))


def rhombus(a=0.04, h=0.008):
    return polygon([[0, 0], [a / 2, -h], [a, 0], [a / 2, h]])


def test_prism_roll_thin_rhombus_matches_hand_solution():
    """A thin rhombus held at its sharp ends rolls about GB with A on the axis (no moment)
    until its side vertex (a/2, -h) meets the table or the thumb face, which happens at
    sin w = (a/2) tan(min(theta, psi)) / h; from then on the force at A restores."""
    a, h, theta, psi = 0.04, 0.008, math.radians(10), math.radians(20)
    o = rhombus(a, h)
    step = math.radians(0.25)
    res = roll_simulation(o.vertices, 0.0, np.array([0, 0.0]), np.array([a, 0.0]), np.array([1.0, 0]),
                          np.array([-1.0, 0]), 0.4 * a, theta, psi, math.radians(17), step=step)
    w1 = math.asin(a / 2 * math.tan(min(theta, psi)) / h)
    for d in res.directions:
        lo, hi = d.restoring_range()
        assert w1 <= lo <= w1 + step + 1e-9
        assert hi == pytest.approx(res.max_tilt)
        assert d.events[0] == pytest.approx(w1, abs=1e-6)
    assert not res.self_restoring  # a cusp gives nothing before w1


def test_prism_roll_thick_rhombus_restores_until_friction_angle():
    """With thickness t, A sits t above the axis; a ray tilted alpha from the normal has
    moment t sin(w - alpha) about the axis, so some ray restores exactly while w < phi_A
    (the axis stays GB until the side vertex lands, later here)."""
    a, h, phi_a = 0.04, 0.008, math.radians(17)
    step = math.radians(0.25)
    res = roll_simulation(rhombus(a, h).vertices, 0.003, np.array([0, 0.0]), np.array([a, 0.0]), np.array([1.0, 0]),
                          np.array([-1.0, 0]), 0.4 * a, math.radians(10), math.radians(20), phi_a, step=step)
    for d in res.directions:
        lo, hi = d.restoring_range()
        assert lo == pytest.approx(step)
        assert phi_a - step <= hi < phi_a
    r0, r1 = (d.restoring_range() for d in res.directions)
    assert r0 == pytest.approx(r1)  # symmetric prism, symmetric answer
    assert not res.self_restoring


def test_prism_roll_thin_smooth_object_restores():
    o = ellipse(0.02, 0.015)
    res = roll_simulation(o.vertices, 0.0005, np.array([-0.02, 0.0]), np.array([0.02, 0.0]), np.array([1.0, 0]),
                          np.array([-1.0, 0]), 0.016, math.radians(10), math.radians(20), math.radians(17))
    assert res.self_restoring


def test_a_remembered_roll_is_the_roll_and_is_not_shared():
    """roll_simulation remembers its results by their inputs: asked again it answers as a fresh
    simulation does (the cache emptied), and what one caller does to its result does not reach the
    next caller's."""
    from ungrasp_ompl.mechanics.roll import _remembered_roll

    args = (rhombus().vertices, 0.003, np.array([0, 0.0]), np.array([0.04, 0.0]), np.array([1.0, 0]),
            np.array([-1.0, 0]), 0.016, math.radians(10), math.radians(20), math.radians(17))
    first = roll_simulation(*args)
    first.directions[0].restoring[:] = ~first.directions[0].restoring
    first.directions[1].events.append(1.0)
    again = roll_simulation(*args)
    _remembered_roll.cache_clear()
    fresh = roll_simulation(*args)
    for d, f in zip(again.directions, fresh.directions):
        assert np.array_equal(d.tilts, f.tilts) and np.array_equal(d.restoring, f.restoring) and d.events == f.events
    assert not np.array_equal(first.directions[0].restoring, again.directions[0].restoring)


def test_stability_command_tall_prism_and_puzzle_piece():
    tall = run_cli("stability", str(ROOT / "tests" / "scenes" / "tall_prism.yaml"))
    assert tall.returncode == 0, tall.stderr
    verdict = tall.stdout.strip().splitlines()[-1]
    assert verdict.startswith("verdict:") and verdict.count("NOT") == 2, verdict  # neither restoring nor held
    assert re.search(r"from 0\.25 to [0-9.]+ deg either way, tried up to 30 deg", tall.stdout), tall.stdout
    piece = run_cli("stability", str(SCENES / "puzzle_piece.yaml"))
    assert piece.returncode == 0, piece.stderr
    verdict = piece.stdout.strip().splitlines()[-1]
    assert verdict.startswith("verdict:") and "NOT" not in verdict, verdict
    assert "from 0.25 to 30.00 deg either way" in piece.stdout
    assert "edge contact at B" in piece.stdout


@pytest.mark.parametrize("name", SHIPPED_3D)
def test_shipped_objects_plan_with_their_plane(tmp_path, name):
    # --time 2: at its friction's +-30 % (docs/model.md 4.7) RRT* finds the 1.5 mm pick's path, seed 1, within 2 s
    proc = run_cli("plan", str(SCENES / f"{name}.yaml"), "--seed", "1", "--time", "2", "--out", str(tmp_path))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    plan = json.loads((tmp_path / "plan.json").read_text())
    mp = plan["manipulation_plane"]
    mu = plan["mu_eff"]  # the plane's friction and G and B, printed
    assert f"{mu['G']:.3f} at G" in proc.stdout and f"{mu['B']:.3f} at B" in proc.stdout, proc.stdout
    assert f"({mp['G'][0] * 1000:.2f}, {mp['G'][1] * 1000:.2f}) mm" in proc.stdout
    assert f"{mp['length_m'] * 1000:.2f} mm" in proc.stdout
    g, b = np.array(mp["G"]), np.array(mp["B"])
    assert mp["length_m"] == pytest.approx(np.linalg.norm(b - g))
    frame = np.array(mp["frame"])
    np.testing.assert_allclose(frame[:3, :3].T @ frame[:3, :3], np.eye(3), atol=1e-12)  # a rotation
    np.testing.assert_allclose(frame[:3, 2], [0, 0, 1])  # z up, plane vertical
    assert plan["mu_eff"]["G"] <= yaml.safe_load((SCENES / f"{name}.yaml").read_text())["friction"]["G"] + 1e-12
    for p in plan["primitives"]:  # every leg classified
        expected = "partial" if p["type"] == "P_dpsi" and len(p["sliding"]) == 2 else "full"
        assert p["stability"] == expected
        assert p["type"] != "P_theta" or p["sliding"] == {}
        assert p["type"] != "P_psi" or list(p["sliding"]) == ["B"]
        assert p["x_moments"] == plan["stability_report"]["x_moments"]["mechanism"]
    printed = re.findall(r"^  (\d+)\. (P_\w+),", proc.stdout, re.M)  # every primitive, numbered, with its type
    assert printed == [(str(k), p["type"]) for k, p in enumerate(plan["primitives"], 1)], proc.stdout


def test_forbidding_partial_legs_removes_p_dpsi(tmp_path):
    """The pick from its start before decision 0107, whose plans pass through a P_dpsi, plans with
    planning.forbid_partial and none of its legs is a P_dpsi or partially stable."""
    data = pick_before_0107()
    data["planning"] = {"forbid_partial": True}
    data["robot"].pop("start_press")  # it needs the clearance left out here
    data["robot"].pop("end_press")
    # the finger may not slide, so d stays; without P_dpsi the pick reaches theta 10 deg, not 3
    data["goal"] = {"theta_max_deg": 10, "d": [0.77, 0.83], "psi_deg": [35, 41]}
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(data))
    proc = run_cli("plan", str(path), "--seed", "1", "--time", "0.5", "--out", str(tmp_path / "o"))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    plan = json.loads((tmp_path / "o" / "plan.json").read_text())
    assert all(p["type"] != "P_dpsi" and p["stability"] == "full" for p in plan["primitives"])


def scene_with(tmp_path, change, base="guitar_pick"):
    data = yaml.safe_load((SCENES / f"{base}.yaml").read_text())
    change(data)
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("outline,word", [
    ({"polygon": [[0, 0], [0.01, 0]]}, "at least 3 points"),
    ({"polygon": [[0, 0], [0.02, 0.02], [0.02, 0], [0, 0.02]]}, "self-intersecting"),
    ({"polygon": [[0, 0], [0.01, 0], [0.02, 0]]}, "zero area"),
    ({"rounded_polygon": {"vertices": [[0, 0], [0.02, 0], [0.01, 0.02]], "radius": 0.02}}, "do not fit"),
    ({"ellipse": {"a": 0.02, "b": -1}}, "object.outline.ellipse.b"),
    ({"polygon": [[0, 0], [0.02, 0]], "ellipse": {"a": 1, "b": 1}}, "exactly one"),
])
def test_degenerate_outline_exits_2(tmp_path, outline, word):
    path = scene_with(tmp_path, lambda d: d["object"].update(outline=outline))
    proc = run_cli("plan", str(path))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and word in proc.stderr and "object.outline" in proc.stderr


def test_no_antipodal_pair_exits_2(tmp_path):
    path = scene_with(tmp_path, lambda d: d.update(friction={"G": 0.0, "A": 0.3, "B": 0.3}))
    proc = run_cli("plan", str(path))
    assert proc.returncode == 2 and "no antipodal pair" in proc.stderr and "friction" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_fixed_pair_breaking_assumption_2_exits_2(tmp_path):
    """G and B on two sides of the triangle at right angles: the chord is far outside the cones."""
    path = scene_with(tmp_path, lambda d: d.update(contacts={"G": [0.025, 0.0], "B": [0.0, 0.02]}), "puzzle_piece")
    proc = run_cli("stability", str(path))
    assert proc.returncode == 2 and "Assumption 2 fails" in proc.stderr and "contacts." in proc.stderr


def test_fixed_pair_is_used(tmp_path):
    path = scene_with(tmp_path, lambda d: d.update(contacts={"G": [0.025, 0.025], "B": [0.0, 0.0]}), "puzzle_piece")
    proc = run_cli("stability", str(path))
    assert proc.returncode == 0, proc.stderr
    assert "fixed" in proc.stdout and "(25.00, 25.00) mm" in proc.stdout


@pytest.mark.parametrize("sagitta", [2e-6, 5e-7])
def test_refined_outline_lies_on_the_rounded_corners(sagitta):
    """The simulator's outline fills in a rounded polygon's arcs: it keeps every sample, every
    added point lies on its corner's circle (centre found independently from the polygon's
    geometry), and no chord strays more than the sagitta from its arc."""
    corners, radii = np.array([[-0.018, 0], [0.018, 0], [0, 0.036]]), np.array([0.008, 0.008, 0.003])
    outline = rounded_polygon(corners, radii)
    fine = outline.refined(sagitta)
    assert len(fine) > len(outline.vertices)
    for v in outline.vertices:  # the samples are kept
        assert np.min(np.linalg.norm(fine - v, axis=1)) < 1e-15
    centres = []
    for i, (p, r) in enumerate(zip(corners, radii)):  # a corner's centre: r from both of its sides
        u1, u2 = corners[i - 1] - p, corners[(i + 1) % 3] - p
        u1, u2 = u1 / np.linalg.norm(u1), u2 / np.linalg.norm(u2)
        half = math.acos(float(u1 @ u2)) / 2
        centres.append(p + (u1 + u2) / np.linalg.norm(u1 + u2) * r / math.sin(half))
    added = [q for q in fine if np.min(np.linalg.norm(outline.vertices - q, axis=1)) > 1e-12]
    assert added
    for q in added:
        off = [abs(np.linalg.norm(q - c) - r) for c, r in zip(centres, radii)]
        assert min(off) < 1e-12
    for a, b in zip(fine, np.roll(fine, -1, axis=0)):  # chords of an arc stray at most the sagitta
        mid = (a + b) / 2
        off = [(r - np.linalg.norm(mid - c)) for c, r in zip(centres, radii)
               if abs(np.linalg.norm(a - c) - r) < 1e-12 and abs(np.linalg.norm(b - c) - r) < 1e-12]
        if off:
            assert min(off) <= sagitta * (1 + 1e-9)


def test_a_fixed_contact_between_samples_lies_on_the_curve_with_its_own_normal():
    """The pick's apex (its 3 mm tip's topmost point, on the axis of symmetry) lies between two arc
    samples: fixed there, G is that point of the circle (the centre found from the corner's
    geometry) and its normal points to the centre; B, half a millimetre from the base side's middle
    (between its samples), is on that side with its normal, so both make the chord's angle with
    their normals. Off the outline by more than the tolerance, it is refused."""
    from ungrasp_ompl.errors import InputError
    from ungrasp_ompl.geometry.plane import FIXED_TOLERANCE, choose_plane

    corners, radii = np.array([[-0.018, 0], [0.018, 0], [0, 0.036]]), np.array([0.008, 0.008, 0.003])
    u1, u2 = corners[0] - corners[2], corners[1] - corners[2]
    u1, u2 = u1 / np.linalg.norm(u1), u2 / np.linalg.norm(u2)
    centre = corners[2] + (u1 + u2) / np.linalg.norm(u1 + u2) * radii[2] / math.sin(math.acos(float(u1 @ u2)) / 2)
    apex = centre + [0.0, radii[2]]
    outline = rounded_polygon(corners, radii)
    assert np.min(np.linalg.norm(outline.candidates().points - apex, axis=1)) > FIXED_TOLERANCE
    plane = choose_plane(outline, 0.25, 0.35, fixed=(apex + [0.0, 0.5 * FIXED_TOLERANCE], [0.0005, 0.0]))
    assert np.allclose(plane.g.point, apex, atol=1e-12) and plane.g.kind == "smooth"
    assert plane.g.radius == pytest.approx(radii[2], rel=1e-9)
    tilt = math.atan2(0.0005, apex[1])  # the chord's angle with the axis
    assert np.allclose(plane.g.normal, [0.0, -1.0], atol=1e-9) and plane.g.beta == pytest.approx(tilt, abs=1e-9)
    assert np.allclose(plane.b.point, [0.0005, 0.0], atol=1e-12) and plane.b.kind == "edge"
    assert np.allclose(plane.b.normal, [0.0, 1.0], atol=1e-12) and plane.b.beta == pytest.approx(tilt, abs=1e-9)
    assert plane.margin == pytest.approx(math.atan(0.25) - tilt, abs=1e-9)
    with pytest.raises(InputError, match="contacts.G"):
        choose_plane(outline, 0.25, 0.35, fixed=(apex + [0.0, 2 * FIXED_TOLERANCE], [0.0005, 0.0]))


@pytest.mark.parametrize("name", sorted(PREVIOUS_PAIRS))
def test_the_thumb_touches_a_smooth_b_where_the_outline_reaches_furthest_along_gb(name):
    """The thumb's face, normal to GB in the object's plane, touches a smooth B of radius R whose
    normal is beta off GB at R sin(beta) across GB and R (1 - cos(beta)) further out (the circle's
    own geometry); the finely refined outline reaches no further; plan.json and the stability
    report carry it."""
    from ungrasp_ompl.scene.stability import analyse

    scene = with_previous_pair(name)  # the thumb on a rounded shoulder or corner
    b = scene.plane.b
    assert b.kind == "smooth" and b.beta > 0
    along, across = b.touch
    assert along == pytest.approx(b.radius * (1 - math.cos(b.beta)), rel=1e-6)
    assert abs(across) == pytest.approx(b.radius * math.sin(b.beta), rel=1e-6)
    u = (b.point - scene.plane.g.point) / scene.plane.length
    fine = scene.object3d.outline.refined(1e-9)
    assert np.max((fine - b.point) @ u) <= along + 1e-12 and np.max((fine - b.point) @ u) > along - 1e-8
    assert scene.plane.to_dict()["contacts"]["B"]["touched_from_m"] == {"along": along, "across": across}
    report = analyse(scene, [])
    assert report.contacts["B"]["touched_from_m"]["across"] == across
    assert any("thumb's face touches the outline" in line for line in report.lines())


@pytest.mark.parametrize("name", ["guitar_pick", "fabric_chalk", "puzzle_piece"])
def test_the_plane_takes_a_double_normal_with_the_thumb_on_a_straight_side(name):
    """The shipped objects' planes lie on a double normal of the outline (GB along both contacts'
    normals, so the table and the thumb's face touch exactly at G and B), with B on a straight side
    and G at the far point (the pick's and the chalk's rounded tip, the puzzle piece's corner); no
    pair of the outline's other candidates has a larger friction margin."""
    from ungrasp_ompl import Scene

    scene = Scene.from_file(name)
    plane, outline = scene.plane, scene.object3d.outline
    assert plane.g.beta == 0.0 and plane.b.beta == 0.0
    assert plane.g.touch == (0.0, 0.0) and plane.b.touch == (0.0, 0.0)
    assert plane.b.kind == "edge" and plane.g.kind in ("smooth", "corner")
    u = (plane.b.point - plane.g.point) / plane.length
    assert np.allclose(plane.g.normal, u, atol=1e-12) and np.allclose(plane.b.normal, -u, atol=1e-12)
    assert np.max((outline.refined(1e-9) - plane.g.point) @ -u) <= 1e-9  # nothing reaches past G along BG
    cand = outline.candidates()
    mu = scene.mu_contacts
    *_, margins = antipodal_pairs(cand.points, cand.normal_lo, cand.normal_hi, outline.vertices,
                                  math.atan(mu[0]), math.atan(mu[2]))
    assert plane.margin >= margins.max() - 1e-12


def test_a_contact_where_its_face_touches_has_no_offset():
    """The puzzle piece's B lies on a straight side along which the thumb's face rests, its G at a
    corner whose normal range holds GB: both faces touch at the contacts."""
    from ungrasp_ompl import Scene

    plane = Scene.from_file("puzzle_piece").plane
    assert plane.g.touch == (0.0, 0.0) and plane.b.touch == (0.0, 0.0)


def test_a_straight_side_supports_the_object_across_the_plane_to_its_ends():
    """ContactPoint.span: the pick's thumb rests on the straight part of its base, which ends where
    the 8 mm shoulders begin, 18 mm - 8 mm / tan(A / 2) each side of B (A the base angle of the
    36 mm by 36 mm triangle); the puzzle piece's, mid hypotenuse, reaches both corners. G, at a
    rounded tip or a corner, supports nothing across. The digits' supports are the spans over l, B's
    no wider than half the thumb (20 mm)."""
    from ungrasp_ompl import Scene

    pick = Scene.from_file("guitar_pick")
    edge = 0.018 - 0.008 / math.tan(math.atan2(0.036, 0.018) / 2)
    np.testing.assert_allclose(pick.plane.b.span, (edge, edge), atol=1e-12)
    assert pick.plane.g.span == (0.0, 0.0)
    np.testing.assert_allclose(pick.digits.support, (0.0, edge / pick.object_length), atol=1e-12)
    puzzle = Scene.from_file("puzzle_piece")
    corners = puzzle.object3d.outline.vertices
    half = np.linalg.norm(corners - puzzle.plane.b.point, axis=1)
    np.testing.assert_allclose(puzzle.plane.b.span, np.sort(half)[:2], atol=1e-12)
    assert puzzle.plane.g.span == (0.0, 0.0)
    np.testing.assert_allclose(puzzle.digits.support, (0.0, 0.01 / puzzle.object_length), atol=1e-12)
    assert puzzle.plane.to_dict()["contacts"]["B"]["span_m"] == list(puzzle.plane.b.span)


@pytest.mark.parametrize("name", ["guitar_pick", "fabric_chalk"])
def test_the_stability_report_says_how_far_a_lies_inside_the_supports(name):
    """At each rolled state the report gives A's distance inside the supports across the plane, the
    lesser of as planned and where the start press puts the object (m); the shipped start keeps the
    scene's across_margin; a flat tip, which holds x-moments along its own edge, has none."""
    from ungrasp_ompl import Scene
    from ungrasp_ompl.mechanics import across_support
    from ungrasp_ompl.mechanics.kinematics import pressed_state
    from ungrasp_ompl.scene.stability import analyse

    scene = Scene.from_file(name)
    dg, q = scene.digits, scene.start
    pressed = pressed_state(*q, dg.press, dg)
    want = min(across_support(q[1], q[2], dg), across_support(pressed[1], pressed[2], dg)) * scene.object_length
    (roll,) = analyse(scene, [("start", q)]).rolls
    assert roll.across == pytest.approx(float(want), rel=1e-12) and roll.across >= 0.001 - 1e-9
    assert roll.to_dict()["across_support_m"] == roll.across
    flat = scene.with_digits(finger_tip="flat")
    assert analyse(flat, [("start", q)]).rolls[0].across is None


def _has_shape(value, kind) -> list[str]:
    """Where value (a plan.json mapping) strays from kind, a TypedDict of planning.result: its keys
    and, for the nested TypedDicts and lists of them, theirs; [] where it has the shape."""
    import typing

    from ungrasp_ompl.planning import result

    hints = typing.get_type_hints(kind, vars(result))
    if set(value) != set(hints):
        return [f"{kind.__name__}: {sorted(value)} != {sorted(hints)}"]
    wrong = []
    for key, hint in hints.items():
        if typing.is_typeddict(hint):
            wrong += _has_shape(value[key], hint)
        elif typing.get_origin(hint) is list and typing.is_typeddict(typing.get_args(hint)[0]):
            for item in value[key]:
                wrong += _has_shape(item, typing.get_args(hint)[0])
    return wrong


@pytest.mark.parametrize("name", ["guitar_pick", "puzzle_piece", "fabric_chalk"])
def test_the_3d_reports_parts_have_the_shapes_plan_json_documents(name):
    """Report3D's four mappings, as with_3d_report builds them from the scene, have the keys of
    their TypedDicts (planning.result), nested ones included, and nothing else."""
    from ungrasp_ompl import Scene
    from ungrasp_ompl.planning.result import AtGAB, ObjectRecord, PlaneRecord, Report3D, StabilityRecord
    from ungrasp_ompl.scene.stability import analyse

    scene = Scene.from_file(name)
    stability = analyse(scene, [("start", scene.start), ("end", scene.start)]).to_dict()
    assert _has_shape(scene.object3d.to_dict(), ObjectRecord) == []
    assert _has_shape(scene.plane.to_dict(), PlaneRecord) == []
    assert _has_shape(dict(zip("GAB", scene.mu)), AtGAB) == []
    assert _has_shape(stability, StabilityRecord) == []
    assert len(stability["roll_simulation"]) == 2
    assert list(Report3D.__dataclass_fields__) == ["object", "manipulation_plane", "mu_eff", "stability_report"]
