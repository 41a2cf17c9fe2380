"""The energy-bounded cage: a hand-solved disc in a V, converging as the grid halves; poses outside
any cage; a bar that escapes only by turning past the old rotation walls; the minimax search
against a bottleneck Dijkstra and against labelling the whole grid; the free poses against direct
signed distances; the pinch's bodies where the state and the robot's finger put them."""

from __future__ import annotations

import heapq
import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import run_cli
from oracle import escape_level_bisection

from ungrasp_ompl.errors import InputError
from ungrasp_ompl.mechanics.cage import (
    CageGrid,
    CageOutcome,
    CageProblem,
    escape_energy,
    escape_level,
    free_space,
    grid_border,
    pinch_problem,
    pose_grid,
)
from ungrasp_ompl.mechanics.convex import ConvexShape, minkowski_difference, signed_distance
from ungrasp_ompl.mechanics.kinematics import digit_axis, finger_corner, thumb_normal
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


def _bottleneck(free: np.ndarray, energy: np.ndarray, start: tuple, border: np.ndarray, periodic: bool) -> float:
    """The oracle: the least highest energy over paths of 26-neighbours from start to the border, by
    Dijkstra on the bottleneck (a path's cost is its highest cell); periodic: the rotation index
    runs modulo the number of distinct layers (the last layer repeats the first)."""
    nx, nz, nr = free.shape
    turn = nr - 1 if periodic else nr
    best = {start: energy[start]}
    heap = [(energy[start], start)]
    while heap:
        level, (i, j, k) = heapq.heappop(heap)
        if level > best[(i, j, k)]:
            continue
        if border[i, j, k]:
            return float(level)
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                for dk in (-1, 0, 1):
                    n = (i + di, j + dj, (k + dk) % turn if periodic else k + dk)
                    if not (0 <= n[0] < nx and 0 <= n[1] < nz and 0 <= n[2] < nr) or not free[n]:
                        continue
                    cost = max(level, energy[n])
                    if cost < best.get(n, math.inf):
                        best[n] = cost
                        heapq.heappush(heap, (cost, n))
    return math.inf


def _random_grid(rng: np.random.Generator, sizes: tuple[int, int], periodic: bool):
    """Random free cells and energies: integers with many ties, uniform values, or (gravity) one
    growing value per row; periodic: the last rotation layer a copy of the first."""
    shape = tuple(int(x) for x in rng.integers(*sizes, 3))
    free = rng.random(shape) < rng.uniform(0.3, 0.9)
    kind = int(rng.integers(3))
    if kind == 0:
        energy = rng.integers(0, 5, shape).astype(float)
    elif kind == 1:
        energy = rng.random(shape)
    else:
        energy = np.sort(rng.random(shape[1]))[None, :, None]
    start = tuple(int(rng.integers(0, n - 1 if periodic else n)) for n in shape)
    free[start] = True
    if periodic:
        free[..., -1] = free[..., 0]
        if kind < 2:
            energy[..., -1] = energy[..., 0]
    return free, energy, start


@pytest.mark.parametrize("seed", range(6))
def test_minimax_search_equals_a_bottleneck_dijkstra_on_random_grids(seed):
    """escape_level (the row search for an energy growing with the height, the watershed
    otherwise; with and without the rotations joined end to end) equals a bottleneck Dijkstra and
    the bisection with scipy's labels; its pass cell is free, at that level, above the start and
    joined to both the start and the border below that level."""
    rng = np.random.default_rng(seed)
    for _ in range(40):
        periodic = bool(rng.random() < 0.5)
        free, energy, start = _random_grid(rng, (3, 11), periodic)
        border = grid_border(free.shape)
        level, cell = escape_level(free, energy, start, border, periodic)
        full = np.broadcast_to(energy, free.shape)
        assert level == _bottleneck(free, full, start, border, periodic)
        assert level == escape_level_bisection(free, energy, start, border, periodic)
        if cell is not None:
            below = free & (full <= level)
            assert below.flat[cell] and full.flat[cell] == level > full[start]
            at = np.unravel_index(cell, free.shape)
            target = np.zeros(free.shape, dtype=bool)
            target[at] = True
            if periodic:  # the first and the last rotation layer are the same poses
                target[..., 0] |= target[..., -1]
            assert _bottleneck(below, full, start, target, periodic) <= level
            assert _bottleneck(below, full, tuple(int(x) for x in at), border, periodic) <= level


