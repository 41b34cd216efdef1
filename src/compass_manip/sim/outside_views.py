"""The outside-view check of the severe levels: no camera the Panda's wrist can hold *outside*
the opening sees enough of the target (ground truth: for certification only).

"Inside or at the opening" means the camera's optical centre lies at most AT_OPENING [m] in
front of the opening plane (x = the interior's front, `CabinetSpec.opening()`), or behind it.
Everything farther out is *outside*. `outside_view_poses` samples that outside zone densely:

* positions on a grid over the whole region in front of the opening a Panda wrist camera can
  reach: planes X_OFFSETS [m] beyond the zone's boundary (AT_OPENING + offset in front of the
  opening plane), across the opening's width plus SIDE_MARGIN [m] past each stile (eyes
  looking sideways past the stiles), and from BELOW [m] under the target storey's floor to
  ABOVE [m] over its ceiling (eyes looking steeply down under the rail), with the grid steps
  of GRID_STEP; positions farther than REACH [m] from the shoulder (0.333 m above the base)
  or below MIN_Z are dropped (a Panda's wrist cannot hold a camera there);
* orientations looking in: each position looks at each of AIM_POINTS (fractions of the
  target's height on its axis: its body, the top of its body, its top), so the target is in
  the image and near its centre, whatever the eye's elevation or side.

Visibility is the visible share of the target's unoccluded image, so from a given position
it depends on the orientation only through the image border: any orientation that keeps the
whole target in the image sees about the same share (a rotation about the optical centre
changes only how the pixels sample the target), and aiming at three points of it covers the
rest (the camera's roll does not matter either, the target fits in the image). A line of sight from an eye farther out crosses the
zone's boundary plane on its way in, so the nearest plane (offset 0) carries the best views
(in every scene measured, docs/scenes.md); the farther planes are sampled too, on a grid of
double steps.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import look_at
from .scenes import SceneSpec

#: The camera is "at the opening" when it is at most this far [m] in front of the opening plane.
AT_OPENING = 0.10
X_OFFSETS = (0.0, 0.05, 0.12, 0.22)
SIDE_MARGIN = 0.12
BELOW = 0.10
ABOVE = 0.35
GRID_STEP = (0.05, 0.04)  # across (y), up (z) [m]
REACH = 0.95
MIN_Z = 0.10
AIM_POINTS = (0.45, 0.7, 0.95)
SHOULDER_Z = 0.333


@dataclass(frozen=True, eq=False)
class OutsideViews:
    """Best visible fraction of the target over the outside sample, the pose that reached it
    (T_world_cam, 4x4) and the number of poses checked."""

    best_visibility: float
    best_pose: np.ndarray | None
    n_poses: int


def target_storey(scene: SceneSpec) -> tuple[float, float]:
    """(floor z, ceiling z) [m] of the storey the target stands in."""
    z = scene.target.aabb()[0][2]
    for zf, zc in scene.cabinet.rows():
        if zf - 1e-6 <= z <= zc:
            return zf, zc
    return scene.cabinet.interior_min[2], scene.cabinet.interior_max[2]


def outside_positions(scene: SceneSpec) -> np.ndarray:
    """(n, 3) eye positions [m] of the outside zone's grid (module doc)."""
    o_lo, o_hi = scene.cabinet.opening()
    zf, zc = target_storey(scene)
    base = np.asarray(scene.robot_base_pos, float)
    shoulder = base + np.array([0.0, 0.0, SHOULDER_Z])
    ys = np.arange(o_lo[1] - SIDE_MARGIN, o_hi[1] + SIDE_MARGIN + 1e-9, GRID_STEP[0])
    zs = np.arange(zf - BELOW, zc + ABOVE + 1e-9, GRID_STEP[1])
    out = []
    for k, off in enumerate(X_OFFSETS):
        x = o_lo[0] - AT_OPENING - off
        every = 1 if k == 0 else 2  # the farther planes on a grid of double steps
        for y in ys[::every]:
            for z in zs[::every]:
                p = np.array([x, y, z])
                if z >= MIN_Z and np.linalg.norm(p - shoulder) <= REACH:
                    out.append(p)
    return np.array(out).reshape(-1, 3)


def outside_view_poses(scene: SceneSpec) -> list[np.ndarray]:
    """Camera poses T_world_cam of the outside zone: every grid position looking at every aim
    point on the target's axis (module doc); `best_outside_visibility` searches them coarse to
    fine."""
    return [look_at(p, a) for p in outside_positions(scene) for a in _aim_points(scene)]


def best_outside_visibility(world, threshold: float, coarse_stride: int = 6, n_refine: int = 18,
                            n_exact: int = 8, margin: float = 0.1) -> OutsideViews:
    """Best visible fraction of the target (only the scene in the way) over the outside zone, coarse
    to fine: (1) every grid position (`outside_positions`) looking at the middle aim point, ray
    cast through every coarse_stride-th pixel; (2) the n_refine best positions, the best
    third of them also with their 8 neighbours half a grid step away (in y and z, still outside
    and reachable), looking at every aim point, through every third pixel; (3) exactly (every
    pixel) the n_exact best stage-2 poses within `margin` of the stage-2 best or of `threshold`.
    The value returned is exact for the pose returned; it is a lower bound of the zone's best."""
    scene = world.scene
    pos = outside_positions(scene)
    if len(pos) == 0:
        return OutsideViews(0.0, None, 0)
    aims = _aim_points(scene)
    mid = aims[len(aims) // 2]
    c1 = np.array([world.visibility_from(look_at(p, mid), stride=coarse_stride, with_robot=False) for p in pos])
    order = np.argsort(-c1, kind="stable")
    x_max = scene.cabinet.opening()[0][0] - AT_OPENING
    shoulder = np.asarray(scene.robot_base_pos, float) + np.array([0.0, 0.0, SHOULDER_Z])
    cand = []
    for rank, i in enumerate(order[:n_refine]):
        steps = (-0.5, 0.0, 0.5) if rank < n_refine // 3 else (0.0,)
        for dy in steps:
            for dz in steps:
                p = pos[i] + np.array([0.0, dy * GRID_STEP[0], dz * GRID_STEP[1]])
                if p[0] <= x_max + 1e-9 and p[2] >= MIN_Z and np.linalg.norm(p - shoulder) <= REACH:
                    cand += [look_at(p, a) for a in aims]
    c2 = np.array([world.visibility_from(T, stride=3, with_robot=False) for T in cand])
    top = np.argsort(-c2, kind="stable")
    keep = [int(i) for i in top[:n_exact] if c2[i] >= min(float(c2.max()), threshold) - margin] or [int(top[0])]
    exact = {i: world.visibility_from(cand[i], with_robot=False) for i in keep}
    i = max(exact, key=exact.get)
    return OutsideViews(float(exact[i]), cand[i], len(pos) + len(cand))


def _aim_points(scene: SceneSpec) -> list[np.ndarray]:
    lo, hi = scene.target.aabb()
    return [np.array([scene.target.pos[0], scene.target.pos[1], lo[2] + f * (hi[2] - lo[2])]) for f in AIM_POINTS]


def camera_outside_m(scene: SceneSpec, T_world_cam: np.ndarray) -> float:
    """How far [m] the camera stands in front of the opening plane (negative: inside)."""
    return float(scene.cabinet.opening()[0][0] - T_world_cam[0, 3])
