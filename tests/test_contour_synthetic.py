"""refine.contour_match.synthetic_image / synthetic_contour_offsets: the contour where the image's own
edge operator finds it on the image a pixel-area template predicts.

The image is formed analytically (a disc whose outermost 0.4 px is a dark band, integrated over
16 x 16 sub-pixels per pixel in linear light), never by the fast renderer; the template is the same
disc's 4 x 4 pixel-area colour and coverage, a coarser sampling."""
from __future__ import annotations

import numpy as np

from ycbvss.refine.contour_match import _minimum_along, synthetic_contour_offsets, synthetic_image
from ycbvss.refine.edge import edge_field, linear_to_srgb, srgb_to_linear

SIZE, CX, CY, R_PX, BAND_PX = 96, 47.3, 48.6, 30.0, 0.4
BRIGHT, DARK, BG = 200, 40, 110          # sRGB values


def _disc(f: int, band_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Colour (linear, per sub-pixel) and hit mask of the disc at f x f sub-pixels per pixel
    (pixel centres at integers)."""
    s = (np.arange(SIZE * f) + 0.5) / f - 0.5
    x, y = np.meshgrid(s, s)
    r = np.hypot(x - CX, y - CY)
    hit = r < R_PX
    lin = np.where(r >= R_PX - band_px, srgb_to_linear(np.uint8(DARK)), srgb_to_linear(np.uint8(BRIGHT)))
    return lin * hit, hit


def _pixels(f: int, band_px: float) -> tuple[np.ndarray, np.ndarray]:
    """(colour averaged over each pixel's covered sub-pixels, linear; coverage) at f x f."""
    lin, hit = _disc(f, band_px)
    s = lin.reshape(SIZE, f, SIZE, f).sum(axis=(1, 3))
    n = hit.reshape(SIZE, f, SIZE, f).sum(axis=(1, 3))
    return s / np.maximum(n, 1), n / float(f * f)


def _u8(lin: np.ndarray) -> np.ndarray:
    return np.repeat(np.clip(np.rint(linear_to_srgb(lin)), 0, 255).astype(np.uint8)[..., None], 3, axis=2)


def _samples() -> tuple[np.ndarray, np.ndarray]:
    a = np.linspace(0.0, 2.0 * np.pi, 96, endpoint=False)
    n = np.stack([np.cos(a), np.sin(a)], axis=1)
    return np.array([CX, CY]) + R_PX * n, n


def _image() -> np.ndarray:
    col, cov = _pixels(16, BAND_PX)
    return _u8(cov * col + (1.0 - cov) * srgb_to_linear(np.uint8(BG)))


def _offsets(band_px: float) -> tuple[np.ndarray, np.ndarray]:
    """(the image's edge offsets, the synthetic prediction's) along the normals from the true contour."""
    img = _image()
    uv, n = _samples()
    t_img = _minimum_along(edge_field(img, 1.0, colour=True), uv, n, 1.5, 0.25)
    col, cov = _pixels(4, band_px)
    instance = (_disc(1, 0.0)[1]).astype(np.int32)
    syn = synthetic_image(instance, cov, _u8(col), img, ring_px=2.5)
    return t_img, synthetic_contour_offsets(uv, n, syn, 1.0)


def test_synthetic_prediction_holds_a_sub_pixel_rim_band():
    t_img, t_syn = _offsets(BAND_PX)
    assert np.all(np.isfinite(t_syn))
    # the dark band moves the image's edge inside the disc
    assert t_img.mean() < -0.15
    # the 4 x 4 pixel-area template predicts it to within 0.03 px on average
    assert abs(float(np.mean(t_syn - t_img))) < 0.03


def test_a_template_without_the_band_misses_it():
    t_img, t_flat = _offsets(0.0)
    assert float(np.mean(t_flat - t_img)) > 0.15


def test_background_beside_the_silhouette_comes_from_beyond_the_ring():
    img = np.zeros((40, 40, 3), np.uint8)
    img[:, :] = 90
    img[18:22, 18:22] = 250                      # the object's own edge in the image, beside the silhouette
    inst = np.zeros((40, 40), np.int32)
    inst[19:21, 19:21] = 1
    col = np.zeros((40, 40, 3), np.uint8)
    col[inst > 0] = 30
    syn = synthetic_image(inst, None, col, img, ring_px=2.5)
    assert np.all(syn[inst > 0] == 30)
    ring = (np.abs(np.arange(40)[:, None] - 19.5) < 3) & (np.abs(np.arange(40)[None, :] - 19.5) < 3) & (inst == 0)
    assert np.all(np.abs(syn[ring].astype(int) - 90) <= 1)


def test_edge_candidates_follow_the_synthetic_prediction():
    """view_edge_candidates(appearance_model="synthetic"): the contour samples lie where the image's
    edge does (the band's), not where the binary silhouette's blur puts them."""
    from ycbvss.refine.templates import ViewRender, view_edge_candidates

    img = _image()
    inst = _disc(1, 0.0)[1].astype(np.int32)
    col4, cov4 = _pixels(4, BAND_PX)
    depth = np.where(inst > 0, 800.0, 0.0).astype(np.float32)
    vr = ViewRender(inst, depth, _u8(col4), [np.eye(4)], [0], area_color=_u8(col4), coverage=cov4.astype(np.float32))
    fld = edge_field(img, 1.0, colour=True)
    c_bin = view_edge_candidates(vr, blur_sigma_px=1.0, normals=True)
    c_syn = view_edge_candidates(vr, blur_sigma_px=1.0, normals=True, image=img, appearance_color=_u8(col4),
                                 appearance_model="synthetic", appearance_coverage=cov4.astype(np.float32))
    assert len(c_syn.uv_c) > 0.9 * len(c_bin.uv_c)

    def rest(c) -> float:       # mean distance (px, along the normals) from each sample to the image's edge
        return float(np.mean(np.abs(_minimum_along(fld, c.uv_c, c.n_c, 1.5, 0.25))))

    # measured: binary 0.49 px, the refiner's 1-D profile prediction 0.23 px, synthetic 0.02 px
    assert rest(c_bin) > 0.3
    assert rest(c_syn) < 0.1


def test_camera_blur_widens_the_edge_by_its_sigma():
    """synthetic_image(psf_sigma_px=s): the edge of a half-plane, in linear light, is a Gaussian step of
    that sigma (its 25-75 % width 1.349 s; the interpolated crossing points of the pixel values)."""
    H, W = 24, 40
    inst = np.zeros((H, W), np.int32)
    inst[:, 20:] = 1
    col = np.full((H, W, 3), 230, np.uint8)
    img = np.full((H, W, 3), 20, np.uint8)
    for s in (0.8, 1.5):
        lin = srgb_to_linear(synthetic_image(inst, None, col, img, ring_px=2.5, psf_sigma_px=s))[H // 2, :, 0]
        lo, hi = srgb_to_linear(np.uint8(20)), srgb_to_linear(np.uint8(230))
        f = (lin - lo) / (hi - lo)                     # 0 .. 1 across the edge at x = 19.5
        assert np.all(np.diff(f) >= -1e-3)
        x = np.arange(W, dtype=float)
        q25, q75 = np.interp(0.25, f, x), np.interp(0.75, f, x)
        assert abs((q25 + q75) / 2 - 19.5) < 0.05
        assert abs((q75 - q25) - 1.349 * s) < 0.2 * s
