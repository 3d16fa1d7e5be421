"""Black objects (refine.dark_objects, RefineOptions.edge_linear_dark): which objects are black,
and why their edges are read in linear light.

The images are 8x8 supersampled discs mixed in linear light and then sRGB-encoded (as Cycles'
pixel filter and film do), never the refiner's renderer. A black disc's rim is brightened by an
additive glossy term the template does not have; the measured quantity is where the image's edge
field has its minimum along each contour sample's radius, against where each space's appearance
prediction puts it.
"""
import numpy as np
import pytest

from ycbvss.refine.contour_match import appearance_offsets, match_contour_to_blur
from ycbvss.refine.dark_objects import albedo_peak, is_black
from ycbvss.refine.edge import contour_points, edge_field, sample_E, srgb_to_linear

SS = 8


def _encode(lin01: np.ndarray) -> np.ndarray:
    x = np.clip(lin01, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055) * 255.0


def test_albedo_peak_is_the_brightest_channels_median_in_linear_light():
    black = np.full((20, 20, 3), 15, np.uint8)           # sRGB 15 -> linear 0.0048
    red = np.zeros((20, 20, 3), np.uint8)
    red[..., 0] = 160                                    # sRGB 160 -> linear 0.35 (a red object is not black)
    mask = np.zeros((20, 20), bool)
    mask[5:15, 5:15] = True
    assert albedo_peak(black, mask) == pytest.approx(0.00478, abs=2e-4)
    assert albedo_peak(red, mask) == pytest.approx(0.3515, abs=2e-3)
    assert is_black(black, mask, 0.02) and not is_black(red, mask, 0.02)
    assert not is_black(black, mask, 0.0)                 # 0: the rule is off
    assert np.isnan(albedo_peak(black, np.zeros_like(mask)))


def _black_disc(cx: float, cy: float, rim_add: float, radius_px: float = 30.0, size: int = 110):
    """Image (uint8 sRGB), instance mask and template of a black disc (linear 0.005) on a table
    (linear 0.2, 0.15, 0.1); the image's outer 1 px of the disc brightened by ``rim_add`` (linear)."""
    yy, xx = (np.mgrid[0:size * SS, 0:size * SS] + 0.5) / SS - 0.5
    r = np.hypot(xx - cx, yy - cy)
    obj = np.where((r > radius_px - 1.0)[..., None], 0.005 + rim_add, 0.005) * np.ones(3)
    lin = np.where((r < radius_px)[..., None], obj, np.array([0.2, 0.15, 0.1]))
    lin = lin.reshape(size, SS, size, SS, 3).mean(axis=(1, 3))
    image = np.clip(np.rint(_encode(lin)), 0, 255).astype(np.uint8)
    py, px = np.mgrid[0:size, 0:size].astype(np.float64)
    inst = (np.hypot(px - cx, py - cy) < radius_px).astype(np.int32)
    tmpl = np.where(inst[..., None] > 0, np.uint8(np.rint(_encode(np.array(0.005)))), 0).astype(np.uint8)
    tmpl = np.repeat(tmpl, 3, axis=2) if tmpl.shape[-1] == 1 else tmpl
    return image, inst, tmpl


def _edge_error(image, inst, tmpl, centre, linear: bool) -> float:
    """Mean radial distance (px) of the image edge field's minimum (sRGB or linear-light field) from
    the contour samples moved by that space's appearance prediction."""
    uv, _ = contour_points(inst, inst * 1000.0, 1)
    labels = np.ones(len(uv), int)
    uvm = match_contour_to_blur(uv, labels, inst, 1.0)
    off, n = appearance_offsets(uv, labels, inst, tmpl, image, 1.0,
                                linear_labels=frozenset({1}) if linear else frozenset())
    at = uvm + off[:, None] * n
    rad = (at - centre) / np.linalg.norm(at - centre, axis=1, keepdims=True)
    field = edge_field(image, 1.0, colour=True, linear=linear)
    s = np.linspace(-2.0, 2.0, 401)
    E = np.stack([sample_E(field, at + t * rad) for t in s], axis=1)
    return float(np.mean(s[np.argmin(E, axis=1)]))


def test_a_black_objects_unmodelled_rim_moves_its_srgb_edge_not_its_linear_one():
    centre = np.array([55.3, 55.6])
    flat = _black_disc(*centre, rim_add=0.0)
    rim = _black_disc(*centre, rim_add=0.02)               # a glossy rim: +0.02 linear, sRGB 15 -> 44
    err = {(name, lin): _edge_error(*scene, centre, lin)
           for name, scene in (("flat", flat), ("rim", rim)) for lin in (False, True)}
    # without the rim both spaces' predictions find the image's edge (< 0.06 px)
    assert abs(err[("flat", False)]) < 0.06 and abs(err[("flat", True)]) < 0.06, err
    # with it the sRGB edge moves inward by > 0.15 px (measured 0.215), the linear-light edge by about
    # half as much (0.105): in linear light the rim only lowers the outer pixel's contrast by 10 %
    moved_srgb = abs(err[("rim", False)] - err[("flat", False)])
    moved_lin = abs(err[("rim", True)] - err[("flat", True)])
    assert moved_srgb > 0.15, err
    assert moved_lin < 0.6 * moved_srgb, err


