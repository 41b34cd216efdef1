"""PNG outputs of a trial: the executed camera path over the scene, the explored curve."""
from __future__ import annotations

import numpy as np

from ..viz.images import save_figure


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_camera_path_png(scene, overview_rgb: np.ndarray, camera_path: np.ndarray, path: str, title: str = "") -> None:
    """Overview render beside top (x-y) and side (x-z) views of every primitive's footprint
    with the executed camera positions (start green, end red) and the target (red box)."""
    plt = _plt()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), gridspec_kw={"width_ratios": [1.3, 1, 1]})
    axes[0].imshow(overview_rgb)
    axes[0].set_axis_off()
    axes[0].set_title("scene at the end of the trial")
    prims = scene.all_primitives()
    for ax, (a, b), names in ((axes[1], (0, 1), ("x [m]", "y [m]")), (axes[2], (0, 2), ("x [m]", "z [m]"))):
        for p in prims:
            lo, hi = p.aabb()
            is_t = p.name == scene.target.name
            ax.add_patch(plt.Rectangle((lo[a], lo[b]), hi[a] - lo[a], hi[b] - lo[b], fill=is_t,
                                       fc="red" if is_t else "none", ec="red" if is_t else "0.5", lw=0.8,
                                       alpha=0.9 if is_t else 0.6))
        cp = np.asarray(camera_path).reshape(-1, 3)
        if len(cp):
            ax.plot(cp[:, a], cp[:, b], "-", color="tab:blue", lw=1.0, marker=".", ms=3)
            ax.plot(cp[0, a], cp[0, b], "o", color="green", ms=7)
            ax.plot(cp[-1, a], cp[-1, b], "s", color="red", ms=7)
        ax.set_xlabel(names[0])
        ax.set_ylabel(names[1])
        ax.set_aspect("equal")
        ax.autoscale_view()
    axes[1].set_title("camera path, top view")
    axes[2].set_title("camera path, side view")
    save_figure(fig, path, title)


def save_explored_png(curve, path: str, t_found: float | None, limit: float, title: str = "") -> None:
    """Explored fraction of the target's surroundings over simulated time."""
    plt = _plt()
    c = np.asarray(curve, float).reshape(-1, 2)
    fig, ax = plt.subplots(figsize=(6, 3.6))
    ax.step(c[:, 0], c[:, 1], where="post", color="tab:blue")
    if t_found is not None:
        ax.axvline(t_found, color="green", ls="--", label=f"found at {t_found:.1f} s")
        ax.legend(loc="lower right")
    ax.set(xlabel="simulated time [s]", ylabel="known fraction", ylim=(0, 1.02),
           xlim=(0, max(limit if t_found is None else t_found * 1.05, 1.0)),
           title=title or "explored fraction of the target's surroundings")
    save_figure(fig, path)
