"""Image-based alignment measures of a set of poses (no GT needed): the mean edge cost of the
template edge points (the f_edge the refiner minimises, per sample) and the mask IoU of the
rendered visible silhouettes against a label image."""
from __future__ import annotations

import numpy as np

from .edge import edge_field, sample_field
from .jacobians import object_point_jacobians
from .templates import edge_samples, ensure_meshes, get_renderer, render_view


def view_alignment(image: np.ndarray, K: np.ndarray, poses: dict[int, np.ndarray], models: dict,
                   label: np.ndarray | None = None, sigma_px: float = 1.0, n_points: int = 1000,
                   seed: int = 0) -> dict[int, dict]:
    """Per object of one view: ``edge_cost`` (mean E over up to n_points template edge points at
    the pose, in [0, 1], lower = better aligned with image edges), ``n_edge`` and, with a label
    image (pixel value = obj_id), ``iou`` of the rendered visible mask vs the label mask."""
    r = get_renderer()
    oids = sorted(poses)
    ensure_meshes(r, {o: models[o] for o in oids})
    H, W = image.shape[:2]
    vr = render_view(r, models, oids, K, W, H, {j: poses[o] for j, o in enumerate(oids)})
    fld = edge_field(image, sigma_px)
    rng = np.random.default_rng(seed)
    out = {}
    for j, o in enumerate(oids):
        X = edge_samples(vr, j, K, n_points, rng)
        rec = {"n_edge": int(len(X))}
        if len(X):
            uv = object_point_jacobians(K, np.eye(4), poses[o], X)[0]
            rec["edge_cost"] = float(sample_field(fld, uv)[0].mean())
        if label is not None:
            m = vr.mask(j)
            lab = label == o
            union = int((m | lab).sum())
            rec["iou"] = float((m & lab).sum() / union) if union else float("nan")
        out[o] = rec
    return out
