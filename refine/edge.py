"""Edge field of an image and edge-point sampling from rendered templates.

Edge field (paper Sec. 3.2): E = 1 - |grad I| / max |grad I| in [0, 1], small on strong edges.
For coarse-to-fine we compute the gradient of the image blurred with a Gaussian of standard
deviation ``sigma_px`` (derivative-of-Gaussian), so the basin of each edge widens with sigma.
The field is sampled bilinearly together with its first and second derivatives (for the
Newton-type step of :mod:`ycbvss.refine.terms`). Outside the image E = 1 and all derivatives 0.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


def to_gray_f32(image: np.ndarray) -> np.ndarray:
    """RGB uint8 (H, W, 3) or gray (H, W) -> gray float32 in [0, 255]."""
    img = np.asarray(image)
    if img.ndim == 3:
        img = cv2.cvtColor(img.astype(np.uint8), cv2.COLOR_RGB2GRAY)
    return img.astype(np.float32)


@dataclass
class EdgeField:
    """E and its derivatives stacked (H, W, 6): E, Eu, Ev, Euu, Euv, Evv (u = column, v = row)."""

    data: np.ndarray
    sigma_px: float

    @property
    def E(self) -> np.ndarray:
        return self.data[..., 0]

    @property
    def shape(self) -> tuple[int, int]:
        return self.data.shape[:2]


def gradient_magnitude(gray: np.ndarray, sigma_px: float) -> np.ndarray:
    """|grad (G_sigma * I)| (H, W) float32 (Sobel on the Gaussian-blurred image)."""
    g = cv2.GaussianBlur(gray, (0, 0), sigmaX=max(sigma_px, 0.3)) if sigma_px > 0 else gray
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3) / 8.0
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3) / 8.0
    return np.sqrt(gx * gx + gy * gy)


def edge_field(image: np.ndarray, sigma_px: float = 1.0) -> EdgeField:
    """Edge field of an image (RGB or gray) at blur ``sigma_px``.

    A uniform image (max gradient 0) gives E = 1 everywhere and zero derivatives (no pull)."""
    mag = gradient_magnitude(to_gray_f32(image), sigma_px)
    mx = float(mag.max())
    E = np.ones_like(mag) if mx <= 1e-6 else 1.0 - mag / mx
    Ev, Eu = np.gradient(E)
    Euv, Euu = np.gradient(Eu)
    Evv, _ = np.gradient(Ev)
    data = np.stack([E, Eu, Ev, Euu, Euv, Evv], axis=-1).astype(np.float32)
    return EdgeField(data, float(sigma_px))


def sample_bilinear(data: np.ndarray, uv: np.ndarray, outside: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Bilinear sample of ``data`` (H, W, C) at pixel positions uv (N, 2) (pixel centres at integers).

    Returns values (N, C) and inside (N,) bool; outside samples get ``outside`` (C,) (default 0)."""
    H, W = data.shape[:2]
    C = data.shape[2]
    uv = np.asarray(uv, dtype=np.float64)
    u, v = uv[:, 0], uv[:, 1]
    inside = np.isfinite(u) & np.isfinite(v) & (u >= 0) & (v >= 0) & (u <= W - 1) & (v <= H - 1)
    out = np.zeros((len(uv), C)) if outside is None else np.tile(np.asarray(outside, float), (len(uv), 1))
    if not np.any(inside):
        return out, inside
    ui, vi = u[inside], v[inside]
    u0 = np.minimum(np.floor(ui).astype(int), W - 2) if W > 1 else np.zeros(len(ui), int)
    v0 = np.minimum(np.floor(vi).astype(int), H - 2) if H > 1 else np.zeros(len(vi), int)
    a, b = (ui - u0)[:, None], (vi - v0)[:, None]
    u1, v1 = np.minimum(u0 + 1, W - 1), np.minimum(v0 + 1, H - 1)
    out[inside] = ((1 - a) * (1 - b) * data[v0, u0] + a * (1 - b) * data[v0, u1]
                   + (1 - a) * b * data[v1, u0] + a * b * data[v1, u1])
    return out, inside


