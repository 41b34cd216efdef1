"""The same sweep on a Ray cluster (optional extra: pip install 'compass-manip[cluster]').

Trials run as Ray tasks (one CPU each, no retries); the driver writes each result to the
same store the moment it arrives, so resuming works as with the local pool. A trial past
the wall-time cap is cancelled with force (its worker is killed). Every node needs the
same compass-manip installed (or a Ray runtime_env that ships it).
"""
from __future__ import annotations

import time
from typing import Callable, Iterable, Iterator

from ..errors import CompassInputError
from .pool import Outcome, call_trial, outcome_of
from .sweep import RunFailure, Spec


def import_ray():
    """The ray module, or CompassInputError saying how to install it."""
    try:
        import ray  # noqa: PLC0415 (optional extra)
    except ImportError:
        raise CompassInputError("--ray needs Ray, an optional extra: pip install 'compass-manip[cluster]'") from None
    return ray


def _init(ray, address: str) -> bool:
    """Connect to `address` ("local" starts a private local instance); True if this call started Ray."""
    if ray.is_initialized():
        return False
    kwargs = dict(include_dashboard=False, log_to_driver=False, configure_logging=False)
    try:
        ray.init(address=None if address == "local" else address, **kwargs)
    except (ConnectionError, ValueError, RuntimeError) as exc:
        raise CompassInputError(f"cannot connect to Ray at {address!r} ({exc}); give 'local', 'auto' or "
                                "ray://HOST:PORT") from None
    return True


def run_ray(trial_fn: Callable, specs: Iterable[Spec], workers: int, wall_cap_s: float,
            address: str = "local") -> Iterator[Outcome]:
    """Run every spec as a Ray task, at most `workers` (and the cluster's CPUs) at a time;
    yield each Outcome as it ends. The wall-time cap counts from a task's submission."""
    specs = list(specs)
    if not specs:
        return
    ray = import_ray()
    started = _init(ray, address)
    # never more in flight than CPUs: a queued task's wall clock would run against the cap
    workers = max(1, min(workers, int(ray.cluster_resources().get("CPU", 1))))
    task = ray.remote(num_cpus=1, max_retries=0)(call_trial)
    fn_ref = ray.put(trial_fn)
    pending = list(reversed(specs))
    running: dict = {}  # ObjectRef -> (spec, t_start)
    try:
        while pending or running:
            while pending and len(running) < workers:
                spec = pending.pop()
                running[task.remote(fn_ref, spec)] = (spec, time.monotonic())
            deadline = min(t for _, t in running.values()) + wall_cap_s
            done, _ = ray.wait(list(running), num_returns=1, timeout=max(0.0, deadline - time.monotonic()))
            for ref in done:
                spec, t0 = running.pop(ref)
                try:
                    yield outcome_of(spec, ray.get(ref))
                except ray.exceptions.RayError as exc:
                    yield Outcome(spec, None, None, RunFailure.WORKER_DIED, f"Ray task failed: {exc}",
                                  time.monotonic() - t0)
            now = time.monotonic()
            for ref, (spec, t0) in list(running.items()):
                if now - t0 >= wall_cap_s:
                    del running[ref]
                    ray.cancel(ref, force=True)
                    yield Outcome(spec, None, None, RunFailure.WALL_TIME,
                                  f"cancelled after the wall-time cap of {wall_cap_s:g} s", now - t0)
    finally:
        for ref in running:
            ray.cancel(ref, force=True)
        if started:
            ray.shutdown()
