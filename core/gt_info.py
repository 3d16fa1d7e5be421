"""BOP masks and ``scene_gt_info`` of a frame, with the fast renderer, by BOP's rules.

The definitions are those of bop_toolkit's ``scripts/calc_gt_info.py`` and
``scripts/calc_gt_masks.py`` (BOP19 visibility), re-implemented here. For instance k of a frame,
each object is rendered ALONE (no mutual occlusion in the renderer) on a 3x canvas centred on the image,
whose centre third gives the image-size masks and depth (one render per object, so the counts and the
PNGs always agree):

- ``mask`` (mask/): the object's silhouette in the image (rendered depth > 0);
- ``mask_visib`` (mask_visib/): pixels of ``mask`` where the scene depth is missing (0) or the
  rendered distance exceeds the scene's distance by at most ``delta_mm`` (15 mm). Distances are
  along the camera ray: ``dist = depth * sqrt(((x - cx)/fx)^2 + ((y - cy)/fy)^2 + 1)`` at integer
  pixel coordinates, compared in float32. Hence ``mask_visib`` is a subset of ``mask``. The scene
  depth is the depth image of the dataset (real for ``convert``, the written synthetic depth for
  ``synth``). Without a depth image every pixel of the mask counts as visible (missing depth).
- ``px_count_all``: pixels of the silhouette on a 3x canvas centred on the image (the part
  outside the image counts); ``px_count_valid``: pixels of ``mask`` with scene depth > 0;
  ``px_count_visib``: pixels of ``mask_visib``; ``visib_fract = px_count_visib / px_count_all``
  (0 if the silhouette is empty), so ``visib_fract <= 1``.
- ``bbox_obj``: [x, y, w, h] of the 3x-canvas silhouette in image coordinates (may start
  outside the image), ``bbox_visib`` of ``mask_visib``, with BOP's ``calc_2d_bbox`` convention
  ``w = x_max - x_min`` (not + 1). As in BOP, both are [-1, -1, -1, -1] when
  ``px_count_visib`` is 0.

:func:`front_most_masks` gives the stricter visible masks of the older ycbvss rule (the object
is also front-most among the annotated objects), an optional extra output only.
"""
from __future__ import annotations

import numpy as np
import trimesh

from .io.mesh import load_geometry_mm
from .scene import Frame, ObjectModel

DELTA_MM = 15.0


def bbox_xywh(mask: np.ndarray) -> list[int]:
    """BOP ``calc_2d_bbox`` of the True pixels: [x_min, y_min, x_max - x_min, y_max - y_min];
    [-1, -1, -1, -1] if none."""
    ys = np.flatnonzero(mask.any(axis=1))
    xs = np.flatnonzero(mask.any(axis=0))
    if xs.size == 0:
        return [-1, -1, -1, -1]
    return [int(xs[0]), int(ys[0]), int(xs[-1] - xs[0]), int(ys[-1] - ys[0])]


def ray_factor(K: np.ndarray, width: int, height: int) -> np.ndarray:
    """Per-pixel factor depth -> distance along the ray, at integer pixel coordinates (float64)."""
    K = np.asarray(K, np.float64)
    xs = (np.arange(width, dtype=np.float64) - K[0, 2]) / K[0, 0]
    ys = (np.arange(height, dtype=np.float64) - K[1, 2]) / K[1, 1]
    return np.sqrt(xs[None, :] ** 2 + ys[:, None] ** 2 + 1.0)


def visible_mask(depth_obj_mm: np.ndarray, depth_scene_mm: np.ndarray | None, factor: np.ndarray,
                 delta_mm: float = DELTA_MM) -> np.ndarray:
    """BOP19 visibility of an object rendered alone: rendered > 0 and (scene depth missing or
    rendered distance - scene distance <= delta)."""
    obj = depth_obj_mm > 0
    if depth_scene_mm is None:
        return obj
    d_obj = (np.asarray(depth_obj_mm, np.float64) * factor).astype(np.float32)
    d_scene = (np.asarray(depth_scene_mm, np.float64) * factor).astype(np.float32)
    return obj & ((d_obj - d_scene <= delta_mm) | (d_scene == 0))


