"""The shape class of an image region from its 3D points and normals: planar faces (box),
a curved side (round), a doubly curved surface (sphere); and a check that a region
called round is curved as much as the queried object would be."""
from __future__ import annotations

import numpy as np


def classify_shape(normals: np.ndarray, points: np.ndarray, cam_pos: np.ndarray,
                   config) -> str:  # config: a detector.DetectorConfig
    """'box' | 'round' | 'sphere' | 'unknown' from world normals (N, 3) of a region's
    pixels and their points (N, 3) [m] seen from cam_pos (3,) [m]."""
    if len(normals) < config.min_side_pixels:
        return "unknown"
    n = normals * np.sign(np.sum(normals * (cam_pos - points), axis=1))[:, None]  # towards the camera
    nz = np.abs(n[:, 2])
    side = nz < 0.3
    slant = (nz >= 0.3) & (nz <= 0.9)
    if slant.mean() >= config.sphere_slant_fraction:
        return "sphere"
    if side.sum() < config.min_side_pixels:
        return "unknown"
    theta = np.degrees(np.arctan2(n[side, 1], n[side, 0]))
    frac = _two_mode_fraction(theta, config.mode_halfwidth_deg)
    if frac >= config.planar_fraction_box:
        return "box"
    if frac < config.planar_fraction_round:
        return "round"
    return "unknown"


def _two_mode_fraction(theta_deg: np.ndarray, halfwidth: float) -> float:
    """Fraction of angles [deg] within +-halfwidth of the best two (circular) modes."""
    hist = np.bincount(np.floor((theta_deg + 180.0) % 360.0).astype(int), minlength=360)[:360]
    w = int(round(halfwidth))
    kernel = np.ones(2 * w + 1)
    win = np.convolve(np.concatenate([hist[-w:], hist, hist[:w]]), kernel, mode="valid")
    i1 = int(np.argmax(win))
    total = win[i1]
    h2 = hist.copy()
    idx = (np.arange(i1 - w, i1 + w + 1)) % 360
    h2[idx] = 0
    win2 = np.convolve(np.concatenate([h2[-w:], h2, h2[:w]]), kernel, mode="valid")
    total += win2.max()
    return float(total / max(len(theta_deg), 1))


def cylinder_relief(half_width: float, radius: float, n: int = 201) -> float:
    """RMS distance [m] from their best plane of points spread evenly across a chord of
    half-width `half_width` [m] (clipped to the radius) of a cylinder of `radius` [m], seen
    square on: the depth relief a curved side of that size shows."""
    a = min(max(float(half_width), 0.0), float(radius))
    x = np.linspace(-a, a, n)
    return float(np.std(np.sqrt(np.maximum(radius * radius - x * x, 0.0))))


def plane_rms(points: np.ndarray) -> float:
    """RMS distance [m] of points (N, 3) [m] from their least-squares plane."""
    P = np.asarray(points, dtype=np.float64)
    P = P[np.isfinite(P).all(axis=1)]
    if len(P) < 3:
        return 0.0
    s = np.linalg.svd(P - P.mean(axis=0), compute_uv=False)
    return float(s[-1] / np.sqrt(len(P)))


def curved_like(points: np.ndarray, radius: float, width: float, min_ratio: float) -> bool:
    """True when points (N, 3) [m] of a region `width` [m] wide deviate from their best
    plane by at least min_ratio x the relief of a cylinder of `radius` [m] over that width
    (`cylinder_relief`). Rendered depth of a can or bottle shows 0.6-2x that relief; a strip
    of a flat box face a fraction of it."""
    expected = cylinder_relief(0.5 * width, radius)
    return expected <= 1e-9 or plane_rms(points) >= min_ratio * expected
