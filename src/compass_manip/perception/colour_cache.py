"""`detector.colour_mask` memoised per RGB value.

The colour test of a pixel (its RGB direction against every named colour, before the
white / grey brightness split) depends on that pixel's own 8-bit RGB value only. A camera
moving through one scene sees mostly the same few thousand values frame after frame, so the
per-value answers are kept in a table of 2^24 entries per colour (16 MB) and each frame
computes only the values it has not met before; the brightness split, which depends on the
whole image, runs on every frame as before. The masks are those of `colour_mask`
(tests/test_perception_colour_cache.py).
"""
from __future__ import annotations

import numpy as np

_UNKNOWN, _NO, _YES = 0, 1, 2


class ColourMaskCache:
    """`cache(rgb, colour)` = `detector.colour_mask(rgb, colour, config)` for (H, W, 3)
    uint8 images (other dtypes are computed directly). One cache per detector config."""

    def __init__(self, config) -> None:
        self.config = config
        self._tables: dict[str, np.ndarray] = {}

    def __call__(self, rgb: np.ndarray, colour: str) -> np.ndarray:
        from .detector import brightness_split, colour_direction_mask, colour_mask

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
        return brightness_split(state == _YES, rgb[..., :3], colour)
