"""Procedural texture images (numpy + OpenCV), deterministic per seed.

Every function returns an (H, W, 3) uint8 RGB image. The patterns are chosen so that a
textured object has corners and interior edges (what the point/flow terms of the refiner
need), while a "plain" texture is a uniform colour (a textureless object).
"""
from __future__ import annotations

import cv2
import numpy as np


def smooth_noise(rng: np.random.Generator, size: int, cells: int, channels: int = 1) -> np.ndarray:
    """Smooth value noise in [0, 1]: a random (cells x cells) grid resized bicubically to size."""
    g = rng.random((cells, cells, channels)).astype(np.float32)
    out = cv2.resize(g, (size, size), interpolation=cv2.INTER_CUBIC)
    out = out.reshape(size, size, channels)
    return np.clip(out, 0.0, 1.0)


def _to_u8(img: np.ndarray) -> np.ndarray:
    return np.clip(np.round(img * 255.0), 0, 255).astype(np.uint8)


def plain(color_rgb: tuple[float, float, float], size: int = 64) -> np.ndarray:
    """A uniform colour (values in [0, 1]) -- the texture of a textureless object."""
    return _to_u8(np.broadcast_to(np.asarray(color_rgb, np.float32), (size, size, 3)).copy())


def checker_labels(rng: np.random.Generator, size: int = 512, n_checks: int = 8) -> np.ndarray:
    """Coloured checkerboard with random rectangles ("labels") and noise on top."""
    c0, c1 = rng.uniform(0.1, 0.5, 3), rng.uniform(0.55, 0.95, 3)
    yy, xx = np.mgrid[0:size, 0:size]
    cell = size // n_checks
    chk = ((yy // cell + xx // cell) % 2).astype(np.float32)[..., None]
    img = c0 * (1 - chk) + c1 * chk
    for _ in range(12):
        x0, y0 = rng.integers(0, size - 40, 2)
        w, h = rng.integers(15, 90, 2)
        img[y0:y0 + h, x0:x0 + w] = rng.uniform(0, 1, 3)
    img = img * (0.85 + 0.3 * smooth_noise(rng, size, 16))
    return _to_u8(img)


def stripes(rng: np.random.Generator, size: int = 512, n_stripes: int = 9) -> np.ndarray:
    """Vertical colour bands of random widths with blob noise (like a can label)."""
    edges = np.sort(rng.choice(np.arange(8, size - 8), n_stripes - 1, replace=False))
    bounds = np.concatenate([[0], edges, [size]])
    img = np.zeros((size, size, 3), np.float32)
    for a, b in zip(bounds[:-1], bounds[1:]):
        img[:, a:b] = rng.uniform(0.1, 0.95, 3)
    # a horizontal band and some dots break the symmetry along the stripes
    y0 = int(rng.integers(size // 4, size // 2))
    img[y0:y0 + size // 8] = img[y0:y0 + size // 8][:, ::-1] * 0.5 + rng.uniform(0.3, 0.9, 3) * 0.5
    for _ in range(40):
        c = tuple(int(v) for v in rng.integers(0, size, 2))
        cv2.circle(img, c, int(rng.integers(4, 16)), tuple(float(v) for v in rng.uniform(0, 1, 3)), -1)
    img = img * (0.85 + 0.3 * smooth_noise(rng, size, 24))
    return _to_u8(img)


def text_blobs(rng: np.random.Generator, size: int = 512) -> np.ndarray:
    """Light background with rows of dark word-like blocks (a printed package)."""
    bg = rng.uniform(0.7, 0.95, 3)
    img = np.broadcast_to(bg, (size, size, 3)).astype(np.float32).copy()
    ink = rng.uniform(0.0, 0.35, 3)
    y = 12
    while y < size - 20:
        h = int(rng.integers(6, 18))
        x = int(rng.integers(6, 30))
        while x < size - 20:
            w = int(rng.integers(8, 50))
            img[y:y + h, x:min(x + w, size - 6)] = ink if rng.random() > 0.15 else rng.uniform(0, 1, 3)
            x += w + int(rng.integers(4, 14))
        y += h + int(rng.integers(6, 20))
    # a logo-like disc
    c = tuple(int(v) for v in rng.integers(size // 4, 3 * size // 4, 2))
    cv2.circle(img, c, size // 8, tuple(float(v) for v in rng.uniform(0, 1, 3)), -1)
    return _to_u8(img)


def wood(rng: np.random.Generator, size: int = 1024) -> np.ndarray:
    """Table-top texture: brown wavy grain plus fine noise (enough texture for optical flow)."""
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float32) / size
    warp = smooth_noise(rng, size, 6)[..., 0]
    grain = 0.5 + 0.5 * np.sin(2 * np.pi * (18 * yy + 3.0 * warp))
    fine = smooth_noise(rng, size, 128)[..., 0]
    base = np.array([0.55, 0.38, 0.22], np.float32)
    dark = np.array([0.35, 0.22, 0.12], np.float32)
    t = (0.6 * grain + 0.4 * fine)[..., None]
    img = base * (1 - t) + dark * t
    # a few knots/marks
    img = np.ascontiguousarray(img)
    for _ in range(25):
        c = tuple(int(v) for v in rng.integers(0, size, 2))
        cv2.ellipse(img, c, (int(rng.integers(4, 20)), int(rng.integers(3, 10))), float(rng.uniform(0, 180)),
                    0, 360, tuple(float(v) for v in dark * 0.8), -1)
    return _to_u8(img)
