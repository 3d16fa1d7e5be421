"""Tests of ycbvss.viz overlay/layout helpers. Budget: < 2 s."""
from __future__ import annotations

import numpy as np
import pytest

from ycbvss.errors import YcbvssError
from ycbvss.viz import (blend_render, colorize_depth, contact_sheet, contour_overlay, put_label, side_by_side,
                        to_rgb8)


def square_mask(H=60, W=80, y0=10, x0=20, n=25):
    m = np.zeros((H, W), bool)
    m[y0:y0 + n, x0:x0 + n] = True
    return m


def test_contour_of_square_is_exactly_its_border():
    img = np.zeros((60, 80, 3), np.uint8)
    m = square_mask()
    out = contour_overlay(img, [m], colors=[(255, 0, 0)])
    drawn = out.any(-1)
    ring = m & ~np.pad(m, 1)[2:, 1:-1] | m & ~np.pad(m, 1)[:-2, 1:-1] | m & ~np.pad(m, 1)[1:-1, 2:] \
        | m & ~np.pad(m, 1)[1:-1, :-2]
    assert ring.sum() == 4 * 25 - 4
    assert (drawn != ring).sum() == 0
    assert (out[drawn] == [255, 0, 0]).all()
    assert not img.any()  # input untouched


def test_thick_contour_stays_inside_and_has_thickness():
    m = square_mask()
    out = contour_overlay(np.zeros((60, 80), np.uint8), [m], thickness=3)
    drawn = out.any(-1)
    assert (drawn & ~m).sum() == 0
    # row through the middle of the square: exactly 3 px drawn at each side
    row = drawn[22, 20:45]
    assert row[:3].all() and row[-3:].all() and not row[3:-3].any()


def test_two_masks_get_distinct_palette_colours():
    m1 = square_mask(x0=2, n=10)
    m2 = square_mask(x0=40, n=10)
    out = contour_overlay(np.zeros((60, 80, 3), np.uint8), [m1, m2])
    c1 = np.unique(out[m1 & out.any(-1)], axis=0)
    c2 = np.unique(out[m2 & out.any(-1)], axis=0)
    assert len(c1) == 1 and len(c2) == 1 and (c1 != c2).any()


def test_blend_render_inside_mask_only():
    rng = np.random.default_rng(0)
    img = rng.integers(0, 256, (30, 40, 3), dtype=np.uint8)
    ren = rng.integers(0, 256, (30, 40, 3), dtype=np.uint8)
    m = np.zeros((30, 40), bool)
    m[5:15, 10:30] = True
    out = blend_render(img, ren, m, alpha=0.25)
    expect = np.rint(0.75 * img.astype(float) + 0.25 * ren.astype(float))
    assert np.abs(out[m].astype(float) - expect[m]).max() <= 0.5
    assert (out[~m] == img[~m]).all()
    with pytest.raises(YcbvssError):
        blend_render(img, ren[:10], m)


def test_contact_sheet_size_and_placement():
    ims = [np.full((20, 30, 3), 10 * (k + 1), np.uint8) for k in range(5)]
    ims[4] = np.full((12, 16), 200, np.uint8)  # smaller, grey: padded
    sheet = contact_sheet(ims, cols=3, gap=2, background=(0, 0, 0))
    assert sheet.shape == (2 * 20 + 2, 3 * 30 + 2 * 2, 3)
    # cell (row 1, col 0) holds image 3; image 4 at (row 1, col 1) is 12x16 then padding
    assert (sheet[22:42, 0:30] == 40).all()
    assert (sheet[22:34, 32:48] == 200).all() and (sheet[34:42, 32:62] == 0).all()
    labelled = contact_sheet(ims, cols=3, labels=["a", "b", "c", "d", "e"], gap=0)
    assert labelled.shape == (40, 90, 3)
    assert (labelled[0:20, 0:30] != 10).any()  # label drawn in the first cell
    with pytest.raises(YcbvssError):
        contact_sheet(ims, cols=2, labels=["only one"])


def test_side_by_side_and_labels():
    a = np.zeros((40, 50, 3), np.uint8)
    b = np.zeros((30, 60, 3), np.uint8)
    out = side_by_side([a, b], ["GT", "render"], gap=0)
    assert out.shape == (40, 110, 3)
    assert out[:20, :50].any() and out[:20, 50:].any()   # both labels drawn near the top-left of each panel
    assert not out[25:30, :50].any()
    assert side_by_side([a, b, a], gap=3).shape == (40, 50 + 60 + 50 + 2 * 3, 3)
    lab = put_label(a, "x")
    assert lab.any() and not a.any()


def test_to_rgb8_and_colorize_depth():
    assert to_rgb8(np.array([[0.0, 1.0, np.nan]])).tolist() == [[[0] * 3, [255] * 3, [0] * 3]]
    assert to_rgb8(np.array([[True, False]]))[0, 0].tolist() == [255, 255, 255]
    d = np.array([[0.0, 500.0, 1000.0]])
    c = colorize_depth(d, 500.0, 1000.0)
    assert (c[0, 0] == 0).all() and (c[0, 1] != c[0, 2]).any()
