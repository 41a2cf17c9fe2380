"""The 3D view of a pincer (robot.gripper.kind pincer): `view DIR` draws its digits turned about
their joint by the exported joint angle (gripper_angle, rad), where mechanics.pincer's forward
kinematics puts them, the object between them; a simulated pincer trial is drawn too; malformed
joint names, records and angles are one-line errors naming the field."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest

from conftest import assert_picture, run_cli

PUZZLE = "pincer_puzzle_piece"
#: Key frames of the strip the fixture draws.
FRAMES = 6


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    """pincer_puzzle_piece planned on the lattice with seed 1, exported, then viewed with a strip of
    FRAMES key frames."""
    out = tmp_path_factory.mktemp("view_pincer") / "out"
    proc = run_cli("plan", PUZZLE, "--planner", "lattice", "--seed", "1", "--export", str(out))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    proc = run_cli("view", str(out), "--frames", str(FRAMES))
    assert proc.returncode == 0, proc.stderr
    assert (out / "view.html").is_file()
    return out


def _trajectory_at(out, times):
    """The exported configurations (T, 7) at view times (s from the trajectory's start), linear in
    between as the view animates them."""
    from ungrasp_ompl.robot.export import read_json

    traj = read_json(out / "trajectory.json")
    t = np.asarray(times) + traj.times[0]
    return np.column_stack([np.interp(t, traj.times, traj.positions[:, j]) for j in range(traj.positions.shape[1])])


def _robot(out):
    """The scene's arm and pincer built from the scene file (robot.pipeline), on the record's base."""
    from ungrasp_ompl.robot.model import load_ur5e
    from ungrasp_ompl.robot.pipeline import gripper_links, gripper_spec
    from ungrasp_ompl.scene import Scene
    from ungrasp_ompl.view.record import read_view_record

    scene = Scene.from_file(PUZZLE)
    base = read_view_record(out / "view_scene.json").base
    return scene, load_ur5e(gripper_spec(scene), base, pincer=gripper_links(scene))


def _turns(thumb, finger, palm):
    """The angles (F,) rad from the thumb's face direction to the finger's, about the palm's y (the
    joint's axis; positive turning z toward x), of digit and palm poses (F, 4, 4)."""
    tz, fz, y = thumb[:, :3, 2], finger[:, :3, 2], palm[:, :3, 1]
    return np.arctan2(np.einsum("fi,fi->f", np.cross(tz, fz), y), np.einsum("fi,fi->f", tz, fz))


def test_the_record_holds_the_pincers_links(export):
    from ungrasp_ompl.robot.pipeline import gripper_links
    from ungrasp_ompl.scene import Scene
    from ungrasp_ompl.view.record import default_record, read_view_record

    record = read_view_record(export / "view_scene.json")
    assert record.pincer == gripper_links(Scene.from_file(PUZZLE))
    assert "pincer" not in default_record().to_dict()["robot"]  # the parallel jaws' record is as it was
    assert_picture(export / "view_frames.png")


def test_digits_at_key_frames_are_where_the_forward_kinematics_puts_them(export):
    """At each key frame the drawn thumb's face (its foot at the joint's level, its direction and
    normal, its tip) and the finger (its dome's centre, its tip corner, its face's end) lie where
    mechanics.pincer.forward puts them for the palm pose and the exported joint angle, within
    1e-9 m; the digits open by the joint angle plus the closed angle, which changes over the frames."""
    from ungrasp_ompl.mechanics.pincer import forward
    from ungrasp_ompl.robot.model import tcp_pose
    from ungrasp_ompl.view import load_scene
    from ungrasp_ompl.view.frames import key_times

    view, _ = load_scene(export)
    planned, robot = _robot(export)
    l, dg = planned.object_length, planned.digits
    radius, offset = planned.robot.gripper.scaled(l)
    r = dg.finger_tip_radius * l
    paths = [b.path for b in view.bodies]
    thumb, finger = paths.index("robot/gripper_thumb"), paths.index("robot/gripper_finger")
    frames = [view.frame_at(float(t)) for t in key_times(view, FRAMES)]
    q = _trajectory_at(export, view.times[frames])
    angles = []
    for k, f in enumerate(frames):
        palm = tcp_pose(robot, q[k])
        o, x, z = palm[:3, 3], palm[:3, 0], palm[:3, 2]
        fk = forward((0.0, 0.0), (0.0, 1.0), (1.0, 0.0), q[k, -1], dg, radius, offset)  # (palm x, palm z) over l

        def point(v):
            return o + l * (v[0] * x + v[1] * z)

        def direction(v):
            return v[0] * x + v[1] * z

        t_pose, f_pose = view.poses[thumb, f], view.poses[finger, f]
        reach = robot.pincer.thumb_reach
        assert np.allclose(t_pose[:3, 3], point(fk["thumb_foot"]), rtol=0, atol=1e-9)
        assert np.allclose(t_pose[:3, 2], direction(fk["thumb_z"]), rtol=0, atol=1e-9)
        assert np.allclose(t_pose[:3, 0], direction(fk["thumb_x"]), rtol=0, atol=1e-9)
        assert np.allclose((t_pose @ [0.0, 0.0, reach, 1.0])[:3], point(fk["thumb_tip"]), rtol=0, atol=1e-9)
        assert np.allclose((f_pose @ [r, 0.0, radius * l, 1.0])[:3], point(fk["dome"]), rtol=0, atol=1e-9)
        assert np.allclose((f_pose @ [0.0, 0.0, radius * l + r, 1.0])[:3], point(fk["finger_corner"]),
                           rtol=0, atol=1e-9)
        # the meshes drawn: the thumb's face ends at its tip, the finger's face where its dome begins,
        # r short of its tip corner and r across from the dome's centre
        finger_z = fk["dome"] / radius  # from the joint, at the origin
        finger_x = (fk["dome"] + dg.finger_tip_radius * finger_z - fk["finger_corner"]) / dg.finger_tip_radius
        face_end = point(fk["dome"] - dg.finger_tip_radius * finger_x)
        for body, end in ((thumb, point(fk["thumb_tip"])), (finger, face_end)):
            mesh, pose = view.bodies[body].mesh, view.poses[body, f]
            face = mesh.vertices[np.abs(mesh.vertices[:, 0]) < 1e-12]  # the contact face, x = 0
            tip = face[np.isclose(face[:, 2], face[:, 2].max(), rtol=0, atol=1e-12)]
            assert np.allclose((tip @ pose[:3, :3].T + pose[:3, 3]).mean(axis=0), end, rtol=0, atol=1e-9)
        turn = _turns(t_pose[None], f_pose[None], palm[None])[0]
        assert turn == pytest.approx(q[k, -1] + robot.pincer.closed_angle, abs=1e-9)
        angles.append(q[k, -1])
    assert max(angles) - min(angles) > 0.05  # the digits turn between the key frames


def test_object_between_the_digits(export):
    """At every frame of every primitive B lies on the thumb's face (within 0.05 mm, between the
    joint's level and the tip) and the finger's dome rests on the object's top face, the object
    drawn where the plan has it and the hand robot.start_press lower, less what the last P_theta
    lets out of it (robot.end_press), linearly in theta."""
    from ungrasp_ompl.planning.result import read_plan
    from ungrasp_ompl.view import load_scene

    view, _ = load_scene(export)
    planned, robot = _robot(export)
    l, t = planned.object_length, planned.object_thickness
    links = robot.pincer
    paths = [b.path for b in view.bodies]
    thumb, finger = paths.index("robot/gripper_thumb"), paths.index("robot/gripper_finger")
    obj = paths.index(f"planned/{PUZZLE}")
    p, e = planned.robot.start_press, planned.robot.final_press
    final = read_plan(export / "plan.json").primitives[-1]
    assert final.type == "P_theta" and e < p
    theta0, theta1 = final.start[0], final.end[0]
    last = [phase for phase in view.phases if phase[0].startswith("P_")][-1]
    checked = 0
    for f, time in enumerate(view.times):
        if not view.phase_at(time)[0].startswith("P_"):
            continue
        body = view.poses[obj, f].copy()
        depth = p
        if view.phase_at(time) == last:
            theta = math.atan2(body[2, 0], math.hypot(body[0, 0], body[1, 0]))
            depth = p + (e - p) * (theta0 - theta) / (theta0 - theta1)
        body[2, 3] -= depth
        b_world = body[:3, :3] @ np.array([l, 0.0, 0.0]) + body[:3, 3]
        b_thumb = np.linalg.solve(view.poses[thumb, f], np.append(b_world, 1.0))
        assert abs(b_thumb[0]) < 5e-5 and 0.0 < b_thumb[2] <= links.thumb_reach + 1e-6, (time, b_thumb)
        dome = view.poses[finger, f] @ np.array([links.tip_radius, 0.0, links.radius, 1.0])
        dome_body = np.linalg.solve(body, dome)
        assert abs(dome_body[2] - (t + links.tip_radius)) < 5e-5, (time, dome_body)
        checked += 1
    assert checked > 50


def test_a_pincer_trajectory_without_its_record_is_drawn_with_a_generic_pincer(export, tmp_path):
    from ungrasp_ompl.view import load_scene
    from ungrasp_ompl.view.record import DEFAULT_PINCER

    d = tmp_path / "old"
    d.mkdir()
    shutil.copy(export / "trajectory.json", d)
    view, sources = load_scene(d)
    assert sources == [d / "trajectory.json"] and view.notes
    paths = [b.path for b in view.bodies]
    thumb, finger = paths.index("robot/gripper_thumb"), paths.index("robot/gripper_finger")
    q = _trajectory_at(export, view.times)
    turn = _turns(view.poses[thumb], view.poses[finger], view.poses[paths.index("robot/gripper_pin")])
    assert np.allclose(turn, q[:, -1] + DEFAULT_PINCER.closed_angle, rtol=0, atol=1e-9)


def test_bad_joint_names_are_one_line_naming_the_field(export, tmp_path):
    d = tmp_path / "names"
    shutil.copytree(export, d)
    doc = json.loads((d / "trajectory.json").read_text())
    doc["joint_names"][-1] = "gripper_width"
    (d / "trajectory.json").write_text(json.dumps(doc))
    proc = run_cli("view", str(d))
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert "joint_names" in lines[0] and "trajectory.json" in lines[0]


@pytest.mark.parametrize("change, field", [
    ("parallel record", "joint_names"),  # a pincer's trajectory with a parallel gripper's record
    ("radius", "robot.pincer.radius"),
    ("offset", "robot.pincer.offset"),
    ("max_angle", "robot.pincer.max_angle"),
    ("angle", "points.positions"),
])
def test_bad_records_and_angles_name_the_field(export, tmp_path, change, field):
    from ungrasp_ompl.errors import InputError
    from ungrasp_ompl.view import load_scene

    d = tmp_path / "bad"
    d.mkdir()
    shutil.copy(export / "trajectory.json", d)
    record = json.loads((export / "view_scene.json").read_text())
    links = record["robot"]["pincer"]
    if change == "parallel record":
        del record["robot"]["pincer"]
    elif change == "radius":
        links["radius"] = -0.01
    elif change == "offset":
        links["offset"] = 2 * links["radius"]
    elif change == "max_angle":
        links["max_angle"] = "wide"
    elif change == "angle":
        links["max_angle"] = 0.1  # below the exported angles
    (d / "view_scene.json").write_text(json.dumps(record))
    with pytest.raises(InputError) as err:
        load_scene(d)
    assert err.value.field == field


@pytest.mark.slow
def test_simulated_pincer_trial_beside_the_plan(export, tmp_path):
    """simulate --plan DIR runs the pincer's plan in MuJoCo (its hinge) and writes DIR/simulation;
    view draws the simulated object beside the planned one, the digits turned by the joint angle."""
    d = tmp_path / "plan"
    shutil.copytree(export, d)
    proc = run_cli("simulate", PUZZLE, "--plan", str(d), "--trials", "2", "--jobs", "1")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = d / "simulation"
    proc = run_cli("view", str(out), "--frames", "3")
    assert proc.returncode == 0, proc.stderr
    assert_picture(out / "view_frames.png")

    from ungrasp_ompl.view import load_scene

    view, sources = load_scene(out)
    assert out / "trial_poses.json" in sources
    groups = {b.group: i for i, b in enumerate(view.bodies)}
    planned, simulated = view.poses[groups["planned"]], view.poses[groups["simulated"]]
    gap = np.linalg.norm(planned[:, :3, 3] - simulated[:, :3, 3], axis=1)
    assert gap[0] == 0.0 and 0.0 < gap.max() < 0.01
    paths = [b.path for b in view.bodies]
    thumb, finger = paths.index("robot/gripper_thumb"), paths.index("robot/gripper_finger")
    q = _trajectory_at(out, view.times)
    turn = _turns(view.poses[thumb], view.poses[finger], view.poses[paths.index("robot/gripper_pin")])
    _, robot = _robot(out)
    assert np.allclose(turn, q[:, -1] + robot.pincer.closed_angle, rtol=0, atol=1e-9)


@pytest.mark.slow
def test_browser_draws_the_pincer(export, tmp_path):
    """The page opens in headless Chromium without a script error, the close-up in the last
    primitive showing the object (yellow) between the finger (blue) and the thumb (red)."""
    from test_view import CHROMIUM_NAMES, _browse, _chromium, _image

    if _chromium() is None:
        pytest.skip(f"no Chromium binary found (looked for {', '.join(CHROMIUM_NAMES)})")
    from ungrasp_ompl.view import load_scene

    view, _ = load_scene(export)
    _, _, a, b = [p for p in view.phases if p[0].startswith("P_")][-1]
    shot = tmp_path / "close.png"
    _browse(export / "view.html", f"t={(a + b) / 2:.3f}&camera=close", shot)
    close = _image(shot)
    yellow = (close[..., 0] > 190) & (close[..., 1] > 140) & (close[..., 2] < 90)
    red = (close[..., 0] > 150) & (close[..., 1] < 110) & (close[..., 2] < 90)
    blue = (close[..., 2] > 150) & (close[..., 0] < 100) & (close[..., 1] < 130)
    assert yellow.sum() > 300 and red.sum() > 300 and blue.sum() > 300, (yellow.sum(), red.sum(), blue.sum())
