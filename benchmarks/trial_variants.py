"""Trial functions for `compass bench --trial-fn` with the grasp stage's settings changed
(the default trial runs `TrialConfig()`): put `benchmarks/` on PYTHONPATH and pass e.g.
`--trial-fn trial_variants:grasp_map_no_near_body`.

* grasp_map_no_near_body: GRASP and INSPECT on the 1 cm map of every depth frame
  (`GraspTrialConfig.grasp_map`), with no unknown space near the body taken as free
  (`near_body_free=False`).
* find_only: no GRASP state (the trial ends at FOUND), as `compass run --find-only`.
"""
from __future__ import annotations

from compass_manip.trial.config import GraspTrialConfig, TrialConfig
from compass_manip.trial.runner import TrialSpec, run_trial


def _run(spec, config: TrialConfig) -> tuple[dict, dict]:
    ts = TrialSpec(method=spec.method, level=spec.level, scene=spec.scene, trial=spec.trial, seed=spec.seed)
    return config.to_dict(), run_trial(ts, config).to_dict()


def grasp_map_no_near_body(spec) -> tuple[dict, dict]:
    return _run(spec, TrialConfig(grasp=GraspTrialConfig(grasp_map=True, near_body_free=False)))


def find_only(spec) -> tuple[dict, dict]:
    return _run(spec, TrialConfig(grasp=GraspTrialConfig(enabled=False)))
