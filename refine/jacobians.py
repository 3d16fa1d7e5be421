"""Analytic Jacobians of pinhole projections w.r.t. left se(3) increments of cameras and objects.

Conventions (as :mod:`ycbvss.geometry.se3`): xi = (v, w), left perturbation T' = exp(xi) T.
For a model point X, world point W = T_m X and camera point Y = T_c W:

- d Y / d xi_c = [I, -[Y]x]                      (camera increment)
- d Y / d xi_m = R_c [I, -[W]x]                  (object increment, applied in the world frame)
- d u / d Y    = [[fx/Z, s/Z, -(fx X + s Y)/Z^2], [0, fy/Z, -fy Y/Z^2]]   (s = K[0,1], the skew)

For a point Y_k fixed in camera k seen from camera i, Y_i = T_c_i T_c_k^-1 Y_k:

- d Y_i / d xi_i = [I, -[Y_i]x];  d Y_i / d xi_k = -R_ik [I, -[Y_k]x] with R_ik = R_c_i R_c_k^T.

The products (d u / d Y) M [I, -[P]x] are formed without (N, 3, 6) temporaries: the rotation
part of a row r is P x r (see :func:`_se3_jac`).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..geometry.se3 import inv_T

MIN_Z_MM = 1.0   # points closer than this (or behind the camera) are invalid


def _project(K: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pinhole projection of camera points Y (N, 3): pixels uv (N, 2), valid (N,) (Z > MIN_Z_MM,
    finite), and the normalised coordinates x, y and depth Zs (N,) (Zs = 1 where invalid)."""
    Z = Y[:, 2]
    valid = (Z > MIN_Z_MM) & (Z < np.inf) & np.isfinite(Y[:, 0]) & np.isfinite(Y[:, 1])
    Zs = np.where(valid, Z, 1.0)
    x, y = Y[:, 0] / Zs, Y[:, 1] / Zs
    uv = np.empty((len(Y), 2))
    uv[:, 0] = K[0, 0] * x + K[0, 1] * y + K[0, 2]
    uv[:, 1] = K[1, 1] * y + K[1, 2]
    return uv, valid, x, y, Zs


def project_jac(K: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Project camera points Y (N, 3): pixels (N, 2), d u / d Y (N, 2, 3), valid (N,) (Z > MIN_Z_MM, finite)."""
    Y = np.asarray(Y, dtype=np.float64)
    uv, valid, x, y, Zs = _project(K, Y)
    fx, fy, s = K[0, 0], K[1, 1], K[0, 1]
    J = np.zeros((len(Y), 2, 3))
    J[:, 0, 0] = fx / Zs
    J[:, 0, 1] = s / Zs
    J[:, 0, 2] = -(fx * x + s * y) / Zs
    J[:, 1, 1] = fy / Zs
    J[:, 1, 2] = -fy * y / Zs
    return uv, J, valid


@njit(cache=True, nogil=True)
def _se3_jac_kernel(M: np.ndarray, P: np.ndarray, out: np.ndarray) -> None:
    for n in range(M.shape[0]):
        p0, p1, p2 = P[n, 0], P[n, 1], P[n, 2]
        for r in range(M.shape[1]):
            r0, r1, r2 = M[n, r, 0], M[n, r, 1], M[n, r, 2]
            out[n, r, 0], out[n, r, 1], out[n, r, 2] = r0, r1, r2
            out[n, r, 3] = p1 * r2 - p2 * r1
            out[n, r, 4] = p2 * r0 - p0 * r2
            out[n, r, 5] = p0 * r1 - p1 * r0


def _se3_jac(M: np.ndarray, P: np.ndarray, out: np.ndarray) -> np.ndarray:
    """M @ [I, -[P]x] for M (N, R, 3) and points P (N, 3), written into ``out`` (N, R, 6).

    Row r of M times -[P]x is P x r (the cross product), so no (N, 3, 6) intermediate is built;
    one compiled pass (the products and differences of the array form, so the same numbers)."""
    _se3_jac_kernel(np.asarray(M, dtype=np.float64), np.asarray(P, dtype=np.float64), out)
    return out


def object_point_jacobians(K: np.ndarray, T_c: np.ndarray, T_m: np.ndarray, X: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Projection of model points X (N, 3) through T_c @ T_m with Jacobians.

    Returns uv (N, 2), J_cam (N, 2, 6), J_obj (N, 2, 6), valid (N,)."""
    X = np.asarray(X, dtype=np.float64)
    W = X @ T_m[:3, :3].T + T_m[:3, 3]
    Y = W @ T_c[:3, :3].T + T_c[:3, 3]
    uv, Ju, valid = project_jac(K, Y)
    n = len(X)
    J_cam = _se3_jac(Ju, Y, np.empty((n, 2, 6)))
    J_obj = _se3_jac((Ju.reshape(2 * n, 3) @ T_c[:3, :3]).reshape(n, 2, 3), W, np.empty((n, 2, 6)))
    return uv, J_cam, J_obj, valid


def transfer_point_jacobians(K_i: np.ndarray, T_c_i: np.ndarray, T_c_k: np.ndarray, Y_k: np.ndarray
                             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Projection into camera i of points Y_k (N, 3) given in camera k, with Jacobians.

    Returns uv (N, 2), J_i (N, 2, 6), J_k (N, 2, 6), valid (N,)."""
    Y_k = np.asarray(Y_k, dtype=np.float64)
    T_ik = T_c_i @ inv_T(T_c_k)
    Y_i = Y_k @ T_ik[:3, :3].T + T_ik[:3, 3]
    uv, Ju, valid = project_jac(K_i, Y_i)
    n = len(Y_k)
    J_i = _se3_jac(Ju, Y_i, np.empty((n, 2, 6)))
    J_k = _se3_jac((Ju.reshape(2 * n, 3) @ T_ik[:3, :3]).reshape(n, 2, 3), Y_k, np.empty((n, 2, 6)))
    np.negative(J_k, out=J_k)
    return uv, J_i, J_k, valid


def backproject_px(K: np.ndarray, uv: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """Pixels uv (N, 2) with z-depth (N,) -> camera points (N, 3) (closed-form K^-1, incl. skew)."""
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    d = np.asarray(depth, dtype=np.float64).reshape(-1)
    fx, fy, s, cx, cy = K[0, 0], K[1, 1], K[0, 1], K[0, 2], K[1, 2]
    y = (uv[:, 1] - cy) / fy
    x = (uv[:, 0] - cx - s * y) / fx
    return np.stack([x * d, y * d, d], axis=1)


def project_points(K: np.ndarray, T: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels (N, 2) of points X (N, 3) under T (4x4), valid (N,) (no Jacobians: the cheap path)."""
    uv, valid, _, _, _ = _project(K, np.asarray(X, dtype=np.float64) @ T[:3, :3].T + T[:3, 3])
    return uv, valid
