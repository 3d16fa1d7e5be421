"""Where the template's interior texture edges can be trusted: not on surface curved at the pixel
scale (:func:`flat_at`), not on soft colour ramps (:func:`sharp_at`).

f_edge's interior samples are edges of the template, which is the model's albedo (texture),
optionally lit by a smooth, shadow-free lighting (:mod:`ycbvss.refine.shading`). On surface that
turns quickly within a pixel or two -- rounded box edges, can rims, the foam brick's bevels -- the
YCB-V scans' textures carry the capture's baked shading, whose edge lies wherever the capture light
put it, while the image's shading edge lies wherever the scene's light puts it; neither is the
geometric crease. :func:`flat_at` tells where the rendered normals within a small window turn less
than a limit (``RefineOptions.interior_max_turn_deg``, off by default; measurements there and in
bench/results/ycbv21/README.md, "interior texture edges on curved surface").
"""
from __future__ import annotations

import cv2
import numpy as np

MIN_SHARPNESS = 1.8    # sharp_at's default: |grad| at sigma 1 over sigma 2.5 (a step edge 2.0-2.3, a wide ramp -> 1)
MAX_TURN_DEG = 20.0     # flat_at's default limit (deg) on the normals' turn within FLAT_RADIUS_PX
FLAT_RADIUS_PX = 2


def flat_at(normal: np.ndarray, instance: np.ndarray, uv: np.ndarray, max_turn_deg: float = MAX_TURN_DEG,
            radius_px: int = FLAT_RADIUS_PX) -> np.ndarray:
    """(N,) bool: at the pixels uv (N, 2; rounded), the rendered unit normals (H, W, 3) of the same
    instance within +-radius_px turn less than ``max_turn_deg`` from the pixel's own (at 640 px
    width the radius covers about 2 mm at 1 m)."""
    if len(uv) == 0:
        return np.zeros(0, bool)
    H, W = instance.shape
    u = np.clip(np.round(uv[:, 0]).astype(int), 0, W - 1)
    v = np.clip(np.round(uv[:, 1]).astype(int), 0, H - 1)
    n0, i0 = normal[v, u], instance[v, u]
    d = np.arange(-radius_px, radius_px + 1)
    dy, dx = (a.ravel() for a in np.meshgrid(d, d, indexing="ij"))
    keep = (dx != 0) | (dy != 0)
    dy, dx = dy[keep], dx[keep]
    uu = np.clip(u[None, :] + dx[:, None], 0, W - 1)        # (neighbours, N), all gathered at once
    vv = np.clip(v[None, :] + dy[:, None], 0, H - 1)
    nb = normal[vv, uu]
    dot = nb[..., 0] * n0[:, 0] + nb[..., 1] * n0[:, 1] + nb[..., 2] * n0[:, 2]
    cos_min = np.minimum(np.where(instance[vv, uu] == i0, dot, 1.0).min(axis=0), 1.0)
    return cos_min >= np.cos(np.radians(max_turn_deg))


def sharpness_ratio(gray: np.ndarray, v: np.ndarray, u: np.ndarray) -> np.ndarray:
    """(N,) edge sharpness at pixels (v, u) of a grey image: the gradient magnitude after a Gaussian
    blur of sigma 1 px over that after sigma 2.5 px (Sobel). A step edge (softened by ~0.5 px of
    anti-aliasing) reads 2.0-2.3; a linear ramp much wider than 2.5 px reads about 1."""
    g = np.asarray(gray, np.float32)
    mags = []
    for s in (1.0, 2.5):
        b = cv2.GaussianBlur(g, (0, 0), s)
        mags.append(np.hypot(cv2.Sobel(b, cv2.CV_32F, 1, 0, ksize=3), cv2.Sobel(b, cv2.CV_32F, 0, 1, ksize=3))[v, u])
    return mags[0] / np.maximum(mags[1], 1e-6)


def sharp_at(gray: np.ndarray, v: np.ndarray, u: np.ndarray, min_ratio: float = MIN_SHARPNESS) -> np.ndarray:
    """(N,) bool: the template's edge pixels (v, u) that are sharp (:func:`sharpness_ratio` >=
    ``min_ratio``). A soft edge -- a colour ramp over several pixels, as the scans' baked shading
    and a banana's darker flank are -- has its gradient maximum wherever the scene's shading tilts
    the ramp, so the image puts it elsewhere than the unlit template: at the exact GT on the suite's
    Blender images the image-minus-template offset of interior edges is 0.149 px (median |.|)
    below 1.8 against 0.088 above 2.2 (bench/bench_interior_offsets.py; the banana's soft edges
    0.333 px)."""
    return sharpness_ratio(gray, v, u) >= min_ratio
