"""BOP masks and ``scene_gt_info`` of a frame, with the fast renderer.

For instance k of a frame (all instances rendered together, one z-buffer):

- full silhouette ``mask`` (BOP mask/): the object rendered alone (unoccluded);
- visible mask ``mask_visib``: pixels where the renderer's instance map says object k is the
  front-most surface **and** (the real depth is invalid (0) **or** rendered depth <= real depth
  + ``delta_mm``). ``delta_mm`` = 15 mm is BOP's default tolerance. (BOP compares distances
  along the ray; we compare z-depths, which differ by the same per-pixel factor >= 1: the
  same test up to ~1 % of delta.) Without a real depth image the visible mask is the
  front-most test alone.
- ``bbox_obj`` = [x, y, w, h] of the full silhouette, including the part outside the image
  (re-rendered on a 3x canvas when the silhouette touches the border), ``bbox_visib`` = the
  bbox of the visible mask ([-1, -1, -1, -1] if empty); ``px_count_all`` = full-silhouette
  pixels inside the image; ``px_count_valid`` = those with valid (> 0) real depth (= all without
  a depth image); ``px_count_visib``; ``visib_fract`` = visib / all (0 if all = 0).
"""
from __future__ import annotations

import numpy as np

from .scene import Frame, ObjectModel

DELTA_MM = 15.0


def bbox_xywh(mask: np.ndarray) -> list[int]:
    """[x, y, w, h] of the True pixels (w = x_max - x_min + 1), or [-1, -1, -1, -1] if none."""
    ys = np.flatnonzero(mask.any(axis=1))
    xs = np.flatnonzero(mask.any(axis=0))
    if xs.size == 0:
        return [-1, -1, -1, -1]
    return [int(xs[0]), int(ys[0]), int(xs[-1] - xs[0] + 1), int(ys[-1] - ys[0] + 1)]


def visible_mask(front_mask: np.ndarray, depth_render_mm: np.ndarray,
                 depth_real_mm: np.ndarray | None, delta_mm: float = DELTA_MM) -> np.ndarray:
    """front-most AND (real depth invalid OR rendered depth <= real depth + delta)."""
    if depth_real_mm is None:
        return front_mask.copy()
    ok = (depth_real_mm <= 0) | (depth_render_mm <= depth_real_mm + delta_mm)
    return front_mask & ok


def _geometry_only(model: ObjectModel):
    """Untextured geometry in mm (no texture decoding when the mesh is not loaded yet)."""
    import trimesh
    if model._mesh is None and model._loader is None and model.path is not None:
        from .io.mesh import load_geometry_mm
        return load_geometry_mm(model.path, model.unit_scale)
    mesh = model.mesh
    return trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), process=False)


def mesh_key(model: ObjectModel) -> tuple:
    """Renderer key of a model's geometry (per model file and scale)."""
    return ("gt_info", int(model.obj_id), str(model.path), float(model.unit_scale), id(model) if model.path is None else 0)


def ensure_meshes(renderer, models: dict[int, ObjectModel], obj_ids) -> None:
    """Upload the (untextured) geometry of the needed models once."""
    for oid in sorted(set(obj_ids)):
        key = mesh_key(models[oid])
        if not renderer.has_mesh(key):
            renderer.add_mesh(key, _geometry_only(models[oid]))


def _bbox_obj_large(renderer, K: np.ndarray, width: int, height: int, key, T: np.ndarray) -> list[int]:
    """bbox of the full silhouette on a 3x canvas centred on the image (truncation included)."""
    K3 = np.array(K, dtype=np.float64)
    K3[0, 2] += width
    K3[1, 2] += height
    out = renderer.render(K3, 3 * width, 3 * height, [(key, T)], outputs=("depth",))
    bb = bbox_xywh(out.depth_mm > 0)
    if bb[0] >= 0:
        bb[0] -= width
        bb[1] -= height
    return bb


def compute_gt_info(renderer, frame: Frame, models: dict[int, ObjectModel],
                    depth_mm_real: np.ndarray | None = None, delta_mm: float = DELTA_MM
                    ) -> tuple[list[np.ndarray], list[np.ndarray], list[dict]]:
    """Masks, visible masks and BOP gt_info dicts for every instance of ``frame``.

    ``models[obj_id].mesh`` must be in the model frame of the instance poses (mm).
    ``depth_mm_real``: the real depth image in mm (0 = invalid) or None.
    Returns (masks, masks_visib, gt_info) in instance order.
    """
    insts = frame.instances
    if not insts:
        return [], [], []
    ensure_meshes(renderer, models, [i.obj_id for i in insts])
    W, H = frame.camera.width, frame.camera.height
    K = frame.camera.K
    items = [(mesh_key(models[i.obj_id]), i.T_m2c) for i in insts]
    out = renderer.render(K, W, H, items, outputs=("depth", "instance", "mask_all"))
    valid = None if depth_mm_real is None else depth_mm_real > 0
    masks, masks_visib, infos = [], [], []
    for k in range(len(insts)):
        m_all = out.masks_all[k]
        front = out.instance == (k + 1)
        m_vis = visible_mask(front, out.depth_mm, depth_mm_real, delta_mm)
        n_all = int(m_all.sum())
        n_valid = n_all if valid is None else int((m_all & valid).sum())
        n_vis = int(m_vis.sum())
        touches = n_all > 0 and (m_all[0].any() or m_all[-1].any() or m_all[:, 0].any() or m_all[:, -1].any())
        if touches:
            bb_obj = _bbox_obj_large(renderer, K, W, H, items[k][0], items[k][1])
        else:
            bb_obj = bbox_xywh(m_all)
            if n_all == 0:   # possibly entirely outside the image
                bb_obj = _bbox_obj_large(renderer, K, W, H, items[k][0], items[k][1])
        masks.append(m_all)
        masks_visib.append(m_vis)
        infos.append({"bbox_obj": bb_obj, "bbox_visib": bbox_xywh(m_vis), "px_count_all": n_all,
                      "px_count_valid": n_valid, "px_count_visib": n_vis,
                      "visib_fract": float(n_vis / n_all) if n_all > 0 else 0.0})
    return masks, masks_visib, infos


def mask_iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two boolean masks (0 if both empty)."""
    u = np.logical_or(a, b).sum()
    return float(np.logical_and(a, b).sum() / u) if u else 0.0
