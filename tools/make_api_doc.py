"""Write docs/api.md, the package's public API: each package's ``__all__``, each name with its kind,
its signature (a class's fields or members) and the first paragraph of its docstring.

    python tools/make_api_doc.py           # write docs/api.md
    python tools/make_api_doc.py --check   # exit 1, naming the first difference, when docs/api.md is stale

tests/test_api.py holds every package's ``__all__`` and the page's names to each other.
"""

from __future__ import annotations

import argparse
import dataclasses
import enum
import importlib
import inspect
import pkgutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import ungrasp_ompl  # noqa: E402

PAGE = ROOT / "docs" / "api.md"

#: The packages in the page's order: the package itself, then from the workflows down to the
#: model's floors, then the command line; any package not named here follows, by name.
ORDER = ("ungrasp_ompl", "ungrasp_ompl.workflows", "ungrasp_ompl.scene", "ungrasp_ompl.planning",
         "ungrasp_ompl.layout", "ungrasp_ompl.benchmark", "ungrasp_ompl.parallel", "ungrasp_ompl.view", "ungrasp_ompl.sim",
         "ungrasp_ompl.geometry", "ungrasp_ompl.mechanics", "ungrasp_ompl.cli")

HEADER = """# The public API

Written by `python tools/make_api_doc.py` from the packages' `__all__` and docstrings: edit those,
not this page (`tests/test_api.py` holds the two to each other). What a package's `__all__` lists
is what a user may use; any other name, though importable by its module's path, is internal and
may change. Units are the code's: metres, radians, seconds and newtons, d over the object length,
unless a name says otherwise.
"""


def packages() -> list[str]:
    """ungrasp_ompl and its subpackages, in the page's order."""
    found = ["ungrasp_ompl"] + [f"ungrasp_ompl.{m.name}" for m in pkgutil.iter_modules(ungrasp_ompl.__path__)
                                if m.ispkg]
    return [p for p in ORDER if p in found] + sorted(p for p in found if p not in ORDER)


def paragraph(doc: str | None) -> str:
    """The first paragraph of a docstring, on one line."""
    text = inspect.cleandoc(doc or "")
    return " ".join(text.split("\n\n", 1)[0].split())


def _default(value: object, longest: int = 60) -> str:
    text = repr(value)
    return "..." if " at 0x" in text or len(text) > longest else text


def signature(name: str, obj: object) -> str:
    """name(parameters) as written in the source (annotations as strings), defaults shortened."""
    try:
        sig = inspect.signature(obj)
    except (TypeError, ValueError):
        return name
    parts, star = [], False
    for p in sig.parameters.values():
        if p.kind is p.KEYWORD_ONLY and not star:
            parts.append("*")
            star = True
        text = ("*" if p.kind is p.VAR_POSITIONAL else "**" if p.kind is p.VAR_KEYWORD else "") + p.name
        star = star or p.kind is p.VAR_POSITIONAL
        if p.annotation is not p.empty:
            text += f": {p.annotation if isinstance(p.annotation, str) else inspect.formatannotation(p.annotation)}"
        if p.default is not p.empty:
            text += f" = {_default(p.default)}"
        parts.append(text)
    back = sig.return_annotation
    arrow = "" if back is sig.empty else f" -> {back if isinstance(back, str) else inspect.formatannotation(back)}"
    return f"{name}({', '.join(parts)}){arrow}"


def describe(name: str, obj: object) -> list[str]:
    """The page's lines for one name."""
    home = getattr(obj, "__module__", None)
    if inspect.isclass(obj) and issubclass(obj, enum.Enum):
        kind, head = "enum", ", ".join(f"`{m.name}`" for m in obj)
        head = f"members: {head}"
    elif inspect.isclass(obj) and dataclasses.is_dataclass(obj):
        kind = "dataclass"
        head = "fields: " + ", ".join(f"`{f.name}`" for f in dataclasses.fields(obj) if f.init)
    elif inspect.isclass(obj):
        kind, head = "class", f"`{signature(name, obj)}`"
    elif callable(obj):
        kind, head = "function", f"`{signature(name, obj)}`"
    else:
        kind, home = "constant", None
        head = f"`{name} = {_default(obj, 400)}`"
    lines = [f"### `{name}`", "", f"*{kind}*" + (f", from `{home}`" if home else "") + f": {head}", ""]
    doc = paragraph(obj.__doc__) if kind != "constant" else ""
    if doc:
        lines += [doc, ""]
    return lines


def page() -> str:
    """The text of docs/api.md."""
    out = [HEADER]
    seen: dict[int, str] = {}
    empty = []
    total = 0
    for package in packages():
        module = importlib.import_module(package)
        names = list(module.__all__)
        if not names:
            empty.append(package)
            continue
        total += len(names)
        out += [f"## `{package}`", "", paragraph(module.__doc__), ""]
        for name in names:
            obj = getattr(module, name)
            first = seen.get(id(obj)) if not isinstance(obj, (str, int, float, tuple)) else None
            if first is not None:
                out += [f"### `{name}`", "", f"The same as `{first}`.", ""]
                continue
            seen[id(obj)] = f"{package}.{name}"
            out += describe(name, obj)
    out += ["## Packages without public names", "",
            ", ".join(f"`{p}`" for p in empty) + ": their `__all__` is empty. The workflows, the benchmark "
            "and the view reach them (pictures, the arm, the robot's files).", ""]
    out.insert(1, f"{total} names in {len(packages()) - len(empty)} packages.\n")
    return "\n".join(out).rstrip("\n") + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="compare docs/api.md with what would be written")
    args = parser.parse_args()
    text = page()
    if args.check:
        old = PAGE.read_text() if PAGE.exists() else ""
        if old == text:
            return 0
        for k, (a, b) in enumerate(zip(old.splitlines() + [""] * 9999, text.splitlines())):
            if a != b:
                print(f"docs/api.md is stale at line {k + 1}:\n  has:    {a}\n  writes: {b}", file=sys.stderr)
                break
        return 1
    PAGE.write_text(text)
    print(f"wrote {PAGE.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