def front_most_masks(renderer, K, width: int, height: int, items, masks_visib) -> list[np.ndarray]:
    """Extra, non-BOP visible masks: BOP's mask_visib AND front-most among the annotated objects."""
    out = renderer.render(K, width, height, items, outputs=("instance",))
    return [m & (out.instance == k + 1) for k, m in enumerate(masks_visib)]


def _geometry_only(model: ObjectModel):
    """Untextured geometry in mm (no texture decoding when the mesh is not loaded yet)."""
    if model._mesh is None and model._loader is None and model.path is not None:
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
        owner = models[oid] if models[oid].path is None else None    # keys with id(model) keep the model referenced
        if not (renderer.has_mesh_of(key, owner) if owner is not None else renderer.has_mesh(key)):
            renderer.add_mesh(key, _geometry_only(models[oid]), owner=owner)


def _large_depth(renderer, K: np.ndarray, width: int, height: int, key, T: np.ndarray) -> np.ndarray:
    """Depth (mm) of one object on a 3x canvas whose centre third is the image (BOP's enlarged canvas)."""
    K3 = np.array(K, dtype=np.float64)
    K3[0, 2] += width
    K3[1, 2] += height
    return renderer.render(K3, 3 * width, 3 * height, [(key, T)], outputs=("depth",)).depth_mm


def gt_info_items(renderer, K: np.ndarray, width: int, height: int, items,
                  depth_scene_mm: np.ndarray | None, delta_mm: float = DELTA_MM
                  ) -> tuple[list[np.ndarray], list[np.ndarray], list[dict]]:
    """Masks, visible masks and gt_info of ``items`` = [(renderer mesh key, T_m2c mm)] by BOP's rules.

    ``depth_scene_mm``: the dataset's depth image in mm (0 = missing) or None (all missing).
    """
    if not items:
        return [], [], []
    factor = ray_factor(K, width, height)
    valid = None if depth_scene_mm is None else np.asarray(depth_scene_mm) > 0
    masks, masks_visib, infos = [], [], []
    for key, T in items:
        # one render per object on the 3x canvas; the image is its centre third (as calc_gt_info does)
        d_large = _large_depth(renderer, K, width, height, key, T)
        d_obj = d_large[height:2 * height, width:2 * width]
        large = d_large > 0
        m = d_obj > 0
        m_vis = visible_mask(d_obj, depth_scene_mm, factor, delta_mm)
        n_all, n_vis = int(large.sum()), int(m_vis.sum())
        bb_obj = [-1, -1, -1, -1]
        if n_vis > 0:                         # BOP leaves both boxes undefined when nothing is visible
            bb_obj = bbox_xywh(large)
            bb_obj[0] -= width
            bb_obj[1] -= height
        masks.append(m)
        masks_visib.append(m_vis)
        infos.append({"bbox_obj": bb_obj, "bbox_visib": bbox_xywh(m_vis), "px_count_all": n_all,
                      "px_count_valid": int(m.sum()) if valid is None else int((m & valid).sum()),
                      "px_count_visib": n_vis, "visib_fract": float(n_vis / n_all) if n_all > 0 else 0.0})
    return masks, masks_visib, infos


def compute_gt_info(renderer, frame: Frame, models: dict[int, ObjectModel],
                    depth_mm_real: np.ndarray | None = None, delta_mm: float = DELTA_MM
                    ) -> tuple[list[np.ndarray], list[np.ndarray], list[dict]]:
    """Masks, visible masks and BOP gt_info dicts for every instance of ``frame`` (BOP's rules).

    ``models[obj_id].mesh`` must be in the model frame of the instance poses (mm).
    ``depth_mm_real``: the frame's depth image in mm (0 = missing) or None.
    Returns (masks, masks_visib, gt_info) in instance order.
    """
    insts = frame.instances
    if not insts:
        return [], [], []
    ensure_meshes(renderer, models, [i.obj_id for i in insts])
    items = [(mesh_key(models[i.obj_id]), i.T_m2c) for i in insts]
    return gt_info_items(renderer, frame.camera.K, frame.camera.width, frame.camera.height, items,
                         depth_mm_real, delta_mm)


def mask_iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two boolean masks (0 if both empty)."""
    u = np.logical_or(a, b).sum()
    return float(np.logical_and(a, b).sum() / u) if u else 0.0
