"""The results store of a benchmark sweep: one SQLite file, one row per finished trial.

Each row holds the trial's key (method, level, scene, trial, seed) as columns, its full
config and result as JSON, and how it ended. A row is written in its own transaction the
moment its trial ends, so a killed sweep loses only the trials that were running; a
re-run skips every key already present. A file written by another schema version, or
(for writing) by another compass-manip version, is refused instead of mixed.
"""
from __future__ import annotations

import json
import os
import sqlite3
import time
from dataclasses import dataclass

from .. import __version__
from ..errors import CompassInputError

#: Bumped whenever the tables change; files of another version are refused.
SCHEMA_VERSION = 1

_SCHEMA = """
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE trials (
    method TEXT NOT NULL, level INTEGER NOT NULL, scene INTEGER NOT NULL,
    trial INTEGER NOT NULL, seed INTEGER NOT NULL,
    success INTEGER NOT NULL,
    failure TEXT,
    error TEXT,
    trial_fn TEXT NOT NULL,
    code_version TEXT NOT NULL,
    config_json TEXT,
    result_json TEXT,
    wall_s REAL NOT NULL,
    finished_at REAL NOT NULL,
    PRIMARY KEY (method, level, scene, trial, seed)
);
"""

_COLUMNS = ("method", "level", "scene", "trial", "seed", "success", "failure", "error", "trial_fn",
            "code_version", "config_json", "result_json", "wall_s", "finished_at")

TrialKey = tuple[str, int, int, int, int]  # (method, level, scene, trial, seed)


@dataclass(frozen=True)
class TrialRecord:
    """One finished trial as stored.

    success: the trial grasped and lifted its target. failure: the trial's failure reason
    name, or a `bench.sweep.RunFailure` value when the runner ended it (error, wall-time
    cap, dead worker); None on success. error: the exception text for runner failures.
    trial_fn: which trial function produced it ("module:name"). config / result: the
    trial's `to_dict()`s (result is None when the runner ended it). wall_s: wall time [s].
    finished_at: Unix time [s] the row was written.
    """

    method: str
    level: int
    scene: int
    trial: int
    seed: int
    success: bool
    failure: str | None
    error: str | None
    trial_fn: str
    config: dict | None
    result: dict | None
    wall_s: float
    code_version: str = __version__
    finished_at: float = 0.0

    @property
    def key(self) -> TrialKey:
        return (self.method, self.level, self.scene, self.trial, self.seed)


