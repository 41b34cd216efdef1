"""compass-manip: confined-space manipulation with active sensing (COMPASS) on a CPU."""
import os as _os

# MuJoCo picks its GL backend when a renderer is first made; headless EGL is the default here.
_os.environ.setdefault("MUJOCO_GL", "egl")
_os.environ.setdefault("PYOPENGL_PLATFORM", _os.environ["MUJOCO_GL"])

__version__ = "0.1.0"