@pytest.mark.parametrize("seed", range(3))
def test_growing_windows_agree_with_labelling_the_whole_grid(seed):
    """On grids large enough that the search labels windows which grow about the start, it finds
    what bisection with labels of the whole grid finds: mostly free cells, with a closed shell of
    random size about the start, pierced or not."""
    rng = np.random.default_rng(100 + seed)
    outcomes = set()
    for _ in range(12):
        periodic = bool(rng.random() < 0.5)
        free, energy, _ = _random_grid(rng, (24, 44), periodic)
        free = rng.random(free.shape) < 0.85
        half = [int(rng.integers(3, 10)) for _ in range(3)]
        start = tuple(int(rng.integers(h + 2, n - h - 3)) for h, n in zip(half, free.shape))
        box = tuple(slice(c - h, c + h + 1) for c, h in zip(start, half))
        inner = tuple(slice(c - h + 1, c + h) for c, h in zip(start, half))
        shell = np.zeros(free.shape, dtype=bool)
        shell[box] = True
        shell[inner] = False
        free &= ~shell
        if rng.random() < 0.5:  # a hole in the shell's top face
            free[start[0], start[1] + half[1], start[2]] = True
        free[start] = True
        if periodic:
            free[..., -1] = free[..., 0]
        border = grid_border(free.shape)
        level, _ = escape_level(free, energy, start, border, periodic)
        assert level == escape_level_bisection(free, energy, start, border, periodic)
        outcomes.add(math.isinf(level))
    assert outcomes == {True, False}


def test_a_bar_in_a_slotted_box_escapes_only_by_turning_upright():
    """A bar 40 x 4 mm lies on the table in a box 30 mm high whose lid, 8 mm thick, has a 10 mm
    slot: tilted by 45 deg the bar needs a gap of 4 / sin 45 + 8 / tan 45 = 13.7 mm to thread it,
    so it gets out only by turning further up. With the rotations walled at +-45 deg it is fully
    caged; over the whole turn it is caged, its centre of mass rising at least to the lid and at
    most until the bar, upright, clears the lid (within one step of the grid)."""
    half, t, lid, thick, slot = 0.02, 0.004, 0.03, 0.008, 0.005
    bar = ConvexShape(np.array([[-half, 0.0], [half, 0.0], [half, t], [-half, t]]))
    box = [np.array([[x0, 0.0], [x0 + thick, 0.0], [x0 + thick, lid + thick], [x0, lid + thick]])
           for x0 in (-0.03 - thick, 0.03)]
    box += [np.array([[x0, lid], [x1, lid], [x1, lid + thick], [x0, lid + thick]])
            for x0, x1 in ((-0.03, -slot), (slot, 0.03))]
    problem = CageProblem(bar, np.array([0.0, t / 2]), WEIGHT, tuple(ConvexShape(b) for b in box),
                          np.array([[-0.03 - thick, 0.0], [0.03 + thick, lid + thick]]))
    grid = CageGrid(step=1 / 32)
    h = grid.step * 2 * half
    walled = escape_energy(problem, replace(grid, max_rotation=math.radians(45)), 2 * half)
    assert walled.outcome is CageOutcome.FULLY_CAGED
    turning = escape_energy(problem, grid, 2 * half)
    assert turning.outcome is CageOutcome.CAGED
    assert WEIGHT * (lid - t / 2) <= turning.escape_energy <= WEIGHT * (lid + thick + half - t / 2 + h)
    assert abs(abs(turning.pass_pose[2]) - math.pi / 2) < math.radians(45)


def test_a_whole_turn_of_rotations_joins_its_ends():
    """The default grid turns the object all the way round in equal steps: the last layer is the
    first turned by 2 pi, the state's own pose is rotation 0."""
    problem = _v_problem()
    axes = pose_grid(problem, CageGrid(), 0.02)
    assert axes.periodic and axes.rotation[axes.start[2]] == 0.0
    assert axes.rotation[-1] - axes.rotation[0] == pytest.approx(2 * math.pi, abs=1e-12)
    assert np.allclose(np.diff(axes.rotation), 2 * math.pi / (len(axes.rotation) - 1))
    assert not pose_grid(problem, CageGrid(max_rotation=math.radians(45)), 0.02).periodic


