"""Trial functions for `compass bench --trial-fn` with the grasp stage's settings changed
(the default trial runs `TrialConfig()`): put `benchmarks/` on PYTHONPATH and pass e.g.
`--trial-fn trial_variants:grasp_map_no_near_body`. Each NAME has its config in NAME_config().

* grasp_map_no_near_body: GRASP and INSPECT on the 1 cm map of every depth frame
  (`GraspTrialConfig.grasp_map`), with no unknown space near the body taken as free
  (`near_body_free=False`), the hand checked on that map only (`fine_map=False`).
* grasp_map_fine: as grasp_map_no_near_body, and the hand's checks near the target on the
  grasp map's frames integrated again at 5 mm (`GraspTrialConfig.fine_map`).
* grasp_scan: as grasp_map_fine, with the near-field scan before INSPECT
  (`GraspTrialConfig.scan`, `trial.grasp_scan`).
* grasp_scan_via: as grasp_scan, and a path to the pre-grasp via the home posture when no
  direct one plans (`GraspTrialConfig.plan_via_home`).
* grasp_scan_more: as grasp_scan_via, with 150 candidates checked by IK instead of 60
  (measured in docs/grasping_log.md, "End to end on the grasp map").
* grasp_scan_long: as grasp_scan_more, with up to 16 scan views and INSPECT views accepted
  from 0.5 % of the hypotheses' weight (`InspectConfig.min_fraction`).
* grasp_inspect_halo: the grasp map with its fine map, 20 INSPECT views and the near-body
  assumption 8 cm from anything seen occupied.
* grasp_look: as grasp_inspect_halo, with look before moving (`GraspTrialConfig.verify`).
* grasp_look_outside: as grasp_look, unknown space outside the confined space's box (down to
  the floor) and beyond the obstacle halo trusted at execution (`VerifyConfig.trust_outside_space`).
* grasp_look_outside_long: as grasp_look_outside with up to 12 look views.
* grasp_look_assumed: the defaults with a best-effort look at the swept space the near-body
  assumption took as free (`VerifyConfig(assumed_only=True, refuse=False)`, branch e2e4).
* grasp_look_outward: as grasp_look_assumed, a third of the look directions away from the base.
* find_only: no GRASP state (the trial ends at FOUND), as `compass run --find-only`.
* find_only_hue: find_only with the detector's hue check on (`DetectorConfig.hue_check`).
* find_only_old: find_only with a match accepted from one frame however little of it shows
  (`DetectorConfig.confirm_completeness=None`, the rule until 2026-11-24's third session; the
  default since then holds a match showing < 60 % of the query TENTATIVE until a second camera
  position confirms it or 30 s pass with nothing contradicting it, `perception.confirm`).
* find_only_border075: find_only with the detector's former rule at the image border (a region
  cut by the border accepted when 75 % of the object shows).
* former_defaults: the grasp stage's defaults until 2026-11-24's second session: no near-field
  scan, the near-body volume swept with joint 1 within +-1.2 rad of home's. The variants below
  that say "the former defaults" start from it, so their records stay reproducible.
* near_yaw06: the former defaults with the near-body volume narrowed to +-0.6 rad
  (`GraspTrialConfig.near_body_yaw`), no scan.
* scan_assumed: the former defaults with the trial's near-field scan before INSPECT (8 views).
* no_scan: the former defaults (the scan off), under its earlier name.
* inspect_groups: the former defaults with up to 3 groups of INSPECT views planned per step.
* scan_yaw06: the scan and the +-0.6 rad volume together: the defaults since 2026-11-24's
  second session (`TrialConfig()`), kept so the comparison can be re-run whatever the default.
* scan_yaw09: the defaults with the near-body volume within +-0.9 rad (docs/grasping_log.md,
  "A point between on the dial").
* scan_survey: the defaults with the scan's views checked and planned with the grasp stage's own
  near-body assumption (`TrialScanConfig.assumed_free`; docs/grasping_log.md, "IG and COMPASS at GRASP").
* scan_back: the defaults with 64 scan candidates a step looking back at the elbow's band beside
  the base from in front of it (`TrialScanConfig.n_back`), valid for the method's own checker.
* insp_all: the defaults with branch insp's INSPECT features on in the trial as in the grasp-only
  harness (32 looks up a step, the escape from a start the method's checker refuses, up to 3 view
  groups planned a step; docs/grasping_log.md, "The severe levels end to end").
* insp_escape_groups: insp_all without the looks up (equal to the defaults since branch sevt).
* insp_before: the trial's INSPECT view choice before branch sevt (`escape=False, plan_groups=1`).
* insp_all_yaw12 / insp_all_noscan: insp_all with the former +-1.2 rad near-body volume and no scan /
  with no scan: branch insp's end-to-end collision reproduced / not (seed 101, level 3, scene 0).
* inspect_long: INSPECT goes on while a view sees 0.5 % of the hypotheses' weight (2 % by default).
* inspect_near: INSPECT aims first at the needed voxels within 20 cm of the detection's points' box
  (`InspectConfig.near_first`).
* base_looks: the defaults with up to 3 looks, when INSPECT ends, at its hypotheses' needed
  voxels outside the confined space (beside / in front of the base), then back the way the arm
  came (`GraspTrialConfig.looks`, `trial.grasp_looks`).
* base_looks_wide: base_looks with 300 poses a look and up to 8 IK solutions of each kept.
* base_looks_far: base_looks_wide with eye points in a larger box around the base (x -0.1..0.7,
  |y| <= 0.5, z 0.5..1.2 m), 0.25-1.2 m away.
* base_looks_way: base_looks_wide with the eye points where the camera has been (next to the way moved).
* find_only_swept3 / find_only_guard0 / find_only_no_creep_guard / find_only_anchor4: find_only with
  the world model's swept margin, creep guard or its anchor changed (`find_only_world`).
* find_only_tree_on_guard / find_only_scan_on_guard / find_only_no_self_occlusion: find_only with the
  tree or the near-field candidates on the guarded checker, or the gains through the arm's own
  body as before 2026-11-25 (`find_only_method`; docs/compass_loop.md, "The gain and the arm's own body").
* find_only_screen20 / find_only_front: find_only_unscreened with the creep guard screening the best
  nodes and near-field candidates before planning (`CompassConfig.guard_screen`), or the fallback
  gain counted in the box in front of the base (`CompassConfig.fallback_box`); both are defaults
  since 2026-11-25's second session.
* find_only_unscreened: find_only on the defaults before that (no screen, the fallback gain on all
  unknown voxels); the variants measured before it (tree_on_guard, scan_on_guard,
  no_self_occlusion) start from it, so their records stay reproducible.
* scan_self_occlusion: the defaults with the grasp stage's near-field scan's gain leaving out the rays
  the arm's own body blocks (`TrialScanConfig.self_occlusion`).
"""
from __future__ import annotations

