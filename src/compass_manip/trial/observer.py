"""Observers of a trial: what the state machine reports to viewers (video, Rerun) as it runs.

The machine calls, in simulated-time order:
- `start(world, method)` once, before the first frame (the world and the method for
  read-only use: the scene, the robot model, `method.occupancy`);
- `state(t, state)` on every change of `TrialState`;
- `decision(t, decision, method)` after each `decide()` at simulated time t [s] (before its
  planning charge); `decision.debug` may hold the method's tree (see `exploration.base`);
- `motion(trajectory, t_start, t_end)` after a trajectory ran, before its frames are fed;
- `frame(frame, method)` after each camera frame was integrated by the method (frame.t);
- `detection(t, found)` when the machine accepts a detection (a `BufferedDetection`);
- `grasp_candidates(t, T_world_grasp, scores)` when a grasp state ranks candidates
  ((N, 4, 4) TCP poses in the world, (N,) scores);
- `end(outcome)` once with the `MachineOutcome`; `close()` always (also after an error).

An observer must not change the trial: it reads what it is given and never writes to the
world, the method or their generators (tests/test_trial_video.py checks that a trial
with observers gives the same result as one without).
"""
from __future__ import annotations


class TrialObserver:
    """Base class: every event is a no-op, so an observer overrides only what it uses."""

    def start(self, world, method) -> None:
        pass

    def state(self, t: float, state) -> None:
        pass

    def decision(self, t: float, decision, method) -> None:
        pass

    def motion(self, trajectory, t_start: float, t_end: float) -> None:
        pass

    def frame(self, frame, method) -> None:
        pass

    def detection(self, t: float, found) -> None:
        pass

    def grasp_candidates(self, t: float, T_world_grasp, scores) -> None:
        pass

    def end(self, outcome) -> None:
        pass

    def close(self) -> None:
        pass


class ObserverGroup(TrialObserver):
    """Forwards every event to each observer in order."""

    def __init__(self, observers) -> None:
        self.observers = tuple(observers)

    def __getattribute__(self, name: str):
        if name in _EVENTS:
            observers = object.__getattribute__(self, "observers")

            def forward(*args, **kwargs):
                for o in observers:
                    getattr(o, name)(*args, **kwargs)

            return forward
        return object.__getattribute__(self, name)

    def close(self) -> None:
        """Close every observer, even when one of them raises (the first error is re-raised)."""
        error = None
        for o in self.observers:
            try:
                o.close()
            except Exception as exc:  # noqa: BLE001 (close the others first)
                error = error or exc
        if error is not None:
            raise error


_EVENTS = frozenset(n for n in vars(TrialObserver) if not n.startswith("_") and n != "close")
