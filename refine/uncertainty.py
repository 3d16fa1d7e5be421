"""Per-object, per-camera and per-pose uncertainty from the covariance of the se(3) increments.

For a left increment xi = (v, w) of a pose T = [R, t], the origin moves by v + w x t, so the
covariance of the translation is A C A^T with A = [I, -[t]x]; the rotation's is the w block.
We report sigma_t_mm (3,) = sqrt(diag) of the translation covariance (in the frame the pose maps
into: world for objects, camera for cameras and per-view poses) and sigma_r_deg = sqrt of the
largest eigenvalue of the rotation covariance, in degrees. For P_ij = T_c T_m the increment is
xi_c + Ad(T_c) xi_m, combining the camera and object covariances (with their cross term).
"""
from __future__ import annotations

import numpy as np

from ..geometry.se3 import adjoint
from ..geometry.so3 import hat


def sigmas_of(T: np.ndarray, C: np.ndarray) -> dict:
    A = np.hstack([np.eye(3), -hat(T[:3, 3])])
    Ct = A @ C @ A.T
    Cr = C[3:, 3:]
    return {"sigma_t_mm": np.sqrt(np.maximum(np.diag(Ct), 0.0)).tolist(),
            "sigma_r_deg": float(np.degrees(np.sqrt(max(float(np.linalg.eigvalsh(0.5 * (Cr + Cr.T)).max()), 0.0))))}


def pose_sigmas(T_c, T_m, cam_cov: dict, obj_cov: dict, cross: dict, im_ids: list, obj_ids: list, known) -> dict:
    out = {"objects": {}, "cameras": {}, "poses": {}}
    for j, C in obj_cov.items():
        out["objects"][obj_ids[j]] = sigmas_of(T_m[j], C)
    for i, C in cam_cov.items():
        out["cameras"][im_ids[i]] = sigmas_of(T_c[i], C)
    for i in range(len(im_ids)):
        for j in range(len(obj_ids)):
            if not known[j] or j not in obj_cov:
                continue
            Ad = adjoint(T_c[i])
            C = Ad @ obj_cov[j] @ Ad.T
            if i in cam_cov:
                X = cross.get((i, j), np.zeros((6, 6)))
                C = C + cam_cov[i] + X @ Ad.T + Ad @ X.T
            out["poses"][(im_ids[i], obj_ids[j])] = sigmas_of(T_c[i] @ T_m[j], C)
    return out
