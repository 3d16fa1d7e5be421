"""Texture registration of both renderers against the analytic projection.

A textured checkerboard plane (binary PLY with per-vertex UV + 4096 px PNG, the layout of the YCBV-SS models)
is rendered at tilted poses by the fast renderer and by Blender (Cycles, through ``render_job``). Every inner
checker corner is a texel boundary ``k * cell`` of the image, i.e. UV ``(k cell / N, 1 - l cell / N)``; its 3D
point is projected with K. The corners are located in the renders as the saddle point of the Gaussian-smoothed
image (exact for a point-symmetric X-junction under any symmetric blur or tone curve), and an affine map
``d = A (x - c) + t`` is fitted to the offsets. A texture magnified by 0.05 % moves features near the border of
a 250 px object by ~0.06 px -- the bias that Blender's silently sheared object matrices (fy != fx) once
produced (A_yy -0.044 % at the 50 deg pose with the YCB-V K).

Bounds: every entry of A below 0.01 % (scale and shear), |mean offset| < 0.02 px, mean |offset| < 0.05 px.
Blender's silhouette is checked too: alpha summed over the image = analytic area of the projected plane,
i.e. mean boundary offset (area difference / perimeter) below 0.01 px.
Budget: ~10 s (fast renderer ~2 s; Blender start-up + two 32-spp frames ~6 s).
"""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest

K_YCBV = np.array([[1066.778, 0.0, 312.9869], [0.0, 1067.487, 241.3109], [0.0, 0.0, 1.0]])
K_ASPECT = np.array([[1000.0, 0.0, 330.4], [0.0, 1030.0, 228.7], [0.0, 0.0, 1.0]])   # fy/fx = 1.03
W, H = 640, 480
TEX_PX, CELLS, SIZE_MM = 4096, 16, 120.0

A_MAX_PCT = 0.01
MEAN_MAX_PX = 0.02
ABS_MAX_PX = 0.05
ALPHA_EDGE_MAX_PX = 0.01


def _pose(rx_deg: float, ry_deg: float, rz_deg: float, t_mm) -> np.ndarray:
    from scipy.spatial.transform import Rotation
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", [180.0 + rx_deg, ry_deg, rz_deg], degrees=True).as_matrix()
    T[:3, 3] = t_mm
    return T


CASES = [(K_YCBV, _pose(50, -15, 10, (0, 0, 450))), (K_ASPECT, _pose(35, 20, -25, (15, -10, 520)))]


@pytest.fixture(scope="module")
def plane(tmp_path_factory):
    """(PLY path, (n, 3) model-frame corner points in mm)."""
    import trimesh
    from PIL import Image
    from trimesh.visual import TextureVisuals

    from ycbvss.io.mesh import write_ply_mm

    n = 5
    xs = np.linspace(-SIZE_MM / 2, SIZE_MM / 2, n)
    X, Y = np.meshgrid(xs, xs)
    V = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    uv = np.column_stack([(X.ravel() + SIZE_MM / 2) / SIZE_MM, 1.0 - (Y.ravel() + SIZE_MM / 2) / SIZE_MM])
    F = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, i * n + j + 1, (i + 1) * n + j, (i + 1) * n + j + 1
            F += [[a, c, b], [b, c, d]]
    cell = TEX_PX // CELLS
    k = np.arange(TEX_PX) // cell
    dark = ((k[:, None] + k[None, :]) % 2).astype(bool)
    img = np.where(dark[..., None], np.array([25, 30, 40], np.uint8), np.array([230, 220, 200], np.uint8))
    mesh = trimesh.Trimesh(V, np.array(F), process=False,
                           visual=TextureVisuals(uv=uv, image=Image.fromarray(img)))
    path = tmp_path_factory.mktemp("texreg") / "plane.ply"
    write_ply_mm(path, mesh, texture_name="plane.png", texture_rgb=img)
    g = np.arange(1, CELLS) / CELLS                       # texel boundaries k * cell, in UV
    gu, gv = np.meshgrid(g, g)
    corners = np.column_stack([gu.ravel() * SIZE_MM - SIZE_MM / 2, (1.0 - gv.ravel()) * SIZE_MM - SIZE_MM / 2,
                               np.zeros(gu.size)])
    return path, corners


def _project(K, T, P):
    X = P @ T[:3, :3].T + T[:3, 3]
    return X[:, :2] / X[:, 2:3] @ K[:2, :2].T + K[:2, 2]