def _tips(scene: Scene) -> dict:
    """The scene's digits with a rounded finger (a dome of half the tip's thickness) and a flat one."""
    dg = scene.digits
    return {"rounded": replace(dg, flat_finger_tip=False, finger_tip_radius=dg.finger_tip_thickness / 2),
            "flat": replace(dg, flat_finger_tip=True, finger_tip_radius=0.0)}


def _in_finger(points: np.ndarray, theta: float, d: float, psi: float, digits, length: float) -> np.ndarray:
    """Whether points (N, 2) lie in the finger, described as the simulator builds it (sim.model): in
    the finger's own frame, a = how far back from the tip along the digit, b = how far into the
    body from the face; the body is 0 <= b <= its thickness at a, from a = r (the dome's radius,
    0 for a flat tip) to the finger's length, and a rounded tip adds the disc of radius r centred
    r back and r in."""
    tip = finger_corner(theta, d, psi, digits.object_thickness, digits.finger_tip_radius) * length
    e, n = digit_axis(theta, psi), thumb_normal(theta, psi)
    rel = points - tip
    a, b = -(rel @ e), rel @ n
    length_f = digits.finger_length * length
    t_tip, t_base, r = (x * length for x in (digits.finger_tip_thickness, digits.finger_base_thickness,
                                            digits.finger_tip_radius))
    body = (a >= r) & (a <= length_f) & (b >= 0) & (b <= t_tip + (t_base - t_tip) * a / length_f)
    return body | (np.hypot(a - r, b - r) <= r) if r > 0 else body


def test_the_cage_sees_the_finger_the_robot_has_and_the_tip_changes_the_free_poses():
    """For a rounded and a flat finger tip: the cage's finger (its shapes' union) is the finger as
    the simulator builds it, point by point around the tip; the free poses of a grid agree with
    signed distances to those shapes and the table computed pose by pose; and the two tips leave
    different free poses (where the object passes the finger's tip)."""
    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    l, t = scene.object_length, scene.object_thickness
    theta, d, psi = math.radians(18), 0.8, math.radians(35)
    grid = CageGrid(step=1 / 24, rotation_step=math.radians(6))
    frees = {}
    for name, digits in _tips(scene).items():
        problem = pinch_problem(theta, d, psi, digits, l, t, l / 2, 0.01)
        assert len(problem.obstacles) == (4 if name == "rounded" else 3)  # thumb, finger, housing (, dome)
        finger_shapes = [problem.obstacles[1]] + list(problem.obstacles[3:])
        tip = finger_corner(theta, d, psi, digits.object_thickness, digits.finger_tip_radius) * l
        g = np.linspace(-0.003, 0.003, 121)
        pts = tip + np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
        inside = np.zeros(len(pts), dtype=bool)
        for shape in finger_shapes:
            inside |= signed_distance(pts[:, None, :], shape.vertices) - shape.radius <= 0
        expected = _in_finger(pts, theta, d, psi, digits, l)
        near_edge = np.zeros(len(pts), dtype=bool)
        for shape in finger_shapes:
            near_edge |= np.abs(signed_distance(pts[:, None, :], shape.vertices) - shape.radius) < 1e-9
        assert np.array_equal(inside[~near_edge], expected[~near_edge])
        axes = pose_grid(problem, grid, l)
        tol = 0.5 * grid.step * l
        free = free_space(problem, axes, tol)
        rng = np.random.default_rng(7)
        cells = rng.integers(0, free.size, 20000)
        i, j, k = np.unravel_index(cells, free.shape)
        c, s = np.cos(axes.rotation[k]), np.sin(axes.rotation[k])
        rel = problem.body.vertices[None] - problem.centre
        placed = problem.centre + np.stack([c[:, None] * rel[..., 0] - s[:, None] * rel[..., 1],
                                            s[:, None] * rel[..., 0] + c[:, None] * rel[..., 1]], axis=-1)
        placed = placed + np.stack([axes.x[i], axes.z[j]], axis=-1)[:, None, :]
        clearance = placed[..., 1].min(axis=1) + tol
        for shape in problem.obstacles:
            clearance = np.minimum(clearance, signed_distance(placed, shape.vertices) - shape.radius + tol)
        decided = np.abs(clearance) > 1e-12
        assert np.array_equal(free.flat[cells][decided], clearance[decided] >= 0)
        frees[name] = (axes, free)
    (ax_r, free_r), (ax_f, free_f) = frees["rounded"], frees["flat"]
    # the same poses on both grids (displacements of the centre of mass from the same pose)
    xs = np.intersect1d(np.round(ax_r.x / 1e-9), np.round(ax_f.x / 1e-9))
    zs = np.intersect1d(np.round(ax_r.z / 1e-9), np.round(ax_f.z / 1e-9))
    pick = lambda ax, free: free[np.isin(np.round(ax.x / 1e-9), xs)][:, np.isin(np.round(ax.z / 1e-9), zs)]
    assert np.count_nonzero(pick(ax_r, free_r) != pick(ax_f, free_f)) > 0


