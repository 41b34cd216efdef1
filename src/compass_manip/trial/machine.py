"""The trial state machine: NFA -> EXPLORE (sense, integrate, detect, decide, move) ->
FOUND -> INSPECT -> GRASP -> DONE, or a failure named by its reason. Without a grasp stage
(find-only trials) FOUND -> DONE. INSPECT (optional, `GraspTrialConfig.inspect`, `trial.inspect`): a few
views planned on the method's map and checker that look at the space in front of the
detected target where the hand will come in; their frames feed that map (their motions and
plans count like the exploration's). GRASP (`grasp_stage.run_grasp_stage`) selects a grasp on the method's
map and executes it in physics; the clock advances by its charge and motions.

The simulated clock advances by each trajectory's duration (Panda limits, `motion.timing`)
plus a charge per decision (fixed by default, so the same seed gives a bit-identical
trial; the measured compute time as an option). Camera frames along every trajectory
(keyframes or a fixed rate, `SensingConfig`) and one at the end of each motion feed the
method's map and the detection buffer. Detection runs on its own thread while the arm moves, the map integrates and the method decides; the
machine waits for it only at decision points, where it reads the buffer's most-centred
accepted detection (and hands partial matches to the method as points of interest); when the
method stops (no reachable view, nothing left to explore) a tentative match still waiting for
a confirming view is accepted (`DetectionBuffer.accept_waiting`, `perception.confirm`).
The target counts as found at the time stamp of the frame holding that detection.
"""
from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from ..exploration.base import Phase, StopReason
from ..motion.timing import time_parameterize
from ..sim.executor import ExecutorConfig, execute
from .observer import TrialObserver
from .result import TrialFailure
from .verify import LookOutcome

_STOP_TO_FAILURE = {
    StopReason.NO_REACHABLE_VIEW: TrialFailure.NO_REACHABLE_VIEW,
    StopReason.PLANNING_FAILED: TrialFailure.PLANNING_FAILED,
    StopReason.EXPLORED: TrialFailure.TARGET_NOT_FOUND,
}


class TrialState(enum.Enum):
    NFA = "nfa"
    EXPLORE = "explore"
    FOUND = "found"
    INSPECT = "inspect"
    GRASP = "grasp"
    DONE = "done"
    FAILED = "failed"


@dataclass(frozen=True, eq=False)
class MachineOutcome:
    """How the run ended: the failure (None when found), the accepted detection (a
    `perception.buffer.BufferedDetection`) and the time it was found [s], the end time [s],
    the states visited in order, the executed camera positions (N, 3) [m], the final
    configuration q_end (7,) [rad], the GRASP state's `GraspStageResult` (None when not
    entered) and the number of INSPECT views reached."""

    failure: TrialFailure | None
    found: object | None
    t_found: float | None
    t_end: float
    states: tuple[TrialState, ...]
    camera_path: np.ndarray
    q_end: np.ndarray
    grasp: object | None = None
    n_inspected: int = 0


