"""The exit codes of the ``ungrasp-ompl`` command, and the one each kind of error (errors) maps to."""

from __future__ import annotations

from ..errors import NoSolutionError, ToolError, UngraspError

EXIT_OK = 0
EXIT_FAILURE = 1  # something the command relies on (not the input) is missing or failed
EXIT_BAD_INPUT = 2
EXIT_NO_SOLUTION = 3


def exit_code(error: UngraspError) -> int:
    """The command's exit code for an error: EXIT_FAILURE for a ToolError, EXIT_NO_SOLUTION for a
    NoSolutionError, EXIT_BAD_INPUT for any other (an InputError, a model's error of its input)."""
    if isinstance(error, ToolError):
        return EXIT_FAILURE
    if isinstance(error, NoSolutionError):
        return EXIT_NO_SOLUTION
    return EXIT_BAD_INPUT
