"""Errors a user can act on. Three kinds, each the command line's exit code (cli.exits): bad input
(InputError, and any other UngraspError), no solution for a sound input (NoSolutionError), and a
failure of something the command relies on (ToolError)."""

from __future__ import annotations


class UngraspError(Exception):
    """Base of the errors the CLI reports as one line without a traceback. Its subclasses keep
    their evidence as attributes; an error pickles with them (a worker process's error arrives
    whole), whatever its constructor takes."""

    def __reduce__(self):
        return _rebuild, (type(self), self.args, self.__dict__)


def _rebuild(cls: type, args: tuple, state: dict) -> UngraspError:
    error = cls.__new__(cls)
    Exception.__init__(error, *args)
    error.__dict__.update(state)
    return error


class InputError(UngraspError, ValueError):
    """Bad input: a scene field, a planner name, an option. Names the field and the reason."""

    def __init__(self, field: str, reason: str, source: str | None = None):
        self.field = field
        self.reason = reason
        self.source = source
        where = f"{source}: " if source else ""
        super().__init__(f"{where}{field}: {reason}")


class UnknownFieldError(InputError):
    """A field a file's format does not have at that place; expected: the fields it has there."""

    def __init__(self, field: str, expected: tuple[str, ...], source: str | None = None):
        super().__init__(field, f"unknown field (expected one of: {', '.join(expected)})", source)
        self.expected = expected


class NoSolutionError(UngraspError):
    """The input is sound, but what it asks has no solution: the robot cannot make, reach, time or
    clear the plan. The CLI reports it as one line and exits 3."""


class ToolError(UngraspError):
    """Something the command relies on, not the input, is missing or failed: a tool (an
    installation problem), or a step such as the touch-off's probe. The CLI reports it as one line
    and exits 1."""
