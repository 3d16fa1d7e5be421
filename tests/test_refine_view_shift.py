"""The 2-D template shift check of a view's camera (ycbvss.refine.view_shift); unit tests. The
images are synthetic: no evidence of accuracy, only of the measure's geometry (the suite case that
motivated it is in refine/view_shift.py's docstring; the check through the refiner's evidence code
on fast-rendered views is in tests/test_refine_status.py, on Cycles images in tests/test_refine_suite.py).

Budget: ~2 s on 2 cores."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from ycbvss.refine.confidence import VIEW_SHIFT_PX, classify
from ycbvss.refine.view_shift import object_shift_px, view_shift_px


def _textured_blob(shape=(240, 320), centre=(120, 160), radius=50, seed=0):
    """An edge-magnitude image of a disc with a random smooth texture on a flat background, and its mask."""
    rng = np.random.default_rng(seed)
    tex = cv2.GaussianBlur(rng.normal(0, 1, shape).astype(np.float32), (0, 0), 2.0)
    yy, xx = np.mgrid[: shape[0], : shape[1]]
    mask = (yy - centre[0]) ** 2 + (xx - centre[1]) ** 2 <= radius ** 2
    img = np.where(mask, 100 + 40 * tex / tex.std(), 60).astype(np.float32)
    gx, gy = cv2.Sobel(img, cv2.CV_32F, 1, 0), cv2.Sobel(img, cv2.CV_32F, 0, 1)
    return np.sqrt(gx * gx + gy * gy), mask


@pytest.mark.parametrize("dy,dx", [(0, 0), (5, -3), (-9, 0), (2, 12)])
def test_object_shift_reads_the_translation_between_template_and_image(dy, dx):
    mag, mask = _textured_blob()
    M = np.float32([[1, 0, dx], [0, 1, dy]])
    moved = cv2.warpAffine(mag, M, (mag.shape[1], mag.shape[0]))       # the image: the object moved by (dx, dy)
    s, best, zero = object_shift_px(moved, mag, mask, reach_px=16)
    assert s == pytest.approx(np.hypot(dx, dy), abs=1e-9)
    assert best > 0.9
    if dx or dy:
        assert zero < best - 0.2


def test_object_shift_beyond_the_reach_reads_the_reach():
    mag, mask = _textured_blob()
    moved = cv2.warpAffine(mag, np.float32([[1, 0, 30], [0, 1, 0]]), (mag.shape[1], mag.shape[0]))
    s, best, zero = object_shift_px(moved, mag, mask, reach_px=8)
    assert best < 0.2 and s == 8.0      # the template fits nowhere in the window: at least the reach off


def test_object_shift_is_nan_for_a_tiny_or_flat_object():
    mag, mask = _textured_blob(radius=6)
    assert np.isnan(object_shift_px(mag, mag, mask)[0])          # fewer than MIN_PX pixels
    flat = np.zeros((240, 320), np.float32)
    _, big = _textured_blob()
    assert np.isnan(object_shift_px(flat, flat, big)[0])         # no contrast in the template


def test_view_shift_is_the_median_of_the_measured_objects():
    assert view_shift_px([0.0, 1.0, 9.0, float("nan")]) == 1.0
    assert np.isnan(view_shift_px([float("nan")]))
    assert np.isnan(view_shift_px([]))


def test_classify_flags_a_view_whose_objects_fit_the_image_elsewhere():
    ok = classify(0.3, 0.5, 0.0, observed=True, view_shift_px=1.0)
    assert ok.status == "converged"
    off = classify(0.3, 0.5, 0.0, observed=True, view_shift_px=VIEW_SHIFT_PX + 0.5)
    assert off.status == "uncertain" and "camera is off" in off.reason
    assert off.confidence == pytest.approx(ok.confidence * 0.5)
    # the bound scales with the image width: 4 px is within it at 1280 px
    assert classify(0.3, 0.5, 0.0, observed=True, width_px=1280, view_shift_px=4.0).status == "converged"
    assert classify(0.3, 0.5, 0.0, observed=True).status == "converged"      # unmeasured: no verdict
