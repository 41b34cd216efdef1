"""RGB and depth from one OpenGL pass of a `mujoco.Renderer`.

`mujoco.Renderer.render()` draws the scene once per image: a frame with RGB and depth costs
two passes (the depth pass in segmentation colours). The colour and depth buffers of one
ordinary pass hold both images; reading them together halves the GL work of a frame
(llvmpipe, the software renderer of a headless machine, spends most of a frame there).
The depth buffer holds reversed-Z window depth; `zbuffer_to_depth` turns it into metric
z-depth with the same float32 projection constants and float64 arithmetic as the
renderer's depth mode, so both give the same numbers (tests/test_rgbd.py checks equality
with the two-pass images).

llvmpipe rasterises on LP_NUM_THREADS worker threads (default: one per core). For one
320x240 frame the hand-off to them costs more CPU than it saves: with LP_NUM_THREADS=0 the
calling thread rasterises, 3.4 ms of process CPU per frame instead of 3.7-4.4 ms with 1 or
2 threads, and 3.4 ms of wall time instead of 4.5-8.2 ms (`docs/compass_loop.md`, "Real
time, third round"); the images are the same (tests/test_rgbd.py). Importing this module
sets it to 0 unless the environment already names a value; it takes effect for GL
contexts created afterwards in this process (Mesa reads it when its screen is created).
"""
from __future__ import annotations

import os

os.environ.setdefault("LP_NUM_THREADS", "0")

import mujoco  # noqa: E402 (after LP_NUM_THREADS, which Mesa reads when the first context is made)
import numpy as np  # noqa: E402


def zbuffer_to_depth(zbuf: np.ndarray, extent: float, znear: float, zfar: float) -> np.ndarray:
    """Metric z-depth [m] (float32) of a reversed-Z depth buffer `zbuf` in [0, 1] of a
    perspective camera whose clip planes are znear * extent and zfar * extent [m]:
    depth = d / (zbuf + c) with the projection's float32 coefficients (1 -> near, 0 -> far)."""
    near, far = np.float32(znear * extent), np.float32(zfar * extent)
    c = -(far + near) / (far - near)
    d = -(np.float32(2) * far * near) / (far - near)
    c = np.float32(-0.5) * c - np.float32(0.5)
    d = np.float32(-0.5) * d
    return (d / (np.asarray(zbuf).astype(np.float64) + c)).astype(np.float32)


def render_rgbd(renderer: mujoco.Renderer) -> tuple[np.ndarray, np.ndarray]:
    """(rgb (H, W, 3) uint8, depth (H, W) float32 [m]) of the renderer's current scene
    (after `update_scene`) from one pass; the renderer must be a perspective camera's."""
    if renderer.scene.camera[0].orthographic:
        raise ValueError("render_rgbd needs a perspective camera")
    ctx = renderer._gl_context  # noqa: SLF001 (the renderer's own GL and MuJoCo contexts)
    if ctx is not None:
        ctx.make_current()
    rgb = np.empty((renderer.height, renderer.width, 3), dtype=np.uint8)
    zbuf = np.empty((renderer.height, renderer.width), dtype=np.float32)
    mujoco.mjr_render(renderer._rect, renderer.scene, renderer._mjr_context)  # noqa: SLF001
    mujoco.mjr_readPixels(rgb, zbuf, renderer._rect, renderer._mjr_context)  # noqa: SLF001
    m = renderer.model
    depth = zbuffer_to_depth(zbuf, m.stat.extent, m.vis.map.znear, m.vis.map.zfar)
    if ctx is not None:  # EGL / OSMesa / GLFW images are bottom-up
        rgb, depth = np.flipud(rgb), np.flipud(depth)
    return np.ascontiguousarray(rgb), np.ascontiguousarray(depth)


_G = mujoco.mjtGeom
_CULLABLE_IDS = np.array([int(t) for t in (_G.mjGEOM_MESH, _G.mjGEOM_BOX, _G.mjGEOM_SPHERE, _G.mjGEOM_CAPSULE,
                                           _G.mjGEOM_CYLINDER, _G.mjGEOM_ELLIPSOID)], dtype=np.int64)


