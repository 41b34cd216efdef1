"""What a sweep is: its config, the trial keys it covers, and the trial function it calls.

A trial function takes a `TrialKey`-like spec (attributes method, level, scene, trial,
seed) and returns `(config_dict, result_dict)`: the trial's full config and its result,
both JSON-able. `real_trial` is the one that runs the simulator (through
`compass_manip.trial.runner.run_trial`); `bench.synthetic` has one that does not, for
testing and measuring the sweep machinery itself.
"""
from __future__ import annotations

import enum
import importlib
import inspect
from dataclasses import dataclass
from typing import Callable

from ..errors import CompassInputError

LEVELS = (1, 2, 3, 4)
#: The longest wall-time cap per trial [s] (a week).
MAX_WALL_CAP_S = 7 * 24 * 3600.0
#: The trial function used when none is given ("module:name").
REAL_TRIAL_FN = "compass_manip.bench.sweep:real_trial"


class RunFailure(enum.Enum):
    """Why the runner, not the trial, ended a trial (stored in the `failure` column)."""

    ERROR = "runner_error"               # the trial function raised; the error text is stored
    WALL_TIME = "wall_time_exceeded"     # the trial ran past the sweep's wall-time cap and was killed
    WORKER_DIED = "worker_died"          # the process running it died (signal, crash)


@dataclass(frozen=True)
class Spec:
    """One trial of a sweep. `seed` is the sweep's base seed; trials of one scene differ by
    `trial`, from which the trial derives its own seed (detector noise, planner, sampling)."""

    method: str
    level: int
    scene: int
    trial: int = 0
    seed: int = 0

    @property
    def key(self) -> tuple[str, int, int, int, int]:
        return (self.method, self.level, self.scene, self.trial, self.seed)


@dataclass(frozen=True)
class SweepConfig:
    """methods × levels × scenes (indices 0..scenes-1) × trials (0..trials-1) at base seed `seed`.

    workers: parallel trials; wall_cap_s: wall time [s] after which a trial is killed and
    recorded as `RunFailure.WALL_TIME`; ray_address: None for the local process pool, else
    a Ray address ("auto", "ray://host:10001") or "local" for a fresh local Ray instance.
    """

    methods: tuple[str, ...]
    levels: tuple[int, ...] = LEVELS
    scenes: int = 20
    trials: int = 10
    seed: int = 0
    workers: int = 1
    wall_cap_s: float = 900.0
    ray_address: str | None = None

    def specs(self) -> list[Spec]:
        """Every trial, scene-major within a level so early results cover every method."""
        return [Spec(m, lv, s, t, self.seed) for lv in self.levels for s in range(self.scenes)
                for t in range(self.trials) for m in self.methods]


def known_methods() -> list[str] | None:
    """Every method a trial can run (`trial.runner.trial_methods`: the registered methods and
    the oracle reference), or None when the trial package is not in this build."""
    try:
        runner = importlib.import_module("compass_manip.trial.runner")
    except ModuleNotFoundError as exc:
        if exc.name and exc.name.startswith(("compass_manip.trial", "compass_manip.exploration")):
            return None
        raise
    return list(runner.trial_methods())


def validate(config: SweepConfig, methods: list[str] | None = None) -> None:
    """Raise CompassInputError naming the first bad value of `config` and what is allowed."""
    if not config.methods:
        raise CompassInputError("no method given; give at least one, e.g. --methods fv,ig,gse,compass")
    allowed = known_methods() if methods is None else methods
    for m in config.methods:
        if allowed is not None and m not in allowed:
            raise CompassInputError(f"method {m!r} is not known; use one of {', '.join(sorted(allowed))}")
        if not m or "," in m:
            raise CompassInputError(f"method {m!r} is not a method name")
    if len(set(config.methods)) != len(config.methods):
        raise CompassInputError(f"methods {','.join(config.methods)} repeat a name; give each once")
    for lv in config.levels:
        if lv not in LEVELS:
            raise CompassInputError(f"level {lv} is not allowed; use levels among 1, 2, 3, 4")
    if not config.levels:
        raise CompassInputError("no level given; use levels among 1, 2, 3, 4")
    if not 1 <= config.scenes <= 1000:
        raise CompassInputError(f"scenes {config.scenes} is not allowed; use 1..1000")
    if not 1 <= config.trials <= 1000:
        raise CompassInputError(f"trials {config.trials} is not allowed; use 1..1000")
    if not 0 <= config.seed < 2**63:
        raise CompassInputError(f"seed {config.seed} is not allowed; use 0 <= seed < 2**63")
    if not 1 <= config.workers <= 1024:
        raise CompassInputError(f"workers {config.workers} is not allowed; use 1..1024")
    if not 0 < config.wall_cap_s <= MAX_WALL_CAP_S:  # nan and inf too: the pool waits with a finite timeout
        raise CompassInputError(f"wall-time cap {config.wall_cap_s} s is not allowed; use a positive number of "
                                f"seconds up to {MAX_WALL_CAP_S:.0f} (a week)")


def resolve_trial_fn(name: str = REAL_TRIAL_FN) -> Callable:
    """The trial function named "module:name", checked importable now (before any work)."""
    module_name, _, attr = name.partition(":")
    if not module_name or not attr:
        raise CompassInputError(f"trial function {name!r} is not allowed; use the form module:function")
    try:
        fn = getattr(importlib.import_module(module_name), attr)
    except (ImportError, AttributeError) as exc:
        raise CompassInputError(f"trial function {name!r} cannot be loaded ({exc})")
    check_trial_fn(fn, name)
    if fn is real_trial:
        _import_trial_runner()
    return fn


def check_trial_fn(fn, name: str) -> None:
    """CompassInputError unless `fn` is a function that can be called with one spec (else every
    trial of the sweep would be stored as a runner error and skipped on resume)."""
    if isinstance(fn, type) or not callable(fn):
        raise CompassInputError(f"trial function {name!r} is a {type(fn).__name__}, not a function; "
                                "give a function of one spec returning (config dict, result dict)")
    try:
        inspect.signature(fn).bind(Spec("compass", 1, 0))
    except TypeError as exc:
        raise CompassInputError(f"trial function {name!r} cannot take one spec ({exc}); "
                                "give a function of one spec returning (config dict, result dict)") from None
    except ValueError:  # no signature to read (some builtins): the first trial will tell
        pass


def _import_trial_runner():
    try:
        return importlib.import_module("compass_manip.trial.runner")
    except ModuleNotFoundError as exc:
        if exc.name and exc.name.startswith("compass_manip.trial"):
            raise CompassInputError("compass_manip.trial.runner.run_trial is not in this build, so real trials "
                                    "cannot run; install a build with the trial package") from None
        raise


def real_trial(spec) -> tuple[dict, dict]:
    """Run one simulated trial through `compass_manip.trial.runner.run_trial`.

    Returns the trial's full config (`TrialConfig.to_dict()`, method config included) and
    its `TrialResult.to_dict()`.
    """
    runner = _import_trial_runner()
    trial_spec = runner.TrialSpec(method=spec.method, level=spec.level, scene=spec.scene, trial=spec.trial,
                                  seed=spec.seed)
    config = _trial_config(spec.method)
    result = runner.run_trial(trial_spec, config)
    return config.to_dict(), result.to_dict()


def _trial_config(method: str):
    """The trial config every method runs with: the trial package's defaults (a method's own
    settings live in its registry entry, which the trial builds from the method name)."""
    from ..trial.config import TrialConfig  # noqa: PLC0415 (the trial package is optional here)

    return TrialConfig()
