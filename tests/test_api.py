"""The public API (docs/api.md): every package's ``__all__`` is what a user may use, the page lists
exactly those names package by package (tools/make_api_doc.py writes it), and no other module
claims an ``__all__`` of its own."""

from __future__ import annotations

import ast
import importlib
import pkgutil
import re
from pathlib import Path

import pytest

import ungrasp_ompl

PACKAGE = Path(ungrasp_ompl.__file__).parent
PAGE = PACKAGE.parent / "docs" / "api.md"

PACKAGES = ["ungrasp_ompl"] + [f"ungrasp_ompl.{m.name}" for m in pkgutil.iter_modules(ungrasp_ompl.__path__)
                               if m.ispkg]


def page_names() -> dict[str, list[str]]:
    """The names docs/api.md lists, by package (a package without names is named in the last section)."""
    listed: dict[str, list[str]] = {}
    package = None
    for line in PAGE.read_text().splitlines():
        if m := re.fullmatch(r"## `([\w.]+)`", line):
            package = m[1]
            listed[package] = []
        elif line.startswith("## "):
            package = None
            if "without public names" in line:
                listed["(none)"] = []
        elif package and (m := re.fullmatch(r"### `(\w+)`", line)):
            listed[package].append(m[1])
        elif "(none)" in listed and package is None:
            listed["(none)"] += re.findall(r"`(ungrasp_ompl[\w.]*)`", line)
    return listed


@pytest.mark.parametrize("package", PACKAGES)
def test_each_package_says_what_is_public_and_has_it(package):
    module = importlib.import_module(package)
    names = getattr(module, "__all__", None)
    assert names is not None, f"{package} has no __all__"
    assert len(set(names)) == len(names), f"{package}.__all__ names one twice"
    for name in names:
        assert getattr(module, name) is not None, f"{package}.{name}"


@pytest.mark.parametrize("package", PACKAGES)
def test_the_api_page_lists_each_package_s_names_both_ways(package):
    names = importlib.import_module(package).__all__
    listed = page_names()
    if not names:
        assert package in listed.get("(none)", []), f"docs/api.md does not list {package} among those without names"
        assert package not in listed
        return
    assert package in listed, f"docs/api.md has no section for {package}: python tools/make_api_doc.py"
    assert sorted(listed[package]) == sorted(names), \
        f"{package}: on the page only {sorted(set(listed[package]) - set(names))}, " \
        f"in __all__ only {sorted(set(names) - set(listed[package]))}: python tools/make_api_doc.py"


def test_the_api_page_names_no_other_package():
    assert set(page_names()) - {"(none)"} <= set(PACKAGES)


def test_the_api_is_small():
    """Tens of names, as a library's API is: the workflows, the scene, planning and its results,
    the options and the errors."""
    total = sum(len(importlib.import_module(p).__all__) for p in PACKAGES)
    assert 20 <= total <= 100, total


def test_only_packages_claim_an_all():
    """A module's names are internal: only a package's __init__.py says what is public."""
    claims = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name == "__init__.py":
            continue
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
                claims.append(f"{path.relative_to(PACKAGE)}:{node.lineno}")
    assert not claims, "modules with an __all__ of their own: " + ", ".join(claims)
