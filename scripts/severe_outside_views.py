"""How much of a severe target (levels 2 and 4 of the default set, seed 0) camera poses more
than 10 cm outside the opening see: poses drawn as the certification's view search draws
them (`sim.view_search.sample_view_poses`, 160 per scene, `default_rng(scene index)`),
reachability ignored, coarse visibility (every third pixel). Ground truth: a measurement for
docs/scenes.md, not part of any method. Run: `python scripts/severe_outside_views.py`."""
import numpy as np
from compass_manip.sim.certify import certified_scene, CertifyConfig
from compass_manip.sim.world import World
from compass_manip.sim.view_search import sample_view_poses
cfg = CertifyConfig()
for lv in (2, 4):
    res = []
    for i in range(20):
        scene = certified_scene(lv, i, 0).scene
        w = World(scene)
        x_front = scene.cabinet.opening()[0][0]
        poses = sample_view_poses(scene, 160, np.random.default_rng(i))
        out = [T for T in poses if T[0, 3] < x_front - 0.10]
        vis = [w.visibility_from(T, stride=3, with_robot=False) for T in out]
        best = max(vis) if vis else 0.0
        res.append((len(out), round(best, 2), sum(v >= 0.3 for v in vis)))
        w.close()
    print(lv, res)
    print(lv, "scenes with an outside (>10 cm) sampled view seeing >= 0.3 (coarse):", sum(r[2] > 0 for r in res), "/ 20")
