"""Run a sweep: skip what the store already holds, run the rest, store each trial as it ends.

    summary = run_sweep(SweepConfig(methods=("fv", "compass"), scenes=2, trials=3), "results.sqlite")

The trial function is injectable (`trial_fn`); by default it is `sweep.real_trial`, which
needs `compass_manip.trial.runner`. Everything is checked (config, store, trial function,
Ray) before the first trial starts.
"""
from __future__ import annotations

import sqlite3
import sys
import time
from collections import Counter
from dataclasses import dataclass
from typing import Callable

from ..errors import CompassInputError
from .pool import Outcome, run_local
from .store import ResultsStore, TrialRecord
from .sweep import REAL_TRIAL_FN, SweepConfig, check_trial_fn, resolve_trial_fn, validate


@dataclass(frozen=True)
class SweepSummary:
    """total: trials in the sweep; skipped: already in the store; ran: run now;
    successes / done: per method, over the whole store's part of this sweep;
    failures: runner and trial failure names of the trials run now, with counts;
    wall_s: wall time of this call [s]."""

    total: int
    skipped: int
    ran: int
    successes: dict
    done: dict
    failures: dict
    wall_s: float


def trial_fn_name(fn: Callable) -> str:
    """"module:qualname" of a trial function (of the wrapped one for a functools.partial)."""
    inner = getattr(fn, "func", fn)
    return f"{getattr(inner, '__module__', '?')}:{getattr(inner, '__qualname__', repr(inner))}"


def record_of(outcome: Outcome, trial_fn: str) -> TrialRecord:
    """The store row for one Outcome."""
    s = outcome.spec
    if outcome.failure is not None:
        return TrialRecord(s.method, s.level, s.scene, s.trial, s.seed, success=False,
                           failure=outcome.failure.value, error=outcome.error, trial_fn=trial_fn,
                           config=None, result=None, wall_s=outcome.wall_s, finished_at=time.time())
    r = outcome.result
    return TrialRecord(s.method, s.level, s.scene, s.trial, s.seed, success=bool(r.get("success")),
                       failure=r.get("failure"), error=None, trial_fn=trial_fn, config=outcome.config,
                       result=r, wall_s=outcome.wall_s, finished_at=time.time())


def _postfix(successes: Counter, done: Counter, methods) -> str:
    return " ".join(f"{m} {successes[m]}/{done[m]}" for m in methods)


def run_sweep(config: SweepConfig, db: str, trial_fn: Callable | None = None, progress: bool | None = None,
              store: ResultsStore | None = None) -> SweepSummary:
    """Run `config`'s trials missing from the results store `db`.

    progress: a tqdm bar on stderr (done / total, ETA, successes per method); None = only
    on a terminal, True = always, False = never. Returns what was run; trial errors and wall-time kills are recorded as
    failures and the sweep goes on.
    """
    t0 = time.perf_counter()
    validate(config)
    if config.ray_address is not None:
        from .ray_pool import import_ray  # noqa: PLC0415 (optional extra)

        import_ray()
    if trial_fn is not None:
        check_trial_fn(trial_fn, repr(trial_fn))
    fn = resolve_trial_fn(REAL_TRIAL_FN) if trial_fn is None else trial_fn
    name = trial_fn_name(fn)
    own_store = store is None
    store = ResultsStore(db, create=True) if own_store else store
    try:
        records = store.records()
        other_fns = sorted({r.trial_fn for r in records} - {name})
        if other_fns:
            raise CompassInputError(f"results store {db!r} holds trials of {', '.join(other_fns)}; this sweep runs "
                                    f"{name}: results of two trial functions are not mixed, use a new --db")
        specs = config.specs()
        wanted = {s.key for s in specs}
        stored = [r for r in records if r.key in wanted]
        todo = [s for s in specs if s.key not in {r.key for r in stored}]
        successes = Counter(r.method for r in stored if r.success)
        done = Counter(r.method for r in stored)
        failures: Counter = Counter()
        if config.ray_address is not None:
            from .ray_pool import run_ray  # noqa: PLC0415

            outcomes = run_ray(fn, todo, config.workers, config.wall_cap_s, config.ray_address)
        else:
            outcomes = run_local(fn, todo, config.workers, config.wall_cap_s)
        from tqdm import tqdm  # noqa: PLC0415

        with tqdm(total=len(specs), initial=len(specs) - len(todo), desc="trials", unit="trial", file=sys.stderr,
                  disable=(None if progress is None else not progress), dynamic_ncols=True) as bar:
            bar.set_postfix_str(_postfix(successes, done, config.methods))
            try:
                for outcome in outcomes:
                    record = record_of(outcome, name)
                    try:
                        store.add(record)
                    except sqlite3.IntegrityError:  # another sweep on the same file stored it first
                        bar.write(f"trial {record.key} was already stored by another run; kept the first")
                        continue
                    done[record.method] += 1
                    successes[record.method] += int(record.success)
                    if record.failure is not None:
                        failures[record.failure] += 1
                    bar.set_postfix_str(_postfix(successes, done, config.methods), refresh=False)
                    bar.update(1)
            finally:
                outcomes.close()  # stops the workers at once when interrupted
        return SweepSummary(total=len(specs), skipped=len(specs) - len(todo), ran=len(todo),
                            successes=dict(successes), done=dict(done), failures=dict(failures),
                            wall_s=time.perf_counter() - t0)
    finally:
        if own_store:
            store.close()
