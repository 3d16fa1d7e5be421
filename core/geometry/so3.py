"""SO(3): rotations as 3x3 matrices, tangent vectors as axis-angle 3-vectors (radians).

All functions accept a single item or a batch (leading dimensions) and are vectorised.
"""
from __future__ import annotations

import numpy as np

_EPS = 1e-12


def hat(w: np.ndarray) -> np.ndarray:
    """Skew-symmetric matrix [w]x of 3-vectors w (..., 3) -> (..., 3, 3)."""
    w = np.asarray(w, dtype=np.float64)
    O = np.zeros(w.shape[:-1] + (3, 3))
    O[..., 0, 1], O[..., 0, 2] = -w[..., 2], w[..., 1]
    O[..., 1, 0], O[..., 1, 2] = w[..., 2], -w[..., 0]
    O[..., 2, 0], O[..., 2, 1] = -w[..., 1], w[..., 0]
    return O


def exp_so3(w: np.ndarray) -> np.ndarray:
    """Rodrigues: axis-angle w (..., 3) [rad] -> rotation matrices (..., 3, 3)."""
    w = np.asarray(w, dtype=np.float64)
    th = np.linalg.norm(w, axis=-1)[..., None, None]
    W = hat(w)
    small = th < 1e-6
    th_s = np.where(small, 1.0, th)
    a = np.where(small, 1.0 - th**2 / 6.0, np.sin(th_s) / th_s)
    b = np.where(small, 0.5 - th**2 / 24.0, (1.0 - np.cos(th_s)) / th_s**2)
    return np.eye(3) + a * W + b * (W @ W)


def log_so3(R: np.ndarray) -> np.ndarray:
    """Inverse of :func:`exp_so3`: rotation matrices (..., 3, 3) -> axis-angle (..., 3) [rad].

    Stable near 0 and near pi (uses the symmetric part to recover the axis there).
    """
    R = np.asarray(R, dtype=np.float64)
    tr = np.trace(R, axis1=-2, axis2=-1)
    c = np.clip((tr - 1.0) / 2.0, -1.0, 1.0)
    th = np.arccos(c)
    v = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                  R[..., 1, 0] - R[..., 0, 1]], axis=-1)
    s = np.sin(th)
    small = th < 1e-6
    near_pi = th > np.pi - 1e-3
    factor = np.where(small, 0.5 + th**2 / 12.0, th / (2.0 * np.where(small, 1.0, s) + _EPS))
    w = v * factor[..., None]
    if np.any(near_pi):
        # near pi the antisymmetric part vanishes: take the axis from the symmetric part
        Rf = R.reshape(-1, 3, 3)
        wf = w.reshape(-1, 3)
        vf = v.reshape(-1, 3)
        thf = th.reshape(-1)
        for k in np.flatnonzero(near_pi.reshape(-1)):
            # symmetric part: (R + R^T)/2 = cos(th) I + (1 - cos(th)) a a^T
            c_k = np.cos(thf[k])
            B = ((Rf[k] + Rf[k].T) / 2.0 - c_k * np.eye(3)) / (1.0 - c_k)
            i = int(np.argmax(np.diag(B)))
            axis = B[:, i] / np.sqrt(max(B[i, i], _EPS))
            axis /= np.linalg.norm(axis) + _EPS
            if axis @ vf[k] < 0:
                axis = -axis
            wf[k] = axis * thf[k]
        w = wf.reshape(w.shape)
    return w


def rotation_angle_deg(R: np.ndarray) -> np.ndarray:
    """Rotation angle of R (..., 3, 3) in degrees, in [0, 180]."""
    R = np.asarray(R, dtype=np.float64)
    c = np.clip((np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    return np.degrees(np.arccos(c))


def orthonormality_error(R: np.ndarray) -> np.ndarray:
    """Frobenius norm of R^T R - I (..., ) for matrices (..., 3, 3)."""
    R = np.asarray(R, dtype=np.float64)
    return np.linalg.norm(np.swapaxes(R, -1, -2) @ R - np.eye(3), axis=(-2, -1))


def is_rotation(R: np.ndarray, tol: float = 1e-4) -> np.ndarray:
    """True where R is orthonormal (|R^T R - I|_F <= tol) with det +1 and finite."""
    R = np.asarray(R, dtype=np.float64)
    ok = np.all(np.isfinite(R), axis=(-2, -1))
    Rf = np.where(ok[..., None, None], R, np.eye(3))
    return ok & (orthonormality_error(Rf) <= tol) & (np.linalg.det(Rf) > 0)


def project_to_so3(M: np.ndarray) -> np.ndarray:
    """Closest rotation (Frobenius) to M (..., 3, 3) via SVD."""
    U, _, Vt = np.linalg.svd(np.asarray(M, dtype=np.float64))
    d = np.sign(np.linalg.det(U @ Vt))
    D = np.ones(U.shape[:-2] + (3,))
    D[..., 2] = d
    return (U * D[..., None, :]) @ Vt


def random_rotation(rng: np.random.Generator, n: int | None = None) -> np.ndarray:
    """Uniformly distributed rotations (Haar measure) from unit quaternions."""
    q = rng.normal(size=(1 if n is None else n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    R = np.stack([
        1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
        2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
        2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1).reshape(-1, 3, 3)
    return R[0] if n is None else R
