"""Names a package exports but loads on first use (PEP 562).

The package itself, ungrasp_ompl.planning and ungrasp_ompl.workflows export names whose modules
load OMPL, the planning stack or a workflow's own stack (together about 0.7 s); loading them on
first use keeps ``import ungrasp_ompl`` and the command line's help fast, and lets a command load
only what it runs.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib import import_module
from typing import Any


def lazy_exports(package: str, where: dict[str, str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module-level ``__getattr__`` and ``__dir__`` of package (its ``__name__``) that load each
    name of where (name -> the module, relative to package, that defines it) on first use and keep it."""
    namespace = import_module(package).__dict__

    def __getattr__(name: str) -> Any:
        if name not in where:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(import_module(where[name], package), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(where))

    return __getattr__, __dir__