def test_pinch_bodies_touch_the_object_where_the_state_says():
    """At the state's pose the object touches the table at G, the thumb at B and the finger (its
    dome when rounded, its tip's corner when flat) at A: zero signed distance (up to rounding)."""
    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    l, t = scene.object_length, scene.object_thickness
    for digits in _tips(scene).values():
        for theta, d, psi in ((math.radians(30), 0.8, 0.0), (math.radians(15), 0.7, math.radians(29)),
                              (math.radians(3), 0.65, math.radians(38))):  # B on the thumb with either tip
            p = pinch_problem(theta, d, psi, digits, l, t, l / 2, 0.01)
            body = p.body.vertices
            assert body[:, 1].min() == pytest.approx(0.0, abs=1e-15)
            gaps = [float(signed_distance(body[None], shape.vertices)[0] - shape.radius) for shape in p.obstacles]
            assert gaps[0] == pytest.approx(0.0, abs=1e-12)  # the thumb
            assert min([gaps[1]] + gaps[3:]) == pytest.approx(0.0, abs=1e-12)  # the finger (its dome, when rounded)
            assert min(gaps) >= -1e-12


def test_minkowski_difference_is_where_the_polygons_meet():
    """For random convex polygons (points and segments among them): its vertices are differences
    of a vertex of each, and, where it has an area, a displacement of the moving polygon makes the
    two overlap exactly when it lies inside (signed distances of the placed polygons)."""
    rng = np.random.default_rng(3)
    for _ in range(40):
        a = ConvexShape(rng.normal(size=(int(rng.integers(1, 7)), 2))).vertices
        b = ConvexShape(rng.normal(size=(int(rng.integers(1, 7)), 2))).vertices
        m = minkowski_difference(a, b[None])[0]
        diffs = (a[:, None] - b[None]).reshape(-1, 2)
        assert all(np.linalg.norm(diffs - v, axis=1).min() < 1e-12 for v in m)
        if len(m) < 3 or len(ConvexShape(m).vertices) < 3:
            continue
        for shift in rng.normal(scale=2.0, size=(50, 2)):
            overlap = signed_distance((b + shift)[None], a)[0]
            inside = signed_distance(shift[None, None], m)[0]
            if abs(overlap) > 1e-9:
                assert (overlap < 0) == (inside < 0)


