"""Typed errors for bad input. The CLI prints their message as one line, no traceback.

Convention: a message names the bad value, where it came from (argument, file and key)
and what is allowed.
"""
from __future__ import annotations

import math
import numbers


class CompassInputError(ValueError):
    """A value given by a user or a caller is outside what is allowed.

    The message names the bad value and says what is allowed.
    """


def real_number(value, name: str, allowed: str = "a finite number") -> float:
    """`value` as a float if it is a finite real number (Python or numpy int / float, not
    bool); otherwise CompassInputError naming `name` and `allowed`."""
    if isinstance(value, (bool,)) or not isinstance(value, numbers.Real) or hasattr(value, "__len__"):
        raise CompassInputError(f"{name} = {value!r:.60} is not allowed; use {allowed}")
    v = float(value)
    if not math.isfinite(v):
        raise CompassInputError(f"{name} = {v} is not allowed; use {allowed}")
    return v
