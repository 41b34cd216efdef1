"""Asynchronous detection on a sliding buffer of observations (the paper's B_t).

`DetectionBuffer.push(obs)` only enqueues (RGB, depth, camera pose, time) and returns at
once; a worker thread runs the detector on each observation in order, so detection never
stalls motion. The buffer keeps the detections of the last `size` observations (a sliding
window). `best()` returns, among the window's ACCEPTED detections, the one whose box centre
is nearest the image centre (the paper's S_obs = -||p_bbox - p_center||); ties go to the
later observation. TENTATIVE detections (matches not clearly whole, `detector.Verdict`) are
never accepted from one frame: `confirm.Confirmer` turns one ACCEPTED when a later frame from
another camera position confirms it, or when nothing confirmed nor contradicted it for
`ConfirmConfig.accept_after_s` of simulated time (`BufferConfig.confirm`; such a late
acceptance enters the window with the observation of the match's latest view), or when the
exploration stops (`accept_waiting`); until then its centroid is a point of interest like a
PARTIAL one's. `sync()` waits until every pushed observation has been processed: the trial
calls it at decision points so that runs are reproducible while detection still runs
concurrently with the motion, mapping and decisions in between.

A detector rate in simulated time (`BufferConfig.min_period_s` > 0) models a detector that
cannot keep up with the camera: it starts on a frame when it is free and is then busy for
min_period_s of simulated time; frames arriving while it is busy wait in a one-frame slot,
a newer one replacing (skipping) the older, and the slot's frame starts when the detector
is free again (at a later push, or at `sync(t_now)` once t_now reaches that time). A rate,
not a latency: a frame's detections carry the frame's time and are read at the first
decision point after the frame started. Which frames are processed depends only on the
frames' time stamps, so a seed still gives one trial.
"""
from __future__ import annotations

import queue
import threading
import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from ..errors import CompassInputError, check_field_types
from ..task import TargetQuery
from ..types import Observation
from .confirm import Confirmer, ConfirmConfig
from .detector import Detection, Detector, Verdict


@dataclass(frozen=True)
class BufferConfig:
    """size: observations in the sliding window (k + 1 in the paper); threaded: run the
    detector on a worker thread (False: in push, for debugging); min_period_s [s] of
    simulated time between the starts of two frames' detection (0: every frame is
    processed; see the module docstring); confirm: how TENTATIVE detections are confirmed
    (`confirm.ConfirmConfig`)."""

    size: int = 8
    threaded: bool = True
    min_period_s: float = 0.0
    confirm: ConfirmConfig = field(default_factory=ConfirmConfig)

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        if not 1 <= self.size <= 1000:
            raise CompassInputError(f"buffer size {self.size} is not allowed; use 1..1000")
        if not (isinstance(self.min_period_s, (int, float)) and 0.0 <= self.min_period_s <= 10.0):
            raise CompassInputError(f"min_period_s {self.min_period_s!r} is not allowed; use 0..10 s "
                                    "(0: detect on every frame)")
        if not isinstance(self.confirm, ConfirmConfig):
            raise CompassInputError(f"BufferConfig.confirm = {self.confirm!r:.40} is not allowed; use a ConfirmConfig")


@dataclass(frozen=True, eq=False)
class BufferedDetection:
    """An accepted detection with the observation it came from."""

    detection: Detection
    observation: Observation


def most_centred(entries: list[BufferedDetection]) -> BufferedDetection | None:
    """The entry whose detection box centre is nearest its image centre (later wins ties)."""
    best, best_d = None, np.inf
    for e in entries:
        H, W = e.observation.depth.shape
        d = e.detection.centre_offset((W, H))
        if d <= best_d:
            best, best_d = e, d
    return best


