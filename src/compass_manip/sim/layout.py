"""Cabinet layouts and object placement for the scene generator.

`draw_cabinet(rng)` draws a cabinet or shelving unit: 1-3 shelves (clearance 0.20-0.35 m),
a face frame, optional vertical partitions and an optional back-corner compartment.
`Compartment` is a free box standing on a support surface; `Placer` places objects in
compartments without overlaps (footprints as circles, with a gap).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .scenes import BOARD_THICKNESS, CabinetSpec, Primitive, SceneObject

T = BOARD_THICKNESS


@dataclass(frozen=True)
class Compartment:
    """A free box [m] on a support surface at z_floor, with room up to z_ceiling. corner:
    True for a back-corner compartment (closed by a front lip of height lip_z [m])."""

    x_lo: float
    x_hi: float
    y_lo: float
    y_hi: float
    z_floor: float
    z_ceiling: float
    row: int
    corner: bool = False
    lip_z: float = 0.0

    @property
    def clearance(self) -> float:
        return self.z_ceiling - self.z_floor


def _u(rng, lo, hi) -> float:
    return float(rng.uniform(lo, hi))


#: Severe levels' bottom storey (`draw_cabinet(rng, severe=True)`): clearance [m] (room for a
#: tall target and the hand lifting it near its top), floor height [m] (the storey stays below
#: the start camera's view), least depth of the interior's back wall from the base [m] (the
#: target stands deep) and the face-frame rail under the shelves [m]. Storey and rail leave the
#: forearm 1 cm under the rail while it lifts the target (the severe grasp margin, `certify`);
#: the rail is 1.5 cm longer than branch gsev's 4-5.5 cm: with the opening farther out, below,
#: a shorter rail let outside eyes see 0.31-0.36 of the bottle in most candidates.
SEVERE_CLEARANCE = (0.36, 0.37)
SEVERE_Z_BOTTOM = (0.26, 0.30)
SEVERE_MIN_X_BACK = 0.82
SEVERE_RAIL = (0.055, 0.07)
#: Severe levels' opening plane [m] from the base: the face frame (its front face 2 cm before
#: the plane) stays 6.7 cm from the fingers at home, which stand at the height of the bottom
#: storey's top (0.61-0.65 m): the start shell a method assumes free (`home_clearance`, the
#: certification's gate). At 0.40-0.42 m (before) the rail stood 0.5-2 cm from them in every
#: candidate. The target at the back stands 0.30-0.34 m behind the opening, so an eye outside
#: it looks down behind the occluder steeply enough only close to it (docs/scenes.md, "The
#: outside-view check").
SEVERE_X_FRONT = (0.465, 0.48)


def draw_cabinet(rng: np.random.Generator, severe: bool = False) -> tuple[CabinetSpec, list[Compartment]]:
    """A cabinet and its compartments (bottom row first). severe: the bottom storey is
    SEVERE_CLEARANCE tall at SEVERE_Z_BOTTOM, the opening plane stands at SEVERE_X_FRONT, the
    interior reaches SEVERE_MIN_X_BACK and the shelves carry a face-frame rail (extra draws only then: other levels draw as before)."""
    n_shelves = int(rng.integers(1, 4))
    clear = [_u(rng, 0.20, 0.35) for _ in range(n_shelves + 1)]
    if severe:
        clear[0] = _u(rng, *SEVERE_CLEARANCE)
    total = sum(clear) + n_shelves * T
    z_bottom = _u(rng, 0.26, float(np.clip(1.30 - total, 0.27, 0.40)))
    x_front, depth = _u(rng, 0.40, 0.47), _u(rng, 0.30, 0.38)
    rail = 0.0
    if severe:
        z_bottom = _u(rng, *SEVERE_Z_BOTTOM)
        x_front = _u(rng, *SEVERE_X_FRONT)
        depth = _u(rng, max(0.30, SEVERE_MIN_X_BACK - x_front), 0.38)
        rail = _u(rng, *SEVERE_RAIL)
    width, yc = _u(rng, 0.56, 0.80), _u(rng, -0.05, 0.05)
    lo = (x_front, yc - width / 2, z_bottom)
    hi = (x_front + depth, yc + width / 2, z_bottom + total)
    shelves, z = [], z_bottom
    for c in clear[:-1]:
        z += c + T
        shelves.append(z)
    frame = (_u(rng, 0.02, 0.08), _u(rng, 0.02, 0.08), _u(rng, 0.02, 0.06),
             _u(rng, 0.0, 0.03) if rng.random() < 0.6 else 0.0)
    rows = [(z_bottom, shelves[0] - T if shelves else hi[2])]
    for i, zs in enumerate(shelves):
        rows.append((zs, shelves[i + 1] - T if i + 1 < len(shelves) else hi[2]))
    inner: list[Primitive] = []
    comps: list[Compartment] = []
    part_row = int(rng.integers(len(rows))) if rng.random() < 0.6 else -1
    corner_row = int(rng.integers(len(rows))) if rng.random() < 0.5 else -1
    for r, (zf, zc) in enumerate(rows):
        y_cuts = [lo[1], hi[1]]
        if r == part_row:
            yp = _u(rng, lo[1] + 0.22, hi[1] - 0.22)
            inner.append(Primitive(f"cab_partition{r}", "box", (depth / 2, T / 2, (zc - zf) / 2),
                                   (x_front + depth / 2, yp, (zf + zc) / 2)))
            y_cuts = [lo[1], yp - T / 2, yp + T / 2, hi[1]]
        for k in range(0, len(y_cuts), 2):
            comps.append(Compartment(x_front, hi[0], y_cuts[k], y_cuts[k + 1], zf, zc, r))
        if r == corner_row:
            corner = _corner(rng, inner, comps, r, hi, zf, zc)
            if corner is not None:
                comps.append(corner)
    cab = CabinetSpec(lo, hi, frame, tuple(shelves), tuple(inner), rail=rail)
    return cab, comps


def _corner(rng, inner: list[Primitive], comps: list[Compartment], r: int, hi, zf: float, zc: float):
    """A back-corner compartment in row r: a short partition and a front lip; the row's
    compartment on that side is shortened in y so nothing is placed across its walls."""
    side = 1.0 if rng.random() < 0.5 else -1.0
    host_i = max((i for i, c in enumerate(comps) if c.row == r), key=lambda i: comps[i].y_hi * side)
    host = comps[host_i]
    w, d = _u(rng, 0.24, 0.30), _u(rng, 0.13, 0.18)
    lip = zf + _u(rng, 0.10, 0.16)
    if host.y_hi - host.y_lo < w + 0.2:
        return None
    x0 = hi[0] - d
    if side > 0:
        y_wall, y_in = host.y_hi, host.y_hi - w
    else:
        y_wall, y_in = host.y_lo, host.y_lo + w
    inner.append(Primitive(f"cab_corner{r}_side", "box", (d / 2, T / 2, (zc - zf) / 2), (x0 + d / 2, y_in, (zf + zc) / 2)))
    inner.append(Primitive(f"cab_corner{r}_lip", "box", (T / 2, w / 2, (lip - zf) / 2),
                           (x0 - T / 2, (y_wall + y_in) / 2, (zf + lip) / 2)))
    # the host compartment keeps its full depth only on the open side of the corner
    if side > 0:
        comps[host_i] = Compartment(host.x_lo, host.x_hi, host.y_lo, y_in - T / 2, zf, zc, r)
        comps.append(Compartment(host.x_lo, x0 - T, y_in - T / 2, host.y_hi, zf, zc, r))
        return Compartment(x0, hi[0], y_in + T / 2, y_wall, zf, zc, r, True, lip)
    comps[host_i] = Compartment(host.x_lo, host.x_hi, y_in + T / 2, host.y_hi, zf, zc, r)
    comps.append(Compartment(host.x_lo, x0 - T, host.y_lo, y_in + T / 2, zf, zc, r))
    return Compartment(x0, hi[0], y_wall, y_in - T / 2, zf, zc, r, True, lip)


class Placer:
    """Places objects inside compartments without overlapping (circle footprints + gap [m])."""

    def __init__(self, gap: float = 0.012):
        self.gap = gap
        self.discs: list[tuple[float, float, float, float, float]] = []  # x, y, radius, z_lo, z_hi

    def fits(self, comp: Compartment, x: float, y: float, radius: float, height: float, z: float | None = None) -> bool:
        z0 = comp.z_floor if z is None else z
        if height > comp.z_ceiling - z0 - 0.03:
            return False
        if not (comp.x_lo + radius + 0.004 <= x <= comp.x_hi - radius - 0.004
                and comp.y_lo + radius + 0.004 <= y <= comp.y_hi - radius - 0.004):
            return False
        for (ox, oy, orad, zl, zh) in self.discs:
            if zl < z0 + height and z0 < zh and np.hypot(x - ox, y - oy) < radius + orad + self.gap:
                return False
        return True

    def keep_out(self, x: float, y: float, radius: float, z_lo: float, z_hi: float) -> None:
        """Reserve a vertical cylinder [m] (e.g. the room the hand needs around a target)."""
        self.discs.append((float(x), float(y), float(radius), float(z_lo), float(z_hi)))

    def add(self, obj: SceneObject, radius: float | None = None) -> None:
        lo, hi = obj.aabb()
        c = (lo + hi) / 2
        r = radius if radius is not None else 0.5 * float(np.hypot(hi[0] - lo[0], hi[1] - lo[1]))
        self.discs.append((float(c[0]), float(c[1]), r, float(lo[2]), float(hi[2])))

    def add_box(self, obj: SceneObject) -> None:
        """Add a one-box object as discs along its longer horizontal axis (boards, books)."""
        for d in box_discs(obj):
            self.discs.append(d)


def box_discs(obj: SceneObject) -> list[tuple[float, float, float, float, float]]:
    """Discs (x, y, radius, z_lo, z_hi) [m] covering a one-box object's footprint."""
    p = obj.parts[0]
    hx, hy = p.size[0], p.size[1]
    lo, hi = obj.aabb()
    axis = np.array([np.cos(p.yaw), np.sin(p.yaw)]) if hx >= hy else np.array([-np.sin(p.yaw), np.cos(p.yaw)])
    half_long, half_short = max(hx, hy), min(hx, hy)
    r = half_short * 1.05 + 0.002
    n = max(1, int(np.ceil(half_long / half_short)))
    out = []
    for k in range(n + 1):
        off = -half_long + half_short + (2 * half_long - 2 * half_short) * (k / max(n, 1))
        c = np.array(p.pos[:2]) + off * axis
        out.append((float(c[0]), float(c[1]), float(np.hypot(r, half_long / max(n, 1))), float(lo[2]), float(hi[2])))
    return out
