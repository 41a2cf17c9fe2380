"""Atomic file writing: a file is either its old self or completely new, never half-written;
reading back the JSON files the commands wrote; parsing YAML, and editing a YAML file's top-level
keys with its comments kept."""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import yaml

from .errors import InputError

# libyaml's C parser when PyYAML has it: the same values as the pure-Python one, ten times faster
# (a scene file: 8 ms -> 0.8 ms; every command and campaign task reads one)
_YAML_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def parse_yaml(text: str) -> Any:
    """text parsed as YAML (its safe subset: plain data, no Python objects); yaml.YAMLError when it
    is not YAML."""
    return yaml.load(text, Loader=_YAML_LOADER)


def edited_yaml(text: str, updates: Mapping[str, Any]) -> str:
    """text, a YAML file whose top level is a block mapping, with each top-level key of updates set
    to its value, every line the change does not touch, comments included, as it was. A mapping
    written in block style is edited entry by entry (its changed entries rewritten, those no longer
    there dropped, new ones added at its end); any other changed value is written on one line in
    flow style where its block was; a key the file lacks is appended. Where the edit cannot be made
    so (the result does not read back as the file's document with the updates), the document with
    the updates is written whole (comments lost)."""
    doc = parse_yaml(text)
    wanted = {**doc, **updates}
    lines = [s if s.endswith("\n") else s + "\n" for s in text.splitlines(keepends=True)]
    edited = "".join(_edited_block(lines, "", doc, wanted))
    try:
        if parse_yaml(edited) == wanted:
            return edited
    except yaml.YAMLError:
        pass
    return yaml.safe_dump(wanted, sort_keys=False, default_flow_style=None)


def _edited_block(lines: list[str], indent: str, old: Mapping[str, Any], new: Mapping[str, Any]) -> list[str]:
    """The lines of a block mapping whose entries start at indent, edited from old to new
    (edited_yaml)."""
    spans = _entry_spans(lines, indent)
    out: list[str] = []
    done = 0
    for key, (first, last) in spans.items():
        out += lines[done:first]
        done = last + 1
        if key not in new:
            continue
        if key in old and new[key] == old[key]:
            out += lines[first:done]
            continue
        head = lines[first].split("#", 1)[0].rstrip()
        inner = next((s for s in lines[first + 1:done] if s.strip() and not s.lstrip().startswith("#")), "")
        if head.endswith(":") and isinstance(old.get(key), dict) and isinstance(new[key], dict) and inner:
            child = inner[:len(inner) - len(inner.lstrip())]
            out += [lines[first]] + _edited_block(lines[first + 1:done], child, old[key], new[key])
        else:
            out.append(_flow_line(indent, key, new[key]))
    out += lines[done:]
    return out + [_flow_line(indent, k, v) for k, v in new.items() if k not in spans]


def _entry_spans(lines: list[str], indent: str) -> dict[str, tuple[int, int]]:
    """Per key of the block mapping whose entries start at indent, its first line and the last line
    of its value (indented deeper, or a sequence's items at the key's own indentation; comments
    after the value belong to what follows)."""
    spans: dict[str, tuple[int, int]] = {}
    key = None
    for k, s in enumerate(lines):
        if not s.strip() or s.lstrip().startswith("#"):
            continue
        depth = len(s) - len(s.lstrip())
        item = s.lstrip().startswith("-") and s.strip()[1:2] in ("", " ")
        if depth == len(indent) and not item:
            key = s.strip().split(":", 1)[0].strip().strip("'\"")
            spans[key] = (k, k)
        elif depth >= len(indent) and key is not None:
            spans[key] = (spans[key][0], k)
    return spans


def _flow_line(indent: str, key: str, value: Any) -> str:
    """key: value on one line at indent, the value in YAML's flow style."""
    flow = yaml.safe_dump({key: value}, default_flow_style=True, sort_keys=False, width=float("inf"))
    return indent + flow.strip()[1:-1] + "\n"  # {key: value} -> key: value


def write_atomic(path: str | os.PathLike[str], write: Callable[[str], None]) -> None:
    """Call write(tmp_path) on a temporary file beside path, then move it into place."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    try:
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file the usual mode
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write text to path atomically."""
    write_atomic(path, lambda tmp: Path(tmp).write_text(text))


def read_json_file(path: str | os.PathLike[str], field: str) -> Any:
    """The parsed JSON of a file the commands wrote; InputError naming field (the file's option or
    name) when it is missing, unreadable, or not JSON (cut short or mistyped: the place is given)."""
    source = str(path)
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(field, "no such file", source) from None
    except json.JSONDecodeError as exc:
        raise InputError(field, f"is not valid JSON (cut short or mistyped?) at line {exc.lineno}, column "
                         f"{exc.colno}", source) from None
    except (OSError, UnicodeDecodeError, RecursionError):
        raise InputError(field, "cannot be read as JSON text", source) from None


def read_versioned_json(path: str | os.PathLike[str], field: str, format: str, version: int) -> dict:
    """The parsed JSON object of a file the commands wrote under a "format" name and a
    "schema_version" (read_json_file's errors, then InputError naming "format" or
    "schema_version" when the file is another kind or another version)."""
    source = str(path)
    doc = read_json_file(path, field)
    if not isinstance(doc, dict) or doc.get("format") != format:
        raise InputError("format", f"expected {format!r}", source)
    if doc.get("schema_version") != version:
        raise InputError("schema_version", f"is {doc.get('schema_version')!r}; this reader understands {version}",
                         source)
    return doc
