"""Synthesis of one YCBV-SS frame; runs INSIDE a Blender worker process (``worker.call``).

Task in, files out: ``rgb/``, ``depth/``, ``mask/``, ``mask_visib/`` of the frame and, written last,
the done marker ``.done/NNNNNN.json`` holding the frame's scene_gt / scene_camera / scene_gt_info
entries and statistics. Randomness comes only from seeds derived from (seed, scene_id, im_id).
"""
from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np

from ..errors import YcbvssError
from ..gt_info import gt_info_items
from ..io.atomic import write_json_atomic
from ..io.images import read_depth_mm, read_label, read_mask, read_rgb
from ..io.mesh import load_geometry_mm
from ..render import Renderer
from .blender import frame_seed
from .composite import CompositeObject, composite_frame, merge_depth
from .frame_files import FrameFiles
from .noise import NoiseParams


def marker_path(split_dir, scene_id: int, im_id: int) -> Path:
    return Path(split_dir) / f"{scene_id:06d}" / ".done" / f"{im_id:06d}.json"


def validate_pose(T: np.ndarray, corners_mm: np.ndarray) -> str | None:
    """Reason why a pose cannot be rendered (NaN, behind the camera), or None."""
    T = np.asarray(T, np.float64)
    if not np.all(np.isfinite(T)):
        return "pose has NaN/inf"
    z = (corners_mm @ T[:3, :3].T + T[:3, 3])[:, 2]
    if np.any(z <= 1.0):
        return f"object (partly) behind the camera (t_z = {T[2, 3]:.1f} mm)"
    return None


