"""Analytic Jacobians of pinhole projections w.r.t. left se(3) increments of cameras and objects.

Conventions (as :mod:`ycbvss.geometry.se3`): xi = (v, w), left perturbation T' = exp(xi) T.
For a model point X, world point W = T_m X and camera point Y = T_c W:

- d Y / d xi_c = [I, -[Y]x]                      (camera increment)
- d Y / d xi_m = R_c [I, -[W]x]                  (object increment, applied in the world frame)
- d u / d Y    = [[fx/Z, 0, -fx X/Z^2], [0, fy/Z, -fy Y/Z^2]]   (skew ignored: s = K[0,1])

For a point Y_k fixed in camera k seen from camera i, Y_i = T_c_i T_c_k^-1 Y_k:

- d Y_i / d xi_i = [I, -[Y_i]x];  d Y_i / d xi_k = -R_ik [I, -[Y_k]x] with R_ik = R_c_i R_c_k^T.
"""
from __future__ import annotations

import numpy as np

from ycbvss.geometry.se3 import inv_T
from ycbvss.geometry.so3 import hat

MIN_Z_MM = 1.0   # points closer than this (or behind the camera) are invalid


def _point_jac(P: np.ndarray) -> np.ndarray:
    """[I, -[P]x] for points P (N, 3) -> (N, 3, 6)."""
    J = np.zeros(P.shape[:-1] + (3, 6))
    J[..., :, :3] = np.eye(3)
    J[..., :, 3:] = -hat(P)
    return J


def project_jac(K: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Project camera points Y (N, 3): pixels (N, 2), d u / d Y (N, 2, 3), valid (N,) (Z > MIN_Z_MM, finite)."""
    Y = np.asarray(Y, dtype=np.float64)
    Z = Y[:, 2]
    valid = np.isfinite(Y).all(axis=1) & (Z > MIN_Z_MM)
    Zs = np.where(valid, Z, 1.0)
    x, y = Y[:, 0] / Zs, Y[:, 1] / Zs
    fx, fy, s = K[0, 0], K[1, 1], K[0, 1]
    uv = np.stack([fx * x + s * y + K[0, 2], fy * y + K[1, 2]], axis=1)
    J = np.zeros((len(Y), 2, 3))
    J[:, 0, 0] = fx / Zs
    J[:, 0, 1] = s / Zs
    J[:, 0, 2] = -(fx * x + s * y) / Zs
    J[:, 1, 1] = fy / Zs
    J[:, 1, 2] = -fy * y / Zs
    return uv, J, valid


def object_point_jacobians(K: np.ndarray, T_c: np.ndarray, T_m: np.ndarray, X: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Projection of model points X (N, 3) through T_c @ T_m with Jacobians.

    Returns uv (N, 2), J_cam (N, 2, 6), J_obj (N, 2, 6), valid (N,)."""
    X = np.asarray(X, dtype=np.float64)
    W = X @ T_m[:3, :3].T + T_m[:3, 3]
    Y = W @ T_c[:3, :3].T + T_c[:3, 3]
    uv, Ju, valid = project_jac(K, Y)
    J_cam = Ju @ _point_jac(Y)
    J_obj = Ju @ (T_c[:3, :3] @ _point_jac(W))
    return uv, J_cam, J_obj, valid


def transfer_point_jacobians(K_i: np.ndarray, T_c_i: np.ndarray, T_c_k: np.ndarray, Y_k: np.ndarray
                             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Projection into camera i of points Y_k (N, 3) given in camera k, with Jacobians.

    Returns uv (N, 2), J_i (N, 2, 6), J_k (N, 2, 6), valid (N,)."""
    T_ik = T_c_i @ inv_T(T_c_k)
    Y_i = Y_k @ T_ik[:3, :3].T + T_ik[:3, 3]
    uv, Ju, valid = project_jac(K_i, Y_i)
    J_i = Ju @ _point_jac(Y_i)
    J_k = -(Ju @ (T_ik[:3, :3] @ _point_jac(Y_k)))
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
    Y = np.asarray(X, dtype=np.float64) @ T[:3, :3].T + T[:3, 3]
    Z = Y[:, 2]
    valid = np.isfinite(Y).all(axis=1) & (Z > MIN_Z_MM)
    Zs = np.where(valid, Z, 1.0)
    x, y = Y[:, 0] / Zs, Y[:, 1] / Zs
    return np.stack([K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2]], axis=1), valid
