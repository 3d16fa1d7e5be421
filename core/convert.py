"""``ycbvss convert ycbv``: original YCB-Video layout -> BOP layout.

- Models: ``models/<name>/textured.obj`` (metres) -> ``models/obj_XXXXXX.ply`` in mm, recentred
  on the bounding-box centre c of the OBJ vertices (the BOP ycbv model frame), binary PLY with
  normals, per-vertex UVs and ``obj_XXXXXX.png`` texture; ``models_info.json`` (diameter, min,
  size, symmetries of the assets manifest).
- Poses: R unchanged, ``t_bop[mm] = 1000 * (t + R c)`` (t, c in metres).
- Scenes: scene id = video number, im_id = frame number; split ``train_real`` (or ``test`` for
  videos 48-59, as BOP ycbv) unless given. rgb/ = byte copies of color.png; depth/ = byte
  copies of depth.png with ``depth_scale = 1000 / factor_depth`` (0.1: BOP ycbv's convention);
  scene_camera.json with cam_K from meta.mat and cam_R_w2c/cam_t_w2c from
  rotation_translation_matrix (mm); mask/, mask_visib/, scene_gt_info.json from the renderer
  (see :mod:`ycbvss.gt_info`).
- Idempotent: a scene whose scene_camera.json lists the same frames and a model whose PLY
  and texture exist are skipped unless ``overwrite``; every file is written atomically.
"""
from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Iterable

import cv2
import numpy as np

from . import __version__
from .errors import YcbvssError, where as fmt_where
from .geometry.model_frame import recentre_pose
from .gt_info import compute_gt_info
from .io.atomic import read_json, write_json_atomic, write_text_atomic
from .io.bop import BopSceneWriter, load_models_info, model_filename
from .io.bop_dataset import write_camera_files, write_models_eval, write_targets
from .io.images import read_depth_mm
from .io.mesh import compute_models_info, load_textured_mm, load_vertices_mm, write_ply_mm
from .io.ycbv import list_frames, load_ycbv_dataset, model_center_mm
from .manifest import bop_symmetries
from .progress import progress
from .render import Renderer
from .scene import Frame, Instance, ObjectModel

TEST_VIDEOS = range(48, 60)


class _Null:
    def write(self, *_):
        pass

    def flush(self):
        pass


def default_split(video: int) -> str:
    return "test" if video in TEST_VIDEOS else "train_real"


def _bop_mesh_from_obj(model: ObjectModel, c_mm: np.ndarray, texture_max_px: int | None = None):
    """Load a YCB-V textured.obj, return (mesh recentred on ``c_mm``, in mm; texture RGB | None)."""
    mesh, tex = load_textured_mm(model.path, 1000.0)
    mesh.vertices = np.asarray(mesh.vertices, np.float64) - c_mm
    if tex is not None and texture_max_px and max(tex.shape[:2]) > texture_max_px:
        s = texture_max_px / max(tex.shape[:2])
        tex = cv2.resize(tex, (max(1, round(tex.shape[1] * s)), max(1, round(tex.shape[0] * s))),
                         interpolation=cv2.INTER_AREA)
    return mesh, tex


