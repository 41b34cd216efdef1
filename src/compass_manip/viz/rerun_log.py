"""Rerun recordings of a trial: `RerunRecorder`, a trial observer writing an .rrd file.

Needs the optional `rerun-sdk` (the `[viz]` extra); `require_rerun()` says how to install
it. Everything is logged on the timeline `sim` (simulated seconds) under `world/` (z up):
- `world/scene`: the scene's primitives as boxes (their axis-aligned bounds; the target red), static;
- `world/robot/links` and `world/robot/skeleton`: link origins and the kinematic chain,
  `world/robot/tcp`: the TCP frame, at every camera frame;
- `world/camera`: the wrist camera's pose and pinhole, with `rgb` (JPEG) and `depth` (mm) images;
- `world/map/occupied` and `world/map/frontiers`: voxel centres at every decision (the map
  the method decided on);
- `world/tree/nodes` (coloured by utility), `world/tree/edges`, `world/tree/chosen` (the
  chosen view's optical axis) when the method exposes its tree (`Decision.debug`);
- `world/camera/detection` (the accepted box) and `world/detection` (its 3-D points);
- `world/grasp/candidates`: approach arrows of ranked grasp candidates;
- `trial/log`: states, decisions (with their stats) and the outcome as text.
Open it with `rerun trial.rrd` (the viewer ships with rerun-sdk).
"""
from __future__ import annotations

import numpy as np

from ..errors import CompassInputError
from ..mapping.frontiers import frontier_mask
from ..mapping.occupancy import VoxelState
from ..robot.kinematics import PandaKinematics
from ..trial.observer import TrialObserver
from .panels import _viridis

#: The pinned optional dependency (pyproject.toml, extra `viz`).
RERUN_REQUIREMENT = "rerun-sdk==0.41.0"


def require_rerun():
    """The `rerun` module, or a one-line CompassInputError naming the extra to install."""
    try:
        import rerun
    except ImportError as exc:
        raise CompassInputError(f"--record needs the optional rerun-sdk package; install it with "
                                f"pip install 'compass-manip[viz]' (or pip install {RERUN_REQUIREMENT})") from exc
    return rerun


