"""Errors a user can act on, and the CLI exit codes they map to."""

from __future__ import annotations

#: Exit codes of the ``ungrasp-ompl`` command.
EXIT_OK = 0
EXIT_FAILURE = 1  # something the command relies on (not the input) is missing or failed
EXIT_BAD_INPUT = 2
EXIT_NO_SOLUTION = 3


class UngraspError(Exception):
    """Base of the errors the CLI reports as one line without a traceback. Its subclasses keep
    their evidence as attributes; an error pickles with them (a worker process's error arrives
    whole), whatever its constructor takes."""

    exit_code = EXIT_BAD_INPUT

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


class ToolError(UngraspError):
    """A tool the command relies on is missing or failed (an installation problem, not the input).
    The CLI reports it as one line and exits 1."""

    exit_code = EXIT_FAILURE
