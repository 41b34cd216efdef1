"""The asynchronous detection buffer: non-blocking push, sliding window, most-centred choice."""
import time

import numpy as np
import pytest

from compass_manip.perception.buffer import BufferConfig, DetectionBuffer
from compass_manip.perception.detector import Detection, Verdict
from compass_manip.task import TargetQuery
from compass_manip.types import Observation

QUERY = TargetQuery("box", "red", (0.05, 0.05, 0.12))
W, H = 320, 240


def _obs(t):
    return Observation(np.ones((H, W), np.float32), np.zeros((H, W, 3), np.uint8), np.eye(3), np.eye(4), t, np.zeros(7))


def _det(t, cu, cv, verdict=Verdict.ACCEPTED):
    return Detection(t, np.eye(4), (int(cu) - 5, int(cv) - 5, int(cu) + 5, int(cv) + 5), (cu, cv), 100,
                     np.full((3, 3), t), np.full(3, t), (0.05, 0.05, 0.12), "box", 1.0, verdict)


class ScriptedDetector:
    """Returns, per observation time, the detections scripted for it (after `delay` s)."""

    def __init__(self, script, delay=0.0):
        self.script, self.delay, self.calls = script, delay, 0

    def __call__(self, obs, query):
        time.sleep(self.delay)
        self.calls += 1
        return self.script.get(obs.t, ())


def test_best_is_the_detection_nearest_the_image_centre():
    centre = ((W - 1) / 2, (H - 1) / 2)
    script = {0.0: (_det(0.0, 20, 30),), 1.0: (_det(1.0, centre[0] + 10, centre[1]),),
              2.0: (_det(2.0, centre[0] + 40, centre[1] - 40), _det(2.0, centre[0], centre[1] + 3, Verdict.PARTIAL))}
    buf = DetectionBuffer(ScriptedDetector(script), QUERY, BufferConfig(size=8))
    try:
        for t in (0.0, 1.0, 2.0, 3.0):
            buf.push(_obs(t))
        buf.sync()
        best = buf.best()
        assert best is not None and best.detection.t == 1.0 and best.observation.t == 1.0
        # the partial match (not accepted) is a hint, not a candidate
        hints = buf.take_hints()
        assert hints.shape == (1, 3) and np.allclose(hints, 2.0)
        assert buf.take_hints().shape == (0, 3)
    finally:
        buf.close()


def test_the_window_slides():
    script = {0.0: (_det(0.0, 160, 120),), 1.0: (), 2.0: ()}
    buf = DetectionBuffer(ScriptedDetector(script), QUERY, BufferConfig(size=2))
    try:
        buf.push(_obs(0.0))
        buf.sync()
        assert buf.best() is not None
        buf.push(_obs(1.0))
        buf.push(_obs(2.0))
        buf.sync()
        assert buf.best() is None  # the detection at t = 0 left the window
    finally:
        buf.close()


def test_push_never_waits_for_the_detector():
    det = ScriptedDetector({}, delay=0.05)
    buf = DetectionBuffer(det, QUERY, BufferConfig(size=4))
    try:
        t0 = time.perf_counter()
        for t in range(6):
            buf.push(_obs(float(t)))
        assert time.perf_counter() - t0 < 0.05  # six pushes take less than one detection
        buf.sync()
        assert det.calls == 6 and buf.n_processed == 6
    finally:
        buf.close()


def test_worker_errors_surface_at_sync():
    class Broken:
        def __call__(self, obs, query):
            raise RuntimeError("detector broke")

    buf = DetectionBuffer(Broken(), QUERY)
    try:
        buf.push(_obs(0.0))
        with pytest.raises(RuntimeError, match="detector broke"):
            buf.sync()
    finally:
        buf.close()
