"""How much of a severe target (levels 2 and 4 of the default set, seed 0) cameras outside the
opening see. Per scene: (1) the poses more than `outside_views.AT_OPENING` (10 cm) in front of the
opening plane among those the view search draws (`sim.view_search.sample_view_poses`, 160 per
scene, `default_rng(scene index)`, reachability ignored, coarse visibility: the measurement
of the previous release), (2) the certification's dense outside-view check
(`sim.outside_views.best_outside_visibility`), (3) the certified view's camera distance in front
of the opening plane. Ground truth: a measurement for docs/scenes.md, not part of any method.
Run: `python scripts/severe_outside_views.py`."""
import numpy as np
from compass_manip.sim import outside_views
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.world import World
from compass_manip.sim.view_search import sample_view_poses

for lv in (2, 4):
    res = []
    for i in range(20):
        cs = certified_scene(lv, i, 0)
        scene = cs.scene
        w = World(scene)
        poses = sample_view_poses(scene, 160, np.random.default_rng(i))
        out = [T for T in poses if outside_views.camera_outside_m(scene, T) > outside_views.AT_OPENING]
        vis = [w.visibility_from(T, stride=3, with_robot=False) for T in out]
        dense = outside_views.best_outside_visibility(w, 0.3).best_visibility
        res.append((len(out), round(max(vis, default=0.0), 2), round(dense, 3), cs.certificate.view_camera_outside_m))
        w.close()
    print(lv, res)
    print(lv, "scenes with a sampled outside view seeing >= 0.3 (coarse):", sum(r[1] >= 0.3 for r in res), "/ 20;",
          "dense check >= 0.3:", sum(r[2] >= 0.3 for r in res), "/ 20; certified camera <= 0.10 m out:",
          sum(r[3] is not None and r[3] <= outside_views.AT_OPENING for r in res), "/ 20")
