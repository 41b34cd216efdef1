"""Panels of a trial video as uint8 RGB arrays: the external scene view, the wrist image
with a detection box, the map's top view, the caption line, and their tiling.

The map's top view looks down the world z axis over the cabinet and the robot's reach at
a horizontal slab of the map (by default 10 cm thick around the camera's height): world
+x points up the image, +y to the left (the robot's view, seen from above). Each map
column (x, y) of the slab is drawn free (white), partly unknown (grey by the unknown
fraction of the column), occupied (dark blue, any occupied voxel) or frontier (orange,
any free voxel next to unknown). The camera path so far is a blue line,
the camera now a blue dot, the tree's nodes small dots coloured by utility (low violet,
high yellow), the chosen next view a red ring with its optical axis, the accepted
detection a green cross.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ..mapping.frontiers import frontier_mask
from ..mapping.occupancy import VoxelState

BACKGROUND = (24, 24, 24)


@dataclass(frozen=True)
class TopViewRegion:
    """World box of the top view: x_min..x_max, y_min..y_max [m] drawn; z_min..z_max [m] the
    height range a slab may cover."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float
    z_min: float
    z_max: float

    @staticmethod
    def around(interior_min, interior_max, robot_base, margin: float = 0.1) -> "TopViewRegion":
        lo, hi, b = (np.asarray(v, float) for v in (interior_min, interior_max, robot_base))
        return TopViewRegion(min(lo[0], b[0]) - margin, hi[0] + margin, min(lo[1], b[1]) - margin,
                             max(hi[1], b[1]) + margin, lo[2], hi[2])


def font(size: int):
    return ImageFont.load_default(size=size)


