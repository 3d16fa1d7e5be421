"""The exact voxel-grid nearest-neighbour path of ADD-S (eval/nn_grid.py): same numbers as a
brute-force search for tracker-level and gross errors, used only when many queries are uncertified."""
from __future__ import annotations

import numpy as np



from scipy.spatial import cKDTree

from ycbvss.eval import model_points as mpmod
from ycbvss.eval.metrics import relative_model_transform
from ycbvss.eval.model_points import ModelPoints
from ycbvss.geometry.so3 import exp_so3


def _surface(rng, n=3000):
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v *= [60.0, 35.0, 90.0]
    v[: n // 3, 2] = np.clip(v[: n // 3, 2], -40, 40)          # a flat cut: not a plain ellipsoid
    return v


def _pairs(rng, n, r_deg, t_mm):
    Rg = exp_so3(rng.normal(size=(n, 3)))
    tg = np.c_[rng.uniform(-100, 100, (n, 2)), rng.uniform(600, 1200, n)]
    Re = exp_so3(rng.normal(size=(n, 3)) * np.radians(r_deg)) @ Rg
    te = tg + rng.normal(size=(n, 3)) * t_mm
    A, b = relative_model_transform(Re, te, Rg, tg)
    return np.ascontiguousarray(A), np.ascontiguousarray(b)


def _brute(pts, A, b):
    tree = cKDTree(pts)
    return np.array([tree.query(pts @ A[j].T + b[j])[0].mean() for j in range(len(A))])


def test_grid_equals_brute_force(monkeypatch):
    rng = np.random.default_rng(4)
    pts = _surface(rng)
    monkeypatch.setattr(mpmod, "GRID_MIN_QUERIES", 50_000)
    for r_deg, t_mm in ((3.0, [10, 10, 20]), (30.0, [80, 80, 80]), (0.2, [0.5, 0.5, 0.5])):
        A, b = _pairs(rng, 120, r_deg, t_mm)
        mp = ModelPoints(pts)
        add, adds = mp.add_adds(A, b)
        ref = _brute(pts, A, b)
        assert np.max(np.abs(adds - ref) / ref) < 1e-12
        assert np.allclose(add, [np.linalg.norm(pts @ A[j].T + b[j] - pts, axis=1).mean() for j in range(len(A))],
                           rtol=1e-12)
        after_probe = (len(A) - mpmod.GRID_PROBE_POSES) * len(pts)
        if r_deg == 3.0:        # tracker-level errors: the grid answers the uncertified queries
            assert mp.stats.get("grid", 0) > 0.9 * after_probe
        elif r_deg == 30.0:     # gross errors: queries beyond the grid's shell go to the KD-tree
            assert 0 < mp.stats.get("grid", 0) < after_probe
        else:                   # refined errors: certified, no grid is built
            assert mp._grid is None and mp.stats.get("grid", 0) == 0
    no_grid = ModelPoints(pts, grid=False)
    A, b = _pairs(rng, 80, 3.0, [10, 10, 20])
    assert np.array_equal(no_grid.add_adds(A, b)[1], ModelPoints(pts).add_adds(A, b)[1]) or np.allclose(
        no_grid.add_adds(A, b)[1], ModelPoints(pts).add_adds(A, b)[1], rtol=1e-13, atol=0)