def convert_models(ycbv_models: dict[int, ObjectModel], models_dir: Path, overwrite: bool = False,
                   obj_ids: Iterable[int] | None = None, show_progress: bool = True,
                   texture_max_px: int | None = None, workers: int = 2) -> tuple[dict, dict]:
    """Write BOP models for ``obj_ids`` (default all) in ``workers`` threads.

    Returns ({obj_id: c_mm}, {obj_id: ObjectModel of the written PLY (mm, BOP frame)}).
    ``texture_max_px``: downsample textures whose longest side is larger (None: keep).
    """
    models_dir = Path(models_dir)
    ids = sorted(ycbv_models if obj_ids is None else set(int(i) for i in obj_ids))
    for oid in ids:
        if oid not in ycbv_models:
            raise YcbvssError("no YCB-Video model (models/<name>/textured.obj) for this object",
                              None, fmt_where(obj_id=oid))
    old_info = {}
    if (models_dir / "models_info.json").is_file():
        try:
            old_info = load_models_info(models_dir)
        except YcbvssError:
            old_info = {}

    def one(oid: int):
        src = ycbv_models[oid]
        ply = models_dir / model_filename(oid)
        png = models_dir / f"obj_{oid:06d}.png"
        c_mm = model_center_mm(src.path)           # cached with the model's diameter: the OBJ is not read again
        disc, cont = bop_symmetries(oid)
        if overwrite or not (ply.is_file() and png.is_file()):
            mesh, tex = _bop_mesh_from_obj(src, c_mm, texture_max_px)
            write_ply_mm(ply, mesh, png.name if tex is not None else None, texture_rgb=tex)
        info = compute_models_info(load_vertices_mm(ply), disc, cont)   # from the stored float32 vertices
        m = ObjectModel(obj_id=oid, path=ply, name=src.name, unit_scale=1.0, diameter_mm=info["diameter"],
                        symmetries_discrete=disc, symmetries_continuous=cont, symmetric=src.symmetric,
                        textureless=src.textureless, info=info)
        return oid, c_mm, m

    centers, bop_models = {}, {}
    with ThreadPoolExecutor(max_workers=max(1, int(workers))) as pool:
        results = pool.map(one, ids)
        for oid, c_mm, m in (progress(results, desc="models", total=len(ids), unit="model")
                             if show_progress else results):
            centers[oid], bop_models[oid] = c_mm, m
    info = {k: m.info for k, m in bop_models.items()}
    merged = {**{k: v for k, v in old_info.items() if k not in info}, **info}
    write_json_atomic(models_dir / "models_info.json", {str(k): merged[k] for k in sorted(merged)})
    return centers, bop_models


def _scene_complete(scene_dir: Path, im_ids: list[int]) -> bool:
    p = scene_dir / "scene_camera.json"
    if not (p.is_file() and (scene_dir / "scene_gt.json").is_file() and (scene_dir / "scene_gt_info.json").is_file()):
        return False
    try:
        return sorted(int(k) for k in read_json(p)) == sorted(im_ids)
    except (YcbvssError, ValueError):
        return False


def dataset_info_md(splits, obj_ids, delta_mm: float) -> str:
    """dataset_info.md of a converted YCB-V root."""
    return (f"# YCB-Video in BOP format (written by ycbvss {__version__}, `ycbvss convert ycbv`)\n\n"
            f"- splits: {', '.join(splits)}; targets: "
            + ", ".join(f"`{'test' if s == 'test' else s}_targets_bop19.json`" for s in splits) + "\n"
            f"- models/: the YCB-Video textured meshes recentred on their bounding-box centre, in mm "
            f"(objects {', '.join(str(o) for o in obj_ids)}); NOT dilated: the GT poses refer to these models.\n"
            "- models_eval/: the same models uniformly remeshed for evaluation (pymeshlab), same models_info.json.\n"
            "- poses: the original YCB-Video annotations (t_bop = 1000 (t + R c)); rgb/depth byte copies "
            "(depth_scale 0.1).\n"
            f"- scene_gt_info.json, mask/, mask_visib/: bop_toolkit calc_gt_info rules (delta {delta_mm:g} mm, "
            "missing depth visible, 3x canvas for px_count_all/bbox_obj, bbox w = x_max - x_min).\n")