from dataclasses import replace

from compass_manip.exploration.compass import CompassConfig
from compass_manip.grasp.select import GraspSelectConfig
from compass_manip.perception.detector import DetectorConfig
from compass_manip.trial.config import GraspTrialConfig, TrialConfig
from compass_manip.trial.grasp_scan import TrialScanConfig
from compass_manip.trial.inspect import InspectConfig
from compass_manip.trial.runner import TrialSpec, run_trial
from compass_manip.trial.verify import VerifyConfig


def _run(spec, config: TrialConfig) -> tuple[dict, dict]:
    ts = TrialSpec(method=spec.method, level=spec.level, scene=spec.scene, trial=spec.trial, seed=spec.seed)
    return config.to_dict(), run_trial(ts, config).to_dict()


def grasp_map_no_near_body_config() -> TrialConfig:
    return TrialConfig(grasp=GraspTrialConfig(scan=TrialScanConfig(max_views=0), grasp_map=True, near_body_free=False,
                                              fine_map=False))


def grasp_map_fine_config() -> TrialConfig:
    return TrialConfig(grasp=GraspTrialConfig(scan=TrialScanConfig(max_views=0), grasp_map=True, near_body_free=False,
                                              fine_map=True))


def grasp_scan_config() -> TrialConfig:
    return TrialConfig(grasp=GraspTrialConfig(grasp_map=True, near_body_free=False, fine_map=True,
                                              scan=TrialScanConfig()))


def grasp_scan_via_config() -> TrialConfig:
    return TrialConfig(grasp=GraspTrialConfig(grasp_map=True, near_body_free=False, fine_map=True,
                                              scan=TrialScanConfig(), plan_via_home=True))


def grasp_map_no_near_body(spec) -> tuple[dict, dict]:
    return _run(spec, grasp_map_no_near_body_config())


