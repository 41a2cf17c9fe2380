"""Atomic file writing: a file is either its old self or completely new, never half-written;
reading back the JSON files the commands wrote; parsing YAML."""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable
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
