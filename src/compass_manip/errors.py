"""Typed errors for bad input. The CLI prints their message as one line, no traceback.

Convention: a message names the bad value, where it came from (argument, file and key)
and what is allowed.
"""
from __future__ import annotations

import functools
import math
import numbers


#: The largest count a config takes (iterations, capacities, samples): larger ones would run or
#: allocate without bound.
MAX_COUNT = 10**8


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


def check_field_types(config, nonnegative_ints: bool = False) -> None:
    """Raise CompassInputError for a dataclass field whose value is not of its default's
    kind: bool fields need True/False, int fields a whole number (0..MAX_COUNT
    with `nonnegative_ints`, unless the default is negative), float fields a real number (ints
    accepted; finite, or the default's infinity), str fields a str, enum fields a member of
    the default's enum, config fields an instance of the default's class, number-tuple
    fields numbers of the default's nesting (finite; non-empty unless annotated `tuple[X, ...]`); a field annotated
    `... | None` may also be None (`float | None` / `int | None` defaulting to None: a
    number or None). Fields whose default is None, or whose default (or
    default_factory's value) is of no kind above, are not checked."""
    import dataclasses

    name = type(config).__name__
    for fname, kind, default, optional in _field_kinds(type(config)):
        value = getattr(config, fname)
        if value is None and optional:
            continue
        where = f"{name}.{fname} = {value!r:.40} is not allowed"
        if kind == "bool":
            if not isinstance(value, (bool, _np().bool_)):
                raise CompassInputError(f"{where}; use True or False")
        elif kind == "int":
            if isinstance(value, (bool, _np().bool_)) or not isinstance(value, numbers.Integral):
                raise CompassInputError(f"{where}; use a whole number")
            if nonnegative_ints and default >= 0 and not 0 <= value <= MAX_COUNT:
                raise CompassInputError(f"{where}; use a whole number 0..{MAX_COUNT:,}")
        elif kind == "float":
            if not (math.isinf(default) and _is_real(value) and value == default):  # inf only as the default
                real_number(value, f"{name}.{fname}",
                            "a finite number" + (f" or {default}" if math.isinf(default) else ""))
        elif kind == "str":
            if not isinstance(value, str):
                raise CompassInputError(f"{where}; use a str such as {default!r}")
        elif kind in ("enum", "config"):
            if not isinstance(value, type(default)):
                allowed = (", ".join(repr(m.name) for m in type(default)) if kind == "enum"
                           else f"a {type(default).__name__}")
                raise CompassInputError(f"{name}.{fname} = {value!r:.40} is not allowed; use {allowed}")
        elif kind == "numbers":
            arr = None
            if not isinstance(value, (str, bytes)) and not dataclasses.is_dataclass(value):
                try:
                    arr = _np().asarray(value, dtype=float)
                except (TypeError, ValueError, OverflowError):
                    pass
            fixed, ann, whole = default  # a fixed shape unless annotated `tuple[X, ...]`; whole: `tuple[int, ...]`
            if (arr is None or arr.ndim != fixed.ndim or (arr.size == 0 and "..." not in ann) or not _np().isfinite(arr).all()
                    or ("..." not in ann and arr.shape != fixed.shape) or (whole and (arr != _np().round(arr)).any())):
                kind_of = "whole numbers" if whole else "finite numbers"
                what = (kind_of if "..." in ann else f"{fixed.size} {kind_of}" if fixed.ndim == 1
                        else f"{kind_of} nested as {fixed.shape}")
                raise CompassInputError(f"{where}; use {what} like {_nested_tuple(fixed, whole)}")


def check_ranges(config, **ranges: tuple[float, float, str]) -> None:
    """Raise CompassInputError naming the first field of `config` outside its closed range,
    given as `name=(lo, hi, unit)`; a (min, max) pair field must have lo <= min <= max <= hi.
    None values (off) are not checked. Run after `check_field_types` (the values are numbers)."""
    for fname, (lo, hi, unit) in ranges.items():
        v = getattr(config, fname)
        u = f" {unit}" if unit else ""
        if v is None:
            continue
        if isinstance(v, (tuple, list)):
            if not lo <= v[0] <= v[1] <= hi:
                raise CompassInputError(f"{type(config).__name__}.{fname} = {tuple(v)}{u} is not allowed; use "
                                        f"(min, max) with {lo:g} <= min <= max <= {hi:g}{u}")
        elif not lo <= v <= hi:
            raise CompassInputError(f"{type(config).__name__}.{fname} = {v}{u} is not allowed; use {lo:g}..{hi:g}{u}")


def _nested_tuple(arr, whole: bool):
    """An array as the nested tuple a user writes (ints when `whole`)."""
    if arr.ndim == 0:
        return int(arr) if whole else float(arr)
    return tuple(_nested_tuple(a, whole) for a in arr)


def _np():
    import numpy as np

    return np


def _is_real(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, _np().bool_))


@functools.lru_cache(maxsize=None)
def _field_kinds(cls) -> tuple:
    """(field name, kind, default, None allowed) of each checked init field of the dataclass
    `cls` (None is allowed when the annotation names it: `float | None`, `Optional[...]`)."""
    import dataclasses
    import enum

    import numpy as np

    out = []
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        if f.default is not dataclasses.MISSING:
            default = f.default
        elif f.default_factory is not dataclasses.MISSING:
            default = f.default_factory()
        else:
            continue
        optional = "None" in str(f.type) or "Optional" in str(f.type)
        if default is None and str(f.type) in ("float | None", "int | None"):  # a number, or None: off
            default = 0.0 if str(f.type).startswith("float") else 0
        kind = None
        if isinstance(default, bool):
            kind = "bool"
        elif isinstance(default, int):
            kind = "int"
        elif isinstance(default, float):
            kind = "float"
        elif isinstance(default, str):
            kind = "str"
        elif isinstance(default, enum.Enum):
            kind = "enum"
        elif dataclasses.is_dataclass(default):
            kind = "config"
        elif isinstance(default, tuple) and default:
            try:
                arr = np.asarray(default, dtype=np.float64)
            except (TypeError, ValueError):
                continue
            if np.isfinite(arr).all():
                ann = str(f.type)
                kind, default = "numbers", (arr, ann, "int" in ann and "float" not in ann)
        if kind is not None:
            out.append((f.name, kind, default, optional))
    return tuple(out)