def grasp_map_fine(spec) -> tuple[dict, dict]:
    return _run(spec, grasp_map_fine_config())


def grasp_scan(spec) -> tuple[dict, dict]:
    return _run(spec, grasp_scan_config())


def grasp_scan_via(spec) -> tuple[dict, dict]:
    return _run(spec, grasp_scan_via_config())


def grasp_scan_more_config() -> TrialConfig:
    """grasp_scan_via with 150 candidates checked by IK (`GraspSelectConfig.max_checked`; the default was 60
    when this variant was measured, 400 since branch gmod, so today it checks fewer than the default)."""
    return TrialConfig(grasp=GraspTrialConfig(grasp_map=True, near_body_free=False, fine_map=True,
                                              scan=TrialScanConfig(), plan_via_home=True,
                                              select=GraspSelectConfig(max_checked=150)))


def grasp_scan_more(spec) -> tuple[dict, dict]:
    return _run(spec, grasp_scan_more_config())


def grasp_scan_long_config() -> TrialConfig:
    """grasp_scan_more with up to 16 scan views and INSPECT views taken from 0.5 % of the hypotheses' weight."""
    return TrialConfig(grasp=GraspTrialConfig(grasp_map=True, near_body_free=False, fine_map=True,
                                              scan=TrialScanConfig(max_views=16), plan_via_home=True,
                                              select=GraspSelectConfig(max_checked=150),
                                              inspect=InspectConfig(min_fraction=0.005)))


def grasp_scan_long(spec) -> tuple[dict, dict]:
    return _run(spec, grasp_scan_long_config())


def find_only_config() -> TrialConfig:
    return TrialConfig(grasp=GraspTrialConfig(enabled=False))


def find_only(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_config())


def find_only_hue_config() -> TrialConfig:
    """find_only with the detector's hue check on (`DetectorConfig.hue_check`)."""
    return TrialConfig(detector=DetectorConfig(hue_check=True), grasp=GraspTrialConfig(enabled=False))


def find_only_hue(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_hue_config())


def find_only_old_config() -> TrialConfig:
    return TrialConfig(detector=DetectorConfig(confirm_completeness=None), grasp=GraspTrialConfig(enabled=False))


def find_only_old(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_old_config())


def grasp_inspect_halo_config() -> TrialConfig:
    """The grasp map with its 5 mm fine map, up to 20 grasp-aware INSPECT views and the
    near-body assumption kept 8 cm from anything seen occupied (`near_body_halo`)."""
    return TrialConfig(grasp=GraspTrialConfig(scan=TrialScanConfig(max_views=0), near_body_yaw=1.2,
                                              grasp_map=True, fine_map=True, near_body_halo=0.08,
                                              inspect=InspectConfig(n_views=20)))


def grasp_inspect_halo(spec) -> tuple[dict, dict]:
    return _run(spec, grasp_inspect_halo_config())


def grasp_inspect_own_config() -> TrialConfig:
    """The grasp map with its 5 mm fine map and up to 20 grasp-aware INSPECT views, with no
    assumption about unknown space beyond the method's own (its swept space and start shell,
    `GraspTrialConfig.method_swept`): no near-body assumption."""
    return TrialConfig(grasp=GraspTrialConfig(scan=TrialScanConfig(max_views=0), grasp_map=True, fine_map=True,
                                              near_body_free=False,
                                              inspect=InspectConfig(n_views=20)))


def grasp_inspect_own(spec) -> tuple[dict, dict]:
    return _run(spec, grasp_inspect_own_config())


def grasp_look_config() -> TrialConfig:
    """grasp_inspect_halo, and look before moving (`GraspTrialConfig.verify`, `trial.verify`):
    the near-body assumption only chooses; the manoeuvre runs once its swept voxels are seen free."""
    return replace(grasp_inspect_halo_config(), grasp=replace(grasp_inspect_halo_config().grasp,
                                                              verify=VerifyConfig()))


def grasp_look(spec) -> tuple[dict, dict]:
    return _run(spec, grasp_look_config())


def grasp_look_outside_config() -> TrialConfig:
    """grasp_look, with unknown space outside the confined space's box (down to the floor) and
    beyond the obstacle halo trusted at execution, as the baselines move
    (`VerifyConfig.trust_outside_space`): only the rest is looked at."""
    return replace(grasp_inspect_halo_config(), grasp=replace(grasp_inspect_halo_config().grasp,
                                                              verify=VerifyConfig(trust_outside_space=True)))


