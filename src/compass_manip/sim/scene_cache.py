"""A disk cache of certified scenes: certification takes seconds to minutes per scene, and
every trial, test and sweep of the same (level, index, seed) would repeat it.

An entry is the accepted `SceneSpec` and its `Certificate` as JSON in
COMPASS_CACHE_DIR/scenes/ (default ~/.cache/compass_manip/scenes/), keyed by the level,
index, seed, the `CertifyConfig` and a hash of the source of every module that generates or
certifies scenes, so a change to any of them (or to the shipped robot model data) makes a
new key instead of a stale hit. Writes are atomic; an unreadable entry is recomputed; an
unwritable cache folder only costs the time.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import tempfile
from functools import lru_cache

from .scenes import SceneSpec

#: Modules whose source decides which scene is accepted and what its certificate holds.
_SOURCES = ("scenes.py", "scene_io.py", "objects.py", "layout.py", "levels.py", "severe.py", "certify.py", "home_clearance.py", "view_search.py", "outside_views.py",
            "oracle.py", "world.py", "physics.py", "fixed_views.py", "aimed_obstacles.py", "layout_grasps.py", os.path.join("..", "exploration", "fixed_views.py"),
            os.path.join("..", "exploration", "world_model.py"))


def cache_folder() -> str:
    root = os.environ.get("COMPASS_CACHE_DIR", os.path.join(os.path.expanduser("~"), ".cache", "compass_manip"))
    return os.path.join(root, "scenes")


@lru_cache(maxsize=1)
def _code_hash() -> str:
    here = os.path.dirname(os.path.abspath(__file__))
    h = hashlib.sha256()
    for name in _SOURCES:
        with open(os.path.join(here, name), "rb") as f:
            h.update(f.read())
    data = os.path.join(os.path.dirname(here), "robot", "data")
    h.update(",".join(sorted(os.listdir(data))).encode())
    return h.hexdigest()[:16]


def entry_path(level: int, index: int, seed: int, config) -> str:
    key = hashlib.sha256(f"{_code_hash()}|{level}|{index}|{seed}|{config!r}".encode()).hexdigest()[:20]
    return os.path.join(cache_folder(), f"level{level}_{index:03d}_seed{seed}_{key}.json")


def load(path: str, certificate_type, failure_type):
    """(scene, certificate, attempts, rejections) from an entry, or None if absent or unreadable."""
    try:
        with open(path, encoding="utf-8") as f:
            d = json.load(f)
        cert = dict(d["certificate"])
        cert["failure"] = None if cert["failure"] is None else failure_type[cert["failure"]]
        cert["path"] = tuple(tuple(float(v) for v in row) for row in cert["path"])
        cert["path_marks"] = tuple(int(v) for v in cert["path_marks"])
        cert["stage_times_s"] = tuple((str(k), float(v)) for k, v in cert["stage_times_s"])
        return (SceneSpec.from_dict(d["scene"]), certificate_type(**cert), int(d["attempts"]),
                tuple(str(r) for r in d["rejections"]))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def store(path: str, scene: SceneSpec, certificate, attempts: int, rejections) -> None:
    """Write an entry atomically; silently skipped where the cache folder is not writable."""
    cert = dataclasses.asdict(certificate)
    cert["failure"] = None if certificate.failure is None else certificate.failure.name
    text = json.dumps({"scene": scene.to_dict(), "certificate": cert, "attempts": attempts,
                       "rejections": list(rejections)})
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path), suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    except OSError:
        pass