def convert_ycbv(src: str | Path, out: str | Path, videos=None, split: str | None = None,
                 overwrite: bool = False, obj_ids: Iterable[int] | None = None, delta_mm: float = 15.0,
                 renderer=None, show_progress: bool = True, texture_max_px: int | None = None,
                 workers: int = 2) -> dict:
    """Convert a YCB-Video root to a BOP dataset root. Returns a summary dict.

    ``videos``: None (all), list of ints, or '0000,0001'; ``split``: None = BOP ycbv's split
    by video (test for 48-59, else train_real); ``obj_ids``: models to convert (default: all
    21; objects seen in the selected videos are always converted, when their video is reached);
    ``texture_max_px``: downsample
    model textures larger than this (None: keep the 4096 px YCB textures); ``workers``: threads
    for the model conversion.
    """
    t0 = time.perf_counter()
    src, out = Path(src), Path(out)
    if out.resolve() == src.resolve():
        raise YcbvssError("output folder must differ from the YCB-Video root", out)
    ds = load_ycbv_dataset(src, videos)
    ids = sorted(set(ds.models) if obj_ids is None else set(int(i) for i in obj_ids))
    centers, bop_models = convert_models(ds.models, out / "models", overwrite, ids, show_progress,
                                         texture_max_px, workers)
    t_models = time.perf_counter() - t0
    write_camera_files(out)
    frame_ids = {v: list_frames(src, v) for v in ds.scene_ids}      # from file names only
    n_frames = sum(len(x) for x in frame_ids.values())
    done = skipped = 0
    bar = progress(total=n_frames, desc="frames", unit="frame", **({} if show_progress else {"file": _Null()}))
    for v in ds.scene_ids:                                           # streaming: one video at a time
        sp = split or default_split(v)
        writer = BopSceneWriter(out / sp, v)
        if not overwrite and _scene_complete(writer.dir, frame_ids[v]):
            skipped += len(frame_ids[v])
            bar.update(len(frame_ids[v]))
            continue
        scene = ds.load_scene(v)                                     # meta.mat files; images stay on disk
        new = sorted(set(scene.obj_ids) - set(bop_models))
        if new:                                                      # objects not requested but present
            t1 = time.perf_counter()
            c2, m2 = convert_models(ds.models, out / "models", overwrite, new, False, texture_max_px, workers)
            centers.update(c2)
            bop_models.update(m2)
            t_models += time.perf_counter() - t1
        if renderer is None:
            renderer = Renderer()
        for f in scene.frames:
            _write_frame(writer, renderer, f, centers, bop_models, delta_mm)
            done += 1
            bar.update(1)
        writer.close()
    bar.close()
    splits = sorted({split or default_split(v) for v in ds.scene_ids})
    for sp in splits:
        write_targets(out, sp)
    write_models_eval(out, show_progress=show_progress, overwrite=overwrite)
    write_text_atomic(out / "dataset_info.md", dataset_info_md(splits, sorted(bop_models), delta_mm))
    dt = time.perf_counter() - t0
    return {"out": str(out), "videos": list(ds.scene_ids), "splits": splits, "frames_written": done,
            "frames_skipped": skipped, "models": sorted(bop_models), "seconds": dt, "seconds_models": t_models,
            "centers_mm": {k: v.tolist() for k, v in centers.items()}}


def _write_frame(writer, renderer, f, centers: dict, bop_models: dict, delta_mm: float) -> None:
    """One YCB-V frame into the BOP scene ``writer``: poses recentred on the model centres (mm),
    images copied, masks and gt_info computed against its depth image."""
    insts = [Instance(obj_id=i.obj_id, T_m2c=recentre_pose(i.T_m2c, centers[i.obj_id]), gt_id=i.gt_id)
             for i in f.instances]
    fb = Frame(scene_id=f.scene_id, im_id=f.im_id, camera=f.camera, instances=insts, depth_scale=f.depth_scale,
               T_w2c=f.T_w2c)
    depth = read_depth_mm(f.depth_path, f.depth_scale, where=f.where)
    if depth.shape != (f.camera.height, f.camera.width):
        raise YcbvssError(f"depth image is {depth.shape[1]}x{depth.shape[0]}, expected "
                          f"{f.camera.width}x{f.camera.height}", f.depth_path, f.where)
    masks, masks_visib, infos = compute_gt_info(renderer, fb, bop_models, depth, delta_mm)
    writer.write_frame(fb, masks=masks, masks_visib=masks_visib, gt_info=infos,
                       rgb_src=f.rgb_path, depth_src=f.depth_path)