def grasp_look_outside(spec) -> tuple[dict, dict]:
    return _run(spec, grasp_look_outside_config())


def grasp_look_outside_long_config() -> TrialConfig:
    """grasp_look_outside with up to 12 look views (`VerifyConfig.max_views`, default 6)."""
    return replace(grasp_inspect_halo_config(), grasp=replace(
        grasp_inspect_halo_config().grasp, verify=VerifyConfig(trust_outside_space=True, max_views=12)))


def grasp_look_outside_long(spec) -> tuple[dict, dict]:
    return _run(spec, grasp_look_outside_long_config())


def grasp_look_assumed_config() -> TrialConfig:
    """The former defaults, and a best-effort look at the space the chosen manoeuvre crosses on the
    near-body assumption before executing it (`VerifyConfig(assumed_only=True, refuse=False)`):
    a look that shows a blocker sends the stage to the next candidate; voxels no view sees are
    crossed as without looking. A look view must see at least 50 of the voxels (estimated,
    `VerifyConfig.min_seen`): on seed 101 level 3 scene 4 the first look saw 1100 of 2884, the
    next five 3-85 each."""
    return TrialConfig(grasp=replace(former_grasp(), verify=VerifyConfig(
        assumed_only=True, refuse=False, strict_first=False, min_seen=50)))


def grasp_look_outward_config() -> TrialConfig:
    """grasp_look_assumed with a third of the look directions pointing away from the base
    (`VerifyConfig.outward`): views of the space beside the body from between it and the base."""
    return TrialConfig(grasp=replace(former_grasp(), verify=VerifyConfig(
        assumed_only=True, refuse=False, strict_first=False, min_seen=50, outward=True)))


def grasp_look_outward(spec) -> tuple[dict, dict]:
    return _run(spec, grasp_look_outward_config())


def grasp_look_assumed(spec) -> tuple[dict, dict]:
    return _run(spec, grasp_look_assumed_config())


def former_grasp() -> GraspTrialConfig:
    """The grasp stage's defaults until 2026-11-24's second session: scan off, near-body yaw 1.2 rad."""
    return replace(GraspTrialConfig(), scan=TrialScanConfig(max_views=0), near_body_yaw=1.2)


def former_defaults_config() -> TrialConfig:
    return TrialConfig(grasp=former_grasp())


def former_defaults(spec) -> tuple[dict, dict]:
    return _run(spec, former_defaults_config())


def near_yaw06_config() -> TrialConfig:
    """The former defaults with the near-body assumption's joint-1 range narrowed to +-0.6 rad."""
    return TrialConfig(grasp=replace(former_grasp(), near_body_yaw=0.6))


def near_yaw06(spec) -> tuple[dict, dict]:
    return _run(spec, near_yaw06_config())


def scan_assumed_config() -> TrialConfig:
    """The former defaults (the near-body assumption included) with the trial's near-field scan first
    (`TrialScanConfig()`, up to 8 views of the unknown box around the base): what the scan sees
    occupied, the assumption (kept near_body_halo away) no longer takes as free."""
    return TrialConfig(grasp=replace(former_grasp(), scan=TrialScanConfig()))


def scan_assumed(spec) -> tuple[dict, dict]:
    return _run(spec, scan_assumed_config())


def inspect_groups_config() -> TrialConfig:
    """The former defaults with INSPECT trying up to 3 groups of views per step (`InspectConfig.plan_groups`)."""
    g = former_grasp()
    return TrialConfig(grasp=replace(g, inspect=replace(g.inspect, plan_groups=3)))


def inspect_groups(spec) -> tuple[dict, dict]:
    return _run(spec, inspect_groups_config())


def no_scan_config() -> TrialConfig:
    """The former defaults (the scan off), under its earlier name."""
    return former_defaults_config()


def no_scan(spec) -> tuple[dict, dict]:
    return _run(spec, no_scan_config())


def scan_yaw06_config() -> TrialConfig:
    """The trial's near-field scan (`scan_assumed`) with the near-body assumption's joint-1 range
    narrowed to +-0.6 rad (`near_yaw06`): the scan sees more, the assumption takes less. The
    defaults since 2026-11-24's second session."""
    return TrialConfig(grasp=replace(former_grasp(), scan=TrialScanConfig(), near_body_yaw=0.6))


