"""The memoised colour mask equals `colour_mask` on rendered and random images."""
import numpy as np
import pytest

from compass_manip.errors import CompassInputError
from compass_manip.perception.colour import ColourMaskCache
from compass_manip.perception.detector import DetectorConfig, colour_mask
from compass_manip.robot.model import Q_HOME
from compass_manip.sim.certify import certified_scene
from compass_manip.sim.world import World
from compass_manip.task import COLOURS


def test_cached_mask_equals_colour_mask():
    config = DetectorConfig()
    cache = ColourMaskCache(config)
    rng = np.random.default_rng(0)
    w = World(certified_scene(4, 0, 0).scene)
    lo, hi = w.model.jnt_range[:7, 0], w.model.jnt_range[:7, 1]
    try:
        images = [w.render(np.clip(Q_HOME + rng.normal(0.0, 0.3, 7), lo, hi)).rgb for _ in range(4)]
    finally:
        w.close()
    images.append(rng.integers(0, 256, (60, 80, 3), dtype=np.uint8))
    # pure and shaded named colours, greys of every brightness
    ref = np.array([COLOURS[c] for c in COLOURS], dtype=np.float64)
    shades = (ref[:, None, :] * np.linspace(0.05, 1.0, 40)[None, :, None] * 255).astype(np.uint8)
    images.append(shades)
    images.append(np.repeat(np.arange(256, dtype=np.uint8)[None, :, None], 3, axis=2))
    hits = 0
    for colour in COLOURS:
        for img in images + images[:2]:  # the second pass reads the cache
            want = colour_mask(img, colour, config)
            assert np.array_equal(cache(img, colour), want)
            hits += int(want.sum())
    assert hits > 1000  # the images hold pixels of the colours
    with pytest.raises(CompassInputError, match="colour"):
        cache(images[0], "mauve")


def test_white_and_grey_are_told_apart_by_tint_under_any_shading():
    """A white surface in shade next to a brightly lit grey one: each keeps its name (by
    brightness the white one, darker here, was called grey)."""
    config = DetectorConfig()
    white, grey = np.asarray(COLOURS["white"]), np.asarray(COLOURS["grey"])
    img = np.zeros((2, 12, 3), np.uint8)
    for k, s in enumerate(np.linspace(0.15, 1.0, 12)):
        img[0, k] = np.round(white * s * 255)
        img[1, k] = np.round(np.minimum(grey * (1.6 - s * 0.5), 1.0) * 255)
    for colour, row in (("white", 0), ("grey", 1)):
        m = colour_mask(img, colour, config)
        assert m[row].all() and not m[1 - row].any(), (colour, m)
    # the memoised path gives the same masks
    cache = ColourMaskCache(config)
    for colour in ("white", "grey"):
        assert np.array_equal(cache(img, colour), colour_mask(img, colour, config))


def test_white_grey_split_on_the_masks_pixels_equals_the_whole_image_rule():
    from compass_manip.perception.colour import _TINT_SPLIT, _blue_ratio, white_grey_split

    rng = np.random.default_rng(3)
    img = rng.integers(0, 256, (50, 70, 3), dtype=np.uint8)
    img[:10] = (np.asarray(COLOURS["white"]) * 200).astype(np.uint8)  # warm and neutral achromatic rows
    img[10:20] = (np.asarray(COLOURS["grey"]) * 250).astype(np.uint8)
    for colour in ("white", "grey", "red"):
        mask = rng.random((50, 70)) < 0.5
        warm = _blue_ratio(img) < _TINT_SPLIT  # the rule on the whole image, as it was computed
        want = mask & ((warm if colour == "white" else ~warm) if colour in ("white", "grey") else True)
        got = white_grey_split(mask.copy(), img, colour)
        assert np.array_equal(got, want) and 0 < got.sum() < mask.sum() + (colour == "red")
