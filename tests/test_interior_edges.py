"""refine.interior_edges: interior edge candidates only where the surface is flat at the pixel scale."""
from __future__ import annotations

import numpy as np

from ycbvss.refine.interior_edges import flat_at


def _rounded_edge_normals(w: int = 40, bevel_px: int = 4) -> np.ndarray:
    """A normal map (w, w, 3): a face looking at the camera for x < 16, then a bevel turning 90 deg
    over ``bevel_px`` pixels, then a face looking sideways."""
    ang = np.clip((np.arange(w) - 16) / bevel_px, 0.0, 1.0) * (np.pi / 2)
    n = np.stack([np.sin(ang), np.zeros(w), -np.cos(ang)], axis=1)
    return np.repeat(n[None], w, axis=0)


def test_flat_at_keeps_faces_and_drops_a_rounded_edge():
    n = _rounded_edge_normals()
    inst = np.ones(n.shape[:2], np.int32)
    uv = np.array([[5.0, 20.0], [17.0, 20.0], [18.0, 20.0], [30.0, 20.0]])
    keep = flat_at(n, inst, uv, max_turn_deg=20.0, radius_px=2)
    assert keep.tolist() == [True, False, False, True]


def test_flat_at_ignores_other_instances():
    n = _rounded_edge_normals()
    inst = np.ones(n.shape[:2], np.int32)
    inst[:, 16:] = 2                          # the bevel belongs to another object: no turn within object 1
    keep = flat_at(n, inst, np.array([[15.0, 20.0]]), max_turn_deg=20.0, radius_px=2)
    assert keep.tolist() == [True]


def test_flat_at_no_points():
    n = _rounded_edge_normals()
    assert flat_at(n, np.ones(n.shape[:2], np.int32), np.zeros((0, 2))).shape == (0,)


def test_interior_points_drop_texture_edges_on_a_rounded_edge_only():
    """A textured object with two colour steps: one on a flat face (x = 12), one on a bevel that
    turns 90 deg over 4 px (x = 30). With the limit, only the flat face's texture edge remains."""
    from ycbvss.refine.edge import all_interior_points

    H = W = 48
    inst = np.zeros((H, W), np.int32)
    inst[4:44, 4:44] = 1
    depth = np.where(inst > 0, 800.0, 0.0).astype(np.float32)
    color = np.full((H, W, 3), 60, np.uint8)
    color[:, 12:] = 140
    color[:, 30:] = 220
    ang = np.clip((np.arange(W) - 28) / 4.0, 0.0, 1.0) * (np.pi / 2)
    n = np.repeat(np.stack([np.sin(ang), np.zeros(W), -np.cos(ang)], axis=1)[None], H, axis=0)
    uv_all, _, _ = all_interior_points(inst, depth, color, None)
    uv_flat, _, _ = all_interior_points(inst, depth, color, None, texture_max_turn_deg=20.0, surface_normal=n)
    near = lambda uv, x: int(np.sum(np.abs(uv[:, 0] - x) < 2.0))
    assert near(uv_all, 11.5) > 20 and near(uv_all, 29.5) > 20          # both texture edges without the limit
    assert near(uv_flat, 11.5) == near(uv_all, 11.5) and near(uv_flat, 29.5) == 0
