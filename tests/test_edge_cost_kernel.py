"""f_edge's compiled cost of across-edge (anchored) samples against its array form, bit for bit."""
from __future__ import annotations

import numpy as np

from ycbvss.refine.cubic_kernel import anchored_edge_values
from ycbvss.refine.edge import edge_field, sample_E
from ycbvss.refine.jacobians import MIN_Z_MM, project_points


def _reference_cost(field, K, T, X, uv0, nrm, ok0) -> float:
    uv, valid = project_points(K, T, X)
    at = uv0 + np.einsum("ni,ni->n", uv - uv0, nrm)[:, None] * nrm
    E = sample_E(field, np.where((valid & ok0)[:, None], at, -1e9))
    return float(np.where(valid & ok0, E, 1.0).sum())


def test_anchored_cost_matches_array_form() -> None:
    rng = np.random.default_rng(2)
    img = (rng.random((120, 160, 3)) * 255).astype(np.uint8)
    img[40:80, 50:110] = 30                                # a block with clear edges
    field = edge_field(img, 1.5)
    K = np.array([[300.0, 0.0, 80.0], [0.0, 300.0, 60.0], [0.0, 0.0, 1.0]])
    H, W = field.shape
    for trial in range(20):
        n = int(rng.integers(1, 700))
        X = rng.normal(0, 60, (n, 3))
        X[: n // 10, 2] -= 2000.0                           # some behind the camera
        T = np.eye(4)
        T[:3, 3] = (rng.normal(0, 20), rng.normal(0, 20), 600.0)
        uv0 = rng.uniform(-10, 170, (n, 2))                 # some anchors outside the image
        nrm = rng.normal(size=(n, 2))
        nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
        ok0 = rng.random(n) < 0.9
        Y = X @ T[:3, :3].T + T[:3, 3]
        got = float(anchored_edge_values(field.E_padded, H, W, K, Y, uv0, nrm, ok0, MIN_Z_MM).sum())
        assert got == _reference_cost(field, K, T, X, uv0, nrm, ok0)
