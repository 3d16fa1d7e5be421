"""Model frames: the bounding-box centre of a model and poses re-expressed in a recentred frame.

BOP (and YCBV-SS) models are recentred on the centre ``c`` of their axis-aligned bounding box:
a point ``X`` of the original frame is ``X - c`` in the recentred one, so a pose ``(R, t)`` of the
original model becomes ``(R, t + R c)``.
"""
from __future__ import annotations

import numpy as np


def bbox_center(vertices: np.ndarray) -> np.ndarray:
    """Centre of the axis-aligned bounding box of (N, 3) vertices, (3,), in their unit."""
    v = np.asarray(vertices, np.float64)
    return (v.min(axis=0) + v.max(axis=0)) / 2.0


def recentre_pose(T_m2c: np.ndarray, c: np.ndarray) -> np.ndarray:
    """4x4 pose of the model recentred by ``X' = X - c``: ``t' = t + R c`` (a new array)."""
    T = np.array(T_m2c, np.float64, copy=True)
    T[:3, 3] = T[:3, 3] + T[:3, :3] @ np.asarray(c, np.float64)
    return T


def uncentre_pose(T_m2c: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Inverse of :func:`recentre_pose`: ``t = t' - R c`` (a new array)."""
    T = np.array(T_m2c, np.float64, copy=True)
    T[:3, 3] = T[:3, 3] - T[:3, :3] @ np.asarray(c, np.float64)
    return T
