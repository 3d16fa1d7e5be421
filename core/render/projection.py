"""OpenGL clip-space projection from a pinhole K (OpenCV pixel-centre convention), pure numpy.

A camera-frame point X (mm, OpenCV axes: x right, y down, z forward) projects to pixel centre
``(u, v) = (fx X/Z + s Y/Z + cx, fy Y/Z + cy)``.  The rasteriser's window pixel (i, j) has its centre at
``(i + 0.5, j + 0.5)``; we map image column u to window x = u + 0.5 and image row v to window y = v + 0.5,
i.e. the image is stored bottom-up in GL terms so that ``glReadPixels`` (which returns window row 0 first)
yields image row 0 (top) first -- no flip on readback.  Clip w = Z, so ``1 / gl_FragCoord.w`` is the camera z.
This mirror turns the usual front-face winding around: outward faces seen by the camera are clockwise in
window coordinates (``FRONT_FACE = "cw"``).
"""
from __future__ import annotations

import numpy as np

FRONT_FACE = "cw"


def projection_from_K(K: np.ndarray, width: int, height: int, znear_mm: float, zfar_mm: float) -> np.ndarray:
    """4x4 (row-major, float64) matrix P mapping camera-frame homogeneous points to GL clip coordinates.

    ``x_ndc = (2u + 1)/W - 1``, ``y_ndc = (2v + 1)/H - 1``, ``z_ndc`` in [-1, 1] for Z in [znear, zfar]
    (standard perspective depth, only used for the z-test), ``w_clip = Z``.
    """
    K = np.asarray(K, dtype=np.float64)
    W, H = float(width), float(height)
    n, f = float(znear_mm), float(zfar_mm)
    P = np.zeros((4, 4))
    P[0, 0] = 2.0 * K[0, 0] / W
    P[0, 1] = 2.0 * K[0, 1] / W
    P[0, 2] = (2.0 * K[0, 2] + 1.0) / W - 1.0
    P[1, 1] = 2.0 * K[1, 1] / H
    P[1, 2] = (2.0 * K[1, 2] + 1.0) / H - 1.0
    P[2, 2] = (f + n) / (f - n)
    P[2, 3] = -2.0 * f * n / (f - n)
    P[3, 2] = 1.0
    return P


def clip_to_pixels(P: np.ndarray, X_cam: np.ndarray, width: int, height: int) -> np.ndarray:
    """Inverse mapping check helper: camera points (..., 3) -> image pixel coordinates (..., 2) through P.

    Equals :func:`ycbvss.camera.project` for any K (used by the tests to verify :func:`projection_from_K`).
    """
    X = np.asarray(X_cam, dtype=np.float64)
    Xh = np.concatenate([X, np.ones(X.shape[:-1] + (1,))], axis=-1)
    c = Xh @ P.T
    ndc = c[..., :2] / c[..., 3:4]
    u = ((ndc[..., 0] + 1.0) * width - 1.0) / 2.0
    v = ((ndc[..., 1] + 1.0) * height - 1.0) / 2.0
    return np.stack([u, v], axis=-1)


def roi_K(K: np.ndarray, x0: float, y0: float, scale: float = 1.0) -> np.ndarray:
    """Intrinsics of the image crop whose top-left pixel is (x0, y0) of the original image, optionally
    resized by ``scale`` (pixel-centre convention kept exact).  Rendering with ``roi_K(K, x0, y0)`` at size
    (w, h) gives exactly ``full_render[y0:y0+h, x0:x0+w]`` at a fraction of the cost."""
    K2 = np.asarray(K, dtype=np.float64).copy()
    K2[0, 2] -= x0
    K2[1, 2] -= y0
    if scale != 1.0:
        K2[:2, :2] *= scale
        K2[:2, 2] = (K2[:2, 2] + 0.5) * scale - 0.5
    return K2
