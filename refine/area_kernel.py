"""Compiled (numba) pixel-area sums of a supersampled template (f x f sub-pixels per pixel).

:func:`ycbvss.refine.templates.average_subpixels` averages the sub-pixels that hit an object in
linear light. The kernel decodes each sub-pixel through the sRGB table and sums per pixel in one
pass, in the order NumPy's ``(lin * hit).sum(axis=(1, 3))`` adds them (row by row of the f x f
block, float32), so the sums are the same bit for bit (tests/test_area_kernel.py) without the
(h f, w f, 3) float32 temporaries.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def subpixel_sums(color_hi: np.ndarray, hit_hi: np.ndarray, decode: np.ndarray, f: int
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel of an (h f, w f) render (``color_hi`` uint8 sRGB (h f, w f, 3), ``hit_hi`` bool):
    the sum (h, w, 3) float32 of the hitting sub-pixels' linear colour (``decode`` (256,) float32:
    code -> linear) and their count (h, w, 1) float32."""
    h, w = color_hi.shape[0] // f, color_hi.shape[1] // f
    s = np.zeros((h, w, 3), np.float32)
    n = np.zeros((h, w, 1), np.float32)
    for y in range(h):
        for x in range(w):
            s0 = np.float32(0.0)
            s1 = np.float32(0.0)
            s2 = np.float32(0.0)
            c = np.float32(0.0)
            for a in range(f):
                for b in range(f):
                    yy, xx = y * f + a, x * f + b
                    hv = np.float32(1.0) if hit_hi[yy, xx] else np.float32(0.0)
                    s0 += decode[color_hi[yy, xx, 0]] * hv
                    s1 += decode[color_hi[yy, xx, 1]] * hv
                    s2 += decode[color_hi[yy, xx, 2]] * hv
                    c += hv
            s[y, x, 0], s[y, x, 1], s[y, x, 2] = s0, s1, s2
            n[y, x, 0] = c
    return s, n
