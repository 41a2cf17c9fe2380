"""The package's layers (docs/architecture.md): no module imports, at run time, from a higher floor.

Every import statement of every module is read from its source (module level and inside
functions alike, since a lazy import is an import all the same); those under ``if TYPE_CHECKING``
are annotations and do not count. Each floor's modules are listed as the architecture page's
table lists them."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import ungrasp_ompl
from conftest import command_parsers

PACKAGE = Path(ungrasp_ompl.__file__).parent

#: The floors, lowest first, as docs/architecture.md's table has them: module or package names
#: relative to ungrasp_ompl.
FLOORS = (
    ("errors", "io", "stream", "runner", "perturbation"),
    ("mechanics",),
    ("geometry",),
    ("scene", "layout", "shipped"),
    ("planning",),
    ("robustness",),
    ("plotting", "robustness_plot"),
    ("tiling",),
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


def _type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or \
        (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _is_module(parts: list[str]) -> bool:
    path = PACKAGE.joinpath(*parts)
    return path.with_suffix(".py").exists() or (path / "__init__.py").exists()


def runtime_imports(module: str, path: Path) -> list[tuple[int, str]]:
    """(line, module relative to the package) of every import of the package's own modules that
    runs: at module level or in a function, not under ``if TYPE_CHECKING``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    found: list[tuple[int, str]] = []

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _type_checking(node):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)] if node.level > 1 else package
                target = ".".join(base + ([node.module] if node.module else []))
                names = [target] if node.module else [".".join(base + [a.name]) if _is_module(base + [a.name])
                                                      else ".".join(base) for a in node.names]
                found.extend((node.lineno, t or "__init__") for t in names)
            elif node.module and node.module.startswith("ungrasp_ompl."):
                found.append((node.lineno, node.module[len("ungrasp_ompl."):]))
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
    above = [f"line {line}: {target} (floor {floor_of(target)})" for line, target in runtime_imports(module, path)
             if floor_of(target) > own]
    assert not above, f"ungrasp_ompl.{module} (floor {own}) imports from above: " + "; ".join(above)


def test_the_reader_sees_a_lazy_import_and_skips_an_annotation(tmp_path):
    """The check's own reader: an import inside a function counts, one under TYPE_CHECKING does not."""
    src = tmp_path / "probe.py"
    src.write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..sim import trial\n"
                   "def f():\n    from ..robot.ik import solve\n    from . import model\n")
    assert runtime_imports("scene.probe", src) == [(5, "robot.ik"), (6, "scene.model")]


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