def test_only_the_two_clamps_of_ycbv_are_black(ycbv_root):
    """The brightest channel's median albedo of the YCB-V textures (20000 surface samples): the
    clamps below 0.01, the next darkest (foam brick, large marker) above 0.05."""
    trimesh = pytest.importorskip("trimesh")
    from PIL import Image

    peaks = {}
    for name in ("051_large_clamp", "052_extra_large_clamp", "061_foam_brick", "040_large_marker"):
        d = ycbv_root / "models" / name
        mesh = trimesh.load(d / "textured.obj", force="mesh", process=False)
        tex = np.asarray(Image.open(d / "texture_map.jpg").convert("RGB"))
        pts, fi = trimesh.sample.sample_surface(mesh, 20000, seed=0)
        bc = trimesh.triangles.points_to_barycentric(mesh.triangles[fi], pts)
        uv = (mesh.visual.uv[mesh.faces[fi]] * bc[:, :, None]).sum(axis=1)
        h, w = tex.shape[:2]
        x = np.clip((uv[:, 0] % 1.0) * w, 0, w - 1).astype(int)
        y = np.clip((1.0 - uv[:, 1] % 1.0) * h, 0, h - 1).astype(int)
        peaks[name] = albedo_peak(tex[y, x][None], np.ones((1, len(x)), bool))
    assert peaks["051_large_clamp"] < 0.01 and peaks["052_extra_large_clamp"] < 0.01, peaks
    assert peaks["061_foam_brick"] > 0.05 and peaks["040_large_marker"] > 0.05, peaks


def test_contrast_matched_keeps_the_linear_edges_position_and_takes_the_srgb_weight():
    from ycbvss.refine.dark_objects import contrast_matched

    centre = np.array([55.3, 55.6])
    image, inst, _ = _black_disc(*centre, rim_add=0.02)
    image = image.copy()
    image[5:15, 5:15] = 255                                # a highlight on the table, the image's strongest edge
    srgb_f = edge_field(image, 1.0, colour=True)
    lin_f = edge_field(image, 1.0, colour=True, linear=True)
    uv, _ = contour_points(inst, inst * 1000.0, 1)
    uv = match_contour_to_blur(uv, np.ones(len(uv), int), inst, 1.0)
    matched = contrast_matched(lin_f, srgb_f, uv)
    a, b, c = (1.0 - sample_E(f, uv) for f in (srgb_f, lin_f, matched))
    # against the highlight the black disc's contour is weaker in linear light than in sRGB (measured
    # 0.17 against 0.57); the rescale restores the sRGB median at the samples
    assert np.median(b) < 0.5 * np.median(a), (np.median(a), np.median(b))
    assert np.median(c) == pytest.approx(np.median(a), rel=0.02)
    # ... and does not move the edge: the minimum along each radius stays where the linear field has it
    rad = (uv - centre) / np.linalg.norm(uv - centre, axis=1, keepdims=True)
    s = np.linspace(-2.0, 2.0, 401)
    at_lin = s[np.argmin(np.stack([sample_E(lin_f, uv + t * rad) for t in s], axis=1), axis=1)]
    at_mat = s[np.argmin(np.stack([sample_E(matched, uv + t * rad) for t in s], axis=1), axis=1)]
    assert np.max(np.abs(at_lin - at_mat)) <= 0.011


def test_edge_term_reads_a_black_objects_own_field():
    """f_edge's groups of the object given an own field (``EdgeTerm.obj_fields``) are read there, the
    others in their view's field: the cost equals the sum of E over each group's projected samples in
    its field."""
    from ycbvss.refine.jacobians import project_points
    from ycbvss.refine.problem import BundleProblem, View
    from ycbvss.refine.terms import EdgeGroup, EdgeTerm

    rng = np.random.default_rng(3)
    img_a = rng.integers(0, 255, (120, 160, 3), dtype=np.uint8)
    img_b = rng.integers(0, 255, (120, 160, 3), dtype=np.uint8)
    f_view, f_own = edge_field(img_a, 1.0, colour=True), edge_field(img_b, 1.0, colour=True, linear=True)
    K = np.array([[200.0, 0.0, 80.0], [0.0, 200.0, 60.0], [0.0, 0.0, 1.0]])
    T_m = np.stack([np.eye(4), np.eye(4)])
    T_m[:, 2, 3] = 1000.0
    T_m[1, 0, 3] = 30.0
    pb = BundleProblem([View(0, K, 160, 120)], [19, 5], np.eye(4)[None], T_m)
    groups = [EdgeGroup(0, j, rng.normal(scale=40.0, size=(50, 3))) for j in (0, 1)]
    term = EdgeTerm([f_view], groups, obj_fields={(0, 0): f_own})
    assert term.field_of(groups[0]) is f_own and term.field_of(groups[1]) is f_view
    expect = 0.0
    for gr, f in zip(groups, (f_own, f_view)):
        uv, ok = project_points(K, pb.T_c[0] @ pb.T_m[gr.j], gr.X)
        expect += float(np.where(ok, sample_E(f, np.where(ok[:, None], uv, -1e9)), 1.0).sum())
    assert term.cost(pb) == pytest.approx(expect, rel=1e-9)
    assert EdgeTerm([f_view], groups).cost(pb) != pytest.approx(expect, rel=1e-3)
