"""Area-integrated templates (``RefineOptions.template_supersample``, ``refine.templates.average_subpixels``).

A camera integrates light over each pixel's area; the fast renderer samples at the pixel centre.
These unit tests check the mechanics with the fast renderer alone (no accuracy claim):

- the crop intrinsics: the colour of ``render_view(..., supersample=f)`` equals the linear-light mean
  of an f x f larger full-frame render (within one 8-bit code for 99.9 % of the pixels; measured: one
  pixel of 33064 off, by 15 codes, where a sub-pixel centre falls on a texel boundary);
- the coverage: summed over the image it equals the plane's analytic projected area to within
  0.01 px of its perimeter (the supersampled silhouette is unbiased);
- the composite: a partly covered pixel is the linear-light mix of the object's colour and the
  background beside it; without ``area`` the point-sampled template is composited as before.
Budget: ~2 s.
"""
from __future__ import annotations

import numpy as np
import pytest

K = np.array([[1066.778, 0.0, 312.9869], [0.0, 1067.487, 241.3109], [0.0, 0.0, 1.0]])
W, H = 640, 480
SIZE_MM = 120.0


def _srgb_to_lin(c: np.ndarray) -> np.ndarray:
    x = np.asarray(c, np.float64) / 255.0
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """(renderer, models, obj_ids, pose, corner points (4, 3) mm) of a textured square plane."""
    import trimesh
    from PIL import Image
    from scipy.spatial.transform import Rotation
    from trimesh.visual import TextureVisuals

    from ycbvss.io.mesh import write_ply_mm
    from ycbvss.refine.templates import ensure_meshes, get_renderer
    from ycbvss.scene import ObjectModel

    d = tmp_path_factory.mktemp("plane")
    h = SIZE_MM / 2
    V = np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]], np.float64)
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float64)
    F = np.array([[0, 1, 2], [0, 2, 3]])
    rng = np.random.default_rng(3)
    tex = (rng.random((64, 64, 3)) * 255).astype(np.uint8)          # random blocks: texture at many scales
    tex = np.kron(tex, np.ones((16, 16, 1), np.uint8))
    m = trimesh.Trimesh(V, F, process=False, visual=TextureVisuals(uv=uv, image=Image.fromarray(tex)))
    path = d / "obj_000001.ply"
    write_ply_mm(path, m, texture_name="obj_000001.png", texture_rgb=tex)
    models = {1: ObjectModel(obj_id=1, name="plane", path=path)}
    r = get_renderer()
    ensure_meshes(r, models)
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", [180 + 40, -20, 15], degrees=True).as_matrix()
    T[:3, 3] = (10.0, -5.0, 600.0)
    return r, models, [1], T, V


def test_area_colour_equals_mean_of_larger_render(scene):
    from ycbvss.refine.templates import area_template, render_view

    r, models, oids, T, _ = scene
    f = 2
    vr = render_view(r, models, oids, K, W, H, {0: T}, supersample=f)
    assert vr.area_color is None and area_template(vr)          # averaged on first use
    K2 = K.copy()
    K2[:2] *= f
    K2[0, 2] = f * K[0, 2] + (f - 1) / 2
    K2[1, 2] = f * K[1, 2] + (f - 1) / 2
    hi = render_view(r, models, oids, K2, W * f, H * f, {0: T})
    lin = _srgb_to_lin(hi.color).reshape(H, f, W, f, 3).mean(axis=(1, 3))
    full = vr.coverage >= 1.0
    ref = 255.0 * np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    err = np.abs(vr.area_color[full].astype(np.float64) - ref[full])
    assert full.sum() > 10000
    # a sub-pixel centre that falls on a texel boundary may round either way in the crop's projection
    assert np.percentile(err, 99.9) <= 1.0, np.percentile(err, 99.9)
    assert np.mean(err.max(axis=1) > 1.0) < 1e-3


def test_coverage_area_matches_projection(scene):
    import cv2

    from ycbvss.refine.templates import area_template, render_view

    r, models, oids, T, V = scene
    vr = render_view(r, models, oids, K, W, H, {0: T}, supersample=4)
    area_template(vr)
    P = (K @ (V @ T[:3, :3].T + T[:3, 3]).T).T
    uv = (P[:, :2] / P[:, 2:]).astype(np.float32)
    area = float(cv2.contourArea(uv))
    perim = float(cv2.arcLength(uv, True))
    offset_px = (float(vr.coverage.sum()) - area) / perim
    assert abs(offset_px) < 0.01, offset_px
    pointwise = (float((vr.instance > 0).sum()) - area) / perim     # the point-sampled mask, for scale
    assert abs(pointwise) < 0.1


def test_composite_mixes_partial_pixels_in_linear_light(scene):
    from dataclasses import replace

    from ycbvss.refine.templates import area_template, composite, render_view

    r, models, oids, T, _ = scene
    vr = render_view(r, models, oids, K, W, H, {0: T}, supersample=4)
    area_template(vr)
    img = np.full((H, W, 3), 40, np.uint8)
    assert np.array_equal(composite(vr, img)[vr.instance > 0], vr.color[vr.instance > 0])   # area=False: point-sampled
    vr = replace(vr, color=vr.area_color)
    out = composite(vr, img, area=True)
    part = (vr.coverage > 0.2) & (vr.coverage < 0.8)
    assert part.sum() > 100
    a = vr.coverage[part][:, None]
    want = a * _srgb_to_lin(vr.color[part]) + (1 - a) * _srgb_to_lin(np.full(3, 40))
    got = _srgb_to_lin(out[part])
    assert np.abs(got - want).max() < 0.004            # ~1 code at mid grey
    assert np.array_equal(out[vr.coverage <= 0], img[vr.coverage <= 0])
