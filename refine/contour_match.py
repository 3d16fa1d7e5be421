"""Where the blurred edge field shows a template's silhouette: blur-matched contour points.

f_edge pulls template contour samples into minima of the image's edge field E (Gaussian blur of
standard deviation sigma, then Sobel; :mod:`ycbvss.refine.edge`). Blurring a curved silhouette
moves the edge-strength maximum towards the centre of curvature by about
kappa * sigma_eff^2 / 2 px (kappa = 1 / radius of curvature): a disc of 20 px radius shows its
edge 0.04 px inside at sigma 1 px and 0.4 px inside at sigma 4 px. The geometric contour point
(pixel centre + half a pixel outward) also sits 0.02-0.05 px outside the true boundary on average
(the half-pixel step along the summed 4-neighbour direction overshoots on diagonal stretches).
Both make the template look larger than what E shows, so the whole scene drifts away from the
cameras by Z * offset / radius (1-3 mm at 1 m). :func:`match_contour_to_blur` instead places each
contour sample where the same edge field, computed on the template's own binary silhouette, has
its minimum: the image and the template then go through the same filter, and the pixel-centre
sampled silhouette is unbiased in area, so the prediction is unbiased for any curvature.
"""
from __future__ import annotations

import cv2
import numpy as np

from .edge import EdgeField, gradient_magnitude, sample_bilinear, sample_E


def search_px(sigma_px: float) -> tuple[float, float]:
    """Half-width and coarse step (px) of the search along the normal around the geometric contour
    point: 1 + sigma / 2 px wide (the blur shift reaches about sigma^2 / (2 * radius)), steps of
    max(0.25, sigma / 8) px; the coarse minimum is refined on a five times finer grid and a parabola."""
    return 1.0 + 0.5 * sigma_px, max(0.25, sigma_px / 8.0)


def _crop_box(uv: np.ndarray, shape: tuple[int, int], margin_px: int) -> tuple[int, int, int, int]:
    """(y0, x0, y1, x1) of the samples uv (N, 2) grown by ``margin_px``, clipped to ``shape``."""
    H, W = shape
    lo = np.floor(uv.min(axis=0)).astype(int) - margin_px
    hi = np.ceil(uv.max(axis=0)).astype(int) + margin_px + 1
    return max(lo[1], 0), max(lo[0], 0), min(hi[1], H), min(hi[0], W)


def _edge_cost(mask_f: np.ndarray, sigma_px: float) -> EdgeField:
    """E only (no derivatives) of a silhouette image, as :func:`ycbvss.refine.edge.edge_field` computes it."""
    mag = gradient_magnitude(mask_f, sigma_px)
    mx = float(mag.max())
    E = np.ones_like(mag) if mx <= 1e-6 else 1.0 - mag / mx
    return EdgeField(E[..., None], float(sigma_px))


def _outward_normals(mask_f: np.ndarray, sigma_px: float, uv: np.ndarray) -> np.ndarray:
    """Unit outward normals (N, 2) at uv of the Gaussian-blurred silhouette (the mask falls outward)."""
    g = cv2.GaussianBlur(mask_f, (0, 0), max(sigma_px, 1.0))
    gu = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3)
    gv = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3)
    grad = sample_bilinear(np.stack([gu, gv], -1), uv)[0]
    n = -grad
    nn = np.linalg.norm(n, axis=1, keepdims=True)
    return np.where(nn > 1e-9, n / np.maximum(nn, 1e-9), 0.0)


def _grid_minimum(field, uv: np.ndarray, n: np.ndarray, t0: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index (N,) of the smallest E along uv + (t0 + s) n over the offsets s (S,), and E (N, S)."""
    t = t0[:, None] + s[None, :]
    P = (uv[:, None, :] + t[..., None] * n[:, None, :]).reshape(-1, 2)
    E = sample_E(field, P).reshape(len(uv), len(s))
    return np.argmin(E, axis=1), E


def _minimum_along(field, uv: np.ndarray, n: np.ndarray, half_px: float, step_px: float) -> np.ndarray:
    """Signed offsets t (N,) in [-half_px, half_px] of the minimum of E along uv + t n: coarse grid
    of ``step_px``, a five times finer grid around its minimum, a parabola through the fine minimum
    and its two neighbours."""
    coarse = np.arange(-half_px, half_px + 1e-9, step_px)
    k, _ = _grid_minimum(field, uv, n, np.zeros(len(uv)), coarse)
    fine_step = step_px / 5.0
    fine = np.arange(-5, 6) * fine_step
    k2, E = _grid_minimum(field, uv, n, coarse[k], fine)
    k2 = np.clip(k2, 1, len(fine) - 2)
    r = np.arange(len(uv))
    e0, e1, e2 = E[r, k2 - 1], E[r, k2], E[r, k2 + 1]
    den = e0 - 2.0 * e1 + e2
    frac = np.where(den > 1e-12, 0.5 * (e0 - e2) / np.where(den > 1e-12, den, 1.0), 0.0)
    return np.clip(coarse[k] + fine[k2] + np.clip(frac, -1.0, 1.0) * fine_step, -half_px, half_px)


def match_contour_to_blur(uv: np.ndarray, labels: np.ndarray, inst: np.ndarray, sigma_px: float) -> np.ndarray:
    """Contour samples uv (N, 2) (px, pixel centres at integers) of the silhouettes ``inst == label``
    moved along their outward normals to the minimum of the edge field (blur ``sigma_px``) of each
    object's own binary silhouette; (N, 2). A sample whose minimum is not found inside the search
    window (:func:`search_px`; flat field, e.g. a one-pixel sliver) keeps its position."""
    out = np.array(uv, dtype=np.float64, copy=True)
    if len(out) == 0:
        return out
    half_px, step_px = search_px(sigma_px)
    margin = int(np.ceil(3.0 * max(sigma_px, 1.0) + half_px)) + 2
    for lab in np.unique(labels):
        sel = np.flatnonzero(labels == lab)
        y0, x0, y1, x1 = _crop_box(out[sel], inst.shape, margin)
        mask_f = (inst[y0:y1, x0:x1] == lab).astype(np.float32) * 255.0
        p = out[sel] - (x0, y0)
        n = _outward_normals(mask_f, sigma_px, p)
        t = _minimum_along(_edge_cost(mask_f, sigma_px), p, n, half_px, step_px)
        ok = (np.abs(t) < half_px - step_px) & np.any(n != 0.0, axis=1)
        out[sel[ok]] = out[sel[ok]] + t[ok, None] * n[ok]
    return out