def view_planes(K: np.ndarray, width: int, height: int, pad_px: float = 2.0) -> np.ndarray:
    """Inward unit normals (4, 3) in the camera's optical frame of the planes through the
    camera centre that bound the image (pixel centres at integer coordinates, edges half a
    pixel out) grown by pad_px pixels: a point p is inside when every `normal . p >= 0`."""
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    left, right = (cx + 0.5 + pad_px) / fx, (width - 0.5 - cx + pad_px) / fx
    top, bottom = (cy + 0.5 + pad_px) / fy, (height - 0.5 - cy + pad_px) / fy
    n = np.array([[1.0, 0.0, left], [-1.0, 0.0, right], [0.0, 1.0, top], [0.0, -1.0, bottom]])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def cull_outside_view(scene: mujoco.MjvScene, T_world_cam: np.ndarray, planes: np.ndarray, near_m: float,
                      margin_m: float = 0.01, geom_aabb: np.ndarray | None = None) -> int:
    """Drop from `scene` (after `update_scene`) every geom whose bounding sphere, grown by
    margin_m [m], lies wholly outside the view (beyond one side plane, `view_planes`, or
    before the near clip plane near_m [m]); returns how many. With shadows and reflections
    off a geom outside the view adds no pixel, so the images do not change; the Panda's
    visual meshes (about 135,000 triangles), mostly behind the wrist camera, are most of
    the GL work of a frame. Planes and other unbounded geoms are kept. (All geoms are tested
    as arrays: a geom on the boundary, which has no pixel either way, may fall on either
    side of it by rounding.) geom_aabb: the model's `geom_aabb` (ngeom, 6) (centre and half
    sizes in each geom's frame): a model geom whose sphere reaches into the view is also
    dropped when its box, grown by margin_m, lies wholly outside (all eight corners beyond
    one plane): the wrist camera's own link 7 and hand (19,000 triangles) are next to it,
    their spheres reach into the view, their boxes mostly do not."""
    R, t = np.asarray(T_world_cam)[:3, :3], np.asarray(T_world_cam)[:3, 3]
    geoms = [scene.geoms[i] for i in range(scene.ngeom)]
    if not geoms:
        return 0
    kind = np.fromiter((int(g.type) for g in geoms), dtype=np.int64, count=len(geoms))
    rbound = np.fromiter((g.modelrbound for g in geoms), dtype=np.float64, count=len(geoms))
    p = (np.array([g.pos for g in geoms], dtype=np.float64) - t) @ R  # centres in the optical frame
    r = rbound + margin_m
    out = np.isin(kind, _CULLABLE_IDS) & (rbound > 0) & ((p[:, 2] + r < near_m) | np.any(p @ planes.T < -r[:, None],
                                                                                         axis=1))
    if geom_aabb is not None:
        cand = np.flatnonzero(np.isin(kind, _CULLABLE_IDS) & ~out)
        objtype = np.fromiter((geoms[i].objtype for i in cand), dtype=np.int64, count=len(cand))
        objid = np.fromiter((geoms[i].objid for i in cand), dtype=np.int64, count=len(cand))
        keep = (objtype == int(mujoco.mjtObj.mjOBJ_GEOM)) & (objid >= 0)
        cand, objid = cand[keep], objid[keep]
        if len(cand):
            mats = np.array([geoms[i].mat for i in cand], dtype=np.float64).reshape(-1, 3, 3)
            box = np.asarray(geom_aabb, dtype=np.float64)[objid]
            local = box[:, None, :3] + box[:, None, 3:] * _CORNER_SIGNS[None]  # (k, 8, 3) in each geom's frame
            corners = p[cand][:, None, :] + np.einsum("ij,kjl,knl->kni", R.T, mats, local)  # optical frame
            beyond_side = np.any(np.all(corners @ planes.T < -margin_m, axis=1), axis=1)
            before_near = np.all(corners[:, :, 2] < near_m - margin_m, axis=1)
            out[cand[beyond_side | before_near]] = True
    for i in np.flatnonzero(out):
        geoms[i].type = mujoco.mjtGeom.mjGEOM_NONE
    return int(np.count_nonzero(out))


_CORNER_SIGNS = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)])