class TrialMachine:
    """Runs one trial of `method` in `world` (see the module docstring). `pass_frames`: push
    whole frames (with labels) to the buffer, for the oracle detector only. grasp: the GRASP
    state, `grasp(q_current, detection, executed_paths, look=...) -> GraspStageResult` (look: the
    machine's executor of the grasp stage's look views, `_look`), or None for a
    find-only trial. inspect: the INSPECT
    state before GRASP, `inspect(q_current, detection) -> trial.inspect.InspectPlan`,
    called up to n_inspect times while the time limit allows (None: no INSPECT). `observer`: a `trial.observer.TrialObserver` told of every event
    (read-only; video, Rerun)."""

    def __init__(self, world, method, buffer, metrics, config, progress=None, pass_frames: bool = False,
                 grasp=None, observer=None, inspect=None, n_inspect: int = 0) -> None:
        self.world, self.method, self.buffer, self.metrics, self.config = world, method, buffer, metrics, config
        self.progress = progress
        self.observer = observer if observer is not None else TrialObserver()
        self.pass_frames = pass_frames
        self.t = 0.0
        self.states: list[TrialState] = []
        self.cam: list[np.ndarray] = []
        self.grasp = grasp
        self.inspect, self.n_inspect = inspect, n_inspect
        self.moved: list[np.ndarray] = []
        self.n_inspected = 0
        self.n_looked = 0

    def _feed(self, frame) -> None:
        obs = frame.observation()
        self.method.observe(obs)
        self.buffer.push(frame if self.pass_frames else obs)
        self.cam.append(frame.T_world_cam[:3, 3].copy())
        self.observer.frame(frame, self.method)

    def _enter(self, state: TrialState) -> None:
        if not self.states or self.states[-1] is not state:
            self.states.append(state)
            self.observer.state(self.t, state)

    def run(self) -> MachineOutcome:
        config = self.config
        limit = config.time_limit_s
        render_seg = self.pass_frames
        ex_cfg = ExecutorConfig(frame_rate=config.sensing.frame_rate, check_step=config.sensing.check_step,
                                render_rgb=True, render_seg=render_seg, keyframes=config.sensing.keyframes,
                                advance=config.sensing.advance)
        q0 = self.world.q
        self.observer.start(self.world, self.method)
        self._feed(self.world.render(q0, t=0.0, rgb=True, seg=render_seg))
        self.metrics.explored_fraction(0.0, self.method.occupancy)
        failure, found = None, None
        while True:
            self.buffer.sync(self.t)
            self.method.add_points_of_interest(self.buffer.take_hints())
            found = self.buffer.best()
            if found is not None:
                self.observer.detection(self.t, found)
                self._enter(TrialState.FOUND)
                break
            if self.t >= limit:
                failure = TrialFailure.TIME_LIMIT
                break
            d = self.method.decide()
            self._enter(TrialState.NFA if d.phase is Phase.NFA else TrialState.EXPLORE)
            self.metrics.decision(d)
            self.observer.decision(self.t, d, self.method)
            self.t += d.compute_s if config.clock.measured else config.clock.planning_charge_s
            if d.stop is not None:  # no view left: a tentative match waiting for one is accepted
                found = self.buffer.accept_waiting(self.t)
                if found is not None:
                    self.observer.detection(self.t, found)
                    self._enter(TrialState.FOUND)
                    break
                failure = _STOP_TO_FAILURE[d.stop]
                break
            if self._move(d.path, ex_cfg, render_seg):
                failure = TrialFailure.COLLISION
                break
            self.metrics.explored_fraction(self.t, self.method.occupancy)
            if self.progress is not None:
                self.progress(f"t = {self.t:6.1f} s  {d.phase.value:7s} decision {self.metrics.decisions:3d}  "
                              f"explored {self.metrics.explored[-1][1]:.2f}")
        t_found = None
        if found is not None:
            t_found = found.detection.t
            if t_found > limit:
                failure, found, t_found = TrialFailure.TIME_LIMIT, None, None
        grasped = None
        if failure is None and found is not None and self.grasp is not None and self.inspect is not None:
            failure = self._inspect(found.detection, ex_cfg, render_seg)
        if failure is None and found is not None and self.grasp is not None:
            self._enter(TrialState.GRASP)
            grasped = self.grasp(self.world.q, found.detection, self.moved,
                                 look=lambda p, count=True: self._look(p, ex_cfg, render_seg, count))
            sel = grasped.selection
            if sel is not None and sel.T_world_tcp is not None:
                self.observer.grasp_candidates(self.t, sel.T_world_tcp[None], np.array([sel.score]))
            self.t += grasped.duration_s
            self.metrics.collisions += grasped.n_collisions
            failure = grasped.failure
        self._enter(TrialState.DONE if failure is None else TrialState.FAILED)
        outcome = MachineOutcome(failure, found, t_found, self.t, tuple(self.states),
                                 np.array(self.cam).reshape(-1, 3), self.world.q, grasped, self.n_inspected)
        self.observer.end(outcome)
        return outcome

    def _inspect(self, detection, ex_cfg, render_seg) -> TrialFailure | None:
        """INSPECT: up to n_inspect planned views of the hand's way in to the detected
        target (`trial.inspect`, `trial.grasp_views`), executed like the exploration's: each
        plan counts in MPSR, its charge and motion advance the clock, its frames feed the
        method's map. A step that plans nothing (charged, not counted) or a view that cannot
        be planned ends the inspection (the grasp is still tried); a contact on
        the way ends the trial (COLLISION)."""
        config = self.config
        pts = np.asarray(detection.points_world, dtype=np.float64).reshape(-1, 3)
        for _ in range(self.n_inspect if len(pts) else 0):
            if self.t >= config.time_limit_s:
                break
            self._enter(TrialState.INSPECT)
            p = self.inspect(self.world.q, detection)
            self.t += p.plan_time_s if config.clock.measured else config.clock.planning_charge_s
            if not p.planned:  # nothing left to look at (or no view sees it): no plan was made
                break
            self.metrics.plans_attempted += 1
            if p.path is None:
                break
            self.metrics.plans_succeeded += 1
            if self._move(p.path, ex_cfg, render_seg):
                return TrialFailure.COLLISION
            self.n_inspected += 1
        return None

    def _look(self, p, ex_cfg, render_seg, count: bool = True) -> LookOutcome:
        """A look view of the GRASP state (`trial.verify`), executed like an INSPECT view: its
        plan counts in MPSR, its motion advances the clock and its frames feed the maps (its
        planning charge is the grasp stage's). Returns a `trial.verify.LookOutcome`. count=False: a motion that was not planned (the
        way back along the view's path) is not counted in MPSR."""
        if self.t >= self.config.time_limit_s or not p.planned:
            return LookOutcome.NONE
        self.metrics.plans_attempted += int(count)
        if p.path is None:
            return LookOutcome.NONE
        self.metrics.plans_succeeded += int(count)
        if self._move(p.path, ex_cfg, render_seg):
            return LookOutcome.COLLISION
        self.n_looked += int(count)
        return LookOutcome.MOVED

    def _move(self, path, ex_cfg, render_seg) -> bool:
        """Execute a joint path (n,7) [rad] on the simulated timeline: its frames feed the
        map and the buffer, the clock advances by its duration; True when the arm touched
        something (counted as collisions; the method is not told of the motion), else the
        method is told, the path is kept as the way the arm moved and a frame at its end is fed."""
        traj = time_parameterize(path, self.config.timing)
        t_start = self.t
        res = execute(self.world, traj, ex_cfg, t0=t_start)
        self.observer.motion(traj, t_start, res.t_end)
        for f in res.frames:
            self._feed(f)
        self.t = res.t_end
        self.metrics.motion(traj, t_start, res.t_end)
        if res.contacts:
            self.metrics.collisions += len(res.contacts)
            return True
        self.method.executed(path)
        self.moved.append(np.asarray(path))
        self._feed(self.world.render(res.q_end, t=self.t, rgb=True, seg=render_seg))
        return False