def _saddles(gray: np.ndarray, uv0: np.ndarray, sigma: float = 1.5, half: float = 2.0, n: int = 9,
             iters: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Critical points of the smoothed image near ``uv0`` (iterated quadratic fits on cubic-spline samples)."""
    import cv2
    from scipy.ndimage import map_coordinates, spline_filter

    g = cv2.GaussianBlur(gray.astype(np.float32), (0, 0), sigma).astype(np.float64)
    coef = spline_filter(g, order=3)
    o = np.linspace(-half, half, n)
    ox, oy = (a.ravel() for a in np.meshgrid(o, o))
    pinv = np.linalg.pinv(np.column_stack([np.ones_like(ox), ox, oy, ox * ox, ox * oy, oy * oy]))
    p = np.asarray(uv0, np.float64).copy()
    ok = np.ones(len(p), bool)
    step = np.zeros_like(p)
    for _ in range(iters):
        mx, my = p[:, :1] + ox[None], p[:, 1:] + oy[None]
        v = map_coordinates(coef, [my.ravel(), mx.ravel()], order=3, prefilter=False, mode="nearest")
        c = v.reshape(mx.shape) @ pinv.T
        hess = np.stack([np.stack([2 * c[:, 3], c[:, 4]], -1), np.stack([c[:, 4], 2 * c[:, 5]], -1)], -2)
        ok &= np.linalg.det(hess) < 0
        step = np.clip(-np.linalg.solve(hess, c[:, 1:3][..., None])[..., 0], -1.0, 1.0)
        p += np.where(ok[:, None], step, 0.0)
    return p, ok & (np.linalg.norm(step, axis=1) < 1e-3)


def _registration(gray: np.ndarray, K, T, corners) -> dict:
    uv0 = _project(K, T, corners)
    uv, ok = _saddles(gray, uv0)
    assert ok.sum() >= 0.95 * len(ok), f"only {ok.sum()}/{len(ok)} checker corners located"
    a, d = uv0[ok], uv[ok] - uv0[ok]
    X = np.column_stack([a - a.mean(0), np.ones(len(a))])
    sol = np.linalg.lstsq(X, d, rcond=None)[0]
    return {"A_pct": 100.0 * sol[:2].T, "mean_px": d.mean(0), "abs_px": float(np.abs(d).mean())}


def _check(res: dict, what: str) -> None:
    A, mean, ab = res["A_pct"], res["mean_px"], res["abs_px"]
    msg = f"{what}: A = {np.round(A, 4).tolist()} %, mean {np.round(mean, 4).tolist()} px, mean |d| {ab:.4f} px"
    assert np.abs(A).max() < A_MAX_PCT, msg
    assert np.abs(mean).max() < MEAN_MAX_PX, msg
    assert ab < ABS_MAX_PX, msg


def _gray(rgb: np.ndarray) -> np.ndarray:
    return rgb.astype(np.float64) @ np.array([0.299, 0.587, 0.114])


def test_fast_renderer_texture_matches_analytic_projection(plane):
    from ycbvss.io.mesh import load_mesh_mm
    from ycbvss.render import Renderer

    path, corners = plane
    r = Renderer()
    r.add_mesh("texreg_plane", load_mesh_mm(path))      # 4096 px texture: downsampled to 2048 + mipmaps
    try:
        for K, T in CASES:
            out = r.render(K, W, H, [("texreg_plane", T)], outputs=("color",))
            _check(_registration(_gray(out.color), K, T, corners), f"fast renderer, fy/fx {K[1, 1] / K[0, 0]:.5f}")
    finally:
        r.remove_mesh("texreg_plane")


@pytest.mark.blender
@pytest.mark.skipif(importlib.util.find_spec("bpy") is None, reason="bpy (Blender as a module) not installed")
def test_blender_texture_matches_analytic_projection(plane, tmp_path):
    from ycbvss.blender_scripts.outputs import read_exr_rgba
    from ycbvss.synth.blender import render_job

    path, corners = plane
    job = {"width": W, "height": H, "samples": 32, "seed": 3, "denoise": False,
           "meshes": {"plane": {"path": str(path)}},
           "frames": [{"id": f"f{i}", "K": K.tolist(), "out_dir": str(tmp_path),
                       "objects": [{"mesh": "plane", "pass_index": 1, "T_m2c": T.tolist()}]}
                      for i, (K, T) in enumerate(CASES)]}
    results = render_job(job)
    h = SIZE_MM / 2
    outline = np.array([[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]])
    for (K, T), res in zip(CASES, results):
        rgba = read_exr_rgba(res["rgba"])
        q = _project(K, T, outline)
        area = 0.5 * abs(np.dot(q[:, 0], np.roll(q[:, 1], -1)) - np.dot(q[:, 1], np.roll(q[:, 0], -1)))
        perimeter = np.linalg.norm(q - np.roll(q, -1, axis=0), axis=1).sum()
        edge_px = (float(rgba[..., 3].astype(np.float64).sum()) - area) / perimeter
        assert abs(edge_px) < ALPHA_EDGE_MAX_PX, f"Blender silhouette: mean boundary offset {edge_px:+.4f} px"
        rgb = np.clip(rgba[..., :3], 0.0, 1.0)
        srgb = np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * rgb ** (1 / 2.4) - 0.055) * 255.0
        _check(_registration(_gray(srgb), K, T, corners), f"Blender, fy/fx {K[1, 1] / K[0, 0]:.5f}")
