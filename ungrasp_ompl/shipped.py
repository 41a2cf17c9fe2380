"""Files shipped inside the package: data files as filesystem paths, and the shipped scenes and
layouts by name.

The repository's top-level ``scenes/`` directory is installed as the package
``ungrasp_ompl.shipped_scenes`` (see setup.py), in a wheel and in an editable install alike, so
``resolve("guitar_pick")`` finds ``scenes/guitar_pick.yaml`` wherever the package is installed.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import re
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import yaml

from .errors import InputError
from .io import parse_yaml

#: The package holding the shipped scene and layout files (the repository's scenes/*.yaml).
SCENES_PACKAGE = "ungrasp_ompl.shipped_scenes"
#: What a shipped file is: a scene (plan, stability, regions, bench, sweep) or a layout (tile).
KINDS = ("scene", "layout")
_SUFFIXES = (".yaml", ".yml")

# Files extracted from a package that is not on the filesystem (a zip) live until exit.
_extracted = contextlib.ExitStack()
atexit.register(_extracted.close)


def package_file(package: str, name: str) -> Path:
    """Returns a filesystem path of the data file ``name`` of ``package``: the file itself for an
    installed (or editable) package, a temporary copy kept until exit for a zipped one.
    Raises FileNotFoundError when the package has no such file."""
    resource = resources.files(package) / name
    if not resource.is_file():
        raise FileNotFoundError(f"{package} has no data file {name}")
    return _extracted.enter_context(resources.as_file(resource))


@dataclass(frozen=True)
class ShippedScene:
    """One shipped scene or layout file."""

    name: str  #: the file's stem, the name a command takes
    kind: str  #: "scene" or "layout" (a layout has ``pieces``)
    description: str  #: its ``description:`` field, else its first comment line
    path: Path  #: where it is on the filesystem
    planar_only: str | None = None  #: why the robot cannot execute it (its ``planar_only:``); None: robot-ready


def _describe(text: str, data: object) -> str:
    """The one-line description of a scene file: ``description:``, else its first comment line."""
    if isinstance(data, dict) and isinstance(data.get("description"), str) and data["description"].strip():
        return data["description"].strip().splitlines()[0]
    for line in text.splitlines():
        if line.startswith("#") and line.lstrip("#").strip():
            return line.lstrip("#").strip()
    return ""


def shipped_scenes() -> list[ShippedScene]:
    """Returns the shipped scenes and layouts, sorted by name. Raises InputError naming the file
    if a shipped file is not valid YAML (a broken installation)."""
    found = []
    for entry in resources.files(SCENES_PACKAGE).iterdir():
        if not entry.is_file() or not entry.name.endswith(_SUFFIXES):
            continue
        text = entry.read_text(encoding="utf-8")
        try:
            data = parse_yaml(text)
        except yaml.YAMLError:
            raise InputError("scene", "not valid YAML", f"shipped {entry.name}") from None
        kind = "layout" if isinstance(data, dict) and "pieces" in data else "scene"
        planar = data.get("planar_only") if isinstance(data, dict) else None
        found.append(ShippedScene(name=Path(entry.name).stem, kind=kind, description=_describe(text, data),
                                  path=package_file(SCENES_PACKAGE, entry.name),
                                  planar_only=str(planar).strip() if planar else None))
    return sorted(found, key=lambda s: s.name)


def shipped_names(text: str) -> str:
    """text with every path of a shipped scene or layout file replaced by its name (guitar_pick for
    .../site-packages/ungrasp_ompl/shipped_scenes/guitar_pick.yaml): how a message names them."""
    folder = os.path.join(str(resources.files(SCENES_PACKAGE)), "")
    return re.sub(re.escape(folder) + r"([\w.-]+?)\.ya?ml\b", r"\1", text)


def resolve(name_or_path: str | os.PathLike[str], kind: str = "scene") -> Path:
    """Returns the file a command's scene or layout argument stands for.

    An existing file, or anything with a directory part (``scenes/x.yaml``, ``./x``), is taken as
    a path and returned as given (a missing one is reported by the loader). A bare name that is
    not an existing file (``guitar_pick``, also ``guitar_pick.yaml``) is the shipped file of that name.
    Raises InputError with field ``kind`` when no shipped file has the name (listing those of
    this kind) or the shipped file is of the other kind.
    """
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    text = os.fspath(name_or_path)
    path = Path(text)
    has_directory = any(sep in text for sep in (os.sep, os.altsep) if sep)
    if not text or has_directory or path.is_file():
        return path
    name = path.stem if path.suffix in _SUFFIXES else path.name
    shipped = shipped_scenes()
    match = next((s for s in shipped if s.name == name), None)
    if match is None:
        names = ", ".join(s.name for s in shipped if s.kind == kind) or "none"
        raise InputError(kind, f"no such file, and no shipped {kind} named '{name}'; shipped {kind}s: {names}", text)
    if match.kind != kind:
        raise InputError(kind, f"the shipped '{name}' is a {match.kind}, not a {kind}", text)
    return match.path
