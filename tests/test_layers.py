"""The package's layers (docs/architecture.md): no module imports from a higher floor, and no
modules import each other in a circle.

Every import statement of every module is read from its source: at module level, inside functions
(a lazy import is an import all the same) and under ``if TYPE_CHECKING`` (an annotation that names
a higher floor's type ties the lower floor to it just as well). Each floor's modules are listed as
the architecture page's table lists them, and a test holds the two lists equal."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import ungrasp_ompl
from conftest import command_parsers

PACKAGE = Path(ungrasp_ompl.__file__).parent

#: The floors, lowest first, as docs/architecture.md's table has them: module or package names
#: relative to ungrasp_ompl.
FLOORS = (
    ("errors", "io", "shipped", "provenance", "parallel", "_lazy"),
    ("mechanics",),
    ("geometry",),
    ("scene",),
    ("planning",),
    ("layout",),
    ("plots",),
    ("robot", "robots"),
    ("sim",),
    ("benchmark",),
    ("view",),
    ("workflows",),
    ("cli", "__main__", "__init__"),
)


def floor_of(module: str) -> int:
    """The floor of a module named relative to the package (``scene.model``)."""
    head = module.split(".")[0]
    for k, names in enumerate(FLOORS):
        if head in names:
            return k
    raise AssertionError(f"ungrasp_ompl.{module} is on no floor of docs/architecture.md")


def _modules() -> list[tuple[str, Path]]:
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).with_suffix("")
        parts = rel.parts[:-1] if rel.name == "__init__" and len(rel.parts) > 1 else rel.parts
        out.append((".".join(parts), path))
    return out


def _is_module(parts: list[str]) -> bool:
    path = PACKAGE.joinpath(*parts)
    return path.with_suffix(".py").exists() or (path / "__init__.py").exists()


def imports(module: str, path: Path) -> list[tuple[int, str]]:
    """(line, module relative to the package) of every import of the package's own modules: at
    module level, in a function or under ``if TYPE_CHECKING``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    found: list[tuple[int, str]] = []

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.ImportFrom):
            if node.level:  # from .x import y, from .. import y: y a module of that package, or a name in it
                base = package[: len(package) - (node.level - 1)] if node.level > 1 else package
                held = base + (node.module.split(".") if node.module else [])
            else:
                held = (node.module or "").split(".")
                if held[0] != "ungrasp_ompl":
                    held = None
                held = held and held[1:]
            if held is not None:
                names = {".".join(held + [a.name]) if _is_module(held + [a.name]) else ".".join(held)
                         for a in node.names}
                found.extend((node.lineno, t or "__init__") for t in sorted(names))
        elif isinstance(node, ast.Import):
            found.extend((node.lineno, a.name[len("ungrasp_ompl."):]) for a in node.names
                         if a.name.startswith("ungrasp_ompl."))
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return found


def test_every_module_is_on_a_floor():
    for module, _ in _modules():
        floor_of(module or "__init__")


@pytest.mark.parametrize("module,path", _modules(), ids=lambda x: str(x) if isinstance(x, str) else "")
def test_no_module_imports_from_a_higher_floor(module, path):
    own = floor_of(module or "__init__")
    above = [f"line {line}: {target} (floor {floor_of(target)})" for line, target in imports(module, path)
             if floor_of(target) > own]
    assert not above, f"ungrasp_ompl.{module} (floor {own}) imports from above: " + "; ".join(above)


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The circles of an import graph (module -> the modules it imports): each set of two or more
    modules that reach one another, and each module that imports itself (Tarjan's strongly
    connected components), sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:  # recursion depth: the longest chain of imports, some tens of modules
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            part = []
            while True:
                w = stack.pop()
                part.append(w)
                if w == v:
                    break
            if len(part) > 1 or v in graph.get(v, ()):
                found.append(sorted(part))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(found)


def test_no_modules_import_each_other_in_a_circle():
    graph = {module or "__init__": {target for _, target in imports(module, path)} for module, path in _modules()}
    assert not circles(graph), "import circles: " + "; ".join(" <-> ".join(c) for c in circles(graph))


def test_the_reader_sees_lazy_imports_and_annotations(tmp_path):
    """The check's own reader: an import inside a function counts, and so does one under TYPE_CHECKING."""
    src = tmp_path / "probe.py"
    src.write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..sim import trial\n"
                   "def f():\n    from ..robot.ik import solve\n    from . import model\n")
    assert imports("scene.probe", src) == [(3, "sim.trial"), (5, "robot.ik"), (6, "scene.model")]


def test_the_circle_finder_finds_a_loop_and_a_self_import():
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert circles({"a": {"a"}, "b": {"a"}}) == [["a"]]
    assert circles({"a": {"b"}, "b": set()}) == []


def test_the_architecture_page_s_floors_are_these():
    """The page's table of floors names, floor by floor, the modules and packages FLOORS holds."""
    text = (PACKAGE.parent / "docs" / "architecture.md").read_text()
    table = text.split("## The layers, lowest first", 1)[1].split("\n## ", 1)[0]
    rows = [line.split("|")[1:-1] for line in table.splitlines() if re.match(r"\| \d+ \|", line)]
    listed = [tuple(re.findall(r"`(?:ungrasp_ompl/)?(\w+)(?:\.py|/)?`", re.sub(r"\(.*?\)", "", cells[1])))
              for cells in rows]
    assert [int(cells[0]) for cells in rows] == list(range(1, len(FLOORS) + 1))
    assert listed == [tuple(names) for names in FLOORS]


def _resolve(dotted: str):
    """The object a dotted name of docs/architecture.md names: from the longest module path that
    imports (`sim.certify.certify`), else from the package's own exports (`Scene.with_digits`)."""
    import importlib

    parts = dotted.split(".")
    obj, rest = ungrasp_ompl, parts
    for i in range(len(parts), 0, -1):
        try:
            obj, rest = importlib.import_module("ungrasp_ompl." + ".".join(parts[:i])), parts[i:]
            break
        except ModuleNotFoundError:
            continue
    for name in rest:
        obj = getattr(obj, name)
    return obj


def test_each_command_s_code_is_where_the_architecture_page_says():
    """The page's table of where a command's code lives has a row for every command; each row's
    entry functions are in cli/commands.py and every dotted name it gives the library resolves."""
    import re

    from ungrasp_ompl.cli import commands

    text = (PACKAGE.parent / "docs" / "architecture.md").read_text()
    table = text.split("## Where a command's code lives", 1)[1].split("\n## ", 1)[0]
    rows = [line.split("|")[1:-1] for line in table.splitlines() if line.startswith("| `")]
    listed = [name for cells in rows for name in re.findall(r"`(\w+)`", cells[0])]
    assert sorted(listed) == sorted(command_parsers())
    for cells in rows:
        for entry in re.findall(r"`(\w+)`", cells[1]):
            assert callable(getattr(commands, entry, None)), entry
        for dotted in re.findall(r"`(\w+(?:\.\w+)+)`", cells[2]):
            assert _resolve(dotted) is not None, dotted
