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


def instance_of(value, cls: type, name: str, default=None):
    """`value` if it is a `cls` (`default` when value is None and a default is given), or
    CompassInputError naming what is expected."""
    if value is None and default is not None:
        return default
    if not isinstance(value, cls):
        raise CompassInputError(f"{name} must be a {cls.__name__}, got {type(value).__name__} {value!r:.40}")
    return value


def check_field_types(config) -> None:
    """Raise CompassInputError for a dataclass field whose value is not of its default's
    kind: bool fields need True/False, int fields a whole number, float fields a finite real
    number (ints accepted). Fields without a bool/int/float default are not checked."""
    import dataclasses

    import numpy as np

    name = type(config).__name__
    for f in dataclasses.fields(config):
        default, value = f.default, getattr(config, f.name)
        if isinstance(default, bool):
            if not isinstance(value, (bool, np.bool_)):
                raise CompassInputError(f"{name}.{f.name} = {value!r:.40} is not allowed; use True or False")
        elif isinstance(default, int):
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
                raise CompassInputError(f"{name}.{f.name} = {value!r:.40} is not allowed; use a whole number")
        elif isinstance(default, float):
            real_number(value, f"{name}.{f.name}")
