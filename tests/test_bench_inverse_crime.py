"""bench/bench_inverse_crime.py's pixel-area control image: its sub-pixels tile each pixel about the
pixel's centre (a grid off by (s - 1) / 2 sub-pixels would move every object 0.375 px at s = 4)."""
import dataclasses
import importlib.util
from pathlib import Path

import numpy as np

_spec = importlib.util.spec_from_file_location("bench_inverse_crime",
                                               Path(__file__).parents[1] / "bench" / "bench_inverse_crime.py")
bic = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bic)


def test_subpixel_camera_puts_the_subpixels_about_each_pixel_centre():
    from ycbvss.camera import Camera

    cam = Camera(np.array([[600.0, 0.0, 320.3], [0.0, 601.0, 240.7], [0.0, 0.0, 1.0]]), 64, 48)
    big = bic.subpixel_camera(cam, 4)
    assert (big.width, big.height) == (256, 192)
    X = np.array([[12.0, -7.0, 900.0], [-40.0, 25.0, 1200.0]])
    uv = (X @ cam.K.T)[:, :2] / X[:, 2:]
    UV = (X @ big.K.T)[:, :2] / X[:, 2:]
    # pixel u covers [u - 0.5, u + 0.5]; its sub-pixels k = 0..3 sit at u - 0.5 + (k + 0.5) / 4, i.e.
    # the big image's index 4 u + k: the point at u lies at index 4 u + 1.5
    assert np.allclose(UV, 4.0 * uv + 1.5, atol=1e-9)


def test_area_image_centroid_matches_the_point_sampled_silhouette():
    """Each object's centroid of coverage in the sub-pixel render agrees with that of its point-sampled
    silhouette within 0.15 px (the sub-pixel grid is centred: a grid off by 1.5 sub-pixels would put
    it 0.53 px off), and the area image's fully covered pixels keep the point-sampled colour's mean
    within 2 % in linear light (textures filtered in linear light; on their encoded values the 1 x
    image's coarser mip levels read darker)."""
    from ycbvss.pipeline.blender_scene import srgb_u8_to_linear
    from ycbvss.procedural.render import render_frame_fast
    from ycbvss.procedural.scene import make_scene
    from ycbvss.render import Renderer

    sc = make_scene(seed=3, n_frames=2, width=320, height=240)
    f = sc.frames[0]
    gl = Renderer(srgb_textures=True)    # minified texture averaged in linear light at 1 x as at 4 x
    point, _, obj_map = render_frame_fast(sc, f, gl, ambient=1.0, diffuse=0.0, with_table=False)
    area = bic.render_control(sc, f, gl, "area", 4)
    _, _, obj_map_hi = render_frame_fast(sc, dataclasses.replace(f, camera=bic.subpixel_camera(f.camera, 4)), gl,
                                         with_table=False)
    checked = 0
    for oid in np.unique(obj_map[obj_map > 0]):
        cover = (obj_map_hi == oid).reshape(240, 4, 320, 4).mean(axis=(1, 3))    # the object's exact coverage
        m = obj_map == oid
        if m.sum() < 400:
            continue
        v, u = np.mgrid[0:240, 0:320]
        c_point = np.array([u[m].mean(), v[m].mean()])
        c_area = np.array([(u * cover).sum(), (v * cover).sum()]) / cover.sum()
        assert np.linalg.norm(c_point - c_area) < 0.15     # the point mask's own quantisation: ~0.05 px
        inner = cover == 1.0
        inner = inner & np.roll(inner, 1, 0) & np.roll(inner, -1, 0) & np.roll(inner, 1, 1) & np.roll(inner, -1, 1)
        lin_a, lin_p = srgb_u8_to_linear(area)[inner].mean(), srgb_u8_to_linear(point)[inner].mean()
        assert abs(float(lin_a - lin_p)) < 0.02 * float(lin_p)
        checked += 1
    assert checked >= 2
