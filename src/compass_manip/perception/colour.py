"""The detector's colour test: `colour_mask`, and `ColourMaskCache`, the same masks memoised
per RGB value.

The colour test of a pixel (its RGB direction against every named colour, before the
white / grey split by tint) depends on that pixel's own 8-bit RGB value only. A camera
moving through one scene sees mostly the same few thousand values frame after frame, so the
cache keeps the per-value answers in a table of 2^24 entries per colour (16 MB) and each
frame computes only the values it has not met before; the white / grey split runs on every
frame (tests/test_perception_colour.py checks the
cache's masks against `colour_mask`).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import CompassInputError
from ..task import COLOURS

_ACHROMATIC = ("white", "grey")
_UNKNOWN, _NO, _YES = 0, 1, 2


def colour_mask(rgb: np.ndarray, colour: str, config) -> np.ndarray:
    """(H, W) bool: pixels whose RGB direction is nearest the named colour's among
    `task.COLOURS` and within `config.colour_max_angle_deg` of it, at least
    `config.min_value` bright (config: a `detector.DetectorConfig`; white and grey are told
    apart by `white_grey_split`)."""
    mask = colour_direction_mask(rgb, colour, config)
    return white_grey_split(mask, rgb, colour)


def colour_direction_mask(rgb: np.ndarray, colour: str, config) -> np.ndarray:
    """`colour_mask` before the white / grey split: a function of each pixel's
    own RGB value only (so it can be cached per value, `ColourMaskCache`)."""
    if colour not in COLOURS:
        raise CompassInputError(f"colour {colour!r} is not one of {tuple(COLOURS)}")
    x = np.asarray(rgb, dtype=np.float32)[..., :3] / 255.0
    val = x.max(axis=-1)
    norm = np.linalg.norm(x, axis=-1) + 1e-9
    names = list(COLOURS)
    refs = np.array([COLOURS[n] for n in names], dtype=np.float32)
    refs /= np.linalg.norm(refs, axis=1, keepdims=True)
    cos = np.einsum("hwc,kc->hwk", x, refs) / norm[..., None]
    if colour in _ACHROMATIC:  # one achromatic class for the direction test
        cos[..., names.index("grey")] = np.maximum(cos[..., names.index("grey")], cos[..., names.index("white")])
        cos[..., names.index("white")] = cos[..., names.index("grey")]
    k = names.index(colour)
    nearest = cos.argmax(axis=-1)
    same = (nearest == k) | ((colour in _ACHROMATIC) & np.isin(nearest, [names.index(c) for c in _ACHROMATIC]))
    ang_ok = cos[..., k] >= math.cos(math.radians(config.colour_max_angle_deg))
    ok = same & ang_ok & (val >= config.min_value)
    if config.hue_check and colour in _HUE_RIVALS:
        ok &= nearest_hue(x) == _HUE_NAMES.index(colour)
    return ok


#: the chromatic colours of `task.COLOURS` told apart by hue as well (brown shares orange's
#: hue and differs in brightness and saturation; white and grey have none)
_HUE_NAMES = tuple(c for c in COLOURS if c not in _ACHROMATIC + ("brown",))
_HUE_RIVALS = frozenset(_HUE_NAMES)


def hue_deg(x: np.ndarray) -> np.ndarray:
    """Hue [deg, 0..360) of RGB values (..., 3) in [0, 1] (the HSV hexagon's angle). It
    depends only on the differences between the channels and their ratios, so it keeps
    under shading (scaling) and under a white highlight (adding the same to every channel),
    where the RGB direction turns towards white."""
    x = np.asarray(x, dtype=np.float32)[..., :3]
    r, g, b = x[..., 0], x[..., 1], x[..., 2]
    mx, mn = x.max(axis=-1), x.min(axis=-1)
    c = np.maximum(mx - mn, 1e-9)
    h = np.where(mx == r, ((g - b) / c) % 6.0, np.where(mx == g, (b - r) / c + 2.0, (r - g) / c + 4.0))
    return (60.0 * h) % 360.0


_HUE_REFS = hue_deg(np.array([COLOURS[c] for c in _HUE_NAMES], dtype=np.float32))


def nearest_hue(x: np.ndarray) -> np.ndarray:
    """Index into `_HUE_NAMES` of the reference hue nearest (around the circle) to each
    pixel's (x: (..., 3) RGB in [0, 1])."""
    d = np.abs(hue_deg(x)[..., None] - _HUE_REFS)
    return np.minimum(d, 360.0 - d).argmin(axis=-1)


def _blue_ratio(rgb) -> np.ndarray:
    """Blue over the larger of red and green, per pixel (or per reference colour)."""
    x = np.asarray(rgb, dtype=np.float32)[..., :3]
    return x[..., 2] / np.maximum(np.maximum(x[..., 0], x[..., 1]), 1e-6)


#: white and grey of `task.COLOURS` differ in tint as well as in brightness (white is warm:
#: blue 0.94 of red, grey neutral); a ratio keeps under shading, brightness does not
_TINT_WHITE, _TINT_GREY = (float(_blue_ratio(np.asarray(COLOURS[c]))) for c in _ACHROMATIC)
_TINT_SPLIT = (_TINT_WHITE + _TINT_GREY) / 2
assert _TINT_WHITE < _TINT_GREY - 0.03, "the palette's white must be warmer than its grey"


def white_grey_split(mask: np.ndarray, rgb: np.ndarray, colour: str) -> np.ndarray:
    """White and grey told apart within `mask` by tint (other colours: mask): a pixel is
    white on white's side of the midpoint between the palette's blue/red ratios (0.94 and
    1.0). Shading keeps a surface's tint but not its brightness, so a shaded white bottle is
    not grey (measured: a white bottle's pixels 0.94-0.95, a grey box's 1.000; split by
    brightness relative to the image, the bottle, the brightest achromatic thing in view,
    had passed as the grey box on level 1, scene 4, seed 2026)."""
    if colour in _ACHROMATIC and mask.any():
        warm = _blue_ratio(rgb) < _TINT_SPLIT
        mask &= warm if colour == "white" else ~warm
    return mask


class ColourMaskCache:
    """`cache(rgb, colour)` = `colour_mask(rgb, colour, config)` for (H, W, 3)
    uint8 images (other dtypes are computed directly). One cache per detector config."""

    def __init__(self, config) -> None:
        self.config = config
        self._tables: dict[str, np.ndarray] = {}

    def __call__(self, rgb: np.ndarray, colour: str) -> np.ndarray:
        rgb = np.asarray(rgb)
        if rgb.dtype != np.uint8 or rgb.ndim != 3 or rgb.shape[-1] < 3:
            return colour_mask(rgb, colour, self.config)
        table = self._tables.get(colour)
        if table is None:
            colour_direction_mask(np.zeros((1, 1, 3), np.uint8), colour, self.config)  # checks the name
            table = self._tables[colour] = np.zeros(1 << 24, dtype=np.uint8)
        key = (rgb[..., 0].astype(np.uint32) << 16) | (rgb[..., 1].astype(np.uint32) << 8) | rgb[..., 2]
        state = table[key]
        unknown = state == _UNKNOWN
        if unknown.any():
            new = np.unique(key[unknown])
            values = np.stack([new >> 16, (new >> 8) & 255, new & 255], axis=-1).astype(np.uint8)
            ok = colour_direction_mask(values[:, None, :], colour, self.config)[:, 0]
            table[new] = np.where(ok, _YES, _NO)
            state = table[key]
        return white_grey_split(state == _YES, rgb[..., :3], colour)
