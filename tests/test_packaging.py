"""The package carries what it loads: the UR5e URDF and the shipped scenes are package data found
with importlib.resources (not read from the clone), and commands take a shipped scene by name."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from importlib import resources
from pathlib import Path

import pytest
import yaml

import ungrasp_ompl
from conftest import ROOT, SCENES, run_process
from ungrasp_ompl.errors import InputError
from ungrasp_ompl.layout.model import Layout
from ungrasp_ompl.robot.model import GripperSpec, load_ur5e
from ungrasp_ompl.robots import ur5e_urdf
from ungrasp_ompl.scene import Scene
from ungrasp_ompl.shipped import SCENES_PACKAGE, resolve, shipped_scenes

PACKAGE_DIR = Path(ungrasp_ompl.__file__).resolve().parent
SCENE_FILES = sorted(SCENES.glob("*.yaml"))


def _kind(path: Path) -> str:
    return "layout" if "pieces" in yaml.safe_load(path.read_text()) else "scene"


def test_urdf_is_package_data_inside_the_package():
    path = ur5e_urdf()
    assert path.is_file()
    assert path.resolve().is_relative_to(PACKAGE_DIR)
    assert path.resolve() == Path(str(resources.files("ungrasp_ompl.robots") / "ur5e.urdf")).resolve()
    # nothing is left for code to find at the clone's top level
    assert not (ROOT / "robots" / "ur5e.urdf").exists()


def test_default_arm_is_built_from_the_shipped_urdf():
    robot = load_ur5e(GripperSpec(finger_length=0.09, thumb_length=0.07, finger_width=0.02, digit_thickness=0.012))
    assert robot.model.existFrame("tool0") and len(robot.arm_joint_ids) == 6


def test_every_scene_file_is_shipped():
    assert SCENE_FILES, "no scenes/*.yaml"
    assert sorted(s.name for s in shipped_scenes()) == [p.stem for p in SCENE_FILES]


@pytest.mark.parametrize("source", SCENE_FILES, ids=lambda p: p.stem)
def test_shipped_scene_resolves_by_name_and_loads(source):
    kind = _kind(source)
    path = resolve(source.stem, kind)
    assert path.parent.resolve() == Path(str(resources.files(SCENES_PACKAGE))).resolve()
    assert path.read_text() == source.read_text()
    assert resolve(source.name, kind) == path  # the file name works as well as the stem
    loaded = Layout.from_file(path) if kind == "layout" else Scene.from_file(path)
    assert loaded.name == yaml.safe_load(source.read_text()).get("name", source.stem)


def test_unknown_name_is_an_input_error_listing_the_shipped_scenes():
    with pytest.raises(InputError) as err:
        resolve("no_such_scene", "scene")
    assert err.value.field == "scene"
    assert "no_such_scene" in str(err.value) and "guitar_pick" in str(err.value)
    assert "tangram" not in err.value.reason  # a layout is not offered as a scene


def test_name_of_the_other_kind_is_an_input_error():
    with pytest.raises(InputError) as err:
        resolve("tangram", "scene")
    assert err.value.field == "scene" and "layout" in err.value.reason
    with pytest.raises(InputError) as err:
        resolve("guitar_pick", "layout")
    assert err.value.field == "layout"


def test_paths_and_existing_files_are_taken_as_given(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # a path with a directory part is never looked up among the shipped scenes
    assert resolve("somewhere/guitar_pick.yaml") == Path("somewhere/guitar_pick.yaml")
    assert resolve("./guitar_pick") == Path("guitar_pick")
    # a local file wins over the shipped scene of the same name
    Path("guitar_pick").write_text("name: mine\n")
    assert resolve("guitar_pick") == Path("guitar_pick")


def test_scenes_command_lists_every_shipped_file():
    proc = run_process("scenes")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    rows = {line.split()[0]: (line.split(maxsplit=3), "".join(lines[k + 2:k + 3])) for k, line in enumerate(lines[1:])
            if line.strip() and not line.startswith(" ")}
    for source in SCENE_FILES:
        assert source.stem in rows, f"{source.stem} not listed:\n{proc.stdout}"
        (_, kind, robot, description), below = rows[source.stem]
        doc = yaml.safe_load(source.read_text())
        assert kind == _kind(source)
        assert description == doc["description"]
        assert robot == ("planar" if "planar_only" in doc else "ready")
        if robot == "planar":  # the reason, from the file, on the line below
            assert below.strip() == f"planar only: {doc['planar_only']}"


def test_readme_python_example_runs_outside_the_clone(tmp_path):
    """The README's API example, as a user pastes it: the installed package, another directory."""
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## Python API", 1)[1]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("Scene('reference_asymmetric', length_m=0.06, ")
    assert "solved reference_asymmetric with RRTstar (seed 1" in proc.stdout
    assert not any(tmp_path.iterdir())  # it writes nothing


def test_scene_repr_is_one_line_in_si_units():
    scene = Scene.from_file("guitar_pick")
    text = repr(scene)
    assert "\n" not in text and len(text) < 300, text
    assert f"length_m={scene.object_length:.4g}," in text and "thickness_m=0.00096," in text
    assert "thumb_m=0.06," in text and f"start=(theta_deg=30, d={scene.start[1]:g}, psi_deg=0)" in text


def test_commands_take_a_shipped_name_from_any_directory(tmp_path):
    proc = run_process("stability", "guitar_pick", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("guitar_pick:")
    proc = run_process("plan", "no_such_scene", cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "scene" in proc.stderr and "guitar_pick" in proc.stderr
    proc = run_process("tile", "guitar_pick", "--out", str(tmp_path / "tiles"), cwd=tmp_path)
    assert proc.returncode == 2 and "not a layout" in proc.stderr
    assert not (tmp_path / "tiles").exists()


@pytest.mark.slow
def test_wheel_carries_the_urdf_and_every_scene(tmp_path):
    """Build the wheel as `pip install .` would (from a copy: the build writes beside the sources)
    and look inside; the CI also installs it and runs commands from it."""
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "setup.py", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    for name in ("ungrasp_ompl", "scenes", "robots"):
        shutil.copytree(ROOT / name, src / name, ignore=shutil.ignore_patterns("__pycache__"))
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path / "dist"),
                           str(src)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    (wheel,) = (tmp_path / "dist").glob("ungrasp_ompl-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    assert "ungrasp_ompl/robots/ur5e.urdf" in names
    for source in SCENE_FILES:
        assert f"ungrasp_ompl/shipped_scenes/{source.name}" in names
    assert not any(n.startswith(("robots/", "scenes/", "tests/")) for n in names)
