"""Blur-matched contour samples (refine.contour_match) against anti-aliased discs.

The images are 8x8 supersampled box-filtered discs (area coverage per pixel, as a camera or Cycles'
pixel filter integrates), not the refiner's renderer; the template is the pixel-centre sampled
silhouette the fast renderer produces. The measured quantity is the mean signed distance (px, along
the radius) from each template contour sample to the minimum of the image's edge field along the
radius: what f_edge drives to zero. A template that looks larger than the image (negative mean)
pushes every object away from the camera by Z * offset / radius.
"""
import numpy as np
import pytest

from ycbvss.refine.contour_match import match_contour_to_blur
from ycbvss.refine.edge import contour_points, edge_field, sample_E

SS = 8


def _disc(radius_px: float, cx: float, cy: float, size: int = 120) -> tuple[np.ndarray, np.ndarray]:
    """Anti-aliased image (dark disc on a bright table, float) and pixel-centre silhouette (int)."""
    yy, xx = (np.mgrid[0:size * SS, 0:size * SS] + 0.5) / SS - 0.5
    inside = (xx - cx) ** 2 + (yy - cy) ** 2 < radius_px ** 2
    cover = inside.reshape(size, SS, size, SS).mean(axis=(1, 3))
    image = (60.0 + 140.0 * (1.0 - cover)).astype(np.float32)
    inst = ((np.arange(size)[None, :] - cx) ** 2 + (np.arange(size)[:, None] - cy) ** 2 < radius_px ** 2)
    return image, inst.astype(np.int32)


def _edge_offset_px(image, uv, centre, sigma_px) -> float:
    """Mean over samples of (radius of the image's E minimum) - (radius of the sample)."""
    field = edge_field(image, sigma_px)
    r = np.linalg.norm(uv - centre, axis=1)
    n = (uv - centre) / r[:, None]
    s = np.linspace(-2.5, 2.5, 501)
    E = np.stack([sample_E(field, uv + t * n) for t in s], axis=1)
    return float(s[np.argmin(E, axis=1)].mean())


@pytest.mark.parametrize("radius_px,sigma_px", [(12.0, 1.0), (25.0, 1.0), (25.0, 4.0)])
def test_matched_contour_sits_on_the_image_edge(radius_px, sigma_px):
    rng = np.random.default_rng(3)
    old, new = [], []
    for _ in range(4):
        cx, cy = 60.0 + rng.random(), 60.0 + rng.random()
        image, inst = _disc(radius_px, cx, cy)
        uv, _ = contour_points(inst, inst * 1000.0, 1)
        uvm = match_contour_to_blur(uv, np.ones(len(uv), int), inst, sigma_px)
        old.append(_edge_offset_px(image, uv, np.array([cx, cy]), sigma_px))
        new.append(_edge_offset_px(image, uvm, np.array([cx, cy]), sigma_px))
    # geometric samples: the blurred edge shows up inside them by about sigma^2 / (2 radius) plus
    # the half-pixel overshoot (measured -0.05 px at 25 px / sigma 1, -0.42 px at sigma 4)
    assert np.mean(old) < -0.03
    assert abs(np.mean(new)) < 0.025, (np.mean(old), np.mean(new))


def test_samples_without_an_edge_minimum_keep_their_position():
    inst = np.zeros((40, 40), np.int32)
    inst[20, 20] = 1                               # a one-pixel sliver: flat, symmetric field
    uv = np.array([[20.5, 20.0], [7.0, 7.0]])      # the second is far from the silhouette
    out = match_contour_to_blur(uv, np.array([1, 1]), inst, 1.0)
    assert np.all(np.isfinite(out))
    np.testing.assert_allclose(out[1], uv[1])
    assert np.linalg.norm(out[0] - uv[0]) <= 1.5