def _fast_renderer(worker, meshes: dict):
    """The per-process fast renderer with the (dilated) output models uploaded once."""
    r = worker.cache.get("fast_renderer")
    if r is None:
        r = worker.cache["fast_renderer"] = Renderer()
    worker.cache.setdefault("corners", {})
    loaded = worker.cache.setdefault("fast_meshes", {})
    for key, spec in meshes.items():
        if loaded.get(key) != spec["path"]:
            m = load_geometry_mm(spec["path"], float(spec.get("unit_scale", 1.0)))   # masks need no texture
            r.add_mesh(key, m)
            v = np.asarray(m.vertices)
            lo, hi = v.min(0), v.max(0)
            worker.cache["corners"][key] = np.array(
                [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
            loaded[key] = spec["path"]
    return r


def _orig_visible(task: dict, obj: dict, label: np.ndarray | None, H: int, W: int) -> np.ndarray:
    if label is not None:
        return label == obj["obj_id"]
    p = obj.get("mask_visib_path")
    if p and Path(p).is_file():
        return read_mask(p)
    return np.zeros((H, W), bool)


class _Skip(Exception):
    """The frame cannot be synthesised; the message is the reason written to its marker."""


def process_frame(worker, config: dict, task: dict) -> dict:
    """Synthesise one frame. ``config``: run-wide settings (see ``synth.run._frame_config``);
    ``task``: the frame (``synth.run.frame_task``). Returns the marker dict (written last, with the
    frame's scene_gt / scene_camera / gt_info entries and timings in s), or a "skipped" marker."""
    t0, c0 = time.perf_counter(), time.process_time()
    split_dir = Path(config["split_dir"])
    sid, iid = int(task["scene_id"]), int(task["im_id"])
    wh = f"scene {sid} frame {iid}"
    W, H = int(task.get("width", 640)), int(task.get("height", 480))
    K = np.asarray(task["K"], np.float64).reshape(3, 3)
    marker = {"scene_id": sid, "im_id": iid, "src_rgb": str(task["rgb_path"]), "warnings": []}
    mpath = marker_path(split_dir, sid, iid)
    try:
        rgb, depth, label = _read_inputs(task, W, H, wh)
        fast = _fast_renderer(worker, config["meshes"])
        objs = _posed_objects(task, config["meshes"], worker.cache["corners"])
    except _Skip as e:
        marker.update(skipped=str(e), scene_gt=[], scene_camera=None, gt_info=[], objects=[])
        write_json_atomic(mpath, marker)
        return marker
    t_gt0, c_gt0 = time.perf_counter(), time.process_time()
    kept = _inside_image(fast, K, W, H, objs, wh, marker)
    t_gt, c_gt = time.perf_counter() - t_gt0, time.process_time() - c_gt0
    res = _render_blender(worker, config, K, W, H, kept, (sid, iid), marker)
    t_c0, c_c0 = time.perf_counter(), time.process_time()
    cobjs = [CompositeObject(k + 1, int(o["obj_id"]), _orig_visible(task, o, label, H, W)) for k, o in enumerate(kept)]
    rng = np.random.default_rng([int(config["seed"]), sid, iid])
    out_rgb, out_depth, cstats = _composite(config, rgb, depth, res, cobjs, rng)
    t_comp, c_comp = time.perf_counter() - t_c0, time.process_time() - c_c0
    t_w0, c_w0 = time.perf_counter(), time.process_time()
    _write_frame(fast, split_dir / f"{sid:06d}", (iid, wh), K, float(task["depth_scale"]), kept,
                 (out_rgb, out_depth, cstats), marker, mpath)
    t_w, c_w = time.perf_counter() - t_w0, time.process_time() - c_w0
    marker["timing"] = {"render_s": res["render_s"], "composite_s": t_comp, "gt_s": t_gt + t_w,
                        "total_s": time.perf_counter() - t0,
                        "render_cpu_s": res.get("render_cpu_s", 0.0), "composite_cpu_s": c_comp,
                        "gt_cpu_s": c_gt + c_w, "total_cpu_s": time.process_time() - c0}
    return marker


def _read_inputs(task: dict, W: int, H: int, wh: str) -> tuple:
    """The real frame: RGB (H, W, 3) uint8, depth (H, W) mm (zeros without a depth image) and the
    YCB-V label image (H, W) or None. Raises _Skip when missing, corrupt or not W x H."""
    try:
        rgb = read_rgb(task["rgb_path"], wh)
        depth = read_depth_mm(task["depth_path"], float(task["depth_scale"]), wh) if task.get("depth_path") \
            else np.zeros((H, W), np.float32)
        label = read_label(task["label_path"], wh) if task.get("label_path") else None
    except YcbvssError as e:
        raise _Skip(f"frame missing or corrupt: {e}") from None
    if rgb.shape[:2] != (H, W) or depth.shape != (H, W):
        raise _Skip(f"image size {rgb.shape[1]}x{rgb.shape[0]} / depth {depth.shape[::-1]} != {W}x{H}")
    return rgb, depth, label


def _posed_objects(task: dict, meshes: dict, corners: dict) -> list[dict]:
    """The task's objects with their mesh key and 4x4 pose ``T`` (mm); raises _Skip for an object
    without a model or with a pose that cannot be rendered (see :func:`validate_pose`)."""
    objs = []
    for ob in task["objects"]:
        key = f"obj_{int(ob['obj_id']):06d}"
        if key not in meshes:
            raise _Skip(f"object {ob['obj_id']}: no model")
        T = np.asarray(ob["T_m2c"], np.float64).reshape(4, 4)
        why = validate_pose(T, corners[key])
        if why is not None:
            raise _Skip(f"object {ob['obj_id']}: {why}")
        objs.append({**ob, "key": key, "T": T})
    return objs


def _inside_image(fast, K: np.ndarray, W: int, H: int, objs: list[dict], wh: str, marker: dict) -> list[dict]:
    """The objects whose full silhouette (fast renderer) touches the image, each with its
    ``mask_all`` (H, W) bool; the others are dropped with a warning in ``marker``."""
    out_all = fast.render(K, W, H, [(o["key"], o["T"]) for o in objs], outputs=("mask_all",)) if objs else None
    kept = []
    for k, o in enumerate(objs):
        if not out_all.masks_all[k].any():
            msg = f"{wh} object {o['obj_id']}: fully outside the image, skipped"
            warnings.warn(msg, stacklevel=3)
            marker["warnings"].append(msg)
            continue
        o["mask_all"] = out_all.masks_all[k]
        kept.append(o)
    return kept


def _render_blender(worker, config: dict, K: np.ndarray, W: int, H: int, kept: list[dict], ids: tuple,
                    marker: dict) -> dict:
    """Render all kept objects together in the worker's Blender session (re-configured only when the
    settings change); ``ids`` = (scene_id, im_id) seed the render. Returns the worker's result
    (``rgba``, ``index`` pass-index image, ``depth_mm``, ``render_s``); Blender's warnings go to ``marker``."""
    sid, iid = ids
    frame = {"id": f"{sid}_{iid}", "K": K.tolist(),
             "objects": [{"mesh": o["key"], "pass_index": k + 1, "T_m2c": o["T"].tolist()}
                         for k, o in enumerate(kept)]}
    cfg = {**config["render"], "width": W, "height": H, "threads": int(config.get("threads", 0))}
    if worker.cache.get("render_cfg") != cfg:
        worker.configure(cfg)
        worker.cache["render_cfg"] = cfg
    res = worker.render(frame, config["meshes"], frame_seed(int(config["seed"]), "cycles", sid, iid))
    marker["warnings"] += list(worker.session.warnings)
    worker.session.warnings[:] = []
    return res


def _composite(config: dict, rgb: np.ndarray, depth: np.ndarray, res: dict, cobjs: list, rng) -> tuple:
    """Composite the render over the real frame (colour fit, noise) and merge the depths: returns
    (RGB (H, W, 3) uint8, depth (H, W) mm, per-object composite statistics)."""
    noise = NoiseParams(**config.get("noise", {}))
    out_rgb, cstats = composite_frame(rgb, res["rgba"], res["index"], cobjs, noise, rng,
                                      fit=bool(config.get("colour_fit", True)),
                                      fit_method=config.get("colour_fit_method", "adaptive"),
                                      clear_px=int(config.get("clear_px", 4)))
    obj_px = res["index"] > 0
    out_depth = merge_depth(depth, res["depth_mm"], obj_px & (res["depth_mm"] > 0))
    return out_rgb, out_depth, cstats


def _write_frame(fast, sdir: Path, ids: tuple, K: np.ndarray, ds_out: float, kept: list[dict], images: tuple,
                 marker: dict, mpath: Path) -> None:
    """Write rgb/, depth/ (uint16, x ``ds_out`` = mm), mask/, mask_visib/ and, last, the marker with
    scene_gt / scene_camera / gt_info (BOP rules against the depth as written). ``ids`` = (im_id,
    where-text), ``images`` = (RGB, depth mm, composite stats)."""
    iid, wh = ids
    out_rgb, out_depth, cstats = images
    files = FrameFiles(wh)
    try:
        files.png(sdir / "rgb" / f"{iid:06d}.png", out_rgb)
        d = np.round(np.nan_to_num(out_depth, nan=0.0, posinf=0.0) / ds_out)
        if d.max(initial=0) > 65535:
            raise YcbvssError(f"depth exceeds uint16 range with depth_scale {ds_out}", sdir / "depth", wh)
        files.png(sdir / "depth" / f"{iid:06d}.png", d.astype(np.uint16))
        depth_written_mm = d.astype(np.float64) * ds_out
        H, W = depth_written_mm.shape
        items = [(o["key"], o["T"]) for o in kept]
        masks, masks_visib, gt_info = gt_info_items(fast, K, W, H, items, depth_written_mm)
        scene_gt, objects = [], []
        for k, o in enumerate(kept):
            files.png(sdir / "mask" / f"{iid:06d}_{k:06d}.png", masks[k].astype(np.uint8) * 255)
            files.png(sdir / "mask_visib" / f"{iid:06d}_{k:06d}.png", masks_visib[k].astype(np.uint8) * 255)
            T = o["T"]
            scene_gt.append({"cam_R_m2c": T[:3, :3].reshape(-1).tolist(), "cam_t_m2c": T[:3, 3].tolist(),
                             "obj_id": int(o["obj_id"])})
            objects.append({"obj_id": int(o["obj_id"]), "src_gt_idx": o.get("gt_idx"), **cstats[k]})
        marker.update(scene_gt=scene_gt, gt_info=gt_info, objects=objects,
                      scene_camera={"cam_K": K.reshape(-1).tolist(), "depth_scale": ds_out})
        files.commit(mpath, marker)
    except BaseException:
        files.abort()
        raise