def sample_field(field: EdgeField, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """E (N,), gradient (N, 2), Hessian (N, 2, 2) and inside (N,) of the field at uv (N, 2)."""
    vals, inside = sample_bilinear(field.data, uv, outside=np.array([1, 0, 0, 0, 0, 0], float))
    grad = vals[:, 1:3]
    H = np.empty((len(uv), 2, 2))
    H[:, 0, 0], H[:, 0, 1], H[:, 1, 0], H[:, 1, 1] = vals[:, 3], vals[:, 4], vals[:, 4], vals[:, 5]
    return vals[:, 0], grad, H, inside


# ---------------------------------------------------------------- template edge points
_N4 = ((0, 1), (0, -1), (1, 0), (-1, 0))


def contour_points(inst: np.ndarray, depth: np.ndarray, label: int) -> tuple[np.ndarray, np.ndarray]:
    """Exterior-contour samples of the silhouette ``inst == label``.

    A contour pixel is an object pixel with a 4-neighbour outside the object that is background or
    a surface farther away (an occluder's edge is not this object's contour); pixels on the image
    border are skipped (truncated silhouettes are no edges). Each sample is moved half a pixel
    outward (to the silhouette boundary between pixel centres). Returns uv (N, 2), depth (N,)."""
    H, W = inst.shape
    m = inst == label
    pad_i = np.pad(inst, 1, constant_values=-1)
    pad_d = np.pad(depth, 1, constant_values=0)
    dirs = np.zeros((H, W, 2), np.float32)
    is_c = np.zeros((H, W), bool)
    for dv, du in _N4:
        ni = pad_i[1 + dv:1 + dv + H, 1 + du:1 + du + W]
        nd = pad_d[1 + dv:1 + dv + H, 1 + du:1 + du + W]
        edge = m & (ni != label) & (ni != -1) & ((ni == 0) | (nd > depth))
        is_c |= edge
        dirs[edge] += (du, dv)
    is_c[0, :] = is_c[-1, :] = False
    is_c[:, 0] = is_c[:, -1] = False
    v, u = np.nonzero(is_c)
    d = dirs[v, u]
    n = np.linalg.norm(d, axis=1, keepdims=True)
    d = np.where(n > 0, d / np.maximum(n, 1e-9), 0.0)
    uv = np.stack([u, v], 1).astype(np.float64) + 0.5 * d
    return uv, depth[v, u].astype(np.float64)


def interior_points(inst: np.ndarray, depth: np.ndarray, color: np.ndarray, label: int,
                    canny_lo: float = 20.0, canny_hi: float = 60.0, erode_px: int = 2
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Interior Canny edges of the rendered colour inside the (eroded) silhouette: uv (N, 2), depth (N,)."""
    m = (inst == label).astype(np.uint8)
    if erode_px > 0:
        m = cv2.erode(m, np.ones((2 * erode_px + 1, 2 * erode_px + 1), np.uint8))
    if not m.any():
        return np.zeros((0, 2)), np.zeros(0)
    ys, xs = np.nonzero(m)
    y0, y1, x0, x1 = max(ys.min() - 2, 0), ys.max() + 3, max(xs.min() - 2, 0), xs.max() + 3
    gray = cv2.cvtColor(np.ascontiguousarray(color[y0:y1, x0:x1]), cv2.COLOR_RGB2GRAY)
    edges = cv2.Canny(gray, canny_lo, canny_hi) > 0
    edges &= m[y0:y1, x0:x1] > 0
    v, u = np.nonzero(edges)
    v, u = v + y0, u + x0
    return np.stack([u, v], 1).astype(np.float64), depth[v, u].astype(np.float64)


def subsample(n_max: int, n: int, rng: np.random.Generator) -> np.ndarray:
    """Indices of at most n_max of n items (random, without replacement, sorted)."""
    if n <= n_max:
        return np.arange(n)
    return np.sort(rng.choice(n, n_max, replace=False))
