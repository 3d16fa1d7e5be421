"""Exact OpenCV pinhole K -> Blender camera parameters (pure math, no bpy).

Blender (sensor_fit HORIZONTAL, square pixels) maps the image plane so that one pixel spans
``sensor_width / (lens * W)``; the frustum is shifted by ``shift * W`` pixels. Blender's pixel ``i`` spans ``[i, i+1]`` (centre ``i + 0.5``) while OpenCV's pixel
``i`` is centred at ``i``: the principal point in Blender's continuous coordinates is ``c + 0.5``.
"""
from __future__ import annotations

import numpy as np

SENSOR_WIDTH_MM = 36.0


def blender_camera_params(K, width: int, height: int) -> dict:
    """Blender camera settings reproducing K exactly (fx, fy, cx, cy; no skew), square pixels.

    Returns ``{"lens", "sensor_width", "shift_x", "shift_y", "y_scale"}``. Blender 5.0 cannot save
    multilayer EXR with a non-square pixel aspect, so fy != fx is realised by scaling the world
    (= OpenCV camera frame) along y by ``y_scale = fy / fx`` (exact for projection and z-depth).
    """
    K = np.asarray(K, np.float64).reshape(3, 3)
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    W, H = float(width), float(height)
    lens = fx * SENSOR_WIDTH_MM / W
    shift_x = -((cx + 0.5) - W / 2.0) / W
    shift_y = ((cy + 0.5) - H / 2.0) / W
    return {"lens": float(lens), "sensor_width": SENSOR_WIDTH_MM, "shift_x": float(shift_x),
            "shift_y": float(shift_y), "y_scale": float(fy / fx)}


# OpenCV camera (x right, y down, z forward) -> Blender camera (x right, y up, looks down -z)
CV_TO_BLENDER_CAM = np.diag([1.0, -1.0, -1.0, 1.0])


def border_from_bbox(bbox_px, width: int, height: int, pad_px: float = 4.0):
    """Pixel bbox (x0, y0, x1, y1), OpenCV pixel centres -> Blender border (min_x, max_x, min_y, max_y)
    in [0, 1] with y measured from the bottom. None if the bbox misses the image."""
    x0, y0, x1, y1 = bbox_px
    x0 = max(0.0, x0 + 0.5 - pad_px)
    x1 = min(float(width), x1 + 0.5 + pad_px)
    y0 = max(0.0, y0 + 0.5 - pad_px)
    y1 = min(float(height), y1 + 0.5 + pad_px)
    if x1 <= x0 or y1 <= y0:
        return None
    return (x0 / width, x1 / width, 1.0 - y1 / height, 1.0 - y0 / height)


def projected_bbox(K, T_m2c_mm, corners_mm) -> tuple[float, float, float, float] | None:
    """Pixel bbox of the projected model bounding-box corners; None if any corner is behind z=1 mm."""
    K = np.asarray(K, np.float64).reshape(3, 3)
    T = np.asarray(T_m2c_mm, np.float64).reshape(4, 4)
    X = np.asarray(corners_mm, np.float64) @ T[:3, :3].T + T[:3, 3]
    if np.any(X[:, 2] <= 1.0):
        return None
    uv = X[:, :2] / X[:, 2:3] @ K[:2, :2].T + K[:2, 2]
    return (float(uv[:, 0].min()), float(uv[:, 1].min()), float(uv[:, 0].max()), float(uv[:, 1].max()))