class RerunRecorder(TrialObserver):
    """Writes the trial to the Rerun recording `path` (see the module docstring)."""

    def __init__(self, path: str, title: str = "trial") -> None:
        self.rr = require_rerun()
        self.path, self.title = path, title
        self.rec = self.rr.RecordingStream("compass_manip", make_default=False)
        self.rec.save(path)
        self._closed = False

    def _at(self, t: float) -> None:
        self.rec.set_time("sim", duration=float(t))

    def _text(self, t: float, text: str) -> None:
        self._at(t)
        self.rec.log("trial/log", self.rr.TextLog(text))

    # ------------------------------------------------------------------ events
    def start(self, world, method) -> None:
        rr = self.rr
        self._kin = PandaKinematics(world.robot)
        self._parent = np.asarray(self._kin.tree.parent)
        self._occ = method.occupancy
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        prims = world.scene.all_primitives()
        boxes = [p.aabb() for p in prims]
        target = {p.name for p in world.scene.target.parts}
        self.rec.log("world/scene", rr.Boxes3D(
            centers=[0.5 * (lo + hi) for lo, hi in boxes], half_sizes=[0.5 * (hi - lo) for lo, hi in boxes],
            labels=[p.name for p in prims],
            colors=[(220, 40, 40) if p.name in target else (150, 150, 150) for p in prims]), static=True)
        self._text(0.0, f"{self.title}: start")

    def state(self, t, state) -> None:
        self._text(t, f"state {state.value}")

    def frame(self, frame, method) -> None:
        rr = self.rr
        self._at(frame.t)
        links = self._kin.fk_links(np.asarray(frame.q, float))
        origins = links[:, :3, 3]
        self.rec.log("world/robot/links", rr.Points3D(origins, radii=0.01))
        chain = [[origins[p], origins[i]] for i, p in enumerate(self._parent) if p >= 0]
        self.rec.log("world/robot/skeleton", rr.LineStrips3D(chain, radii=0.006, colors=(230, 230, 230)))
        T = self._kin.T_world_tcp(np.asarray(frame.q, float))
        self.rec.log("world/robot/tcp", rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3]),
                     rr.TransformAxes3D(0.08))
        T = frame.T_world_cam
        h, w = frame.depth.shape
        self.rec.log("world/camera", rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3]),
                     rr.Pinhole(image_from_camera=frame.K, resolution=[w, h], camera_xyz=rr.ViewCoordinates.RDF))
        depth = np.where(np.isfinite(frame.depth), frame.depth, 0.0)
        self.rec.log("world/camera/depth", rr.DepthImage(np.clip(depth * 1000.0, 0, 65535).astype(np.uint16),
                                                         meter=1000.0))
        if frame.rgb is not None:
            self.rec.log("world/camera/rgb", rr.Image(frame.rgb).compress(jpeg_quality=85))

    def decision(self, t, decision, method) -> None:
        rr = self.rr
        self._at(t)
        occ = self._occ
        occupied = np.argwhere(occ.state == VoxelState.OCCUPIED)
        self.rec.log("world/map/occupied", rr.Points3D(occ.voxel_to_world(occupied), radii=occ.resolution / 2,
                                                       colors=(60, 80, 170)))
        front = np.argwhere(frontier_mask(occ.state))
        self.rec.log("world/map/frontiers", rr.Points3D(occ.voxel_to_world(front), radii=occ.resolution / 2,
                                                        colors=(255, 150, 30)))
        dbg = decision.debug or {}
        if "tree_cam_world" in dbg and "tree_utility" in dbg:
            pos, util = np.asarray(dbg["tree_cam_world"], float), np.asarray(dbg["tree_utility"], float)
            ok = np.isfinite(util)
            span = np.ptp(util[ok]) if ok.any() else 1.0
            level = np.where(ok, (util - (util[ok].min() if ok.any() else 0.0)) / (span or 1.0), 0.0)
            colors = [_viridis(a) if k else (120, 120, 120) for a, k in zip(level, ok)]
            labels = [f"U {u:.3f}" if k else "" for u, k in zip(util, ok)]
            self.rec.log("world/tree/nodes", rr.Points3D(pos, radii=0.006, colors=colors, labels=labels,
                                                         show_labels=False))
            parent = np.asarray(dbg.get("tree_parent", []), int)
            edges = [[pos[p], pos[i]] for i, p in enumerate(parent[: len(pos)]) if p >= 0]
            self.rec.log("world/tree/edges", rr.LineStrips3D(edges, radii=0.002, colors=(120, 120, 200)))
            k = dbg.get("chosen_node")
            if k is not None and "tree_view_dir" in dbg:
                axis = np.asarray(dbg["tree_view_dir"], float)[k]
                self.rec.log("world/tree/chosen", rr.Arrows3D(origins=[pos[k]], vectors=[0.15 * axis],
                                                              colors=(230, 30, 30), radii=0.008))
        stats = ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in decision.stats.items())
        what = "stop " + decision.stop.name.lower() if decision.stop is not None else "move"
        self._text(t, f"decision ({decision.phase.value}): {what}; {stats}")

    def detection(self, t, found) -> None:
        rr = self.rr
        det = found.detection
        self._at(det.t)
        self.rec.log("world/camera/detection", rr.Boxes2D(array=np.asarray(det.bbox, float),
                                                          array_format=rr.Box2DFormat.XYXY, colors=(0, 255, 0),
                                                          labels=f"target {det.score:.2f}"))
        self.rec.log("world/detection", rr.Points3D(np.asarray(det.points_world, float), radii=0.004,
                                                    colors=(0, 220, 0)))
        self._text(t, f"detection accepted (frame at {det.t:.2f} s, shape {det.shape}, score {det.score:.2f})")

    def grasp_candidates(self, t, T_world_grasp, scores) -> None:
        rr = self.rr
        T = np.asarray(T_world_grasp, float).reshape(-1, 4, 4)
        s = np.asarray(scores, float).reshape(-1)
        span = np.ptp(s) if len(s) else 1.0
        self._at(t)
        self.rec.log("world/grasp/candidates", rr.Arrows3D(
            origins=T[:, :3, 3] - 0.08 * T[:, :3, 2], vectors=0.08 * T[:, :3, 2],
            colors=[_viridis(a) for a in (s - (s.min() if len(s) else 0)) / (span or 1.0)],
            labels=[f"{v:.3f}" for v in s], show_labels=False))

    def end(self, outcome) -> None:
        verdict = "found" if outcome.failure is None else outcome.failure.name.lower()
        self._text(outcome.t_end, f"{self.title}: end, {verdict}")
        self.close()

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self.rec.flush()
            self.rec.disconnect()
