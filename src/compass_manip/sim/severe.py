"""The hiding layout of the severe levels (2 and 4): a tall bottle behind a low, wide box.

The target is a bottle 0.215-0.235 m tall with a long, thin neck (8-9 cm, radius 1.1-1.35
cm), standing at the back of the bottom storey (`layout.draw_cabinet(rng, severe=True)`:
0.36-0.37 m clearance, a 5.5-7 cm face-frame rail under the shelf above, the opening plane
0.465-0.48 m from the base, clear of the start shell around the hand at home, so the bottle
stands 0.27-0.34 m behind it, at most 0.80 m from the base). A cereal box lying on its side (4.5-5 cm
deep, 19-24 cm wide) stands 1.5-2 cm in front of it, its top 6.7-7.5 cm below the bottle's top
and above its shoulder, so from outside the opening only the neck shows above it; the rail
and the shelf above limit how steeply an outside eye looks down behind the box: no camera
more than 10 cm in front of the opening sees >= 30 % of the bottle (`outside_views`, checked
by the certification; the thin neck and the distance behind the opening keep most candidates
below it by construction, docs/scenes.md).
The wrist camera looks down behind the box from above it. The only grasp is horizontal on
the neck (`oracle.NECK_*`), over the box: in the planner's sphere model the palm reaches
3.7 cm below the TCP and link 7 5.3 cm below it from 9.5 cm behind it, so the box's front
face stays within 10 cm of the bottle's axis and the storey leaves >= 12.5 cm above the
bottle's top for the hand, its camera and the lift. The certification keeps that grasp, its
pre-grasp and lift 1 cm clear of everything but the target (`CertifyConfig.
severe_grasp_margin`); for that room the box's top is 5 mm lower, the storey 2 cm taller and
its rail 1 cm shorter (the forearm lifts under it) and the target within 4 cm of its
compartment's centre line (the forearm passes the face frame's stiles) than before that
margin (docs/grasping.md, "The severe grasp's clearance"). The corridor of the hand (above the
box) and of the wrist and forearm (in front of it) is kept free of other objects.
"""
from __future__ import annotations

import numpy as np

from .layout import Compartment, Placer
from .objects import build_object, draw_mass
from .scenes import SceneObject

#: Target bottle: total height [m], body radius, neck radius, neck height [m], mass [kg].
TARGET_HEIGHT = (0.215, 0.235)
BODY_RADIUS = (0.03, 0.034)
NECK_RADIUS = (0.011, 0.0135)
NECK_HEIGHT = (0.08, 0.09)
TARGET_MASS = (0.08, 0.2)
#: Room above the bottle's top [m] the hand, its camera and the 4 cm lift need.
HEADROOM = 0.125
#: Occluder: its top below the bottle's top [m], gap to the bottle [m], depth and width [m].
DROP = (0.067, 0.075)
GAP = (0.015, 0.02)
OCC_DEPTH = (0.045, 0.05)
OCC_WIDTH = (0.19, 0.24)
#: The occluder's front face stays within this distance [m] of the bottle's axis (the wrist).
MAX_FRONT = 0.10
#: Farthest target centre from the base along x [m] (the neck grasp is still reached there:
#: certified), the hand corridor's half width [m] and
#: the target's largest offset from its compartment's centre line [m] (side eyes).
MAX_TARGET_X = 0.80
CORRIDOR_HALF_WIDTH = 0.095
#: The target's compartment reaches this far from the base [m] (not the part of a storey in
#: front of a back-corner compartment).
MIN_X_BACK = 0.81
MAX_Y_OFFSET = 0.04


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(rng.uniform(lo, hi))


def severe_target(rng: np.random.Generator, placer: Placer, comps: list[Compartment], colour: str,
                  occluder_colour: str, name_occluder: str) -> tuple[SceneObject, SceneObject, Compartment] | None:
    """(target, occluder, compartment) in the bottom storey, or None when it has no room."""
    pool = [c for c in comps if c.row == 0 and not c.corner and c.y_hi - c.y_lo >= OCC_WIDTH[1] + 0.03
            and c.clearance >= TARGET_HEIGHT[0] + HEADROOM and c.x_hi >= MIN_X_BACK]
    if not pool:
        return None
    c = pool[int(rng.integers(len(pool)))]
    h_t = _u(rng, TARGET_HEIGHT[0], min(TARGET_HEIGHT[1], c.clearance - HEADROOM))
    r, r_n, h_n = _u(rng, *BODY_RADIUS), _u(rng, *NECK_RADIUS), _u(rng, *NECK_HEIGHT)
    x = min(c.x_hi - r - _u(rng, 0.005, 0.02), MAX_TARGET_X)
    yc = 0.5 * (c.y_lo + c.y_hi)
    y = yc + _u(rng, -MAX_Y_OFFSET, MAX_Y_OFFSET)
    t = build_object("target", "bottle", colour, (r, h_t - h_n, r_n, h_n), _u(rng, *TARGET_MASS), x, y, c.z_floor,
                     0.0, "target")
    gap = _u(rng, *GAP)
    depth = min(_u(rng, *OCC_DEPTH), MAX_FRONT - r - gap)
    width = _u(rng, *OCC_WIDTH)
    h_o = h_t - _u(rng, *DROP)
    x_o = x - r - gap - depth / 2
    y_o = float(np.clip(y + _u(rng, -0.02, 0.02), c.y_lo + width / 2 + 0.005, c.y_hi - width / 2 - 0.005))
    if x_o - depth / 2 < c.x_lo + 0.01:
        return None
    occ = build_object(name_occluder, "cereal_box", occluder_colour, (depth, width, h_o), draw_mass("cereal_box", rng),
                       x_o, y_o, c.z_floor, 0.0, "occluder")
    placer.add(t, r)
    placer.add_box(occ)
    _keep_corridor(placer, t, occ, c)
    return t, occ, c


def _keep_corridor(placer: Placer, t: SceneObject, occ: SceneObject, c: Compartment) -> None:
    """Reserve the hand's corridor above the occluder (from the target to the opening) and the
    wrist's and forearm's in front of it (full height), as discs along -x."""
    (ox0, _, _), (_, _, oz1) = occ.aabb()
    x, y = float(t.pos[0]), float(t.pos[1])
    while x > c.x_lo - 0.05:
        z_lo = c.z_floor if x + CORRIDOR_HALF_WIDTH < ox0 - 0.01 else oz1 + 0.003
        placer.keep_out(x, y, CORRIDOR_HALF_WIDTH, z_lo, c.z_ceiling)
        x -= 0.04
    for dy in (-0.05, 0.0, 0.05):  # just in front of the occluder, the wrist reaches its top's height
        placer.keep_out(ox0 - 0.055, y + dy, 0.05, c.z_floor, c.z_ceiling)

