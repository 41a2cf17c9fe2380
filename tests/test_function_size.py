"""Functions stay small: at most MAX_LINES lines and MAX_PARAMETERS parameters (self and cls aside),
or their docstring says why not in a line starting "Size:"."""

from __future__ import annotations

import ast
from pathlib import Path

import ungrasp_ompl

PACKAGE = Path(ungrasp_ompl.__file__).parent
MAX_LINES = 80
MAX_PARAMETERS = 8


def oversized() -> list[str]:
    """Every function of the package over a limit without its reason, as 'path:line name (lines, parameters)'."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            args = node.args
            names = [a.arg for a in args.posonlyargs + args.args + args.kwonlyargs]
            count = len(names) - (1 if names and names[0] in ("self", "cls") else 0)
            lines = node.end_lineno - node.lineno + 1
            doc = ast.get_docstring(node) or ""
            reason = any(line.strip().startswith("Size:") for line in doc.splitlines())
            if (lines > MAX_LINES or count > MAX_PARAMETERS) and not reason:
                found.append(f"{path.relative_to(PACKAGE)}:{node.lineno} {node.name} ({lines} lines, {count} parameters)")
    return found


def test_every_function_is_small_or_says_why():
    assert oversized() == []


def test_the_check_finds_a_long_function(tmp_path, monkeypatch):
    """The check itself: a 90-line function without a reason is found, and with one is not."""
    body = "\n".join(f"    x{k} = {k}" for k in range(88))
    (tmp_path / "long.py").write_text(f"def long():\n    '''Doc.'''\n{body}\n")
    monkeypatch.setattr(__import__(__name__), "PACKAGE", tmp_path)
    assert [f.split()[1] for f in oversized()] == ["long"]
    (tmp_path / "long.py").write_text(f"def long():\n    '''Doc.\n\n    Size: one loop.'''\n{body}\n")
    assert oversized() == []
