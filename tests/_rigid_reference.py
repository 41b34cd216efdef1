"""The rigid-transform test written with numpy's allclose: the reference the compiled
`geometry.is_rigid` is compared with."""
import numpy as np


def is_rigid_reference(T, tol=1e-6):
    T = np.asarray(T)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        return False
    R = T[:3, :3]
    return bool(np.allclose(R.T @ R, np.eye(3), atol=tol) and abs(np.linalg.det(R) - 1.0) < tol
                and np.allclose(T[3], [0, 0, 0, 1], atol=tol))