def test_plan_reports_its_smallest_escape_energy_on_request(tmp_path):
    """plan --cage prints the smallest escape energy along the plan and writes it into plan.json;
    the state it names has that cage when computed on its own."""
    out = tmp_path / "run"
    proc = run_cli("plan", str(SCENES / "guitar_pick.yaml"), "--planner", "lattice", "--cage", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((out / "plan.json").read_text())["cage"]
    energy = doc["min_escape_energy_mj"]
    assert ("infinite" if energy is None else f"{energy:.4f} mJ") in proc.stdout, proc.stdout
    assert f"primitive {doc['primitive'] + 1} ({doc['primitive_type']})" in proc.stdout
    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    again = scene.cage([doc["state"]])[0]
    assert again.outcome.value == doc["outcome"]
    assert doc["min_escape_energy_mj"] == pytest.approx(again.escape_energy_mj, rel=1e-12, abs=0.0)
    assert sum(doc["counts"].values()) == doc["samples"]
    proc = run_cli("plan", str(SCENES / "reference_asymmetric.yaml"), "--cage")
    assert proc.returncode != 0 and "--cage" in proc.stderr


def test_scene_cage_needs_a_weight():
    scene = Scene.from_file(SCENES / "reference_asymmetric.yaml")
    with pytest.raises(InputError, match="object.thickness"):
        scene.cage(scene.start)


def test_a_grid_too_fine_to_hold_is_refused_naming_it():
    """A pose grid beyond MAX_GRID_CELLS is refused before anything is allocated."""
    scene = Scene.from_file(SCENES / "guitar_pick.yaml")
    with pytest.raises(InputError) as err:
        scene.cage(scene.start, grid=CageGrid().refined(40.0))
    assert err.value.field == "grid"


@pytest.mark.parametrize("args,field", [
    (("--refine", "40"), "--refine"),
    (("--refine", "nan"), "--refine"),
    (("--squeeze", "-1"), "--squeeze"),
    (("--start-psi-offset-deg", "nan"), "--start-psi-offset-deg"),
    (("--start-psi-offset-deg", "400"), "--start-psi-offset-deg"),
])
def test_cage_options_out_of_range_exit_2_naming_them(tmp_path, args, field):
    out = tmp_path / "out"
    proc = run_cli("cage", "guitar_pick", "--planner", "lattice", *args, "--out", str(out))
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stderr.strip().splitlines() == [proc.stderr.strip()] and f"error: {field}:" in proc.stderr
    assert not out.exists()


def test_cage_warns_of_a_plan_the_scene_rejects(tmp_path):
    """A plan made for another object runs, with the legs this scene's model rejects named."""
    plan_dir = tmp_path / "puzzle"
    assert run_cli("plan", "puzzle_piece", "--planner", "lattice", "--out", str(plan_dir)).returncode == 0
    proc = run_cli("cage", "guitar_pick", "--plan", str(plan_dir / "plan.json"), "--force")
    assert proc.returncode == 0, proc.stderr
    assert "warning: the model rejects this plan for guitar_pick: primitive" in proc.stdout


def test_the_cage_workflow_returns_its_profile_as_values(tmp_path):
    """cage_report is the command without the printing: its weakest state is the profile's least
    escape energy, its smallest margin the plan's own, and write() puts both into cage.json."""
    import json

    from ungrasp_ompl.planning import PlannerOptions
    from ungrasp_ompl.workflows.cage import CageOptions, cage_report
    from ungrasp_ompl.planning.path_margin import path_friction_margin

    scene = Scene.from_file("guitar_pick")
    report = cage_report(scene, CageOptions(planner=PlannerOptions(planner="lattice")))
    assert report.planned and report.plan.solved and not report.problems
    energies = [c.escape_energy for c in report.profile.cages]
    assert report.weakest.escape_energy == min(energies)
    assert report.smallest_margin == path_friction_margin(scene, report.plan).smallest
    doc = json.loads(report.write(tmp_path)[0].read_text())
    assert doc["min_friction_margin_deg"] == pytest.approx(math.degrees(report.smallest_margin))
    with pytest.raises(InputError) as err:
        cage_report(scene, CageOptions(planner=PlannerOptions(planner="lattice"), refine=0.0))
    assert err.value.field == "refine"


def test_a_curved_object_is_caged_as_its_solid():
    """The Go stone's cage problem: its section is the dome (at G's end it has no height, at the
    apex the stone's 7 mm), its weight the glass's density times the semi-ellipsoid's volume
    (2/3 pi a^2 c, within the hull's sampling) and its centre of mass 3c/8 above the table."""
    from ungrasp_ompl.geometry.collision import object_solid
    from ungrasp_ompl.geometry.solids import solid_mass_properties
    from ungrasp_ompl.mechanics.cage import pinch_problem

    scene = Scene.from_file("go_stone")
    l, c = scene.object_length, scene.object_thickness
    volume, centre = solid_mass_properties(object_solid(scene.digits.section, l, scene.digits.width * l, True))
    assert volume == pytest.approx(2 / 3 * math.pi * (l / 2) ** 2 * c, rel=2e-3)
    assert centre[0] == pytest.approx(l / 2, abs=1e-9) and centre[2] == pytest.approx(3 * c / 8, rel=2e-3)
    theta, d, psi = scene.start
    body = pinch_problem(theta, d, psi, scene.digits, l, c, centre[0], 0.04, centre_z=centre[2]).body.vertices
    along = body @ np.array([math.cos(theta), math.sin(theta)])
    up = body @ np.array([-math.sin(theta), math.cos(theta)])
    assert up.max() == pytest.approx(c, abs=1e-9) and up[np.argmin(along)] == pytest.approx(0.0, abs=1e-9)
    assert along.min() == pytest.approx(0.0, abs=1e-9) and along.max() == pytest.approx(l, abs=1e-9)
