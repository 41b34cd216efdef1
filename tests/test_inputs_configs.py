"""The config dataclasses a user builds (trial, exploration, perception, grasp, sim) refuse a
value of the wrong kind in __post_init__ with a CompassInputError naming Class.field, the
value and what is allowed; run_trial and certified_scene refuse a wrong spec or config before
any scene is generated."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from compass_manip.errors import CompassInputError, _field_kinds
from compass_manip.exploration.baseline_common import ViewPlanningConfig
from compass_manip.exploration.compass import CompassConfig
from compass_manip.exploration.escape import EscapeConfig
from compass_manip.exploration.fixed_views import FixedViewsConfig
from compass_manip.exploration.greedy_ig import GreedyIGConfig
from compass_manip.exploration.gse import GSEConfig
from compass_manip.exploration.mue_rrt import TreeConfig, UtilityWeights
from compass_manip.exploration.nfa import NFAConfig
from compass_manip.exploration.world_model import WorldModelConfig
from compass_manip.grasp.candidates import CandidateConfig
from compass_manip.grasp.hypotheses import HypothesisConfig
from compass_manip.grasp.select import GraspSelectConfig
from compass_manip.grasp.target import TargetConfig
from compass_manip.perception.buffer import BufferConfig
from compass_manip.perception.confirm import ConfirmConfig
from compass_manip.perception.detector import DetectorConfig
from compass_manip.sim import certify
from compass_manip.sim.advance import AdvanceConfig
from compass_manip.sim.certify import CertifyConfig
from compass_manip.sim.grasp_exec import GraspExecConfig
from compass_manip.sim.grasp_only import GraspOnlyConfig
from compass_manip.sim.keyframes import KeyframeRule
from compass_manip.sim.near_field import NearFieldScanConfig
from compass_manip.trial import runner
from compass_manip.trial.config import ClockConfig, GraspTrialConfig, SensingConfig, TrialConfig
from compass_manip.trial.grasp_looks import BaseLookConfig
from compass_manip.trial.grasp_scan import TrialScanConfig
from compass_manip.trial.inspect import InspectConfig
from compass_manip.trial.oracle_method import OracleConfig
from compass_manip.trial.verify import VerifyConfig

CONFIGS = [ClockConfig, SensingConfig, GraspTrialConfig, TrialConfig, BaseLookConfig, TrialScanConfig, InspectConfig,
           OracleConfig, VerifyConfig, ViewPlanningConfig, CompassConfig, EscapeConfig, FixedViewsConfig,
           GreedyIGConfig, GSEConfig, TreeConfig, UtilityWeights, NFAConfig, WorldModelConfig, BufferConfig,
           ConfirmConfig, DetectorConfig, CandidateConfig, HypothesisConfig, GraspSelectConfig, TargetConfig,
           AdvanceConfig, CertifyConfig, GraspExecConfig, GraspOnlyConfig, KeyframeRule, NearFieldScanConfig]
#: (class, field, kind) of every field whose kind the check knows (bool, int, float, str, enum, config, numbers)
FIELDS = [(cls, name, kind) for cls in CONFIGS for name, kind, _, _ in _field_kinds(cls)]


def _refused(call, *needles: str) -> str:
    with pytest.raises(CompassInputError) as info:
        call()
    msg = str(info.value)
    assert "\n" not in msg and all(n in msg for n in needles), msg
    return msg


def test_every_config_builds_with_its_defaults_and_the_sweep_covers_them():
    for cls in CONFIGS:
        cls()
    assert len(FIELDS) > 300 and {k for _, _, k in FIELDS} == {"bool", "int", "float", "str", "enum", "config",
                                                              "numbers"}


@pytest.mark.parametrize("cls, name, kind", FIELDS, ids=[f"{c.__name__}.{n}" for c, n, _ in FIELDS])
def test_a_value_of_the_wrong_kind_names_the_field(cls, name, kind):
    bad = "abc" if kind != "str" else 3
    _refused(lambda: cls(**{name: bad}), f"{cls.__name__}.{name}", "not allowed")
    default = getattr(cls(), name)  # None for `float | None` fields that are off by default
    if kind == "float":
        for v in (math.nan, -math.inf if default is not None and math.isinf(default) else math.inf):
            _refused(lambda: cls(**{name: v}), f"{cls.__name__}.{name}")
    if kind == "int" and (default is None or default >= 0):
        for v in (-1, 10**9):  # a count that would run or allocate without bound
            _refused(lambda: cls(**{name: v}), f"{cls.__name__}.{name}")


@pytest.mark.parametrize("call, needles", [
    (lambda: TrialConfig(method=None), ("TrialConfig.method", "use a CompassConfig")),
    (lambda: TrialConfig(grasp={"enabled": False}), ("TrialConfig.grasp", "use a GraspTrialConfig")),
    (lambda: TrialConfig(time_limit_s="60"), ("TrialConfig.time_limit_s", "'60'")),
    (lambda: TrialConfig(surroundings_margin=-0.1), ("TrialConfig.surroundings_margin", "0..1 m")),
    (lambda: TrialConfig(surroundings_margin=math.nan), ("TrialConfig.surroundings_margin",)),
    (lambda: SensingConfig(frame_rate=-3.0), ("SensingConfig.frame_rate", "0..1000 Hz")),
    (lambda: SensingConfig(check_step=0.0), ("SensingConfig.check_step", "1e-4..0.5 rad")),
    (lambda: ClockConfig(measured="no"), ("ClockConfig.measured", "True or False")),
    (lambda: GraspTrialConfig(enabled=0), ("GraspTrialConfig.enabled",)),
    (lambda: GreedyIGConfig(formulation="occlusion-aware"), ("GreedyIGConfig.formulation", "'OCCLUSION_AWARE'")),
    (lambda: InspectConfig(view_distance=0.3), ("InspectConfig.view_distance", "(0.25, 0.5)")),
    (lambda: BaseLookConfig(eye=(0.25, -0.35, 0.55)), ("BaseLookConfig.eye", "nested as (2, 3)")),
    (lambda: TreeConfig(rays=(20, math.nan)), ("TreeConfig.rays",)),
    (lambda: TreeConfig(rays=(20, 15.5)), ("TreeConfig.rays", "2 whole numbers")),
    (lambda: InspectConfig(view_distance=(0.3,)), ("InspectConfig.view_distance", "2 finite numbers")),
    (lambda: NFAConfig(safe_box_min=(0.0, 0.0)), ("NFAConfig.safe_box_min", "3 finite numbers")),
    (lambda: TrialScanConfig(back_eye=((0.2, 0.3, 0.5),)), ("TrialScanConfig.back_eye", "nested as (2, 3)")),
    (lambda: CandidateConfig(depths=((0.01,),)), ("CandidateConfig.depths", "finite numbers like (0.0,)")),
    (lambda: WorldModelConfig(max_range=math.inf), ("WorldModelConfig.max_range",)),
    (lambda: GSEConfig(local_range=math.nan), ("GSEConfig.local_range",)),
    (lambda: WorldModelConfig(near_base_box=((0.0, 0.0, 0.0), (1.0, 1.0))), ("WorldModelConfig.near_base_box",)),
    (lambda: WorldModelConfig(near_base_box=((1.0, 0.0, 0.0), (0.0, 1.0, 1.0))), ("min < max",)),
    (lambda: WorldModelConfig(near_base_box="base"), ("WorldModelConfig.near_base_box",)),
])
def test_named_bad_values(call, needles):
    _refused(call, *needles)


#: (config, field, a value outside its range): resolutions, ranges, angles, margins, shares, counts
OUT_OF_RANGE = [
    (TreeConfig, "step", -0.1), (TreeConfig, "res", 0.0), (TreeConfig, "cone", 4.0), (TreeConfig, "gain_range", 1e12),
    (TreeConfig, "view_distance", (0.45, 0.2)), (TreeConfig, "ik_q7", 0), (UtilityWeights, "momentum", -0.2),
    (UtilityWeights, "cost_offset", 0.0), (WorldModelConfig, "max_range", -1.5),
    (WorldModelConfig, "obstacle_halo", 2.0),
    (WorldModelConfig, "sweep_step", 0.0), (NFAConfig, "edge_resolution", 0.0), (NFAConfig, "backoff", -0.1),
    (GreedyIGConfig, "p_unknown", 1.0), (GreedyIGConfig, "cone", -1.0), (GreedyIGConfig, "min_information", -8.0),
    (GSEConfig, "res", 1e12), (GSEConfig, "global_distance", (-0.2, 0.5)), (GSEConfig, "retry_iterations_factor", 0),
    (CompassConfig, "verify_resolution", 0.0), (CompassConfig, "max_attempts", 0), (EscapeConfig, "max_approach", -1.0),
    (FixedViewsConfig, "standoff", 1e12), (OracleConfig, "n_views", 0), (OracleConfig, "distance", (0.8, 0.25)),
    (DetectorConfig, "min_value", -0.1), (DetectorConfig, "max_depth", 0.0), (DetectorConfig, "size_slack", -0.01),
    (VerifyConfig, "max_range", 0.0), (VerifyConfig, "way_sigma", -1.0), (CandidateConfig, "line_radius", -0.004),
    (HypothesisConfig, "min_turn", -0.26), (GraspSelectConfig, "max_joint_step", 0.0),
    (GraspSelectConfig, "robot_clearance", 1e12), (CertifyConfig, "config_noise", -0.5), (CertifyConfig, "margin", 1.0),
    (CertifyConfig, "min_obstacle_removal", 1.5), (GraspExecConfig, "settle", -0.3),
    (GraspExecConfig, "hold_time", 1e12), (GraspOnlyConfig, "fine_margin", 0.0),
    (NearFieldScanConfig, "edge_step", 0.0), (NearFieldScanConfig, "max_range", -1.0),
    (NFAConfig, "scan_resolution", 0.0), (GraspExecConfig, "min_width", 1.0),
]


@pytest.mark.parametrize("cls, name, bad", OUT_OF_RANGE, ids=[f"{c.__name__}.{n}={v}" for c, n, v in OUT_OF_RANGE])
def test_a_value_outside_its_range_names_the_field_and_the_range(cls, name, bad):
    msg = _refused(lambda: cls(**{name: bad}), f"{cls.__name__}.{name} = ")
    assert ".." in msg or "<=" in msg, msg  # the allowed range is stated


@pytest.mark.parametrize("call", [
    lambda: GSEConfig(local_range=math.inf),  # its default: no limit
    lambda: DetectorConfig(confirm_completeness=None),  # `float | None`
    lambda: ConfirmConfig(accept_after_s=None),
    lambda: GraspSelectConfig(max_failed_plans=None),
    lambda: TreeConfig(iterations=np.int64(50), step=np.float32(0.1), view_distance=[0.2, 0.4]),
    lambda: ClockConfig(planning_charge_s=0),  # an int for a float field
    lambda: SensingConfig(frame_rate=0.0),  # frames only at the end of each motion, as the executor allows
    lambda: GreedyIGConfig(roi_margin=-0.05),  # a negative margin where the default is negative
    lambda: FixedViewsConfig(heights=(0.8, 0.5), lateral=(0.5,)),  # `tuple[float, ...]`: any length
    lambda: GraspSelectConfig(lift_heights=(0.05,)),
    lambda: FixedViewsConfig(heights=[0.8, 0.5], lateral=[0.0, 1.0]),  # lists (a TypeError before)
    lambda: GraspExecConfig(contact_depth=1.0, contact_force=1e9),  # never counted as a collision
    lambda: CertifyConfig(min_view_visibility=1.01),  # no view passes (tests/test_sim_certify.py)
    lambda: TreeConfig(space_margin=-0.05, cone=math.pi),
    lambda: WorldModelConfig(near_base_box=((-0.35, -0.6, 0.0), (0.75, 0.6, 1.15))),
])
def test_valid_values_are_still_accepted(call):
    call()


def test_run_trial_refuses_a_bad_spec_or_config_before_the_scene(monkeypatch):
    def no_scene(*a, **k):
        raise AssertionError("a scene was generated")

    monkeypatch.setattr(runner, "certified_scene", no_scene)
    _refused(lambda: runner.run_trial("compass L1 s0"), "spec = 'compass L1 s0'", "TrialSpec")
    _refused(lambda: runner.run_trial(runner.TrialSpec("compass", 1, 0), {"time_limit_s": 5}), "config must be a "
             "TrialConfig")


@pytest.mark.parametrize("args, needle", [
    (("teleport", 1, 0), "method 'teleport' is not registered; use one of compass"),
    (("compass", "1", 0), "level '1' is not allowed"),
    (("compass", 1, 0, 1.5), "trial 1.5 is not allowed"),
    (("compass", 1, 0, 0, -1), "seed -1 is not allowed"),
    (("compass", 1, True), "scene True is not allowed"),
])
def test_trial_spec_is_checked_when_built(args, needle):
    _refused(lambda: runner.TrialSpec(*args), needle)


def test_run_trial_refuses_a_progress_or_observer_it_cannot_call(monkeypatch):
    monkeypatch.setattr(runner, "certified_scene", lambda *a, **k: (_ for _ in ()).throw(AssertionError("scene")))
    spec = runner.TrialSpec("compass", 1, 0)
    _refused(lambda: runner.run_trial(spec, progress="yes"), "progress = 'yes'")
    _refused(lambda: runner.run_trial_full(spec, observer=object()), "observer object has no", "close")


def test_certified_scene_refuses_a_config_that_is_not_a_certify_config(monkeypatch):
    monkeypatch.setattr(certify, "regenerate", lambda *a: (_ for _ in ()).throw(AssertionError("generated")))
    _refused(lambda: certify.certified_scene(1, 0, 0, config={"max_attempts": 3}, cache=False),
             "config must be a CertifyConfig")
    _refused(lambda: certify.certified_scene(1, 0, 0, config=dataclasses.replace), "CertifyConfig")
    _refused(lambda: certify.certified_scene(1, 0, 0, cache="no"), "cache = 'no'", "True or False")
