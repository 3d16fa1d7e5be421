"""SE(3): rigid transforms as 4x4 matrices T = [[R, t], [0, 1]]; tangent xi = (v, w) 6-vectors.

The translation unit is whatever the caller uses (ycbvss uses millimetres throughout). The
tangent ordering is (v: translation part, w: rotation part [rad]). Left perturbation convention:
``T' = exp_se3(xi) @ T``.
"""
from __future__ import annotations

import numpy as np

from .so3 import exp_so3, hat, log_so3


def make_T(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Stack R (..., 3, 3) and t (..., 3) into T (..., 4, 4)."""
    R = np.asarray(R, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64).reshape(R.shape[:-2] + (3,))
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = t
    T[..., 3, 3] = 1.0
    return T


def inv_T(T: np.ndarray) -> np.ndarray:
    """Inverse rigid transform, (..., 4, 4)."""
    T = np.asarray(T, dtype=np.float64)
    Rt = np.swapaxes(T[..., :3, :3], -1, -2)
    return make_T(Rt, -(Rt @ T[..., :3, 3:4])[..., 0])


def compose(*Ts: np.ndarray) -> np.ndarray:
    """Compose transforms left to right: compose(A, B, C) = A @ B @ C (broadcasting)."""
    out = np.asarray(Ts[0], dtype=np.float64)
    for T in Ts[1:]:
        out = out @ np.asarray(T, dtype=np.float64)
    return out


def transform_points(T: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Apply T (4, 4) to points X (N, 3) -> (N, 3); or batched T (B, 4, 4) to X (N, 3) -> (B, N, 3)."""
    T = np.asarray(T, dtype=np.float64)
    X = np.asarray(X, dtype=np.float64)
    return X @ np.swapaxes(T[..., :3, :3], -1, -2) + T[..., None, :3, 3]


def _V(w: np.ndarray) -> np.ndarray:
    th = np.linalg.norm(w, axis=-1)[..., None, None]
    W = hat(w)
    small = th < 1e-6
    th_s = np.where(small, 1.0, th)
    b = np.where(small, 0.5 - th**2 / 24.0, (1.0 - np.cos(th_s)) / th_s**2)
    c = np.where(small, 1.0 / 6.0 - th**2 / 120.0, (th_s - np.sin(th_s)) / th_s**3)
    return np.eye(3) + b * W + c * (W @ W)


def exp_se3(xi: np.ndarray) -> np.ndarray:
    """Exponential map: xi = (v, w) (..., 6) -> T (..., 4, 4)."""
    xi = np.asarray(xi, dtype=np.float64)
    v, w = xi[..., :3], xi[..., 3:]
    return make_T(exp_so3(w), (_V(w) @ v[..., None])[..., 0])


def log_se3(T: np.ndarray) -> np.ndarray:
    """Logarithm: T (..., 4, 4) -> xi = (v, w) (..., 6)."""
    T = np.asarray(T, dtype=np.float64)
    w = log_so3(T[..., :3, :3])
    v = np.linalg.solve(_V(w), T[..., :3, 3:4])[..., 0]
    return np.concatenate([v, w], axis=-1)


def adjoint(T: np.ndarray) -> np.ndarray:
    """Adjoint (6x6) of T for the (v, w) ordering: exp(Ad_T xi) = T exp(xi) T^-1."""
    R, t = T[:3, :3], T[:3, 3]
    A = np.zeros((6, 6))
    A[:3, :3] = R
    A[:3, 3:] = hat(t) @ R
    A[3:, 3:] = R
    return A


def interpolate_T(T0: np.ndarray, T1: np.ndarray, s: float | np.ndarray) -> np.ndarray:
    """Interpolate between poses: rotation by SLERP (geodesic), translation linearly.

    ``s`` in [0, 1] (scalar or array (K,)); returns (4, 4) or (K, 4, 4). This decoupled
    interpolation is what camera trajectories want (the SE(3) geodesic would make the camera
    centre follow a screw motion).
    """
    s_arr = np.atleast_1d(np.asarray(s, dtype=np.float64))
    R0, R1 = T0[:3, :3], T1[:3, :3]
    w = log_so3(R0.T @ R1)
    R = R0 @ exp_so3(s_arr[:, None] * w[None])
    t = (1 - s_arr)[:, None] * T0[:3, 3] + s_arr[:, None] * T1[:3, 3]
    out = make_T(R, t)
    return out[0] if np.ndim(s) == 0 else out


def perturb_T(T: np.ndarray, t_sigma: float, r_sigma_deg: float, rng: np.random.Generator) -> np.ndarray:
    """Random deviation of pose(s) T (..., 4, 4): R <- exp(w) R, t <- t + dt with
    dt ~ N(0, t_sigma^2 I) (translation unit of T) and w ~ N(0, (r_sigma_deg in rad)^2 I)."""
    T = np.asarray(T, dtype=np.float64)
    shape = T.shape[:-2]
    w = rng.normal(scale=np.radians(r_sigma_deg), size=shape + (3,))
    dt = rng.normal(scale=t_sigma, size=shape + (3,))
    return make_T(exp_so3(w) @ T[..., :3, :3], T[..., :3, 3] + dt)
