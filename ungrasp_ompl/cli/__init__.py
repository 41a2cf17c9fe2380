"""The ``ungrasp-ompl`` command.

Exit codes (``cli.exits``): 0 solved (or done); 2 bad input (one line naming the field and
the reason); 3 no solution (with the reason found), including a plan the
robot cannot execute (out of reach, or beyond its limits); 1 a tool the
command relies on is missing or failed (one line).
"""

from __future__ import annotations

import argparse
import os
import sys

from ..errors import InputError, UngraspError
from ..shipped import shipped_names
from . import commands
from .exits import EXIT_OK, exit_code
from .parser import build_parser
from .progress import Progress

__all__ = ["main", "run"]


#: Options fields whose flag is not --field-name (the library names its options' fields).
_FIELD_FLAGS = {"alphas": "--alpha", "tip_radii": "--tip-radius", "friction_scales": "--friction-scale",
                "start_psi_offset": "--start-psi-offset-deg", "start_theta_deg": "--start-theta",
                "plan.trials": "--certify", "starts.d_range": "--d", "starts.d_step": "--step"}


def _as_flag(exc: InputError, parser: argparse.ArgumentParser, args: argparse.Namespace) -> InputError:
    """The error of a library option named by the flag a person typed for it, when the command
    has that flag (an error in a file names the flag when that flag gave the file); any other
    error (a scene's field) as it is."""
    if not exc.field.isidentifier():
        return exc
    flag = _FIELD_FLAGS.get(f"{args.command}.{exc.field}", _FIELD_FLAGS.get(exc.field, "--" + exc.field.replace("_", "-")))
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[args.command]
    action = next((a for a in sub._actions if flag in a.option_strings), None)
    if action is None:
        return exc
    if exc.source is None:
        return InputError(flag, exc.reason)
    given = getattr(args, action.dest, None)
    return InputError(flag, exc.reason, exc.source) if given and exc.source.startswith(str(given)) else exc


def run(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    parser = build_parser()
    args = None
    try:
        args = parser.parse_args(argv)
        return commands.COMMANDS[args.command](args)
    except UngraspError as exc:
        for bar in list(Progress.open):
            bar.close(ok=False)
        if isinstance(exc, InputError) and args is not None:
            exc = _as_flag(exc, parser, args)
        print(f"ungrasp-ompl: error: {shipped_names(str(exc))}", file=sys.stderr)
        return exit_code(exc)
    except KeyboardInterrupt:
        for bar in list(Progress.open):
            bar.close(ok=False)
        print("ungrasp-ompl: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader went away (e.g. piped into head)
        return EXIT_OK


def main(argv: list[str] | None = None) -> None:
    """Console entry point. Leaves through os._exit so that nanobind's reports of objects
    still alive at interpreter exit (noise to a user) are not printed."""
    code = run(argv)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    main()

