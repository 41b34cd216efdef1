"""A near-field scan for the grasp-only harness: greedy views of the unknown space around the
robot's base and arm (the paper's Omega_safe), so that no unknown space near the body has to
be assumed free.

The exploration's NFA (`exploration.nfa`) moves only the wrist; the space the elbow (links
3-4) needs on its way into the cabinet lies below and beside the camera at home, and a wrist
scan from home does not see it (diagnosed in docs/grasping_log.md: the certified grasps' arm
configurations and transfers were blocked by unknown voxels 0.2-0.35 m from the base, free
in truth). Here the candidates also turn joint 1 and bend joints 2 and 4, the gain is the
exploration's own (`mapping.infogain.info_gain_batch` on the unknown voxels of the box), and
each chosen view's frame is integrated before the next choice. As with the harness's other
views, a candidate's straight way from home is checked against ground-truth contacts (the
simulator stands in for the scan's validity checks on the map).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CompassInputError, check_field_types, check_ranges
from ..exploration.nfa import safe_box_map
from ..mapping.infogain import info_gain_batch
from ..mapping.observe import integrate_observation
from ..mapping.occupancy import OccupancyMap
from ..robot.model import GRIPPER_MAX_WIDTH, Q_MAX, Q_MIN


@dataclass(frozen=True)
class NearFieldScanConfig:
    """n_candidates sampled configurations (joint 1 within +-yaw_range [rad] of home, joints
    2 and 4 moved within bend ranges [rad], joints 5-7 uniform within their limits); up to
    max_views views, stopping when the best gain falls below min_gain [voxels]; the gain
    counts unknown voxels in the box box_min..box_max [m] relative to the robot base, with
    rays (nu, nv) up to max_range [m]; edge_step [rad] of the straight way's contact check."""

    n_candidates: int = 160
    max_views: int = 24
    min_gain: int = 40
    yaw_range: float = 1.2
    bend2: tuple[float, float] = (-0.3, 0.7)
    bend4: tuple[float, float] = (-0.4, 0.7)
    box_min: tuple[float, float, float] = (-0.35, -0.6, 0.0)
    box_max: tuple[float, float, float] = (0.75, 0.6, 1.15)
    rays: tuple[int, int] = (20, 15)
    max_range: float = 1.0
    edge_step: float = 0.05

    def __post_init__(self) -> None:
        check_field_types(self, nonnegative_ints=True)
        check_ranges(self, yaw_range=(0.0, 6.3, "rad"), max_range=(0.05, 10.0, "m"), edge_step=(1e-4, 0.5, "rad"))
        if self.n_candidates < 1 or self.max_views < 0 or self.min_gain < 0:
            raise CompassInputError(f"n_candidates {self.n_candidates} / max_views {self.max_views} / min_gain "
                                    f"{self.min_gain} not allowed; use >= 1, >= 0, >= 0")
        if not np.all(np.asarray(self.box_max) > np.asarray(self.box_min)):
            raise CompassInputError(f"box_max {self.box_max} must exceed box_min {self.box_min} [m]")


#: The wider scan (docs/grasping_log.md): joint 1 within +-2.2 rad, beside and behind the base.
WIDE_SCAN = NearFieldScanConfig(n_candidates=240, max_views=32, yaw_range=2.2, box_min=(-0.5, -0.7, 0.0),
                                box_max=(0.75, 0.7, 1.2))


def scan_candidates(q_home: np.ndarray, n: int, rng: np.random.Generator, config: NearFieldScanConfig) -> np.ndarray:
    """(n, 7) configurations [rad] around home (see `NearFieldScanConfig`), within the limits."""
    Q = np.repeat(np.asarray(q_home, dtype=np.float64)[None], n, axis=0)
    Q[:, 0] += rng.uniform(-config.yaw_range, config.yaw_range, n)
    Q[:, 1] += rng.uniform(*config.bend2, n)
    Q[:, 3] += rng.uniform(*config.bend4, n)
    Q[:, 4] = rng.uniform(-2.5, 2.5, n)
    Q[:, 5] = rng.uniform(0.3, 3.6, n)
    Q[:, 6] = rng.uniform(-2.5, 2.5, n)
    return np.clip(Q, Q_MIN + 1e-3, Q_MAX - 1e-3)


def straight_free(world, q0: np.ndarray, q1: np.ndarray, step: float) -> bool:
    """No ground-truth contact along the straight joint segment q0 -> q1 (checked every step [rad])."""
    n = max(1, int(np.ceil(np.max(np.abs(q1 - q0)) / step)))
    return not any(world.in_collision(q0 + (q1 - q0) * k / n, GRIPPER_MAX_WIDTH) for k in range(n + 1))


def near_field_scan(world, occ: OccupancyMap, spheres, rng: np.random.Generator,
                    config: NearFieldScanConfig | None = None) -> tuple[list, list[np.ndarray]]:
    """Greedy near-field views from home: (frames integrated into occ, in order; the view
    configurations). Each step scores the reachable candidates by the unknown voxels of the
    box their camera would see on the map as it is then, renders the best one and
    integrates its frame into occ; a chosen candidate is not scored again."""
    config = config or NearFieldScanConfig()
    q_home = np.asarray(world.robot.q_home, dtype=np.float64)
    Q = scan_candidates(q_home, config.n_candidates, rng, config)
    Q = np.array([q for q in Q if not world.in_collision(q, GRIPPER_MAX_WIDTH)
                  and straight_free(world, q_home, q, config.edge_step)]).reshape(-1, 7)
    frames, views = [], []
    if len(Q) == 0:
        return frames, views
    T = spheres.kinematics.T_world_cam_batch(Q)
    base = np.asarray(world.robot.base_pos, dtype=np.float64)
    K = world.camera.K
    size = (world.camera.width, world.camera.height)
    left = np.ones(len(Q), dtype=bool)
    scratch = None
    for _ in range(config.max_views):
        scratch = safe_box_map(occ, base + config.box_min, base + config.box_max, scratch)
        idx = np.nonzero(left)[0]
        if len(idx) == 0:
            break
        gains = info_gain_batch(scratch, T[idx], K, config.max_range, config.rays, size)
        best = int(np.argmax(gains))
        if gains[best] < config.min_gain:
            break
        i = int(idx[best])
        left[i] = False
        frame = world.render(Q[i], rgb=False, seg=False)
        integrate_observation(occ, frame, spheres, world.camera.depth_max)
        frames.append(frame)
        views.append(Q[i])
    return frames, views