def scan_yaw06(spec) -> tuple[dict, dict]:
    return _run(spec, scan_yaw06_config())


def find_only_border075_config() -> TrialConfig:
    """find_only with the detector's former rule at the image border: a region cut by the border
    is accepted when 75 % of the query's height and width show (`DetectorConfig.border_completeness`,
    None by default since 2026-11-24: never accepted there)."""
    return replace(find_only_config(), detector=DetectorConfig(border_completeness=0.75, confirm_completeness=None))


def find_only_border075(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_border075_config())


def scan_yaw09_config() -> TrialConfig:
    """The defaults with the near-body volume swept with joint 1 within +-0.9 rad of home's (0.6 by
    default): a point between the defaults and the former 1.2 rad on the grasps / collisions dial."""
    return TrialConfig(grasp=replace(GraspTrialConfig(), near_body_yaw=0.9))


def scan_yaw09(spec) -> tuple[dict, dict]:
    return _run(spec, scan_yaw09_config())


def scan_survey_config() -> TrialConfig:
    """The defaults with the near-field scan's views checked and planned with the GRASP stage's own
    near-body assumption (`TrialScanConfig.assumed_free`, `grasp_scan.survey_checker`): the scan's
    arm may stand where the grasp's arm would go, and looks beside and in front of the base."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, scan=replace(g.scan, assumed_free=True)))


def scan_survey(spec) -> tuple[dict, dict]:
    return _run(spec, scan_survey_config())


def scan_back_config() -> TrialConfig:
    """The defaults with 64 scan candidates a step that look back at the elbow's band beside the
    base from in front of it (`TrialScanConfig.n_back`), valid for the method's own checker."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, scan=replace(g.scan, n_back=64)))


def scan_back(spec) -> tuple[dict, dict]:
    return _run(spec, scan_back_config())


def scan_back_via_config() -> TrialConfig:
    """scan_back, and a path to the pre-grasp via the home posture when none plans directly
    (`GraspTrialConfig.plan_via_home`): a look-back view leaves the arm folded towards the base."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, scan=replace(g.scan, n_back=64), plan_via_home=True))


def scan_back_via(spec) -> tuple[dict, dict]:
    return _run(spec, scan_back_via_config())


def scan_back_return_config() -> TrialConfig:
    """scan_back, and the arm back along the scan's own paths to where the scan started before
    INSPECT and GRASP (`TrialScanConfig.return_back`)."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, scan=replace(g.scan, n_back=64, return_back=True)))


def scan_back_return(spec) -> tuple[dict, dict]:
    return _run(spec, scan_back_return_config())


def insp_all_config() -> TrialConfig:
    """The defaults with branch insp's INSPECT features on in the trial, as in the grasp-only harness:
    32 looks up a step (`InspectConfig.n_up`), the escape from a start invalid for the method's
    checker (`escape`) and up to 3 view groups planned a step (`plan_groups`)."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, inspect=replace(g.inspect, n_up=32, escape=True, plan_groups=3)))


def insp_all(spec) -> tuple[dict, dict]:
    return _run(spec, insp_all_config())


def insp_escape_groups_config() -> TrialConfig:
    """The defaults with INSPECT's escape and up to 3 view groups a step, no looks up."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, inspect=replace(g.inspect, escape=True, plan_groups=3)))


def insp_escape_groups(spec) -> tuple[dict, dict]:
    return _run(spec, insp_escape_groups_config())


def inspect_long_config() -> TrialConfig:
    """The defaults with INSPECT going on while a view sees at least 0.5 % of the hypotheses' weight
    (`InspectConfig.min_fraction`, 2 % by default): on the severe levels the hypotheses need thousands
    of voxels of the arm's space in front of the cabinet, and the best view toward the target sees
    1-2 % of that weight, so INSPECT stopped before looking at the hand's way in over the box."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, inspect=replace(g.inspect, min_fraction=0.005)))


def inspect_long(spec) -> tuple[dict, dict]:
    return _run(spec, inspect_long_config())


def inspect_near_config() -> TrialConfig:
    """The defaults with INSPECT's views aimed first at the needed voxels within 20 cm of the detection's
    points' box (`InspectConfig.near_first`): the hand's way in over the severe levels' box, which the
    trial's map leaves unknown while the arm's space in front of the cabinet dominates the hypotheses'
    needed voxels (docs/grasping_log.md, "The severe levels end to end")."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, inspect=replace(g.inspect, near_first=0.2)))


