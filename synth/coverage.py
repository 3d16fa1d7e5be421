"""Coverage of the real object pixels by the render of the enlarged model, and the scale choice.

coverage(o, s) = (# original visible pixels of o inside o's full silhouette at scale s)
               / (# original visible pixels of o), summed over all frames of the sequence(s).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import YcbvssError
from ..io.images import read_label, read_mask
from ..io.mesh import load_geometry_mm
from ..render import Renderer

SCALE_GRID = (1.02, 1.025, 1.03, 1.035, 1.04, 1.045, 1.05)
TARGET = 0.995


def covered_counts(renderer, K: np.ndarray, width: int, height: int, items: list[tuple[str, np.ndarray]],
                   visible: list[np.ndarray], scales: tuple[float, ...]) -> np.ndarray:
    """(n_items, n_scales) int: visible pixels of each item covered by its own full silhouette at each scale."""
    out = np.zeros((len(items), len(scales)), np.int64)
    if not items:
        return out
    for j, s in enumerate(scales):
        r = renderer.render(K, width, height, items, outputs=("mask_all",), scales=[s] * len(items))
        for k, m in enumerate(r.masks_all):
            out[k, j] = int(np.count_nonzero(m & visible[k]))
    return out


def choose_scale(covered: np.ndarray, total: int, grid: tuple[float, ...] = SCALE_GRID,
                 target: float = TARGET) -> tuple[float, float, bool]:
    """Smallest grid scale whose coverage >= target. Returns (scale, coverage, flagged): flagged when even
    the largest scale misses the target (then the largest is used)."""
    cov = np.asarray(covered, np.float64) / max(int(total), 1)
    if total == 0:
        return float(grid[0]), 1.0, False
    for s, c in zip(grid, cov):
        if c >= target:
            return float(s), float(c), False
    return float(grid[-1]), float(cov[-1]), True


def coverage_frame(worker, config: dict, task: dict) -> dict:
    """Runs in a worker process: covered counts of one frame. ``config["coverage_meshes"]``:
    ``{key: {"path", "unit_scale", "centre_mm"}}`` (undilated input models, recentred here);
    ``config["scales"]``: the scales (1.0 first). Returns ``{"scene_id", "im_id", "objects": [[obj_id, visible_px,
    [covered per scale]], ...]}``."""
    r = worker.cache.get("fast_renderer")
    if r is None:
        r = worker.cache["fast_renderer"] = Renderer()
    loaded = worker.cache.setdefault("coverage_meshes", {})
    out = {"scene_id": task["scene_id"], "im_id": task["im_id"], "objects": []}
    try:
        label = read_label(task["label_path"]) if task.get("label_path") else None
    except YcbvssError:
        return out
    items, vis, oids = [], [], []
    for ob in task["objects"]:
        T = np.asarray(ob["T_m2c"], np.float64)
        if not np.all(np.isfinite(T)) or T[2, 3] <= 0:
            continue
        if label is not None:
            v = label == ob["obj_id"]
        elif ob.get("mask_visib_path") and Path(ob["mask_visib_path"]).is_file():
            v = read_mask(ob["mask_visib_path"])
        else:
            continue
        key = f"cov_obj_{int(ob['obj_id']):06d}"
        spec = config["coverage_meshes"][key]
        ident = (spec["path"], tuple(spec["centre_mm"]), spec.get("unit_scale", 1.0))
        if loaded.get(key) != ident:
            m = load_geometry_mm(spec["path"], float(spec.get("unit_scale", 1.0)))
            m.vertices = np.asarray(m.vertices, np.float64) - np.asarray(spec["centre_mm"], np.float64)
            r.add_mesh(key, m)
            loaded[key] = ident
        items.append((key, T))
        vis.append(v)
        oids.append(int(ob["obj_id"]))
    cov = covered_counts(r, np.asarray(task["K"]), int(task["width"]), int(task["height"]), items, vis,
                         tuple(config["scales"]))
    out["objects"] = [[oid, int(vis[k].sum()), cov[k].tolist()] for k, oid in enumerate(oids)]
    return out
