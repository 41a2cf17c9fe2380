"""Shared fixtures. OMPL's RNG is seeded once per pytest process, before any planning."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"
REFERENCE_SCENES = ("reference_asymmetric", "reference_upper_obstacle", "reference_equal_digits")

#: The pairs the plane chooser took before it knew the outlines' double normals (contacts, object
#: frame, m): G near the pick's tip and on the chalk's straight side, B on a rounded shoulder or corner.
PREVIOUS_PAIRS = {"guitar_pick": {"G": [0.000718, 0.032210], "B": [-0.007146, 0.000281]},
                  "fabric_chalk": {"G": [0.033752, 0.019497], "B": [0.003374, 0.002159]}}


#: The set-up of the object scenes before their clearances (the pick's reference goal, theta up to
#: 3 deg, no clearances, the default termination): top-level sections of the scene file.
BEFORE_CLEARANCES = {"goal": {"theta_max_deg": 3, "d": [0.57, 0.63], "psi_deg": [36, 42]}, "planning": {},
                     "robot": {}, "start": {"theta_deg": 30, "d": 0.8, "psi_deg": 0}}


def with_previous_pair(name: str, **sections):
    """The shipped scene NAME with its contacts fixed at PREVIOUS_PAIRS[name], and any top-level
    sections of its file replaced by SECTIONS."""
    import yaml

    from ungrasp_ompl import Scene

    doc = yaml.safe_load((SCENES / f"{name}.yaml").read_text())
    return Scene.from_dict({**doc, **sections, "contacts": PREVIOUS_PAIRS[name]},
                           source=f"{name}.yaml, previous pair")


#: The deepest (mm) the measured trials of the base plans sank into a digit or the table, rounded up
#: to the next hundredth of a millimetre (docs/results/sinking.json, "the bound").
SINKING_BOUND_MM = next(r["bound_mm"] for r in json.loads((ROOT / "docs" / "results" / "sinking.json").read_text())
                        ["rows"] if r["label"] == "the bound")


def pick_before_0107() -> dict:
    """The guitar pick from its start before decision 0107, whose plans pass through a P_dpsi: the
    document of scenes/guitar_pick_reference_start.yaml (start d 0.77, the shortest plans), named
    guitar_pick as the scene was. For tests of what a plan with a P_dpsi does (the carry, the
    spread it lands over) and of trials recorded from that start. A new document each call, for the
    caller to edit."""
    import yaml

    doc = yaml.safe_load((SCENES / "guitar_pick_reference_start.yaml").read_text())
    doc["name"] = "guitar_pick"
    return doc


def small_landing(doc: dict) -> dict:
    """A scene document whose robot, where the scene aims by the expected landing (robot.landing
    expected: nine simulated releases), aims by the release simulated with no error drawn
    (robot.landing simulated: one release): the small budget, as the tests' planning times, for
    tests about something else than the landing. The shipped object scenes aim by the model of the
    fall (robot.landing modelled, milliseconds) and pass unchanged; the expected landing is tested
    in test_simulation."""
    robot = doc.get("robot", {})
    if robot.get("landing") != "expected":
        return doc
    return {**doc, "robot": {**{k: v for k, v in robot.items() if k != "landing_pairs"}, "landing": "simulated"}}


def small_landing_file(name: str, directory: Path) -> Path:
    """The shipped scene NAME with small_landing, written as DIRECTORY/NAME.yaml (so named NAME)."""
    import yaml

    path = directory / f"{name}.yaml"
    path.write_text(yaml.safe_dump(small_landing(yaml.safe_load((SCENES / f"{name}.yaml").read_text()))))
    return path


def write_scene(directory: Path, change, name: str = "scene.yaml") -> Path:
    """A copy of the asymmetric reference scene with change(data) applied to its YAML document,
    written as DIRECTORY/NAME."""
    import yaml

    data = yaml.safe_load((SCENES / "reference_asymmetric.yaml").read_text())
    change(data)
    path = directory / name
    path.write_text(yaml.safe_dump(data))
    return path


def peg_scene_file(directory: Path) -> Path:
    """The asymmetric reference scene with a 2 mm peg that the object meets while pivoting through
    about 17 deg, which cuts the start off from the goal (primitives only lower theta): no secure
    path exists. Written as DIRECTORY/peg.yaml."""
    import math

    def peg(data: dict) -> None:
        x, z = 0.018 * math.cos(math.radians(17.5)), 0.018 * math.sin(math.radians(17.5))
        data["obstacles"] = [{"name": "peg", "center": [x, z], "size": [0.002, 0.002]}]

    return write_scene(directory, peg, "peg.yaml")


#: The longest test files first (their total time on two cores, `pytest --durations=0`, about 300 s
#: down to 15 s): xdist hands each worker whole files in collection order (pyproject passes
#: --no-loadscope-reorder, else it orders them by their number of tests), so a long file that
#: started last would leave the other core idle for its whole length. The rest keep their order.
LONGEST_FILES = ("test_simulation.py", "test_tiling.py", "test_sinking.py", "test_bad_input.py", "test_scenes.py",
                 "test_cli.py", "test_certify.py", "test_cluster.py", "test_view.py", "test_objectives.py", "test_benchmark.py",
                 "test_yardstick.py", "test_tolerance.py", "test_lattice_build.py", "test_force_closure.py",
                 "test_planning.py", "test_design.py", "test_workflows.py", "test_cage.py")


def pytest_collection_modifyitems(items):
    rank = {name: k for k, name in enumerate(LONGEST_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: within a file, as written


@pytest.fixture(scope="package")  # the tests directory, no package of its own: once per test process
def scenes():
    from ungrasp_ompl import Scene

    return {name: Scene.from_file(SCENES / f"{name}.yaml") for name in REFERENCE_SCENES}


def paths(node, prefix=()):
    """Every key path into a YAML tree below its root (sections and leaves)."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        yield prefix + (k,)
        yield from paths(v, prefix + (k,))


