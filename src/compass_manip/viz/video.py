"""Trial videos: `VideoRecorder`, a trial observer that writes an MP4 on the simulated timeline.

One video frame every 1 / fps seconds of simulated time (`VideoConfig.fps`, 10 by default),
from t = 0 to the first tick at or after the trial's end (which shows the final state), so a
trial of T seconds gives ceil(T * fps) + 1 frames and plays in real time. Each frame shows,
left to right: the scene from a fixed external camera with the robot where it is at that instant (interpolated along the
running trajectory), the wrist camera's last RGB frame (with the accepted detection's box
once there is one), the method's map from above (`viz.panels.TopView`), and below them a
caption (simulated time, state, decisions, found). Between events the panels are held.

The recorder renders the scene in its own MuJoCo model and reads the method's map and the
decisions without writing to them, so a trial gives the same result with or without a
video (tests/test_trial_video.py). Encoding: imageio's ffmpeg plugin with the ffmpeg
binary of the `imageio-ffmpeg` wheel (H.264, yuv420p).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import CompassInputError
from ..robot.kinematics import PandaKinematics
from ..trial.observer import TrialObserver
from . import panels


@dataclass(frozen=True)
class VideoConfig:
    """fps: video frames per simulated second; panel_width / panel_height [px] of each of the
    three panels; caption_height [px]; quality: ffmpeg quality 0..10 (imageio's scale)."""

    fps: float = 10.0
    panel_width: int = 400
    panel_height: int = 300
    caption_height: int = 36
    quality: float = 7.0

    def __post_init__(self) -> None:
        if not 0.5 <= self.fps <= 60:
            raise CompassInputError(f"video fps {self.fps} is not allowed; use 0.5..60")
        if (3 * self.panel_width) % 16 or (self.panel_height + self.caption_height) % 16:
            raise CompassInputError(f"video size {3 * self.panel_width}x{self.panel_height + self.caption_height} px "
                                    "is not allowed; both sides must be multiples of 16 px")


class SceneCamera:
    """Renders the scene from a fixed camera (front-left, above; the cabinet's top and side
    boards see-through, as `sim.world.render_overview`) in its own copy of the model."""

    def __init__(self, world, width: int, height: int) -> None:
        from ..sim.world import World, overview_camera, see_through_geoms

        self.world = World(world.scene, world.robot)
        m = self.world.model
        m.geom_rgba[see_through_geoms(self.world), 3] = 0.15
        self.renderer = mujoco.Renderer(m, height, width)
        self.cam, self.opt = overview_camera(self.world, distance=2.0)

    def render(self, qpos: np.ndarray, q_arm: np.ndarray) -> np.ndarray:
        """The scene with every joint at `qpos` (the trial world's, copied) but the arm at q_arm [rad]."""
        d = self.world.data
        d.qpos[:] = qpos
        d.qpos[:7] = q_arm
        mujoco.mj_kinematics(self.world.model, d)
        self.renderer.update_scene(d, self.cam, self.opt)
        self.renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False  # 4x faster on a software GL
        self.renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        return self.renderer.render().copy()

    def close(self) -> None:
        self.renderer.close()
        self.world.close()


class VideoRecorder(TrialObserver):
    """Writes the trial's video to `path` (an .mp4; see the module docstring). `title`
    starts the caption (e.g. method and scene)."""

    def __init__(self, path: str, config: VideoConfig | None = None, title: str = "") -> None:
        self.path, self.config, self.title = path, config or VideoConfig(), title
        self.frames_written = 0
        self._writer = None
        self._scene_cam = None

    # ------------------------------------------------------------------ events
    def start(self, world, method) -> None:
        c = self.config
        self._scene_cam = SceneCamera(world, c.panel_width, c.panel_height)
        self._world = world  # read only: its joint positions (objects, fingers) at each frame
        self._qpos = world.data.qpos.copy()
        self._q = world.q
        self._kin = PandaKinematics(world.robot)
        cab = world.scene.cabinet
        self._top = panels.TopView(panels.TopViewRegion.around(cab.interior_min, cab.interior_max,
                                                               world.scene.robot_base_pos),
                                   c.panel_width, c.panel_height)
        self._occ = method.occupancy
        self._k = 0
        self._motion = None
        self._state, self._decisions, self._last = "", 0, ""
        self._found_t = self._detection_xy = self._tree = self._chosen = None
        self._cam_path: list[np.ndarray] = []
        self._overview_key, self._overview = None, None
        self._wrist = panels.with_title(np.zeros((c.panel_height, c.panel_width, 3), np.uint8), "wrist camera")
        self._map = self._draw_map()

    def state(self, t, state) -> None:
        self._advance(t)
        self._state = state.value.upper()

    def decision(self, t, decision, method) -> None:
        self._advance(t)
        self._decisions += 1
        dbg = decision.debug or {}
        self._tree = None
        if "tree_cam_world" in dbg and "tree_utility" in dbg:
            self._tree = (np.asarray(dbg["tree_cam_world"]), np.asarray(dbg["tree_utility"], float))
        self._chosen = None
        if decision.path is not None:
            T = self._kin.T_world_cam(np.asarray(decision.path)[-1])
            self._chosen = (T[:3, 3], T[:3, 2])
        u = decision.stats.get("U")
        self._last = f" ({decision.phase.value}{'' if u is None else f', U {u:.2f}'})"
        if decision.stop is not None:
            self._last = f" (stop: {decision.stop.name.lower()})"
        self._map = self._draw_map()

    def motion(self, trajectory, t_start, t_end) -> None:
        self._motion = (np.asarray(trajectory.t, float) - trajectory.t[0] + t_start, np.asarray(trajectory.q, float))

    def frame(self, frame, method) -> None:
        self._advance(frame.t)
        self._q = np.asarray(frame.q, float).copy()
        self._qpos = self._world.data.qpos.copy()
        self._cam_path.append(frame.T_world_cam[:3, 3].copy())
        if frame.rgb is not None and self._found_t is None:
            self._wrist = panels.with_title(panels.fit(frame.rgb, self.config.panel_width, self.config.panel_height),
                                            "wrist camera")
        self._map = self._draw_map()

    def detection(self, t, found) -> None:
        self._advance(t)
        det = found.detection
        self._found_t = float(det.t)
        self._detection_xy = np.asarray(det.centroid_world, float)[:2]
        rgb = found.observation.rgb
        if rgb is not None:
            boxed = panels.draw_box(rgb, det.bbox, f"target {det.score:.2f}")
            self._wrist = panels.with_title(panels.fit(boxed, self.config.panel_width, self.config.panel_height),
                                            "wrist camera: accepted detection")
        self._map = self._draw_map()

    def end(self, outcome) -> None:
        self._advance(outcome.t_end)
        if outcome.failure is not None:
            self._last = f"{self._last}  -> {outcome.failure.name.lower()}"
        self._advance(outcome.t_end, inclusive=True)
        self.close()

    def close(self) -> None:
        if self._writer is not None:
            self._writer.close()
            self._writer = None
        if self._scene_cam is not None:
            self._scene_cam.close()
            self._scene_cam = None

    # ---------------------------------------------------------------- timeline
    def _advance(self, t: float, inclusive: bool = False) -> None:
        """Write the frames of every tick before t [s]; inclusive (at the end): also the first tick
        at or after t, which shows the final state."""
        fps = self.config.fps
        last = math.ceil(t * fps - 1e-9) - (0 if inclusive else 1)
        while self._k <= last:
            self._write(self._compose(self._k / fps))
            self._k += 1

    def _arm_at(self, tau: float) -> np.ndarray:
        if self._motion is not None:
            times, Q = self._motion
            if times[0] <= tau <= times[-1]:
                return np.array([np.interp(tau, times, Q[:, j]) for j in range(Q.shape[1])])
        return self._q

    def _compose(self, tau: float) -> np.ndarray:
        c = self.config
        q = self._arm_at(tau)
        key = np.round(q, 6).tobytes()
        if key != self._overview_key:
            self._overview_key = key
            self._overview = panels.with_title(self._scene_cam.render(self._qpos, q), "scene")
        found = "no" if self._found_t is None or tau < self._found_t else f"at {self._found_t:.1f} s"
        text = (f"{self.title}  t = {tau:6.1f} s  {self._state}  decisions {self._decisions}{self._last}  "
                f"found: {found}")
        return panels.tile([self._overview, self._wrist, self._map], panels.caption(text, 3 * c.panel_width,
                                                                                    c.caption_height))

    def _draw_map(self) -> np.ndarray:
        path = np.array(self._cam_path).reshape(-1, 3)
        return panels.with_title(self._top.draw(self._occ, path, self._tree, self._chosen, self._detection_xy),
                                 "map from above")

    def _write(self, rgb: np.ndarray) -> None:
        if self._writer is None:
            import imageio.v2 as imageio

            self._writer = imageio.get_writer(self.path, format="FFMPEG", mode="I", fps=self.config.fps,
                                              codec="libx264", quality=self.config.quality, pixelformat="yuv420p",
                                              macro_block_size=16, ffmpeg_log_level="error")
        self._writer.append_data(rgb)
        self.frames_written += 1
