"""Contour samples lifted at the rim (ycbvss.refine.edge.rim_depth) and the renderer's back-face depth.

A cylinder seen from the side: its silhouette belongs to the rim, where the viewing ray grazes the
side, at the depth of the ray's closest approach to the axis. The surface at a contour pixel's centre
has already turned towards the camera and lies millimetres nearer."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from ycbvss.refine.edge import all_contour_points, rim_depth
from ycbvss.refine.jacobians import backproject_px
from ycbvss.render import Renderer

K = np.array([[1066.8, 0.0, 313.0], [0.0, 1067.5, 241.3], [0.0, 0.0, 1.0]])
W, H = 640, 480
RADIUS_MM, HEIGHT_MM = 30.0, 160.0


@pytest.fixture(scope="module")
def cylinder_render():
    r = Renderer()
    # axis along camera y (trimesh's cylinder axis is z: turn it), 900 mm away, off-centre
    r.add_mesh("cyl", trimesh.creation.cylinder(radius=RADIUS_MM, height=HEIGHT_MM, sections=256))
    T = np.eye(4)
    T[:3, :3] = trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0])[:3, :3]
    T[:3, 3] = (40.0, -10.0, 900.0)
    out = r.render(K, W, H, [("cyl", T)], outputs=("depth", "instance", "back_depth"))
    return out, T[:3, 3]


def _rim_gap_mm(out, centre, with_back: bool) -> np.ndarray:
    """z of each lifted side-contour sample minus z of its ray's closest approach to the axis (mm)."""
    back = (out.back_depth_mm, out.back_instance) if with_back else (None, None)
    uv, z, _ = all_contour_points(out.instance, out.depth_mm, *back)
    P = backproject_px(K, uv, z)
    side = np.abs(P[:, 1] - centre[1]) < HEIGHT_MM / 2 - 15.0          # not the caps' edges
    P = P[side]
    w = P[:, [0, 2]] / np.linalg.norm(P[:, [0, 2]], axis=1, keepdims=True)   # ray direction in the xz plane
    s = w @ centre[[0, 2]]                                                  # closest approach along the ray
    z_rim = s * w[:, 1]
    return P[:, 2] - z_rim


def test_back_depth_is_the_exit_of_the_ray(cylinder_render):
    out, centre = cylinder_render
    m = out.instance > 0
    assert np.array_equal(m, out.back_instance > 0)
    # on the axis' column the ray crosses the whole diameter
    v, u = np.nonzero(m)
    chord = out.back_depth_mm[m] - out.depth_mm[m]
    assert float(chord.max()) == pytest.approx(2 * RADIUS_MM, abs=1.0)
    assert float(chord.min()) >= 0.0


def test_contour_samples_lie_on_the_rim(cylinder_render):
    out, centre = cylinder_render
    front = _rim_gap_mm(out, centre, with_back=False)
    rim = _rim_gap_mm(out, centre, with_back=True)
    assert len(rim) > 200
    # the contour pixel's surface: about sqrt(2 R x) nearer than the rim (x <= 1 px ~ 0.84 mm here)
    assert float(np.median(front)) < -1.5
    # the chord's midpoint: on the rim within the pixel's depth resolution
    assert abs(float(np.median(rim))) < 0.3
    assert float(np.percentile(np.abs(rim), 90)) < 1.0


def test_rim_depth_keeps_the_front_where_the_chord_is_not_the_rims():
    front = np.array([900.0, 900.0, 900.0, 900.0])
    back = np.array([906.0, 906.0, 1000.0, 0.0])
    same = np.array([True, False, True, True])
    z = rim_depth(front, back, same, max_chord_mm=40.0)
    assert z.tolist() == [903.0, 900.0, 900.0, 900.0]
