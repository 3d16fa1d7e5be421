"""Coverage of the real object pixels by the render of the enlarged model, and the scale choice.

coverage(o, s) = (# original visible pixels of o inside o's full silhouette at scale s)
               / (# original visible pixels of o), summed over all frames of the sequence(s).
"""
from __future__ import annotations

import numpy as np

SCALE_GRID = (1.02, 1.025, 1.03, 1.035, 1.04, 1.045, 1.05)
TARGET = 0.995


def covered_counts(renderer, K: np.ndarray, width: int, height: int, items: list[tuple[str, np.ndarray]],
                   visible: list[np.ndarray], scales: tuple[float, ...]) -> np.ndarray:
    """(n_items, n_scales) int: visible pixels of each item covered by its own full silhouette at each scale."""
    out = np.zeros((len(items), len(scales)), np.int64)
    if not items:
        return out
    for j, s in enumerate(scales):
        r = renderer.render(K, width, height, items, outputs=("mask_all",), scales=[s] * len(items))
        for k, m in enumerate(r.masks_all):
            out[k, j] = int(np.count_nonzero(m & visible[k]))
    return out


def choose_scale(covered: np.ndarray, total: int, grid: tuple[float, ...] = SCALE_GRID,
                 target: float = TARGET) -> tuple[float, float, bool]:
    """Smallest grid scale whose coverage >= target. Returns (scale, coverage, flagged): flagged when even
    the largest scale misses the target (then the largest is used)."""
    cov = np.asarray(covered, np.float64) / max(int(total), 1)
    if total == 0:
        return float(grid[0]), 1.0, False
    for s, c in zip(grid, cov):
        if c >= target:
            return float(s), float(c), False
    return float(grid[-1]), float(cov[-1]), True
