"""The detector's rate in simulated time (`BufferConfig.min_period_s`): which frames it
processes, worked out by hand from the frames' time stamps."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.perception.buffer import BufferConfig, DetectionBuffer
from compass_manip.perception.detector import Detection, Verdict
from compass_manip.task import TargetQuery
from compass_manip.types import Observation

QUERY = TargetQuery("box", "red", (0.05, 0.05, 0.12))
W, H = 32, 24


def _obs(t):
    return Observation(np.ones((H, W), np.float32), np.zeros((H, W, 3), np.uint8), np.eye(3), np.eye(4), t, np.zeros(7))


class Recorder:
    """Records the time of every frame it is run on; an accepted detection at the image
    centre for the frames in `hits`."""

    def __init__(self, hits=()):
        self.seen, self.hits = [], set(hits)

    def __call__(self, obs, query):
        self.seen.append(obs.t)
        if obs.t not in self.hits:
            return ()
        c = ((W - 1) / 2, (H - 1) / 2)
        return (Detection(obs.t, np.eye(4), (10, 6, 20, 16), c, 100, np.zeros((3, 3)), np.zeros(3),
                          (0.05, 0.05, 0.12), "box", 1.0, Verdict.ACCEPTED),)


def _run(times, period, sync_at=(), threaded=True, hits=()):
    det = Recorder(hits)
    buf = DetectionBuffer(det, QUERY, BufferConfig(size=8, threaded=threaded, min_period_s=period))
    try:
        for t in times:
            for ts in [s for s in sync_at if s <= t and s not in _run.done]:
                buf.sync(ts)
                _run.done.add(ts)
            buf.push(_obs(t))
        buf.sync(max([*times, *sync_at]))
        return det.seen, buf
    finally:
        buf.close()
        _run.done = set()


_run.done = set()


def test_zero_period_processes_every_frame():
    seen, buf = _run([0.0, 0.1, 0.2, 0.3], 0.0)
    assert seen == [0.0, 0.1, 0.2, 0.3] and buf.n_skipped == 0


@pytest.mark.parametrize("threaded", [True, False])
def test_busy_detector_takes_the_newest_frame_when_free(threaded):
    # period 0.5 s: 0.0 starts (busy to 0.5); 0.2 waits, 0.4 replaces it (0.2 skipped);
    # at 0.6 the detector has been free since 0.5: 0.4 starts at 0.5 (busy to 1.0) and
    # 0.6 waits; 0.9 replaces 0.6; at 1.3 0.9 starts at 1.0 (busy to 1.5) and 1.3 waits;
    # the final sync at 1.3 < 1.5 leaves 1.3 in the slot
    seen, buf = _run([0.0, 0.2, 0.4, 0.6, 0.9, 1.3], 0.5, threaded=threaded)
    assert seen == [0.0, 0.4, 0.9]
    assert buf.n_skipped == 2 and buf.n_processed == 3


def test_sync_at_a_decision_starts_the_waiting_frame_once_the_detector_is_free():
    # 0.0 starts (busy to 0.5), 0.3 waits; a decision at 0.4 leaves it waiting, the one at
    # 0.7 starts it (at 0.5, busy to 1.0); 1.2 comes after that and starts at once
    seen, buf = _run([0.0, 0.3, 1.2], 0.5, sync_at=(0.4, 0.7))
    assert seen == [0.0, 0.3, 1.2] and buf.n_skipped == 0


def test_a_frame_left_in_the_slot_is_never_read_and_a_processed_one_is():
    seen, buf = _run([0.0, 0.2, 0.3], 0.5, hits=(0.2,))
    assert seen == [0.0]  # 0.2 was replaced by 0.3, which still waits
    assert buf.best() is None
    seen, buf = _run([0.0, 0.3], 0.5, sync_at=(0.6,), hits=(0.3,))
    assert seen == [0.0, 0.3]
    assert buf.best() is not None and buf.best().detection.t == 0.3  # the frame's own time


def test_same_frames_same_choice():
    times = list(np.cumsum(np.random.default_rng(5).uniform(0.05, 0.6, 200)))
    a, _ = _run(times, 0.4, threaded=True)
    b, _ = _run(times, 0.4, threaded=False)
    assert a == b
    # starts are at least 0.4 s apart: at most one per 0.4 s of the frames' span, plus one
    assert len(a) <= (times[-1] - times[0]) / 0.4 + 1
    assert 0.3 * len(times) < len(a) < len(times)


@pytest.mark.parametrize("bad", [-0.1, 11.0, float("nan"), "0.5"])
def test_bad_period_is_refused(bad):
    with pytest.raises(CompassInputError, match="min_period_s"):
        BufferConfig(min_period_s=bad)
