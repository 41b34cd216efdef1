"""PNG outputs of scenes: overview, and wrist-camera frames (RGB | depth | segmentation)."""
from __future__ import annotations

import os

import numpy as np

from ..types import Frame


def save_frame_png(frame: Frame, path: str, target_label: int | None = None, title: str = "") -> None:
    """RGB, depth [m] and segmentation side by side; the target's pixels outlined in the RGB."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [p for p in (frame.rgb, frame.depth, frame.seg) if p is not None]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.4), squeeze=False)
    axes = axes[0]
    k = 0
    if frame.rgb is not None:
        axes[k].imshow(frame.rgb)
        if target_label is not None and frame.seg is not None and np.any(frame.seg == target_label):
            axes[k].contour(frame.seg == target_label, levels=[0.5], colors="yellow", linewidths=1.2)
        axes[k].set_title("RGB")
        k += 1
    depth = np.where(np.isfinite(frame.depth) & (frame.depth > 0), frame.depth, np.nan)
    im = axes[k].imshow(depth, cmap="viridis")
    fig.colorbar(im, ax=axes[k], fraction=0.046, label="depth [m]")
    axes[k].set_title("depth (blank: no return)")
    k += 1
    if frame.seg is not None:
        axes[k].imshow(frame.seg, cmap="tab20", interpolation="nearest")
        axes[k].set_title("segmentation")
    for ax in axes:
        ax.set_xticks([])
        ax.set_yticks([])
    save_figure(fig, path, title)


def save_rgb_png(rgb: np.ndarray, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    plt.imsave(path, rgb)


def save_figure(fig, path: str, title: str = "", dpi: int = 90) -> None:
    """Title (if any), tight layout, write `path` (its folder created) and close the figure."""
    import matplotlib.pyplot as plt

    if title:
        fig.suptitle(title)
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