def fit(rgb: np.ndarray, width: int, height: int) -> np.ndarray:
    """`rgb` scaled to fit width x height [px] (aspect kept), centred on a dark background."""
    img = Image.fromarray(np.ascontiguousarray(rgb[..., :3]))
    s = min(width / img.width, height / img.height)
    w, h = max(1, round(img.width * s)), max(1, round(img.height * s))
    out = Image.new("RGB", (width, height), BACKGROUND)
    out.paste(img.resize((w, h), Image.BILINEAR), ((width - w) // 2, (height - h) // 2))
    return np.asarray(out)


def with_title(rgb: np.ndarray, title: str) -> np.ndarray:
    img = Image.fromarray(rgb)
    ImageDraw.Draw(img).text((6, 4), title, fill=(255, 255, 255), font=font(14), stroke_width=2,
                             stroke_fill=(0, 0, 0))
    return np.asarray(img)


def draw_box(rgb: np.ndarray, bbox, label: str) -> np.ndarray:
    """The wrist image with the detection box (u0, v0, u1, v1) [px, inclusive] drawn in green."""
    img = Image.fromarray(np.ascontiguousarray(rgb))
    d = ImageDraw.Draw(img)
    u0, v0, u1, v1 = (int(v) for v in bbox)
    d.rectangle((u0, v0, u1, v1), outline=(0, 255, 0), width=2)
    d.text((u0, max(0, v0 - 13)), label, fill=(0, 255, 0), font=font(11))
    return np.asarray(img)


def map_columns(occ, region: TopViewRegion, z_lo: float, z_hi: float):
    """Per map column of the region between heights z_lo..z_hi [m]: unknown fraction, any
    occupied, any frontier (each (nx, ny) over world x, y) and the world (x, y) [m] of voxel
    column [0, 0]'s centre."""
    lo = occ.world_to_voxel(np.array([[region.x_min, region.y_min, z_lo]]))[0]
    hi = occ.world_to_voxel(np.array([[region.x_max, region.y_max, z_hi]]))[0]
    lo = np.clip(lo, 0, np.array(occ.shape) - 1)
    hi = np.clip(hi, 0, np.array(occ.shape) - 1) + 1
    block = occ.state[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]]
    unknown = (block == VoxelState.UNKNOWN).mean(axis=2)
    occupied = (block == VoxelState.OCCUPIED).any(axis=2)
    frontier = frontier_mask(block).any(axis=2)
    origin = occ.voxel_to_world(lo[None])[0][:2]
    return unknown, occupied, frontier, origin


class TopView:
    """Draws the map's top view into a width x height panel (see the module docstring)."""

    def __init__(self, region: TopViewRegion, width: int, height: int) -> None:
        self.region, self.width, self.height = region, width, height
        self.scale = min(width / (region.y_max - region.y_min), height / (region.x_max - region.x_min))  # px/m
        self.u0 = 0.5 * (width - self.scale * (region.y_max - region.y_min))
        self.v0 = 0.5 * (height - self.scale * (region.x_max - region.x_min))

    def px(self, xy) -> np.ndarray:
        """World (x, y) [m] (..., 2) -> panel pixels (u, v)."""
        xy = np.asarray(xy, float)
        u = self.u0 + self.scale * (self.region.y_max - xy[..., 1])
        v = self.v0 + self.scale * (self.region.x_max - xy[..., 0])
        return np.stack([u, v], axis=-1)

    def slab(self, z: float, half: float = 0.05) -> tuple[float, float]:
        """The slab [m] of thickness 2 * half around height z, inside the region's heights."""
        lo = float(np.clip(z - half, self.region.z_min, self.region.z_max - 2 * half))
        return lo, lo + 2 * half

    def draw(self, occ, camera_path, tree=None, chosen=None, detection_xy=None, slab=None) -> np.ndarray:
        """camera_path (N, 3) [m]; tree: (positions (M, 3) [m], utilities (M,)) or None;
        chosen: (position (3,), optical axis (3,)) or None; detection_xy (2,) [m] or None;
        slab (z_lo, z_hi) [m] (default: around the last camera position's height)."""
        path = np.asarray(camera_path, float).reshape(-1, 3)
        if slab is None:
            slab = self.slab(path[-1, 2] if len(path) else 0.5 * (self.region.z_min + self.region.z_max))
        unknown, occupied, frontier, origin = map_columns(occ, self.region, *slab)
        grey = (255 - 150 * unknown).astype(np.uint8)
        rgb = np.repeat(grey[..., None], 3, axis=2)
        rgb[occupied] = (40, 60, 140)
        rgb[frontier & ~occupied] = (255, 150, 30)
        # voxel columns (i along x, j along y) -> image rows (x up) and columns (y to the left)
        img = Image.fromarray(np.ascontiguousarray(rgb[::-1, ::-1]))
        res = occ.resolution
        low = origin - res / 2  # the low corner of voxel column [0, 0] (origin is its centre)
        (u_a, v_a), (u_b, v_b) = self.px(low + res * np.array(unknown.shape)), self.px(low)
        w, h = max(1, round(u_b - u_a)), max(1, round(v_b - v_a))
        out = Image.new("RGB", (self.width, self.height), BACKGROUND)
        out.paste(img.resize((w, h), Image.NEAREST), (round(u_a), round(v_a)))
        d = ImageDraw.Draw(out)
        d.text((6, self.height - 18), f"slab z {slab[0]:.2f}..{slab[1]:.2f} m", fill=(255, 255, 255), font=font(12))
        if len(path) > 1:
            d.line([tuple(p) for p in self.px(path[:, :2])], fill=(30, 120, 255), width=2)
        if tree is not None:
            pos, util = tree
            ok = np.isfinite(util)
            if ok.any():
                span = np.ptp(util[ok]) or 1.0
                level = (util[ok] - util[ok].min()) / span
                for (u, v), a in zip(self.px(pos[ok][:, :2]), level):
                    d.ellipse((u - 2, v - 2, u + 2, v + 2), fill=_viridis(a))
        if len(path):
            u, v = self.px(path[-1, :2])
            d.ellipse((u - 5, v - 5, u + 5, v + 5), fill=(30, 120, 255), outline=(255, 255, 255))
        if chosen is not None:
            p, axis = (np.asarray(a, float) for a in chosen)
            u, v = self.px(p[:2])
            ue, ve = self.px(p[:2] + 0.12 * axis[:2])
            d.line((u, v, ue, ve), fill=(230, 30, 30), width=3)
            d.ellipse((u - 7, v - 7, u + 7, v + 7), outline=(230, 30, 30), width=3)
        if detection_xy is not None:
            u, v = self.px(detection_xy)
            d.line((u - 8, v - 8, u + 8, v + 8), fill=(0, 200, 0), width=3)
            d.line((u - 8, v + 8, u + 8, v - 8), fill=(0, 200, 0), width=3)
        return np.asarray(out)


def _viridis(a: float) -> tuple[int, int, int]:
    stops = np.array([(68, 1, 84), (59, 82, 139), (33, 145, 140), (94, 201, 98), (253, 231, 37)], float)
    x = float(np.clip(a, 0, 1)) * (len(stops) - 1)
    i = min(int(x), len(stops) - 2)
    return tuple(int(c) for c in stops[i] + (x - i) * (stops[i + 1] - stops[i]))


def caption(text: str, width: int, height: int) -> np.ndarray:
    img = Image.new("RGB", (width, height), (0, 0, 0))
    ImageDraw.Draw(img).text((8, (height - 18) // 2), text, fill=(255, 255, 255), font=font(18))
    return np.asarray(img)


def tile(panels, caption_rgb: np.ndarray) -> np.ndarray:
    """Panels side by side (equal heights) above the caption (the same total width)."""
    return np.ascontiguousarray(np.vstack([np.hstack(panels), caption_rgb]))
