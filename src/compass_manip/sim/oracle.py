"""The simulator's door to ground truth for ablations and metrics (never for methods)."""
from __future__ import annotations

# --- perception and trial oracles ---
# Segmentation-label detector (an explicitly named oracle for ablations), the truth check
# of an accepted detection, the target's surroundings box for the explored-fraction metric
# and the best view of the target (for grasp-only runs). Only trial/, bench/ and tests use
# these; methods never do.

import numpy as np

from ..perception.detector import Detection, Verdict
from ..perception.target import backproject_image, upright_extents


class OracleSegmentationDetector:
    """Detects the target from the simulator's segmentation labels (an oracle: the frames
    must carry `seg`, so the trial pushes whole frames into the buffer for it). At least
    `min_pixels` target pixels are one ACCEPTED detection."""

    def __init__(self, target_label: int, min_pixels: int = 40) -> None:
        self.target_label, self.min_pixels = int(target_label), int(min_pixels)

    def __call__(self, frame, query=None) -> tuple[Detection, ...]:
        if frame.seg is None:
            raise ValueError("the oracle detector needs frames rendered with segmentation")
        mask = (frame.seg == self.target_label) & np.isfinite(frame.depth) & (frame.depth > 0)
        if mask.sum() < self.min_pixels:
            return ()
        pts, _ = backproject_image(frame.depth, frame.K, frame.T_world_cam)
        rows, cols = np.nonzero(mask)
        P = pts[rows, cols]
        u0, u1, v0, v1 = int(cols.min()), int(cols.max()), int(rows.min()), int(rows.max())
        return (Detection(t=float(frame.t), T_world_cam=np.asarray(frame.T_world_cam), bbox=(u0, v0, u1, v1),
                          centre_px=((u0 + u1) / 2, (v0 + v1) / 2), n_pixels=int(len(rows)), points_world=P,
                          centroid_world=P.mean(axis=0), extents=upright_extents(P), shape="oracle", score=1.0,
                          verdict=Verdict.ACCEPTED),)


def detection_is_target(scene, detection: Detection, margin: float = 0.015, min_fraction: float = 0.5) -> bool:
    """Whether at least `min_fraction` of the detection's 3D points lie in the target's
    bounding box grown by `margin` [m] (ground truth)."""
    lo, hi = scene.target.aabb()
    P = np.asarray(detection.points_world, float).reshape(-1, 3)
    if len(P) == 0:
        return False
    inside = np.all((P >= lo - margin) & (P <= hi + margin), axis=1)
    return bool(inside.mean() >= min_fraction)


def target_surroundings(scene, margin: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """World box (min, max) [m]: the target's bounding box grown by `margin` [m], clipped to
    the cabinet's interior: the region whose explored fraction a trial records."""
    lo, hi = scene.target.aabb()
    ilo, ihi = np.asarray(scene.cabinet.interior_min), np.asarray(scene.cabinet.interior_max)
    return np.maximum(lo - margin, ilo), np.minimum(hi + margin, ihi)


def best_target_view(world, rng: np.random.Generator, n_samples: int = 24, distance: float = 0.35):
    """The collision-free configuration (7,) [rad] among camera IK solutions looking at the
    target from `distance` [m] that sees most of it, and that visible fraction; (None, 0.0)
    when no sampled view sees it (for grasp-only runs)."""
    from ..robot.ik import ik_look_at

    q_home = np.asarray(world.robot.q_home)
    sols = ik_look_at(np.asarray(world.scene.target.pos, float), distance, q_home, rng=rng,
                      n_samples=n_samples).solutions
    best, best_vis = None, 0.0
    for q in sols:
        if world.in_collision(q):
            continue
        vis = world.target_visibility(q, stride=2)
        if vis > best_vis:
            best, best_vis = q.copy(), vis
    world.set_q(q_home)
    return best, best_vis
