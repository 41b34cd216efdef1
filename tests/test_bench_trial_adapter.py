"""`sweep.real_trial` against the interface the trial package implements (a stand-in module here)."""
from __future__ import annotations

import sys
import types
from dataclasses import asdict, dataclass, field

import pytest

from compass_manip.bench.pool import call_trial
from compass_manip.bench.sweep import RunFailure, Spec, real_trial


@dataclass(frozen=True)
class TrialSpec:
    method: str
    level: int
    scene: int
    trial: int = 0
    seed: int = 0


@dataclass(frozen=True)
class TrialConfig:
    time_limit_s: float = 200.0
    method: dict = field(default_factory=lambda: {"name": "compass", "w": [1.0, 0.5]})

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class TrialResult:
    spec: TrialSpec
    seen_config: TrialConfig

    def to_dict(self) -> dict:
        return {**asdict(self.spec), "success": self.spec.trial % 2 == 0, "failure": None, "tft_s": 12.0,
                "config_limit": self.seen_config.time_limit_s}


def _run_trial(spec, config=None, progress=None):
    if spec.scene == 9:
        raise ValueError("scene 9 is broken")
    return TrialResult(spec, config)


@pytest.fixture
def trial_package(monkeypatch):
    pkg = types.ModuleType("compass_manip.trial")
    pkg.__path__ = []
    runner = types.ModuleType("compass_manip.trial.runner")
    runner.TrialSpec, runner.run_trial = TrialSpec, _run_trial
    config = types.ModuleType("compass_manip.trial.config")
    config.TrialConfig = TrialConfig
    for name, mod in (("compass_manip.trial", pkg), ("compass_manip.trial.runner", runner),
                      ("compass_manip.trial.config", config)):
        monkeypatch.setitem(sys.modules, name, mod)


def test_real_trial_passes_the_spec_and_stores_the_config_it_ran(trial_package):
    config, result = real_trial(Spec("gse", 3, 4, 2, 11))
    assert config == {"time_limit_s": 200.0, "method": {"name": "compass", "w": [1.0, 0.5]}}
    assert result == {"method": "gse", "level": 3, "scene": 4, "trial": 2, "seed": 11, "success": True,
                      "failure": None, "tft_s": 12.0, "config_limit": 200.0}


def test_a_raising_real_trial_becomes_a_recorded_error(trial_package):
    message = call_trial(real_trial, Spec("gse", 3, 9, 0, 0))
    assert message[0] == "error" and "scene 9 is broken" in message[1]
    assert RunFailure.ERROR.value == "runner_error"


def test_a_result_that_is_not_json_is_a_recorded_error():
    message = call_trial(lambda spec: ({}, {"when": object()}), Spec("fv", 1, 0))
    assert message[0] == "error" and "not JSON serializable" in message[1]
