"""Ranges typed on the command line: ``START:STOP:STEP`` (STOP included within rounding) or one number."""

from __future__ import annotations

import math

from ..errors import InputError

#: The most values a range may give.
MAX_VALUES = 10000


def parse_range(text: str, option: str) -> list[float]:
    """The values of ``START:STOP:STEP`` or of a single number; InputError(option) on bad text:
    not numbers, not finite, two parts, a step that is not positive, STOP below START, too many."""
    parts = [p.strip() for p in str(text).split(":")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise InputError(option, f"must be START:STOP:STEP or a number, got {text!r}") from None
    if len(values) not in (1, 3):
        raise InputError(option, f"must be START:STOP:STEP or a number, got {text!r}")
    if not all(math.isfinite(v) for v in values):
        raise InputError(option, f"must be finite numbers, got {text!r}")
    if len(values) == 1:
        return values
    start, stop, step = values
    if step <= 0:
        raise InputError(option, f"step must be positive, got {step:g}")
    if stop < start:
        raise InputError(option, f"stop {stop:g} lies below start {start:g}")
    n = int(math.floor((stop - start) / step + 1e-9))
    if n >= MAX_VALUES:
        raise InputError(option, f"gives {n + 1} values; at most {MAX_VALUES}")
    return [round(start + k * step, 10) for k in range(n + 1)]


def parse_alpha_range(text: str) -> list[float]:
    """Alphas (over the object length) from ``START:STOP:STEP`` or a number; InputError("alpha")."""
    return parse_range(text, "alphas")
