"""SE(3) helpers on 4x4 numpy arrays. Lengths in [m], angles in [rad]."""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from .errors import CompassInputError


def make_T(R: np.ndarray | None = None, t: np.ndarray | None = None) -> np.ndarray:
    """Homogeneous 4x4 transform from a 3x3 rotation and a translation [m]."""
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if t is not None:
        T[:3, 3] = t
    return T


def inv_T(T: np.ndarray) -> np.ndarray:
    """Inverse of a rigid transform."""
    R = T[:3, :3]
    out = np.eye(4)
    out[:3, :3] = R.T
    out[:3, 3] = -R.T @ T[:3, 3]
    return out


def is_rigid(T: np.ndarray, tol: float = 1e-6) -> bool:
    """True if T is a finite 4x4 rigid transform (orthonormal, det +1, last row 0 0 0 1):
    |R^T R - I| <= tol + 1e-5 I elementwise (np.allclose's test), |det R - 1| < tol and the
    last row within tol + 1e-5 |row| of 0 0 0 1 (one compiled test: it runs for every IK
    target)."""
    T = np.asarray(T)
    if T.shape != (4, 4):
        return False
    if T.dtype != np.float64:
        try:
            T = T.astype(np.float64)
        except (TypeError, ValueError):
            return False
    return bool(_is_rigid_kernel(T, float(tol)))


@nb.njit(cache=True)
def _is_rigid_kernel(T, tol):
    for i in range(4):
        for j in range(4):
            if not math.isfinite(T[i, j]):
                return False
    for i in range(3):
        for j in range(3):
            g = T[0, i] * T[0, j] + T[1, i] * T[1, j] + T[2, i] * T[2, j]
            e = 1.0 if i == j else 0.0
            if not abs(g - e) <= tol + 1e-5 * e:
                return False
    det = (T[0, 0] * (T[1, 1] * T[2, 2] - T[1, 2] * T[2, 1]) - T[0, 1] * (T[1, 0] * T[2, 2] - T[1, 2] * T[2, 0])
           + T[0, 2] * (T[1, 0] * T[2, 1] - T[1, 1] * T[2, 0]))
    if not abs(det - 1.0) < tol:
        return False
    for j in range(4):
        e = 1.0 if j == 3 else 0.0
        if not abs(T[3, j] - e) <= tol + 1e-5 * e:
            return False
    return True


def check_rigid(T: np.ndarray, name: str = "T") -> np.ndarray:
    """Return T as float64 or raise CompassInputError naming the problem."""
    try:
        T = np.asarray(T, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CompassInputError(f"{name} must be a 4x4 rigid transform of numbers, got {T!r:.80}") from exc
    if T.shape != (4, 4):
        raise CompassInputError(f"{name} must be a 4x4 rigid transform, got shape {T.shape}")
    if not np.all(np.isfinite(T)):
        raise CompassInputError(f"{name} contains NaN or inf; a finite rigid transform is required")
    if not is_rigid(T, tol=1e-5):
        raise CompassInputError(
            f"{name} is not rigid (rotation not orthonormal with det +1, or last row not 0 0 0 1)"
        )
    return T


def rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def quat_to_R(q_wxyz: np.ndarray) -> np.ndarray:
    """Rotation matrix from a unit quaternion (w, x, y, z)."""
    w, x, y, z = np.asarray(q_wxyz, dtype=np.float64) / np.linalg.norm(q_wxyz)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def R_to_quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) with w >= 0 from a rotation matrix."""
    R = np.asarray(R, dtype=np.float64)
    tr = np.trace(R)
    if tr > 0:
        s = 2.0 * np.sqrt(tr + 1.0)
        q = [0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
        s = 2.0 * np.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        q = [(R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif R[1, 1] > R[2, 2]:
        s = 2.0 * np.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2])
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1])
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s]
    q = np.array(q)
    q /= np.linalg.norm(q)
    return q if q[0] >= 0 else -q


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray = (0.0, 0.0, 1.0)) -> np.ndarray:
    """T_world_cam of a camera at `eye` [m] looking at `target` [m].

    Camera frame convention (OpenCV): +z forward (optical axis), +x right, +y down.
    """
    eye = np.asarray(eye, dtype=np.float64)
    z = np.asarray(target, dtype=np.float64) - eye
    n = np.linalg.norm(z)
    if n < 1e-9:
        raise CompassInputError("look_at: eye and target coincide; they must differ")
    z /= n
    up = np.asarray(up, dtype=np.float64)
    x = np.cross(z, up)
    if np.linalg.norm(x) < 1e-6:  # looking along up: pick any perpendicular
        x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return make_T(np.column_stack([x, y, z]), eye)


#: Largest distance of the principal point from the image centre, as a fraction of the
#: image's width / height, for a depth image to count as taken with intrinsics K.
PRINCIPAL_POINT_TOLERANCE = 0.1


def check_intrinsics(K: np.ndarray, image_shape: tuple[int, int] | None = None, name: str = "K") -> np.ndarray:
    """K as float64 (3, 3), or CompassInputError naming what is wrong.

    A pinhole matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] [px] (OpenCV, no skew) with
    1 <= fx, fy <= 1e6 px. With image_shape (H, W) the principal point must lie within
    `PRINCIPAL_POINT_TOLERANCE` of the image centre ((W - 1) / 2, (H - 1) / 2) along each
    axis: an image of another size (or transposed) does not belong to K.
    """
    try:
        K = np.asarray(K, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CompassInputError(f"{name} must be a 3x3 array of numbers [px], got {K!r:.80}") from exc
    if K.shape != (3, 3) or not np.all(np.isfinite(K)):
        raise CompassInputError(f"{name} must be a finite 3x3 pinhole matrix [px], got shape {K.shape}: "
                                f"{np.array2string(K, precision=4)}")
    fx, fy = K[0, 0], K[1, 1]
    if not (1.0 <= fx <= 1e6 and 1.0 <= fy <= 1e6):
        raise CompassInputError(f"{name} focal lengths fx {fx}, fy {fy} px are not allowed; use 1..1e6 px")
    if K[0, 1] != 0.0 or K[1, 0] != 0.0 or K[2, 0] != 0.0 or K[2, 1] != 0.0 or K[2, 2] != 1.0:
        raise CompassInputError(
            f"{name} = {np.array2string(K, precision=4)} is not a pinhole matrix [[fx, 0, cx], [0, fy, cy], "
            "[0, 0, 1]] (no skew; transposed?)"
        )
    if image_shape is not None:
        H, W = image_shape
        for c, n, axis in ((K[0, 2], W, "cx"), (K[1, 2], H, "cy")):
            if abs(c - 0.5 * (n - 1)) > PRINCIPAL_POINT_TOLERANCE * n + 0.5:
                raise CompassInputError(
                    f"{name} principal point {axis} = {c} px does not fit an image of {W}x{H} px (W x H; centre "
                    f"{0.5 * (W - 1)}, {0.5 * (H - 1)}); the depth image and K come from different cameras "
                    "or the image is transposed"
                )
    return K
