"""Contour samples at the table (``RefineOptions.edge_table_mm``, ``refine.templates.near_plane``):
where an object meets the table its contact shadow moves the image's edge, so f_edge can leave
out the contour samples less than ``edge_table_mm`` above the support plane."""
from __future__ import annotations

import numpy as np
from ycbvss.refine.templates import ViewRender, near_plane, view_edge_candidates

K = np.array([[500.0, 0.0, 20.0], [0.0, 500.0, 25.0], [0.0, 0.0, 1.0]])


def test_near_plane_heights():
    # plane y = 30 mm (camera frame) with its normal -y: height above it = 30 - Y
    n_c, d_c = np.array([0.0, -1.0, 0.0]), -30.0
    depth = np.full(4, 1000.0)
    v = np.array([25.0, 35.0, 38.9, 41.0])          # Y = (v - 25) * 2 mm at 1000 mm: 0, 20, 27.8, 32
    uv = np.c_[np.full(4, 20.0), v]
    np.testing.assert_array_equal(near_plane(uv, depth, n_c, d_c, K, 5.0), [False, False, True, True])
    # the same points twice as far: Y doubles, so only the first stays above 5 mm
    np.testing.assert_array_equal(near_plane(uv, 2 * depth, n_c, d_c, K, 5.0), [False, True, True, True])


def _block() -> ViewRender:
    """One flat block (rows 10-39, columns 8-31) at 1000 mm in a 50 x 40 view."""
    inst = np.zeros((50, 40), np.int32)
    depth = np.zeros((50, 40), np.float32)
    inst[10:40, 8:32], depth[10:40, 8:32] = 1, 1000.0
    return ViewRender(inst, depth, np.zeros((50, 40, 3), np.uint8), [np.eye(4)], [0])


def test_contour_samples_near_the_table_are_left_out():
    vr = _block()
    # the table plane through the block's lower boundary (v = 39.5 -> Y = 29 mm), normal -y
    plane = (np.array([0.0, -1.0, 0.0]), -29.0, K, 10.0)
    c0 = view_edge_candidates(vr, blur_sigma_px=None)
    c1 = view_edge_candidates(vr, blur_sigma_px=None, table_plane=plane)
    h0 = -(c0.uv_c[:, 1] - 25.0) * 2.0 * (c0.d_c / 1000.0) + 29.0       # height above the plane (mm)
    low = h0 < 10.0
    assert low.sum() > 20 and (~low).sum() > 40          # the lower edge and the sides' lowest 5 px go
    assert len(c1.uv_c) == int((~low).sum())
    np.testing.assert_allclose(np.sort(c1.uv_c[:, 1]), np.sort(c0.uv_c[~low, 1]))
    # the interior candidates are not touched
    assert len(c1.uv_i) == len(c0.uv_i)



def test_offset_mode_keeps_the_table_samples_and_gives_only_them_normals():
    vr = _block()
    plane = (np.array([0.0, -1.0, 0.0]), -29.0, K, 10.0)
    c0 = view_edge_candidates(vr, blur_sigma_px=None)
    c1 = view_edge_candidates(vr, blur_sigma_px=None, table_plane=plane, table_offset=True, normals=True,
                              normals_contact_mm=1e-3)
    assert len(c1.uv_c) == len(c0.uv_c)
    h = -(c1.uv_c[:, 1] - 25.0) * 2.0 * (c1.d_c / 1000.0) + 29.0
    has_n = np.any(c1.n_c != 0.0, axis=1)
    # no other object here, so the shared-offset samples are exactly the table's
    np.testing.assert_array_equal(has_n, h < 10.0)
    assert has_n.sum() > 20