def inspect_near(spec) -> tuple[dict, dict]:
    return _run(spec, inspect_near_config())


def insp_all_yaw12_config() -> TrialConfig:
    """insp_all with the former wide near-body volume (joint 1 within +-1.2 rad of home's) and no scan: the
    configuration in which branch insp saw the looks up run link 4 into an unseen base wall (seed 101,
    level 3, scene 0), to tell whether the narrow volume of today's defaults is what prevents it."""
    g = former_grasp()
    return TrialConfig(grasp=replace(g, inspect=replace(g.inspect, n_up=32, escape=True, plan_groups=3)))


def insp_all_yaw12(spec) -> tuple[dict, dict]:
    return _run(spec, insp_all_yaw12_config())


def insp_all_noscan_config() -> TrialConfig:
    """insp_all without the near-field scan (the near-body volume at today's +-0.6 rad): with insp_all_yaw12,
    tells which of the two changes since branch insp keeps the looks up off the base wall."""
    g = replace(GraspTrialConfig(), scan=TrialScanConfig(max_views=0))
    return TrialConfig(grasp=replace(g, inspect=replace(g.inspect, n_up=32, escape=True, plan_groups=3)))


def insp_all_noscan(spec) -> tuple[dict, dict]:
    return _run(spec, insp_all_noscan_config())


def insp_before_config() -> TrialConfig:
    """The defaults with INSPECT's view choice before branch sevt (no escape, one planner call a step:
    `escape=False, plan_groups=1`; no looks up), the trial's defaults until 2026-11-24's fourth session."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, inspect=replace(g.inspect, n_up=0, escape=False, plan_groups=1)))


def insp_before(spec) -> tuple[dict, dict]:
    return _run(spec, insp_before_config())


def base_looks_config() -> TrialConfig:
    """The defaults with up to 3 looks at INSPECT's hypotheses' needed voxels outside the confined
    space when INSPECT ends, then back the way the arm came (`GraspTrialConfig.looks`)."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, looks=replace(g.looks, max_looks=3)))


def base_looks(spec) -> tuple[dict, dict]:
    return _run(spec, base_looks_config())


def base_looks_wide_config() -> TrialConfig:
    """base_looks with 300 camera poses a look and every IK solution of each kept (up to 8)."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, looks=replace(g.looks, max_looks=3, n_poses=300, n_solutions=8)))


def base_looks_wide(spec) -> tuple[dict, dict]:
    return _run(spec, base_looks_wide_config())


def base_looks_far_config() -> TrialConfig:
    """base_looks_wide with eye points anywhere within x -0.1..0.7, |y| <= 0.5, z 0.5..1.2 m of the
    base, 0.25-1.2 m from the voxel looked at."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, looks=replace(g.looks, max_looks=3, n_poses=300, n_solutions=8,
                                                      eye=((-0.1, -0.5, 0.5), (0.7, 0.5, 1.2)), distance=(0.25, 1.2))))


def base_looks_far(spec) -> tuple[dict, dict]:
    return _run(spec, base_looks_far_config())