class ResultsStore:
    """A results file opened for reading (`create=False`) or for a sweep (`create=True`)."""

    def __init__(self, path: str, create: bool = False):
        if not isinstance(path, (str, os.PathLike)) or os.fspath(path) in ("", ":memory:"):
            raise CompassInputError(f"results store {path!r:.60} is not allowed; give a .sqlite file path")
        path = os.fspath(path)
        self.path = path
        exists = os.path.exists(path) and os.path.getsize(path) > 0
        if not exists and not create:
            what = "is empty" if os.path.isfile(path) else "does not exist"
            raise CompassInputError(f"results store {path!r} {what}; give a file written by compass bench")
        if os.path.isdir(path):
            raise CompassInputError(f"results store {path!r} is a directory; give a .sqlite file path")
        parent = os.path.dirname(os.path.abspath(path))
        if create and not os.path.isdir(parent):
            raise CompassInputError(f"results store {path!r}: directory {parent!r} does not exist")
        try:
            self._conn = sqlite3.connect(path, timeout=30.0)
        except sqlite3.Error as exc:
            raise CompassInputError(f"results store {path!r} cannot be opened ({exc}); give a writable .sqlite path")
        if exists:
            self._check(for_writing=create)
        else:
            self._init()

    def _init(self) -> None:
        try:
            with self._conn:
                self._conn.executescript(_SCHEMA)
                self._conn.executemany("INSERT INTO meta VALUES (?, ?)", [
                    ("schema_version", str(SCHEMA_VERSION)), ("compass_manip_version", __version__),
                    ("created_at", str(time.time()))])
        except sqlite3.Error as exc:
            raise CompassInputError(f"results store {self.path!r} cannot be written ({exc}); give a writable path")

    def _check(self, for_writing: bool) -> None:
        try:
            meta = dict(self._conn.execute("SELECT key, value FROM meta").fetchall())
            self._conn.execute("SELECT COUNT(*) FROM trials").fetchone()
        except sqlite3.DatabaseError as exc:
            self._conn.close()
            raise CompassInputError(f"{self.path!r} is not a compass results store ({exc}); "
                                    "give a file written by compass bench")
        version = meta.get("schema_version")
        if version != str(SCHEMA_VERSION):
            self._conn.close()
            raise CompassInputError(f"results store {self.path!r} has schema version {version}; this compass-manip "
                                    f"reads and writes version {SCHEMA_VERSION}: use the version that wrote it, "
                                    "or a new file")
        writer = meta.get("compass_manip_version")
        if for_writing and writer != __version__:
            self._conn.close()
            raise CompassInputError(f"results store {self.path!r} was written by compass-manip {writer}, this is "
                                    f"{__version__}; results of two versions are not mixed: use a new --db")
        self.meta = meta
        if for_writing:  # a sweep must be able to store its first trial, not fail after running it
            try:
                self._conn.execute("UPDATE meta SET value = value WHERE key = 'schema_version'")  # changes nothing
                self._conn.rollback()
            except sqlite3.Error as exc:
                self._conn.close()
                raise CompassInputError(f"results store {self.path!r} cannot be written ({exc}); give a file you "
                                        "may write to, or a new --db") from None

    def close(self) -> None:
        self._conn.close()

    def __enter__(self) -> "ResultsStore":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def done_keys(self) -> set[TrialKey]:
        """Keys of every trial already stored."""
        rows = self._conn.execute("SELECT method, level, scene, trial, seed FROM trials").fetchall()
        return {tuple(r) for r in rows}

    def add(self, record: TrialRecord) -> None:
        """Write one finished trial in its own transaction (durable when this returns)."""
        values = (record.method, record.level, record.scene, record.trial, record.seed, int(record.success),
                  record.failure, record.error, record.trial_fn, record.code_version,
                  None if record.config is None else json.dumps(record.config),
                  None if record.result is None else json.dumps(record.result),
                  float(record.wall_s), record.finished_at or time.time())
        with self._conn:
            self._conn.execute(f"INSERT INTO trials ({', '.join(_COLUMNS)}) VALUES ({', '.join('?' * len(_COLUMNS))})",
                               values)

    def records(self) -> list[TrialRecord]:
        """Every stored trial, ordered by key."""
        rows = self._conn.execute(f"SELECT {', '.join(_COLUMNS)} FROM trials "
                                  "ORDER BY method, level, scene, trial, seed").fetchall()
        out = []
        for r in rows:
            d = dict(zip(_COLUMNS, r))
            try:
                config = None if d["config_json"] is None else json.loads(d["config_json"])
                result = None if d["result_json"] is None else json.loads(d["result_json"])
            except (TypeError, ValueError) as exc:  # edited or damaged by hand: name the row
                key = tuple(d[k] for k in _COLUMNS[:5])
                raise CompassInputError(f"results store {self.path!r}: trial {key} holds no valid JSON ({exc}); "
                                        "delete that row or use a file written by compass bench") from None
            out.append(TrialRecord(
                method=d["method"], level=d["level"], scene=d["scene"], trial=d["trial"], seed=d["seed"],
                success=bool(d["success"]), failure=d["failure"], error=d["error"], trial_fn=d["trial_fn"],
                config=config, result=result,
                wall_s=d["wall_s"], code_version=d["code_version"], finished_at=d["finished_at"]))
        return out

    def count(self) -> int:
        return int(self._conn.execute("SELECT COUNT(*) FROM trials").fetchone()[0])