class DetectionBuffer:
    """Sliding window of observations and their detections, filled by a worker thread."""

    def __init__(self, detector: Detector, query: TargetQuery, config: BufferConfig | None = None) -> None:
        self.detector, self.query = detector, query
        self.config = config or BufferConfig()
        self._window: deque[tuple[Observation, tuple[Detection, ...]]] = deque(maxlen=self.config.size)
        self._lock = threading.Lock()
        self._queue: queue.Queue = queue.Queue()
        self._hints: list[np.ndarray] = []
        self.confirmer = Confirmer(query, self.config.confirm)
        self._error: BaseException | None = None
        self.compute_s: list[float] = []  # detector time per observation [s]
        self.n_processed = 0
        self.n_skipped = 0  # frames replaced in the slot before the detector was free
        self._pending: Observation | None = None  # the slot (min_period_s > 0)
        self._t_free = -float("inf")  # simulated time [s] at which the detector is free
        self._thread = None
        if self.config.threaded:
            self._thread = threading.Thread(target=self._work, name="detection", daemon=True)
            self._thread.start()

    # ---------------------------------------------------------------- producer side
    def push(self, obs: Observation) -> None:
        """Enqueue an observation (needs rgb for appearance detectors, and its time `t` [s]
        when min_period_s > 0); never blocks."""
        if self.config.min_period_s <= 0.0:
            self._start(obs)
            return
        self._release(obs.t)
        if obs.t >= self._t_free:
            self._t_free = obs.t + self.config.min_period_s
            self._start(obs)
        else:
            self.n_skipped += self._pending is not None
            self._pending = obs

    def _release(self, t_now: float) -> None:
        """Start the slot's frame if the detector is free by simulated time t_now [s]."""
        if self._pending is not None and self._t_free <= t_now:
            obs, self._pending = self._pending, None
            self._t_free += self.config.min_period_s
            self._start(obs)

    def _start(self, obs: Observation) -> None:
        if self._thread is None:
            self._process(obs)
        else:
            self._queue.put(obs)

    def sync(self, t_now: float | None = None, timeout: float = 60.0) -> None:
        """Wait until all started observations are processed (first starting the slot's
        frame if the detector is free by simulated time t_now [s]); re-raise a worker error."""
        if t_now is not None:
            self._release(t_now)
        if self._thread is not None:
            deadline = time.monotonic() + timeout
            while self._queue.unfinished_tasks and time.monotonic() < deadline:
                time.sleep(0.0005)
            if self._queue.unfinished_tasks:
                raise TimeoutError("detection worker did not finish within the timeout")
        if self._error is not None:
            raise self._error

    def close(self) -> None:
        if self._thread is not None:
            self._queue.put(None)
            self._thread.join(timeout=5.0)
            self._thread = None

    # ---------------------------------------------------------------- consumer side
    def best(self) -> BufferedDetection | None:
        """The most centred ACCEPTED detection in the window, or None."""
        with self._lock:
            entries = [BufferedDetection(d, o) for o, dets in self._window for d in dets if d.accepted]
        return most_centred(entries)

    def accept_waiting(self, t_now: float) -> BufferedDetection | None:
        """When no further view can be had (the exploration stopped at simulated time t_now
        [s]): every tentative match nothing vetoed is accepted now (`Confirmer.due(now=True)`,
        found at t_now); returns `best()`. Call after `sync`."""
        late = self.confirmer.due(float(t_now), now=True)
        with self._lock:
            self._window.extend((o, (d,)) for d, o in late)
        return self.best()

    def take_hints(self) -> np.ndarray:
        """Centroids (N, 3) [m] of PARTIAL and (not yet confirmed) TENTATIVE detections since
        the last call (low-confidence matches of the query: points of interest for exploration)."""
        with self._lock:
            h, self._hints = self._hints, []
        return np.array(h).reshape(-1, 3)

    # ---------------------------------------------------------------- worker
    def _work(self) -> None:
        while True:
            obs = self._queue.get()
            try:
                if obs is None:
                    return
                if self._error is None:
                    self._process(obs)
            except BaseException as exc:  # surfaced by sync()
                self._error = exc
            finally:
                self._queue.task_done()

    def _process(self, obs: Observation) -> None:
        t0 = time.perf_counter()
        dets = self.confirmer(tuple(self.detector(obs, self.query)), obs)
        late = self.confirmer.due(float(obs.t))  # tentative matches accepted after waiting
        dt = time.perf_counter() - t0
        with self._lock:
            self._window.append((obs, dets))
            self._window.extend((o, (d,)) for d, o in late)
            self._hints.extend(d.centroid_world for d in dets if d.verdict in (Verdict.PARTIAL, Verdict.TENTATIVE))
            self.compute_s.append(dt)
            self.n_processed += 1
