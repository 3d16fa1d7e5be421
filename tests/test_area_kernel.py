"""The compiled pixel-area sums (refine.area_kernel) against their array form: the supersampled
template's area colour and coverage bit for bit."""
from __future__ import annotations

import numpy as np
import pytest

from ycbvss.refine.templates import _decode_table, average_subpixels
from ycbvss.refine.srgb import encode_u8


def _reference(color_hi: np.ndarray, hit_hi: np.ndarray, f: int) -> tuple[np.ndarray, np.ndarray]:
    """average_subpixels' array form: decode, weight by the hits, sum over each f x f block."""
    h, w = color_hi.shape[0] // f, color_hi.shape[1] // f
    lin = _decode_table()[color_hi].reshape(h, f, w, f, 3)
    hit = hit_hi.reshape(h, f, w, f, 1).astype(np.float32)
    n = hit.sum(axis=(1, 3))
    avg = (lin * hit).sum(axis=(1, 3)) / np.maximum(n, 1.0)
    return encode_u8(avg), (n[..., 0] / float(f * f)).astype(np.float32)


@pytest.mark.parametrize("f", [2, 3])
def test_area_average_matches_array_form(f: int) -> None:
    rng = np.random.default_rng(5)
    for _ in range(5):
        h, w = rng.integers(20, 60, size=2)
        color = rng.integers(0, 256, size=(h * f, w * f, 3), dtype=np.uint8)
        hit = rng.random((h * f, w * f)) < rng.uniform(0.2, 0.9)
        got, ref = average_subpixels(color, hit, f), _reference(color, hit, f)
        assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])
        partial = (ref[1] > 0) & (ref[1] < 1)
        assert partial.sum() > 100      # partly covered pixels, where the average is over fewer sub-pixels
