"""Pinhole camera (OpenCV axes, no distortion, as BOP): intrinsics K, image size, projection."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import YcbvssError


def check_K(K: np.ndarray, path: str | None = None, where: str | None = None) -> np.ndarray:
    """Validate and return K as a (3, 3) float64 array; raise YcbvssError if malformed or singular."""
    K = np.asarray(K, dtype=np.float64)
    if K.size == 9:
        K = K.reshape(3, 3)
    if K.shape != (3, 3):
        raise YcbvssError(f"camera matrix K must be 3x3, got shape {K.shape}", path, where)
    if not np.all(np.isfinite(K)):
        raise YcbvssError("camera matrix K contains NaN/inf", path, where)
    if abs(np.linalg.det(K)) < 1e-9 or K[0, 0] <= 0 or K[1, 1] <= 0:
        raise YcbvssError(f"camera matrix K is singular or has non-positive focal length: {K.tolist()}",
                          path, where)
    return K


@dataclass
class Camera:
    """Pinhole camera. ``K`` (3x3, pixels), ``width``/``height`` (pixels).

    Pixel centres are at integer coordinates (OpenCV convention): pixel (u, v) covers
    [u - 0.5, u + 0.5] x [v - 0.5, v + 0.5].
    """

    K: np.ndarray
    width: int = 640
    height: int = 480

    def __post_init__(self):
        self.K = check_K(self.K)
        self.width, self.height = int(self.width), int(self.height)

    @property
    def fx(self) -> float:
        return float(self.K[0, 0])

    @property
    def fy(self) -> float:
        return float(self.K[1, 1])

    @property
    def cx(self) -> float:
        return float(self.K[0, 2])

    @property
    def cy(self) -> float:
        return float(self.K[1, 2])

    def project(self, X_cam: np.ndarray) -> np.ndarray:
        """Project camera-frame points (..., 3) to pixels (..., 2)."""
        return project(self.K, X_cam)

    def backproject(self, uv_px: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """Pixels (..., 2) with z-depth (...) -> camera-frame points (..., 3), same unit as depth."""
        return backproject(self.K, uv_px, depth)

    def scaled(self, s: float) -> "Camera":
        """Camera for an image resized by factor s (pixel-centre convention kept exact)."""
        K = self.K.copy()
        K[:2, :2] *= s
        K[:2, 2] = (K[:2, 2] + 0.5) * s - 0.5
        return Camera(K, int(round(self.width * s)), int(round(self.height * s)))


def project(K: np.ndarray, X_cam: np.ndarray) -> np.ndarray:
    """Pinhole projection of (..., 3) camera-frame points to (..., 2) pixels."""
    X = np.asarray(X_cam, dtype=np.float64)
    z = X[..., 2:3]
    xy = X[..., :2] / z
    return xy @ K[:2, :2].T + K[:2, 2]


def backproject(K: np.ndarray, uv_px: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """Inverse of :func:`project` given z-depth: (..., 2), (...) -> (..., 3)."""
    uv = np.asarray(uv_px, dtype=np.float64)
    d = np.asarray(depth, dtype=np.float64)[..., None]
    Kinv = np.linalg.inv(K)
    uv1 = np.concatenate([uv, np.ones(uv.shape[:-1] + (1,))], axis=-1)
    return (uv1 @ Kinv.T) * d


def depth_to_points(K: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """Depth image (H, W) -> camera-frame points (H, W, 3) in the depth's unit (0 = invalid)."""
    H, W = depth.shape
    u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    return backproject(K, np.stack([u, v], -1), depth)
