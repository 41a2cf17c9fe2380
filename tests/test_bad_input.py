"""Every command answers bad input with one line and exit 2, and writes nothing then.

Property: take a shipped scene or layout, replace one of its values (a leaf or a whole section)
by nan, -1, an absurd number, a string, null, a list or an arbitrary number, or a number by a
plausible one near it, and run each
command that reads such a file. The command ends with exit 0 (done), 2 (bad input: one line on
stderr, naming a field, and nothing in the output directory) or 3 (no solution), and never
with a traceback. Commands run in this process through ``cli.run`` (conftest.run_cli) with small budgets, so an
uncaught exception fails the test with its own traceback.

The files the commands read back (plan.json for simulate --plan and cage --plan, trajectory.json
and view_scene.json for view) are fuzzed alike: a value replaced, or the file cut short.

CI runs the small default profile; ``python tools/fuzz_inputs.py`` runs the long one.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from conftest import ROOT, leaf, paths, run_cli, small_landing, small_landing_file
from ungrasp_ompl.cli.exits import EXIT_BAD_INPUT, EXIT_NO_SOLUTION, EXIT_OK

SHIPPED = [yaml.safe_load(p.read_text()) for p in sorted((ROOT / "scenes").glob("*.yaml"))]
SCENES = [small_landing(doc) for doc in SHIPPED if "frame" not in doc]
#: The shipped layouts, each cut to two of its pieces: every field of the layout format is still
#: there to be mutated (each piece has the same fields), and a valid mutant tiles in about 4 s
#: instead of the seven-piece tangram's 12-16 s. test_tiling runs the whole tangram.
LAYOUTS = [{**doc, "pieces": doc["pieces"][3:5]} for doc in SHIPPED if "frame" in doc]

#: Small budgets (short planning times, one trial, the cage's grid twice as coarse): a valid
#: mutated file runs the whole command.
SCENE_COMMANDS = {
    "plan": ("--seed", "1", "--time", "0.2", "--out", "{out}"),
    "stability": (),
    "regions": ("--out", "{out}/regions.png"),
    "bench": ("--planners", "RRTstar", "--runs", "1", "--time", "0.2", "--jobs", "1", "--seed", "1",
              "--out", "{out}"),
    "sweep": ("--alpha", "0.2:0.3:0.1", "--runs", "1", "--time", "0.2", "--jobs", "1", "--seed", "1",
              "--out", "{out}"),
    "simulate": ("--trials", "1", "--perturb", "none", "--jobs", "1", "--time", "0.2", "--out", "{out}"),
    "map": ("--alpha", "0.4", "--time", "0.2", "--jobs", "1", "--seed", "1", "--out", "{out}"),
    "cage": ("--planner", "lattice", "--refine", "0.5", "--out", "{out}"),
    "design": ("--alpha", "0.4", "--tip-radius", "1", "--goal", "scene", "--jobs", "1", "--out", "{out}"),
}
LAYOUT_COMMANDS = {
    "tile": ("--planner", "lattice", "--approaches", "1", "--out", "{out}"),
}

#: The replacements a careless edit or a broken generator produces.
BAD_VALUES = st.one_of(
    st.sampled_from([math.nan, -1, 1e308, -1e308, 0, "x", None, [1, 2, 3], [], {}, True]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-10**30, max_value=10**30),
    st.text(max_size=8),
)


def replaced(doc, path, value):
    """A copy of doc with the node at path replaced by value."""
    doc = yaml.safe_load(yaml.safe_dump(doc))
    node = doc
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return doc


#: A plausible edit of a number: scaled by up to 2, or moved by up to its own size or one unit.
NEARBY = st.tuples(st.sampled_from(["scale", "shift"]), st.floats(min_value=-1.0, max_value=1.0))


def nearby(value, how):
    kind, u = how
    return value * (1.0 + u) if kind == "scale" else value + u * max(abs(value), 1.0)


@st.composite
def mutation(draw, docs, commands):
    """(command, its arguments' template, mutated document, the path changed): one value of one of
    docs replaced by a bad one or, for a number, by a plausible one nearby (which reaches the
    planners and the simulator with scenes no test wrote)."""
    doc = draw(st.sampled_from(docs))
    path = draw(st.sampled_from(list(paths(doc))))
    command = draw(st.sampled_from(sorted(commands)))
    old = leaf(doc, path)
    if isinstance(old, (int, float)) and not isinstance(old, bool) and draw(st.booleans()):
        value = nearby(old, draw(NEARBY))
    else:
        value = draw(BAD_VALUES)
    return command, commands[command], replaced(doc, path, value), path


def run_mutated(command, template, doc):
    """Run command on doc written to a file; returns (exit code, stderr, files under the output dir)."""
    with tempfile.TemporaryDirectory() as tmp:
        scene = Path(tmp) / "scene.yaml"
        scene.write_text(yaml.safe_dump(doc))
        out = Path(tmp) / "out"
        proc = run_cli(command, str(scene), *(a.format(out=out) for a in template))
        written = sorted(p.name for p in out.rglob("*")) if out.exists() else []
        return proc.returncode, proc.stderr, written


def check(code, stderr, written, path):
    assert code in (EXIT_OK, EXIT_BAD_INPUT, EXIT_NO_SOLUTION), (path, code, stderr)
    assert "Traceback" not in stderr, (path, stderr)
    if code == EXIT_BAD_INPUT:
        lines = stderr.rsplit("\r", 1)[-1].strip().splitlines()  # what a terminal shows: a progress line is wiped
        assert len(lines) == 1 and lines[0].startswith("ungrasp-ompl: error: "), (path, stderr)
        assert written == [], (path, stderr, written)


#: Examples per test: a few dozen in CI (fixed, derandomised); tools/fuzz_inputs.py sets more and a seed.
LONG = int(os.environ.get("UNGRASP_FUZZ_EXAMPLES", "0"))
SLOW_SETTINGS = dict(deadline=None, derandomize=not LONG,
                     suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@pytest.mark.slow
@settings(max_examples=LONG or 40, **SLOW_SETTINGS)
@given(mutation(SCENES, SCENE_COMMANDS))
def test_scene_commands_answer_any_mutated_value(case):
    command, template, doc, path = case
    code, stderr, written = run_mutated(command, template, doc)
    event(f"exit {code}")
    check(code, stderr, written, path)


@pytest.mark.slow
@settings(max_examples=LONG // 4 or 6, **SLOW_SETTINGS)
@given(mutation(LAYOUTS, LAYOUT_COMMANDS))
def test_layout_commands_answer_any_mutated_value(case):
    command, template, doc, path = case
    code, stderr, written = run_mutated(command, template, doc)
    event(f"exit {code}")
    check(code, stderr, written, path)


BROKEN_FILES = {
    "empty": b"",
    "not YAML": b"object: [1, 2\n  length: :\n",
    "a list": b"- 1\n- 2\n",
    "a number": b"3.5\n",
    "binary": bytes(range(256)),
    "not UTF-8": b"name: \xff\xfe\n",
}


@pytest.mark.parametrize("content", BROKEN_FILES.values(), ids=BROKEN_FILES.keys())
@pytest.mark.parametrize("command", sorted(SCENE_COMMANDS) + sorted(LAYOUT_COMMANDS))
def test_broken_files_exit_2(tmp_path, command, content):
    scene = tmp_path / "scene.yaml"
    scene.write_bytes(content)
    out = tmp_path / "out"
    template = {**SCENE_COMMANDS, **LAYOUT_COMMANDS}[command]
    proc = run_cli(command, str(scene), *(a.format(out=out) for a in template))
    assert proc.returncode == EXIT_BAD_INPUT, proc.stderr
    check(proc.returncode, proc.stderr, sorted(out.rglob("*")) if out.exists() else [], "file")


# --- files read back: plan.json (simulate --plan, cage --plan), the exported trajectory (view) ---

@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """What plan --export DIR writes for guitar_pick: plan.json,
    trajectory.json, view_scene.json; the scene file beside DIR. (RRT*, seed 1, first finds the
    pick's path, secure over its friction's +-30 %, after some 5,000 iterations: --time 1.)"""
    base = tmp_path_factory.mktemp("exported")
    scene = small_landing_file("guitar_pick", base)
    out = base / "export"
    assert run_cli("plan", str(scene), "--seed", "1", "--time", "1", "--export", str(out)).returncode == EXIT_OK
    return out


#: Read-back commands, with the directory holding the edited file as {dir} and the scene file
#: as {scene}; small budgets.
READ_BACK = {
    "plan.json": {"cage": ("cage", "{scene}", "--plan", "{dir}", "--refine", "0.5", "--out", "{out}"),
                  "simulate": ("simulate", "{scene}", "--plan", "{dir}", "--trials", "1", "--jobs", "1",
                               "--perturb", "none", "--out", "{out}")},
    "trajectory.json": {"view": ("view", "{dir}", "--out", "{out}/view.html")},
    "view_scene.json": {"view": ("view", "{dir}", "--out", "{out}/view.html")},
}


def short_paths(node, prefix=()):
    """paths(node), but of a long list only its first, second and last items (a trajectory's samples)."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        if isinstance(node, list) and 1 < k < len(node) - 1:
            continue
        yield prefix + (k,)
        yield from short_paths(v, prefix + (k,))


#: An edit of a JSON file: cut short at a share of its length, or one value (the k-th of its key
#: paths, modulo their count) replaced by a bad one or, for a number, by one nearby.
EDITS = st.one_of(st.tuples(st.just("cut"), st.floats(0.0, 0.999)),
                  st.tuples(st.just("replace"), st.integers(0, 10**6), BAD_VALUES),
                  st.tuples(st.just("nearby"), st.integers(0, 10**6), NEARBY))


def edit(text, change):
    """(the file's text after the change, what changed)."""
    if change[0] == "cut":
        return text[:int(len(text) * change[1])], "cut short"
    doc = json.loads(text)
    keys = list(short_paths(doc))
    path = keys[change[1] % len(keys)]
    old = leaf(doc, path)
    if change[0] == "nearby" and isinstance(old, (int, float)) and not isinstance(old, bool):
        value = nearby(old, change[2])
    else:
        value = math.nan if change[0] == "nearby" else change[2]
    node = doc
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return json.dumps(doc), path


def run_edited(exported, name, template, change):
    """Run a command on a copy of the export with the file edited; (exit code, stderr, files written,
    what changed)."""
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "in"
        shutil.copytree(exported, src)
        text, where = edit((exported / name).read_text(), change)
        (src / name).write_text(text)
        out = Path(tmp) / "out"
        proc = run_cli(*(a.format(dir=src, out=out, scene=exported.parent / "guitar_pick.yaml") for a in template))
        written = sorted(p.name for p in out.rglob("*")) if out.exists() else []
        return proc.returncode, proc.stderr, written, where


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(READ_BACK))
@settings(max_examples=LONG // 4 or 12, **SLOW_SETTINGS)
@given(data=st.data())
def test_files_read_back_answer_any_edit(exported, name, data):
    """plan.json, trajectory.json and view_scene.json hand-edited or cut short: exit 0, 2 (one line
    naming the field, nothing written) or 3, never a traceback or a Python exception's text."""
    command = data.draw(st.sampled_from(sorted(READ_BACK[name])))
    code, stderr, written, where = run_edited(exported, name, READ_BACK[name][command], data.draw(EDITS))
    event(f"{name} {command}: exit {code}")
    check(code, stderr, written, (name, where))
    assert "Error" not in stderr and "Exception" not in stderr, (name, where, stderr)
