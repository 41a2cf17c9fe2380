"""io.edited_yaml: a scene file's top-level keys set to new values with every other line kept, its
comments among them; what it writes reads back as the file's document with the updates."""

from __future__ import annotations

import pytest

from conftest import SCENES
from ungrasp_ompl.io import edited_yaml, parse_yaml

FILES = sorted(SCENES.glob("*.yaml"))


def _comments(text: str) -> list[str]:
    return [s for s in text.splitlines() if s.lstrip().startswith("#")]


@pytest.mark.parametrize("path", FILES, ids=[p.stem for p in FILES])
def test_an_edit_reads_back_as_the_updates_and_keeps_every_comment(path):
    text = path.read_text()
    doc = parse_yaml(text)
    updates = {"start": {**doc.get("start", {}), "d": 0.5}, "digits": {**doc["digits"], "alpha": 0.31},
               "added": [1.5, {"x": "y"}]}
    edited = edited_yaml(text, updates)
    assert parse_yaml(edited) == {**doc, **updates}
    assert _comments(edited) == _comments(text)
    changed = set(edited.splitlines()) - set(text.splitlines())
    assert len(changed) <= 4  # the start's line, alpha's (or the digits' line), the one added


def test_entries_no_longer_there_are_dropped_and_unchanged_values_keep_their_lines():
    text = ("# head\na:\n  x: 1  # kept\n  y: 2  # dropped with y\n  z:\n    - 3\n# about b\nb: {p: 1}\n"
            "c: 3\n")
    edited = edited_yaml(text, {"a": {"x": 1, "z": [4], "w": 5}, "b": {"p": 1}})
    assert parse_yaml(edited) == {"a": {"x": 1, "z": [4], "w": 5}, "b": {"p": 1}, "c": 3}
    assert edited.splitlines() == ["# head", "a:", "  x: 1  # kept", "  z: [4]", "  w: 5", "# about b", "b: {p: 1}",
                                   "c: 3"]


def test_a_file_that_cannot_be_edited_line_by_line_is_written_whole():
    text = "{a: 1, b: {c: 2}}  # a flow mapping on one line\n"
    edited = edited_yaml(text, {"b": {"c": 3}})
    assert parse_yaml(edited) == {"a": 1, "b": {"c": 3}}
