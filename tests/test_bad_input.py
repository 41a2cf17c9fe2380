"""Every command answers bad input with one line and exit 2, and writes nothing then.

Property: take a shipped scene or layout, replace one of its values (a leaf or a whole section)
by nan, -1, an absurd number, a string, null, a list or an arbitrary number, or a number by a
plausible one near it, and run each
command that reads such a file. The command ends with exit 0 (done), 2 (bad input: one line on
stderr, naming a field, and nothing in the output directory) or 3 (no solution), and never
with a traceback. Commands run in this process through ``cli.run`` with small budgets, so an
uncaught exception fails the test with its own traceback.

CI runs the small default profile; ``python tools/fuzz_inputs.py`` runs the long one.
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from conftest import ROOT
from ungrasp_ompl.cli import run
from ungrasp_ompl.errors import EXIT_BAD_INPUT, EXIT_NO_SOLUTION, EXIT_OK

SHIPPED = sorted((ROOT / "scenes").glob("*.yaml"))
LAYOUTS = [p for p in SHIPPED if "frame" in (yaml.safe_load(p.read_text()) or {})]
SCENES = [p for p in SHIPPED if p not in LAYOUTS]

#: Small budgets: a valid mutated file runs the whole command.
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
    "cage": ("--planner", "lattice", "--out", "{out}"),
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


def paths(node, prefix=()):
    """Every key path into a YAML tree below its root (sections and leaves)."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        yield prefix + (k,)
        yield from paths(v, prefix + (k,))


def replaced(doc, path, value):
    """A copy of doc with the node at path replaced by value."""
    doc = yaml.safe_load(yaml.safe_dump(doc))
    node = doc
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return doc


def leaf(doc, path):
    """The node at path."""
    for k in path:
        doc = doc[k]
    return doc


#: A plausible edit of a number: scaled by up to 2, or moved by up to its own size or one unit.
NEARBY = st.tuples(st.sampled_from(["scale", "shift"]), st.floats(min_value=-1.0, max_value=1.0))


def nearby(value, how):
    kind, u = how
    return value * (1.0 + u) if kind == "scale" else value + u * max(abs(value), 1.0)


@st.composite
def mutation(draw, files, commands):
    """(command, its arguments' template, mutated document, the path changed): one value replaced by
    a bad one or, for a number, by a plausible one nearby (which reaches the planners and the
    simulator with scenes no test wrote)."""
    source = draw(st.sampled_from(files))
    doc = yaml.safe_load(source.read_text())
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
        argv = [command, str(scene), *(a.format(out=out) for a in template)]
        err = io.StringIO()
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            code = run(argv)
        written = sorted(p.name for p in out.rglob("*")) if out.exists() else []
        return code, err.getvalue(), written


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
    argv = [command, str(scene), *(a.format(out=out) for a in template)]
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = run(argv)
    assert code == EXIT_BAD_INPUT, err.getvalue()
    check(code, err.getvalue(), sorted(out.rglob("*")) if out.exists() else [], "file")
