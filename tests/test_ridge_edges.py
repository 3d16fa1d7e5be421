"""Interior texture samples located on the template's own edge field (refine.edge.ridge_edges).

The images are analytic: each pixel holds the exact share of its area on either side of the edge
(a camera's pixel-area integration), so the true edge position is known to floating precision.
"""
import cv2
import numpy as np

from ycbvss.refine.edge import all_interior_points, edge_field, ridge_edges, sample_field, subpixel_offsets


def _area_step(x0_px: float, w: int = 64, h: int = 48, dark: float = 40.0, bright: float = 200.0) -> np.ndarray:
    """RGB uint8 image, dark left of the vertical line u = x0_px, bright right of it (pixel centres at
    integers, pixel i covering [i - 0.5, i + 0.5]), each pixel the area-weighted mix."""
    u = np.arange(w, dtype=np.float64)
    frac = np.clip(u + 0.5 - x0_px, 0.0, 1.0)          # share of the pixel right of the edge
    row = dark + (bright - dark) * frac
    img = np.repeat(row[None, :], h, axis=0)
    return np.repeat(np.rint(img)[..., None], 3, axis=2).astype(np.uint8)


def _area_line(c_px: float, width_px: float, w: int = 64, h: int = 48) -> np.ndarray:
    """A dark vertical line of ``width_px`` centred at u = c_px on a bright background, area-integrated."""
    u = np.arange(w, dtype=np.float64)
    lo, hi = c_px - width_px / 2, c_px + width_px / 2
    cover = np.clip(np.minimum(u + 0.5, hi) - np.maximum(u - 0.5, lo), 0.0, 1.0)
    row = 220.0 - 180.0 * cover
    img = np.repeat(row[None, :], h, axis=0)
    return np.repeat(np.rint(img)[..., None], 3, axis=2).astype(np.uint8)


def test_ridge_edges_locate_a_step_edge_to_a_few_hundredths_of_a_pixel():
    inside = np.zeros((48, 64), bool)
    inside[8:40, 8:56] = True
    for x0 in (20.0, 20.3, 31.55, 40.8):
        v, u, uv = ridge_edges(_area_step(x0), inside, sigma_px=1.0)
        assert len(uv) >= 25, x0
        err = uv[:, 0] - x0
        assert np.abs(err).max() < 0.06, (x0, np.abs(err).max())   # 8-bit rounding and the bicubic read
        assert np.abs(uv[:, 1] - v).max() < 1e-6                      # moved across the edge only


def test_ridge_samples_sit_at_the_minima_of_the_image_field():
    """On fine texture the ridge samples have (nearly) zero edge-field slope across the edge in the
    image they came from; Canny samples with the grey parabola do not (the bias the ridge removes)."""
    rng = np.random.default_rng(3)
    small = rng.integers(0, 256, (24, 32, 3)).astype(np.uint8)
    img = cv2.resize(small, (128, 96), interpolation=cv2.INTER_CUBIC)        # print-like blobs, 2-4 px
    inside = np.zeros((96, 128), bool)
    inside[6:90, 6:122] = True
    fld = edge_field(img, 1.0, colour=True)

    def across_slope(uv: np.ndarray) -> np.ndarray:
        """|dE/dn| (1/px) along the direction n of E's largest curvature (across the edge)."""
        _, g, H, _ = sample_field(fld, uv)
        w, vec = np.linalg.eigh(H)
        n = vec[:, :, 1]                        # eigenvector of the largest eigenvalue
        return np.abs(np.einsum("ni,ni->n", g, n))

    _, _, uv = ridge_edges(img, inside, sigma_px=1.0)
    gray = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    v, u = np.nonzero((cv2.Canny(gray, 20, 60) > 0) & inside)
    uv_c = np.stack([u, v], 1) + subpixel_offsets(gray, v, u)
    med_r = float(np.median(across_slope(uv)))
    med_c = float(np.median(across_slope(uv_c)))
    assert len(uv) > 300
    assert med_r < 0.01, med_r
    assert med_r < 0.25 * med_c, (med_r, med_c)


def test_thin_line_sides_are_symmetric_about_its_centre():
    inside = np.zeros((48, 64), bool)
    inside[8:40, 8:56] = True
    for c, wd in ((30.0, 3.0), (30.4, 2.5), (25.7, 4.0)):
        _, _, uv = ridge_edges(_area_line(c, wd), inside, sigma_px=1.0)
        left, right = uv[uv[:, 0] < c, 0], uv[uv[:, 0] > c, 0]
        assert len(left) >= 25 and len(right) >= 25, (c, wd)
        assert abs(0.5 * (left.mean() + right.mean()) - c) < 0.05, (c, wd, left.mean(), right.mean())


def test_all_interior_points_uses_the_ridge_locator_when_asked():
    img = _area_step(30.3)
    inst = np.zeros((48, 64), np.int32)
    inst[4:44, 4:60] = 1
    depth = np.where(inst > 0, 800.0, 0.0).astype(np.float32)
    uv_r, d_r, l_r = all_interior_points(inst, depth, img, None, texture_ridge_sigma_px=1.0)
    uv_c, _, _ = all_interior_points(inst, depth, img, None)
    assert len(uv_r) >= 30 and np.all(l_r == 1) and np.all(d_r == 800.0)
    assert np.abs(uv_r[:, 0] - 30.3).max() < 0.06
    assert len(uv_c) > 0