def base_looks_way_config() -> TrialConfig:
    """base_looks_wide with the eye points where the camera has been (next to the executed way)."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, looks=replace(g.looks, max_looks=3, n_poses=300, n_solutions=8,
                                                      eye_from_way=True)))


def base_looks_way(spec) -> tuple[dict, dict]:
    return _run(spec, base_looks_way_config())


def scan_back16_config() -> TrialConfig:
    """scan_back_return with up to 16 scan views instead of 8."""
    g = GraspTrialConfig()
    return TrialConfig(grasp=replace(g, scan=replace(g.scan, n_back=64, return_back=True, max_views=16)))


def scan_back16(spec) -> tuple[dict, dict]:
    return _run(spec, scan_back16_config())


def find_only_world(**changes) -> TrialConfig:
    """find-only COMPASS with these `WorldModelConfig` fields changed."""
    c = CompassConfig()
    return TrialConfig(method=replace(c, world=replace(c.world, **changes)), grasp=GraspTrialConfig(enabled=False))


def find_only_swept3_config() -> TrialConfig:
    """find-only with the world model's swept-space margin 3 cm instead of 5 cm
    (`WorldModelConfig.swept_margin`; docs/compass_loop.md, "Three grazing contacts")."""
    return find_only_world(swept_margin=0.03)


def find_only_swept3(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_swept3_config())


def find_only_guard0_config() -> TrialConfig:
    """find-only with the pure creep guard: no unknown voxel next to seen free space may be
    covered either (`WorldModelConfig.creep_anchor` 0; docs/compass_loop.md, "The creep guard")."""
    return find_only_world(creep_anchor=0.0)


def find_only_guard0(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_guard0_config())


def find_only_no_creep_guard_config() -> TrialConfig:
    """find-only without the creep guard (`WorldModelConfig.creep_guard`), as before 2026-11-24."""
    return find_only_world(creep_guard=False)


def find_only_no_creep_guard(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_no_creep_guard_config())


def find_only_anchor4_config() -> TrialConfig:
    """find-only with the creep guard's anchor at 4 cm instead of 2 cm (`WorldModelConfig.creep_anchor`:
    unknown voxels up to two voxels from seen free space may be covered)."""
    return find_only_world(creep_anchor=0.04)


def find_only_anchor4(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_anchor4_config())


def find_only_method(**changes) -> TrialConfig:
    """find-only COMPASS with these `CompassConfig` fields changed."""
    return TrialConfig(method=replace(CompassConfig(), **changes), grasp=GraspTrialConfig(enabled=False))


def find_only_unscreened_method(**changes) -> TrialConfig:
    """find_only_method on the defaults before 2026-11-25's second session: no guard screen, the
    fallback gain on all unknown voxels (the variants measured then keep their records)."""
    return find_only_method(**{"guard_screen": 0, "fallback_box": None, **changes})


def find_only_unscreened_config() -> TrialConfig:
    """find-only on the defaults before the guard screen and the fallback box were adopted."""
    return find_only_unscreened_method()


def find_only_unscreened(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_unscreened_config())


def find_only_tree_on_guard_config() -> TrialConfig:
    """find-only with the viewpoint tree grown on the guarded checker (`CompassConfig.tree_on_guard`;
    docs/compass_loop.md, "The gain and the arm's own body")."""
    return find_only_unscreened_method(tree_on_guard=True)


def find_only_tree_on_guard(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_tree_on_guard_config())


def find_only_scan_on_guard_config() -> TrialConfig:
    """find-only with the near-field candidates pulled back on the guarded checker
    (`CompassConfig.scan_on_guard`)."""
    return find_only_unscreened_method(scan_on_guard=True)


def find_only_scan_on_guard(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_scan_on_guard_config())


def find_only_no_self_occlusion_config() -> TrialConfig:
    """find-only with the gains counting the rays the arm's own body blocks, as before 2026-11-25
    (`TreeConfig.self_occlusion`, `NFAConfig.self_occlusion`)."""
    c = CompassConfig()
    return find_only_unscreened_method(tree=replace(c.tree, self_occlusion=False),
                                       nfa=replace(c.nfa, self_occlusion=False))


def find_only_no_self_occlusion(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_no_self_occlusion_config())


def scan_self_occlusion_config() -> TrialConfig:
    """The defaults with the grasp stage's near-field scan scoring its candidates without the rays
    the arm's own body blocks (`TrialScanConfig.self_occlusion`)."""
    t = TrialConfig()
    return replace(t, grasp=replace(t.grasp, scan=replace(t.grasp.scan, self_occlusion=True)))


def scan_self_occlusion(spec) -> tuple[dict, dict]:
    return _run(spec, scan_self_occlusion_config())


def find_only_screen20_config() -> TrialConfig:
    """find-only with up to 20 of the best nodes screened against the creep guard before planning
    (`CompassConfig.guard_screen`)."""
    return find_only_unscreened_method(guard_screen=20)


def find_only_screen20(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_screen20_config())


def find_only_front_config() -> TrialConfig:
    """find-only with the fallback gain (no gain in the confined space from the tree) counted in the box
    in front of the base, x 0..1.2 m, |y| <= 0.6 m, z 0..1.15 m from the base (`CompassConfig.fallback_box`),
    instead of on all unknown voxels."""
    return find_only_unscreened_method(fallback_box=((0.0, -0.6, 0.0), (1.2, 0.6, 1.15)))


def find_only_front(spec) -> tuple[dict, dict]:
    return _run(spec, find_only_front_config())
