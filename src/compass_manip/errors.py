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


def float_array(value, name: str, what: str = "numbers"):
    """`value` as a float64 numpy array, or CompassInputError if it is not numbers
    (text, ragged lists, None inside, objects)."""
    import numpy as np

    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise CompassInputError(f"{name} must be {what}, got {value!r:.80}") from exc


def points_array(value, name: str = "points"):
    """`value` as float64 points (N, 3) [m] (any array whose size is a multiple of 3 is
    read as consecutive x, y, z), or CompassInputError if it is not numbers or its size is
    not a multiple of 3."""
    p = float_array(value, name, "(N, 3) numbers [m]")
    if p.size % 3:
        raise CompassInputError(f"{name} must have shape (N, 3) [m], got {p.shape}")
    return p.reshape(-1, 3)
