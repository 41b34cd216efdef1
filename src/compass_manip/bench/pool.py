"""A local pool of worker processes that runs trials with a wall-time cap.

`concurrent.futures` cannot stop one running task, so this pool keeps its own workers:
each runs one trial at a time; a trial past the cap has its worker killed (SIGKILL) and
replaced, a worker that dies is reported and replaced, and the sweep goes on. Workers
come from a fork server (safe beside threads the parent may hold) and ignore SIGINT: the
parent stops them when it is interrupted.
"""
from __future__ import annotations

import json
import multiprocessing as mp
import signal
import time
import traceback
from collections import deque
from dataclasses import dataclass
from multiprocessing.connection import wait
from typing import Callable, Iterable, Iterator

from .sweep import RunFailure, Spec


@dataclass(frozen=True)
class Outcome:
    """How one trial ended: its config and result dicts, or the runner's failure and error text."""

    spec: Spec
    config: dict | None
    result: dict | None
    failure: RunFailure | None
    error: str | None
    wall_s: float


def call_trial(trial_fn: Callable, spec: Spec) -> tuple:
    """Run `trial_fn(spec)` and return ("ok", config, result, wall_s) or ("error", text, wall_s).

    The dicts are checked JSON-able here, so a bad result is a recorded error, not a crash.
    """
    t0 = time.perf_counter()
    try:
        config, result = trial_fn(spec)
        json.dumps(config), json.dumps(result)
        return ("ok", config, result, time.perf_counter() - t0)
    except Exception:  # noqa: BLE001 (every trial error is recorded and the sweep goes on)
        return ("error", traceback.format_exc(limit=8), time.perf_counter() - t0)


def outcome_of(spec: Spec, message: tuple) -> Outcome:
    """The Outcome for a `call_trial` message."""
    if message[0] == "ok":
        return Outcome(spec, message[1], message[2], None, None, message[3])
    return Outcome(spec, None, None, RunFailure.ERROR, message[1], message[2])


def _worker_main(conn, trial_fn: Callable) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    while True:
        try:
            spec = conn.recv()
        except (EOFError, OSError):
            return
        if spec is None:
            return
        try:
            conn.send(call_trial(trial_fn, spec))
        except (BrokenPipeError, OSError):
            return  # the parent is gone


class _Worker:
    def __init__(self, ctx, trial_fn: Callable):
        self.conn, child = ctx.Pipe()
        self.process = ctx.Process(target=_worker_main, args=(child, trial_fn), daemon=True)
        self.process.start()
        child.close()
        self.spec: Spec | None = None
        self.t_start = 0.0

    def kill(self) -> None:
        if self.process.is_alive():
            self.process.kill()
        self.process.join(5.0)
        self.conn.close()


def _context():
    methods = mp.get_all_start_methods()
    return mp.get_context("forkserver" if "forkserver" in methods else "spawn")


def run_local(trial_fn: Callable, specs: Iterable[Spec], workers: int, wall_cap_s: float) -> Iterator[Outcome]:
    """Run every spec on `workers` processes; yield each Outcome the moment its trial ends."""
    pending = deque(specs)
    if not pending:
        return
    ctx = _context()
    idle = [_Worker(ctx, trial_fn) for _ in range(min(workers, len(pending)))]
    busy: dict = {}  # conn -> worker
    try:
        while pending or busy:
            while idle and pending:
                w = idle.pop()
                w.spec, w.t_start = pending.popleft(), time.monotonic()
                w.conn.send(w.spec)
                busy[w.conn] = w
            deadline = min(w.t_start for w in busy.values()) + wall_cap_s
            ready = wait(list(busy), timeout=max(0.0, deadline - time.monotonic()))
            for conn in ready:
                w = busy.pop(conn)
                try:
                    message = conn.recv()
                except (EOFError, OSError):
                    w.process.join(5.0)
                    code = w.process.exitcode
                    w.kill()
                    yield Outcome(w.spec, None, None, RunFailure.WORKER_DIED,
                                  f"worker process died with exit code {code}", time.monotonic() - w.t_start)
                    if pending:
                        idle.append(_Worker(ctx, trial_fn))
                    continue
                idle.append(w)
                yield outcome_of(w.spec, message)
            now = time.monotonic()
            for conn, w in list(busy.items()):
                if now - w.t_start >= wall_cap_s:
                    del busy[conn]
                    w.kill()
                    yield Outcome(w.spec, None, None, RunFailure.WALL_TIME,
                                  f"killed after the wall-time cap of {wall_cap_s:g} s", now - w.t_start)
                    if pending:
                        idle.append(_Worker(ctx, trial_fn))
    finally:
        for w in idle:
            try:
                w.conn.send(None)
            except OSError:
                pass
        for w in idle:
            w.process.join(2.0)
            w.kill()
        for w in busy.values():
            w.kill()
