"""Edge field sampling: sub-pixel minima (bicubic), exact interpolant gradients, colour edges.

Budget: < 2 s (small synthetic images only)."""
from __future__ import annotations

import numpy as np

from ycbvss.refine.edge import edge_field, sample_E, sample_field


def _step_image(b_px: float, width: int = 40, height: int = 12, lo: float = 40.0, hi: float = 200.0) -> np.ndarray:
    """A vertical step edge at column position b_px (pixel centres at integers, pixel u covers
    [u - 0.5, u + 0.5]), anti-aliased by exact area coverage. uint8 grey (H, W)."""
    u = np.arange(width, dtype=np.float64)
    cover = np.clip(b_px - (u - 0.5), 0.0, 1.0)          # fraction of the pixel left of the edge
    row = lo * cover + hi * (1.0 - cover)
    return np.repeat(np.round(row)[None], height, axis=0).astype(np.uint8)


def _argmin_u(field, v: float, u0: float, u1: float) -> float:
    us = np.arange(u0, u1, 0.01)
    E = sample_E(field, np.stack([us, np.full_like(us, v)], 1))
    return float(us[np.argmin(E)])


def test_bicubic_edge_minimum_lies_between_pixel_centres():
    """An edge half-way between two pixels: bicubic sampling puts E's minimum on it (< 0.1 px),
    bilinear sampling only on a pixel centre (measured error 0.3-0.5 px)."""
    err_cubic, err_linear = [], []
    for b in (20.2, 20.35, 20.5, 20.65, 20.8):
        img = _step_image(b)
        fc = edge_field(img, 1.0, interp="cubic")
        fl = edge_field(img, 1.0, interp="linear")
        err_cubic.append(abs(_argmin_u(fc, 6.0, 17.0, 24.0) - b))
        err_linear.append(abs(_argmin_u(fl, 6.0, 17.0, 24.0) - b))
    assert max(err_cubic) < 0.1, err_cubic
    assert max(err_linear) > 0.25, err_linear


def test_cubic_gradient_is_the_derivative_of_the_sampled_field():
    rng = np.random.default_rng(0)
    img = (rng.random((30, 40)) * 255).astype(np.uint8)
    f = edge_field(img, 1.5)
    uv = rng.uniform([2, 2], [37, 27], size=(200, 2))
    _, g, _, inside = sample_field(f, uv)
    assert inside.all()
    h = 1e-5
    gu = (sample_E(f, uv + [h, 0]) - sample_E(f, uv - [h, 0])) / (2 * h)
    gv = (sample_E(f, uv + [0, h]) - sample_E(f, uv - [0, h])) / (2 * h)
    err = np.abs(np.stack([gu, gv], 1) - g).max()
    assert err < 1e-5 * max(np.abs(g).max(), 1e-3), err
    # E itself: interpolating (equal to the grid values at pixel centres)
    ij = rng.integers([1, 1], [39, 29], size=(50, 2)).astype(float)
    assert np.abs(sample_E(f, ij) - f.E[ij[:, 1].astype(int), ij[:, 0].astype(int)]).max() < 1e-6


def test_colour_edge_field_sees_an_isoluminant_boundary():
    """Two colours of the same grey value (a yellow bottle on a light table, in the extreme): the
    grey-level field shows (almost) no edge, the colour field does."""
    img = np.zeros((40, 60, 3), np.uint8)
    img[:, :30] = (255, 200, 0)           # grey 0.299 R + 0.587 G + 0.114 B = 193.6
    img[:, 30:] = (150, 200, 255)         # grey 191.4
    img[:8, :8] = 0                       # a black/white reference edge sets the normalisation
    img[:8, 8:16] = 255
    v = np.full(5, 25.0)
    uv = np.stack([np.linspace(29.0, 30.0, 5), v], 1)
    e_grey = sample_E(edge_field(img, 1.0, colour=False), uv).min()
    e_colour = sample_E(edge_field(img, 1.0, colour=True), uv).min()
    assert e_grey > 0.95, e_grey
    assert e_colour < 0.6, e_colour
