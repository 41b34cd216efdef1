"""A synthetic trial function: no simulator, deterministic numbers shaped like a TrialResult.

It exists to test and measure the sweep machinery (store, pool, Ray, resume, report)
without the seconds a simulated trial costs. Its records are labelled with their trial
function, and the report warns when it renders them: they are not benchmark results.
Behaviour knobs (wall time per trial, scenes whose trials raise or run slow) come from a
frozen `SyntheticConfig`; bind one with `functools.partial(synthetic_trial, config=...)`.
"""
from __future__ import annotations

import time
import zlib
from dataclasses import asdict, dataclass

import numpy as np

#: Probability of a successful grasp at level 1 per method name (others: 0.5); -0.05 per level.
_SKILL = {"compass": 0.8, "gse": 0.5, "ig": 0.35, "fv": 0.3, "compass-no-nfa": 0.6,
          "compass-no-grasp-constraints": 0.25, "oracle": 0.95}
TIME_LIMIT_S = 200.0


@dataclass(frozen=True)
class SyntheticConfig:
    """sleep_s: wall time [s] every trial takes; raise_scenes: scene indices whose trials
    raise RuntimeError; slow_scenes: scene indices whose trials take slow_s [s] instead."""

    sleep_s: float = 0.0
    raise_scenes: tuple[int, ...] = ()
    slow_scenes: tuple[int, ...] = ()
    slow_s: float = 60.0


def synthetic_trial(spec, config: SyntheticConfig = SyntheticConfig()) -> tuple[dict, dict]:
    """(config_dict, result_dict) for `spec`; same spec, same numbers."""
    time.sleep(config.slow_s if spec.scene in config.slow_scenes else config.sleep_s)
    if spec.scene in config.raise_scenes:
        raise RuntimeError(f"synthetic failure in scene {spec.scene} trial {spec.trial}")
    rng = np.random.default_rng([spec.seed, spec.level, spec.scene, spec.trial, zlib.crc32(spec.method.encode())])
    skill = _SKILL.get(spec.method, 0.5) - 0.05 * (spec.level - 1)
    found = rng.random() < min(1.0, skill + 0.15)
    tft = float(rng.uniform(30.0, 190.0)) if found else TIME_LIMIT_S
    success = bool(found and rng.random() < skill / min(1.0, skill + 0.15))
    tau = float(rng.uniform(20.0, 80.0))
    ts = np.arange(0.0, tft + 1e-9, 10.0)
    curve = [[float(t), float(0.9 * (1.0 - np.exp(-t / tau)))] for t in ts]
    if found and not success:
        failure = "object_dropped" if rng.random() < 0.3 else "grasp_failed"
    else:
        failure = None if success else "target_not_found"
    planning = rng.lognormal(np.log(20.0), 0.4, size=16)
    result = {
        "method": spec.method, "level": spec.level, "scene": spec.scene, "trial": spec.trial, "seed": spec.seed,
        "success": success, "failure": failure, "tft_s": tft,
        "pft_m": float(tft / 30.0 * rng.uniform(0.7, 1.3)),
        "mpsr": float(np.clip(rng.normal(0.6, 0.1), 0.0, 1.0)),
        "am": float(np.clip(rng.normal(0.06, 0.01), 0.0, None)),
        "gpq": float(rng.uniform(0.4, 0.8)) if found else None,
        "collisions": int(rng.random() < 0.1),
        "explored_curve": curve, "decisions": int(rng.integers(5, 40)),
        "planning_ms_median": float(np.median(planning)), "planning_ms_p90": float(np.percentile(planning, 90)),
        "wall_s": float(config.sleep_s), "true_detection": bool(found) if found else None,
        "found": bool(found),
    }
    return {"trial_fn": "compass_manip.bench.synthetic:synthetic_trial", "synthetic": asdict(config),
            "method": spec.method}, result