def leaf(doc, path):
    """The node at path."""
    for k in path:
        doc = doc[k]
    return doc


def command_parsers() -> dict:
    """The command line's commands: name -> its argparse parser, as the program builds them."""
    from ungrasp_ompl.cli.parser import build_parser

    return dict(build_parser()._subparsers._group_actions[0].choices)


def run_cli(*args: str) -> subprocess.CompletedProcess:
    """Run the command line ARGS in this process (``cli.run``, what the console script calls before
    it leaves), its stdout and stderr caught: the whole command, without a new interpreter's second of imports.
    What only a new process shows (C libraries' own output, the working directory, the installed
    entry point) is tested through run_process."""
    import contextlib
    import io

    from ungrasp_ompl.cli import run

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = run(list(args))
        except SystemExit as exc:  # argparse's --help and --version
            code = exc.code if isinstance(exc.code, int) else 0
    return subprocess.CompletedProcess(["ungrasp-ompl", *args], code, out.getvalue(), err.getvalue())


def run_process(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    """Run `python -m ungrasp_ompl ARGS` as a new process, as a user would."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.run([sys.executable, "-m", "ungrasp_ompl", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


def pytest_configure(config):
    """One landing cache (sim.landing.CACHE_VARIABLE) for the whole run, new and empty: the same
    placement's landing, nine simulated releases, is computed once, in whichever test process meets
    it first (xdist's workers inherit the variable), never read from an earlier run or a user's
    cache. Tests of the landing itself call predict_landing and expected_landing, which never cache."""
    from ungrasp_ompl.sim.landing import CACHE_VARIABLE

    if not hasattr(config, "workerinput"):  # the controller (or the one process without xdist)
        config._ungrasp_cache = os.environ[CACHE_VARIABLE] = tempfile.mkdtemp(prefix="ungrasp-landings-")


#: pytest's exit status, once the run has finished (pytest_sessionfinish), for pytest_unconfigure.
EXIT_STATUS: list[int] = []


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    """Remove the run's landing cache, then leave without interpreter finalisation, where nanobind
    (OMPL's bindings) lists the objects still alive: noise after pytest's summary. pytest has
    finished by now."""
    if hasattr(config, "_ungrasp_cache"):
        shutil.rmtree(config._ungrasp_cache, ignore_errors=True)
    if EXIT_STATUS:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(EXIT_STATUS[-1])


def pytest_sessionfinish(exitstatus):
    EXIT_STATUS.append(int(exitstatus))


def distinct_colours(rgb) -> int:
    """How many different colours an (H, W, 3) array of integers 0-255 holds: each pixel's three
    channels packed into one integer, whose 1-D unique is about fifty times faster than
    numpy's unique over rows (axis=0) on a picture of a few megapixels."""
    import numpy as np

    rgb = np.asarray(rgb, dtype=np.uint32)
    return len(np.unique((rgb[..., 0] << 16) | (rgb[..., 1] << 8) | rgb[..., 2]))


def assert_picture(path: Path, colours: tuple[tuple[float, float, float], ...] = ()) -> None:
    """path is a PNG that shows a drawing: a real image of some size, not blank (a share of its
    pixels is neither white nor one flat colour), holding each of the given RGB colours (0-1,
    within 0.08) somewhere."""
    import matplotlib.image as mpimg
    import numpy as np

    img = mpimg.imread(str(path))[..., :3]
    assert img.shape[0] >= 200 and img.shape[1] >= 200, img.shape
    ink = np.any(img < 0.95, axis=-1).mean()
    assert 0.01 < ink < 0.99, f"{path}: {ink:.3f} of the pixels drawn"
    assert distinct_colours((img * 255).astype(np.uint8)) > 8
    for c in colours:
        near = np.all(np.abs(img - np.asarray(c)) < 0.08, axis=-1)
        assert near.any(), f"{path}: no pixel of colour {c}"


def mujoco_drop(spec, pose, duration: float):
    """The object of a SimModelSpec put at pose (4x4, world) and left to gravity and the table in
    MuJoCo for duration (s), the hand parked a metre above: its pose (4x4) at the end."""
    import mujoco
    import numpy as np

    from ungrasp_ompl.sim.model import build_mjcf, model_ids

    model = mujoco.MjModel.from_xml_string(build_mjcf(spec))
    data = mujoco.MjData(model)
    ids = model_ids(model)
    palm = model.jnt_qposadr[model.body_jntadr[ids.palm_body]]
    data.qpos[palm:palm + 7] = [0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0]
    data.mocap_pos[ids.palm_mocap] = [0.0, 0.0, 1.0]
    obj = model.jnt_qposadr[model.body_jntadr[ids.object_body]]
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(pose[:3, :3]).ravel())
    data.qpos[obj:obj + 3], data.qpos[obj + 3:obj + 7] = pose[:3, 3], quat
    mujoco.mj_step(model, data, nstep=round(duration / model.opt.timestep))
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = data.xmat[ids.object_body].reshape(3, 3), data.xpos[ids.object_body]
    return out


def flat_tip(scene):
    """The scene with a flat finger tip (an edge across the width), as tools/sim_campaigns.py's edge rows."""
    from dataclasses import replace

    return replace(scene, digits=replace(scene.digits, flat_finger_tip=True, finger_tip_radius=0.0))


def sim_spec(name: str, flat: bool = False):
    """The simulated world (a SimModelSpec) of a shipped scene, its finger tip flat where asked, as
    sim.setup.trial_setup builds it (no plan needed)."""
    import numpy as np

    from ungrasp_ompl import Scene
    from ungrasp_ompl.robot.model import load_ur5e
    from ungrasp_ompl.robot.pipeline import gripper_links, gripper_spec
    from ungrasp_ompl.sim.setup import gripper_geometry, object_outline
    from ungrasp_ompl.sim.spec import PairFriction, SimModelSpec, SimObject, curved_solid

    scene = Scene.from_file(SCENES / f"{name}.yaml")
    if flat:
        scene = flat_tip(scene)
    robot = load_ur5e(gripper_spec(scene), np.array(scene.robot.base), pincer=gripper_links(scene))
    l = scene.object_length
    solid = curved_solid(scene.digits.section, l, scene.digits.width * l, scene.object3d is not None)
    return SimModelSpec(obj=SimObject(object_outline(scene), scene.object_thickness, scene.sim.density, solid),
                        gripper=gripper_geometry(scene, robot), friction=PairFriction.from_contacts(scene.mu_contacts),
                        timestep=scene.sim.timestep, grip_force=scene.sim.grip_force,
                        servo_stiffness=2 * scene.sim.grip_force / scene.sim.squeeze)
