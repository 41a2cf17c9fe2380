"""The 3D view (issue 14): `view DIR` writes one offline HTML page (meshcat) that a real browser
draws, a key-frame strip, and one-line errors; the object sits between the digits as planned."""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest

from conftest import SCENES, assert_picture, distinct_colours, run_cli

#: Debian's package is `chromium`; other systems name the binary differently.
CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")
#: The time of the screenshots: the home pose (the start) and the third primitive of guitar_pick seed 1.
EARLY_S, LATE_S = 0.0, 4.3


def _chromium() -> str | None:
    return next((p for p in map(shutil.which, CHROMIUM_NAMES) if p), None)


def _browse(page: Path, query: str, out: Path, *, dump_dom: bool = False, size=(1000, 700)) -> subprocess.CompletedProcess:
    """Open page?query in headless Chromium (software WebGL, every network request sent to a dead
    proxy so that nothing can be downloaded) and take a screenshot to out, or dump the DOM after the
    scripts ran."""
    binary = _chromium()
    with tempfile.TemporaryDirectory() as profile:
        args = [binary, "--headless", "--disable-gpu", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                "--disable-dev-shm-usage", "--no-first-run", f"--user-data-dir={profile}",
                "--proxy-server=127.0.0.1:9", f"--window-size={size[0]},{size[1]}", "--virtual-time-budget=5000",
                "--enable-logging=stderr", "--v=0"]
        if os.geteuid() == 0:
            args.append("--no-sandbox")  # Chromium refuses to run as root with its sandbox
        args += ["--dump-dom"] if dump_dom else [f"--screenshot={out}"]
        proc = subprocess.run(args + [f"{page.as_uri()}?{query}"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Uncaught" not in proc.stderr, [line for line in proc.stderr.splitlines() if "Uncaught" in line]
    return proc


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    """guitar_pick planned with seed 1 and exported, then viewed with a strip of 4 key frames."""
    out = tmp_path_factory.mktemp("view") / "out"
    proc = run_cli("plan", str(SCENES / "guitar_pick.yaml"), "--seed", "1", "--export", str(out))
    assert proc.returncode == 0, proc.stderr
    assert f"view it: ungrasp-ompl view {out}" in proc.stdout
    assert (out / "view_scene.json").is_file()
    proc = run_cli("view", str(out), "--frames", "4")
    assert proc.returncode == 0, proc.stderr
    assert str(out / "view.html") in proc.stdout and str(out / "view_frames.png") in proc.stdout
    return out


def _image(path: Path) -> np.ndarray:
    import matplotlib.image as mpimg

    return (mpimg.imread(str(path))[..., :3] * 255).astype(np.int16)


def _drawn(img: np.ndarray) -> float:
    """The share of pixels that are not the page's background (a vertical grey-blue gradient: each
    row's most common colour)."""
    rows = img.reshape(img.shape[0], -1, 3)
    background = np.array([np.median(r, axis=0) for r in rows])
    return float(np.mean(np.abs(img - background[:, None, :]).sum(axis=-1) > 30))


@pytest.mark.slow
def test_page_is_self_contained(export):
    html = (export / "view.html").read_text()
    assert "MeshCat.Viewer" in html and "handle_command_bytearray" in html  # meshcat's viewer, inlined
    assert not re.search(r"<(script|link|img|iframe)[^>]+(src|href)\s*=", html, re.I), "the page loads a file"
    assert not re.search(r"""(src|href|url)\s*[=(]\s*["']?(https?:)?//""", html, re.I), "the page names a URL"
    assert len(html) < 5_000_000


def test_strip_of_key_frames(export):
    strip = export / "view_frames.png"
    # the arm's blue housings, the yellow object (shaded) are drawn
    assert_picture(strip)
    img = _image(strip)
    assert img.shape[1] > 4 * 200 and img.shape[0] >= 400, img.shape
    yellow = (img[..., 0] > 170) & (img[..., 1] > 120) & (img[..., 2] < 70)
    blue = (img[..., 2] > 120) & (img[..., 0] < 110)
    assert yellow.sum() > 200 and blue.sum() > 2000, (yellow.sum(), blue.sum())


def test_object_between_the_digits(export):
    """At every frame of every primitive, B lies on the thumb's face (within 0.05 mm of it, between
    the palm and the tip) and the finger's rounded tip rests on the object's top face at A, the
    object drawn where the plan has it and the hand robot.start_press lower, less what the last
    P_theta lets out of it (robot.end_press), linearly in theta."""
    from ungrasp_ompl.planning.result import read_plan
    from ungrasp_ompl.scene import Scene
    from ungrasp_ompl.view import load_scene
    from ungrasp_ompl.view.record import read_view_record

    scene, _ = load_scene(export)
    record = read_view_record(export / "view_scene.json")
    planned = Scene.from_file(SCENES / "guitar_pick.yaml")
    l, t, r = planned.object_length, planned.object_thickness, record.digits["finger_tip_radius"]
    paths = [b.path for b in scene.bodies]
    thumb, finger = paths.index("robot/gripper_thumb"), paths.index("robot/gripper_finger")
    obj = paths.index("planned/guitar_pick")
    g = record.gripper
    p, e = planned.robot.start_press, planned.robot.final_press
    final = read_plan(export / "plan.json").primitives[-1]
    assert final.type == "P_theta" and e < p
    theta0, theta1 = final.start[0], final.end[0]
    last = [phase for phase in scene.phases if phase[0].startswith("P_")][-1]
    checked = 0
    for f, time in enumerate(scene.times):
        if not scene.phase_at(time)[0].startswith("P_"):
            continue
        body = scene.poses[obj, f].copy()
        depth = p
        if scene.phase_at(time) == last:  # let out along the last P_theta, linearly in theta
            theta = math.atan2(body[2, 0], math.hypot(body[0, 0], body[1, 0]))
            depth = p + (e - p) * (theta0 - theta) / (theta0 - theta1)
        body[2, 3] -= depth  # where the pressed hand holds it
        b_world = body[:3, :3] @ np.array([l, 0.0, 0.0]) + body[:3, 3]
        b_thumb = np.linalg.solve(scene.poses[thumb, f], np.append(b_world, 1.0))
        assert abs(b_thumb[0]) < 5e-5 and 0.0 < b_thumb[2] <= g.thumb_length + 1e-6, (time, b_thumb)
        dome = scene.poses[finger, f] @ np.array([r, 0.0, g.finger_length - r, 1.0])
        dome_body = np.linalg.solve(body, dome)
        assert abs(dome_body[2] - (t + r)) < 5e-5, (time, dome_body)  # touching the top face
        checked += 1
    assert checked > 50


@pytest.mark.slow
def test_browser_draws_the_scene_and_the_robot_moves(export, tmp_path):
    if _chromium() is None:
        pytest.skip(f"no Chromium binary found (looked for {', '.join(CHROMIUM_NAMES)}); "
                    "install Debian's `chromium` package to run the browser test")
    page = export / "view.html"
    shots = {}
    for name, query in (("early", f"t={EARLY_S}"), ("late", f"t={LATE_S}"), ("close", f"t={LATE_S}&camera=close")):
        shots[name] = tmp_path / f"{name}.png"
        _browse(page, query, shots[name])
        shutil.copy(shots[name], export / f"browser_{name}.png")  # kept beside the export for a person to look at
    early, late, close = (_image(shots[k]) for k in ("early", "late", "close"))
    for img in (early, late, close):
        assert img.shape[:2] == (700, 1000), img.shape
        assert _drawn(img) > 0.08, _drawn(img)  # the table and the arm, not an empty or error page
        assert distinct_colours(img // 16) > 40  # shaded parts in several colours
    # the robot moved: the middle of the view (the overlays left out) differs between the two times
    mid = (slice(60, 560), slice(150, 850))
    moved = np.abs(early[mid] - late[mid]).sum(axis=-1) > 60
    assert moved.mean() > 0.02, moved.mean()
    # the close-up shows the object (yellow) between the finger (blue) and the thumb (red)
    yellow = (close[..., 0] > 190) & (close[..., 1] > 140) & (close[..., 2] < 90)
    red = (close[..., 0] > 150) & (close[..., 1] < 110) & (close[..., 2] < 90)
    blue = (close[..., 2] > 150) & (close[..., 0] < 100) & (close[..., 1] < 130)
    assert yellow.sum() > 300 and red.sum() > 300 and blue.sum() > 300, (yellow.sum(), red.sum(), blue.sum())


@pytest.mark.slow
def test_browser_shows_the_running_primitive(export, tmp_path):
    if _chromium() is None:
        pytest.skip(f"no Chromium binary found (looked for {', '.join(CHROMIUM_NAMES)})")
    dom = _browse(export / "view.html", f"t={LATE_S}", tmp_path / "unused.png", dump_dom=True).stdout
    assert 'data-view-ready="1"' in dom  # the page's scripts ran to the end
    from ungrasp_ompl.view import load_scene

    phase = re.search(r'<div id="phase-text">([^<]*)</div>', dom).group(1)
    scene, _ = load_scene(export)
    running = scene.phase_at(LATE_S)  # the trajectory's own phase at that time
    assert running[0].startswith("P_") and phase == running[1], (phase, running)
    assert re.search(rf'<span id="time">{LATE_S:.2f} / {scene.times[-1]:.2f} s</span>', dom), dom[-3000:]


def test_bad_input_is_one_line(tmp_path):
    cases = [
        (("view", str(tmp_path / "missing")), ("DIR", "missing")),
        (("view", str(tmp_path)), ("DIR", "trajectory.json")),
    ]
    for args, words in cases:
        proc = run_cli(*args)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
        for w in words:
            assert w in lines[0], lines[0]


def test_bad_options_and_records(export, tmp_path):
    d = tmp_path / "copy"
    shutil.copytree(export, d)
    for args, word in ((("--frames", "0"), "--frames"), (("--out", str(d / "v.png")), "--out")):
        proc = run_cli("view", str(d), *args)
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
        assert word in proc.stderr
    doc = json.loads((d / "view_scene.json").read_text())
    doc["pieces"][0]["target"] = [[1, 0], [0, 1]]
    (d / "view_scene.json").write_text(json.dumps(doc))
    proc = run_cli("view", str(d))
    assert proc.returncode == 2 and "pieces.target" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_trajectory_without_record_shows_the_robot(export, tmp_path):
    d = tmp_path / "old"
    d.mkdir()
    shutil.copy(export / "trajectory.json", d)
    proc = run_cli("view", str(d), "--out", str(tmp_path / "robot.html"))
    assert proc.returncode == 0, proc.stderr
    assert "robot only" in proc.stdout and (tmp_path / "robot.html").is_file()


@pytest.mark.slow
def test_simulated_trial_beside_the_plan(tmp_path):
    """simulate records trial 0's object poses (the campaign's own trial 0 again), and the view
    draws the simulated object beside the planned one."""
    out = tmp_path / "sim"
    proc = run_cli("simulate", "guitar_pick", "--trials", "1", "--jobs", "1", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert f"view it: ungrasp-ompl view {out}" in proc.stdout
    poses = json.loads((out / "trial_poses.json").read_text())
    assert poses["final_pose_difference_m"] == 0.0  # the recorded run is the campaign's trial 0
    assert len(poses["times_s"]) > 100 and poses["outcome"]
    proc = run_cli("view", str(out), "--frames", "3")
    assert proc.returncode == 0, proc.stderr
    assert "simulated trial 0" in proc.stdout
    assert_picture(out / "view_frames.png")

    from ungrasp_ompl.view import load_scene

    scene, sources = load_scene(out)
    assert out / "trial_poses.json" in sources
    groups = {b.group: i for i, b in enumerate(scene.bodies)}
    planned, simulated = scene.poses[groups["planned"]], scene.poses[groups["simulated"]]
    gap = np.linalg.norm(planned[:, :3, 3] - simulated[:, :3, 3], axis=1)
    assert gap[0] == 0.0 and 0.0 < gap.max() < 0.01  # the same until the trial starts, then close
