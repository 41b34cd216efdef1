"""A contact sheet: many RGB images (e.g. the overviews of a level's scenes) on one PNG grid."""
from __future__ import annotations

import math

import numpy as np

from ..errors import CompassInputError
from .images import save_figure


def contact_sheet(images: list[np.ndarray], titles: list[str] | None = None, columns: int = 5) -> np.ndarray:
    """The images (H, W, 3) uint8, all the same size, tiled row by row on a white grid with a
    4 px gap; titles (one per image) are drawn by `save_contact_sheet`, not here."""
    if not images:
        raise CompassInputError("contact sheet needs at least one image")
    h, w = images[0].shape[:2]
    if any(im.shape[:2] != (h, w) or im.ndim != 3 for im in images):
        raise CompassInputError("contact sheet images must all be (H, W, 3) of the same size")
    columns = max(1, min(columns, len(images)))
    rows = math.ceil(len(images) / columns)
    gap = 4
    sheet = np.full((rows * (h + gap) + gap, columns * (w + gap) + gap, 3), 255, np.uint8)
    for k, im in enumerate(images):
        r, c = divmod(k, columns)
        sheet[gap + r * (h + gap):gap + r * (h + gap) + h, gap + c * (w + gap):gap + c * (w + gap) + w] = im[..., :3]
    return sheet


def save_contact_sheet(images: list[np.ndarray], path: str, titles: list[str] | None = None, columns: int = 5,
                       title: str = "") -> None:
    """Write the contact sheet of `images` as a PNG, each tile captioned with its title."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    columns = max(1, min(columns, len(images)))
    rows = math.ceil(len(images) / columns)
    fig, axes = plt.subplots(rows, columns, figsize=(3.2 * columns, 2.6 * rows), squeeze=False)
    for k, ax in enumerate(axes.ravel()):
        ax.set_xticks([])
        ax.set_yticks([])
        if k < len(images):
            ax.imshow(images[k])
            if titles:
                ax.set_title(titles[k], fontsize=8)
        else:
            ax.axis("off")
    save_figure(fig, path, title, dpi=80)
