"""Checks of output paths given on the command line, run before any work starts.

`check_output_dir(path, option="--out") -> str` returns the absolute folder path (created
if missing) or raises `CompassInputError` naming the option, the path and what is wrong:
an existing file, a path under a file, a folder that cannot be created or written (a
read-only folder, /proc, ...). The check writes and removes one probe file, so it tests
what the operating system allows rather than guessing from permission bits (which root
ignores).
"""
from __future__ import annotations

import os
import tempfile

from .errors import CompassInputError


def check_output_dir(path: str | os.PathLike, option: str = "--out") -> str:
    """The absolute path of a writable output folder, created (with parents) if missing.

    Raises CompassInputError when `path` is empty, names an existing non-folder, lies under
    a file, or cannot be created or written.
    """
    if path is None or os.fspath(path) == "":
        raise CompassInputError(f"{option} is empty; give a folder to write to")
    p = os.path.abspath(os.fspath(path))
    if os.path.exists(p) and not os.path.isdir(p):
        raise CompassInputError(f"{option} {os.fspath(path)!r} is an existing file, not a folder; "
                                "give a new or existing folder")
    parent = p
    while not os.path.exists(parent):  # the deepest existing ancestor must be a folder
        parent = os.path.dirname(parent)
    if not os.path.isdir(parent):
        raise CompassInputError(f"{option} {os.fspath(path)!r} lies under the file {parent!r}; "
                                "give a folder path")
    try:
        os.makedirs(p, exist_ok=True)
    except OSError as exc:
        raise CompassInputError(f"{option} {os.fspath(path)!r} cannot be created ({exc.strerror or exc}); "
                                "give a folder you may write to") from exc
    try:
        fd, probe = tempfile.mkstemp(prefix=".compass-write-check-", dir=p)
    except OSError as exc:
        raise CompassInputError(f"{option} {os.fspath(path)!r} is not writable ({exc.strerror or exc}); "
                                "give a folder you may write to") from exc
    os.close(fd)
    os.remove(probe)
    return p


def check_output_file(path: str | os.PathLike, option: str = "--out") -> str:
    """The absolute path of a file to be written: its folder must exist and be writable and
    the path must not be an existing folder. Raises CompassInputError otherwise."""
    if path is None or os.fspath(path) == "":
        raise CompassInputError(f"{option} is empty; give a file to write to")
    p = os.path.abspath(os.fspath(path))
    if os.path.isdir(p):
        raise CompassInputError(f"{option} {os.fspath(path)!r} is a folder; give a file path")
    folder = os.path.dirname(p)
    if not os.path.isdir(folder):
        raise CompassInputError(f"{option} {os.fspath(path)!r}: folder {folder!r} does not exist or is not a folder")
    check_output_dir(folder, option)
    return p
