"""What a depth image says about the surfaces it sees, for the map's surface guard
(`MapConfig.surface_guard`, applied in `integration`).

`depth_cues` gives per pixel the surface normal and sample spacing (from its neighbouring
pixels) and the shadow interval of rays that pass beside an occluding edge; `guard_patch`
marks the voxels around a hit that meet its tangent plane, so the scan does not free them.
Grid conventions as in `raycast` (grid units: x / res - k0).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Scratch marks shared with `integration`: untouched, and kept from being freed by the scan.
MARK_NONE = np.uint8(0)
MARK_GUARD = np.uint8(3)

#: The surface guard's patch: the voxels within R = 2 + floor(0.75 spacing / res) voxels of a
#: hit voxel (spacing: of the neighbouring samples on the surface; R at most this) that meet
#: the hit's tangent plane are not freed by the scan, so the patches of neighbouring hits
#: close up also where grazing incidence spreads the samples apart.
GUARD_RADIUS_MAX = 4


@njit(cache=True, inline="always")
def _cam_point(depth, u, v, fx, fy, cx, cy):
    d = depth[v, u]
    return (u - cx) / fx * d, (v - cy) / fy * d, d


@njit(cache=True)
def depth_cues(depth, fx, fy, cx, cy, R_world_cam, stride, max_jump, half_diag):
    """What the depth image says about the surface at each pixel `backproject` returns (same
    order and stride): (N, 6) columns n_x, n_y, n_z (unit normal in the world frame, sign
    arbitrary), spacing [m] of the neighbouring samples on the surface (the longer of the two
    tangents used), and the shadow interval [start, end) of ranges [m] along this pixel's ray
    where it frees nothing (start +inf: none).

    The normal comes from the measured points of the neighbouring sampled pixels: along u and
    along v the neighbour with the smaller depth step (a surface does not continue across a
    depth edge); NaN where the pixel or both neighbours on an axis are not finite depths, or
    where the smaller step exceeds max_jump [m] plus the step of a surface at 88 deg to the
    ray (30 pixel footprints). Shadows: a pixel with a neighbour farther by more than a depth
    jump (max_jump plus 10 pixel footprints, or a no-return) is an occluding edge at depth
    d_e; the object goes on, unseen, behind it. A farther pixel's ray frees nothing from
    depth d_e - half_diag [m] as long as it passes within half_diag of the edge's shadow
    (a voxel cube centred on it may reach into the shadow; `_shadow`)."""
    H, W = depth.shape
    off = stride // 2
    nu = (W - off + stride - 1) // stride
    nv = (H - off + stride - 1) // stride
    out = np.full((nu * nv, 6), np.nan)
    out[:, 4] = np.inf
    out[:, 5] = 0.0
    t = np.zeros((2, 3))  # the two tangents of the current pixel (set when its neighbour qualifies)
    for jv in range(nv):
        v = jv * stride + off
        for ju in range(nu):
            u = ju * stride + off
            d = depth[v, u]
            if not (d > 0.0 and d < np.inf):
                continue
            n = jv * nu + ju
            px, py, pz = _cam_point(depth, u, v, fx, fy, cx, cy)
            foot = d * stride / fx
            jump = max_jump + 10.0 * foot
            tol = max_jump + 30.0 * foot
            ok = True
            edge = False
            for a in range(2):
                best = np.inf
                for sgn in (-1, 1):
                    uu = u + sgn * stride * (1 - a)
                    vv = v + sgn * stride * a
                    if uu < 0 or uu >= W or vv < 0 or vv >= H:
                        continue
                    dd = depth[vv, uu]
                    if dd > d + jump:  # also +inf (no return)
                        edge = True
                    if not (dd > 0.0 and dd < np.inf) or abs(dd - d) >= best:
                        continue
                    best = abs(dd - d)
                    qx, qy, qz = _cam_point(depth, uu, vv, fx, fy, cx, cy)
                    t[a, 0] = (qx - px) * sgn
                    t[a, 1] = (qy - py) * sgn
                    t[a, 2] = (qz - pz) * sgn
                if best > tol:
                    ok = False
            if edge:
                _shadow(depth, out, u, v, d, jump, half_diag, fx, fy, cx, cy, stride, off, nu, nv)
            if not ok:
                continue
            n0 = t[0, 1] * t[1, 2] - t[0, 2] * t[1, 1]
            n1 = t[0, 2] * t[1, 0] - t[0, 0] * t[1, 2]
            n2 = t[0, 0] * t[1, 1] - t[0, 1] * t[1, 0]
            s = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
            if s == 0.0:
                continue
            for a in range(3):
                out[n, a] = (R_world_cam[a, 0] * n0 + R_world_cam[a, 1] * n1 + R_world_cam[a, 2] * n2) / s
            out[n, 3] = math.sqrt(max(t[0, 0] ** 2 + t[0, 1] ** 2 + t[0, 2] ** 2, t[1, 0] ** 2 + t[1, 1] ** 2
                                      + t[1, 2] ** 2))
    return out


@njit(cache=True, inline="always")
def _shadow(depth, out, u, v, d, jump, half_diag, fx, fy, cx, cy, stride, off, nu, nv):
    """Limit the known free space of the rays beside the occluding edge pixel (u, v) at depth
    d: a ray k sampled pixels away passes k * stride * z / fx [m] beside the edge's shadow at
    depth z, so from depth d - half_diag until that distance reaches half_diag the voxels it
    crosses may reach into the shadow."""
    k = int(math.ceil(half_diag * fx / (d * stride)))  # pixels within half_diag of the edge at depth d
    z_stop = max(d - half_diag, 0.0)
    ju0, jv0 = (u - off) // stride, (v - off) // stride
    for jv in range(max(0, jv0 - k), min(nv, jv0 + k + 1)):
        vv = jv * stride + off
        for ju in range(max(0, ju0 - k), min(nu, ju0 + k + 1)):
            uu = ju * stride + off
            dd = depth[vv, uu]
            if not dd > d + jump:
                continue
            z_resume = half_diag * fx / (stride * math.sqrt((ju - ju0) ** 2 + (jv - jv0) ** 2))
            if z_resume <= z_stop:
                continue
            xc = (uu - cx) / fx
            yc = (vv - cy) / fy
            ray = math.sqrt(xc * xc + yc * yc + 1.0)  # range [m] per metre of z-depth
            m = jv * nu + ju
            out[m, 4] = min(out[m, 4], z_stop * ray)
            out[m, 5] = max(out[m, 5], z_resume * ray)


@njit(cache=True, inline="always")
def guard_patch(mk, row_dirty, ix, iy, iz, p0, p1, p2, n0, n1, n2, R, nx, ny, nz):
    """Mark GUARD the unmarked voxels within R voxels of voxel (ix, iy, iz) whose cube meets
    the plane through p (grid units) with unit normal n: over the two axes where n is
    smaller, the few voxels along the third whose centre lies within the cube's reach."""
    ext = 0.5 * (abs(n0) + abs(n1) + abs(n2))
    i_c = (ix, iy, iz)
    p = (p0, p1, p2)
    nv = (n0, n1, n2)
    dims = (nx, ny, nz)
    a = 0  # the axis where |n| is largest
    if abs(n1) > abs(nv[a]):
        a = 1
    if abs(n2) > abs(nv[a]):
        a = 2
    b, c = (a + 1) % 3, (a + 2) % 3
    half = ext / abs(nv[a])
    # linear index strides of the axes a, b, c in the (nx, ny, nz) C-order grid
    strides = (ny * nz, nz, 1)
    for kb in range(max(0, i_c[b] - R), min(dims[b], i_c[b] + R + 1)):
        for kc in range(max(0, i_c[c] - R), min(dims[c], i_c[c] + R + 1)):
            # the plane's coordinate along axis a above the centre of cell (kb, kc)
            za = p[a] - (nv[b] * (kb + 0.5 - p[b]) + nv[c] * (kc + 0.5 - p[c])) / nv[a]
            lo = max(max(0, i_c[a] - R), int(math.ceil(za - half - 0.5)))
            hi = min(min(dims[a] - 1, i_c[a] + R), int(math.floor(za + half - 0.5)))
            base = kb * strides[b] + kc * strides[c]
            for ka in range(lo, hi + 1):
                lin = base + ka * strides[a]
                if mk[lin] == MARK_NONE:
                    mk[lin] = MARK_GUARD
                    row_dirty[lin // nz] = 1
