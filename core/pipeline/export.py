"""``ycbvss export``: a BOP dataset with refined annotations, and ``ycbvss gt``: a split's GT as BOP19 CSV.

Export reads the source dataset (``--dataset``/``--split``) and a ``ycbvss refine`` output folder
(``REFINE/<split>/<scene>/scene_gt.json``, ``scene_camera.json``, ``REFINE/refine/<scene>_status.json``)
and writes a complete BOP root:

- ``<split>/<scene>/scene_gt.json``: the refined pose of each instance (source instance order);
  an instance the refiner did not return (scene not refined, or several instances of one object in an
  image, which the refiner does not separate) keeps its source pose, marked ``"refined": false``;
- ``scene_camera.json``: cam_K/depth_scale of the source, ``cam_R_w2c``/``cam_t_w2c`` solved by the
  refiner where it solved them (else the source's);
- ``scene_gt_info.json``, ``mask/``, ``mask_visib/``: recomputed for the new poses by BOP's rules
  (:mod:`ycbvss.gt_info`);
- ``scene_gt_refine.json`` (side file, same layout as scene_gt.json): per instance ``refined``,
  ``status``, ``confidence``, ``reason`` from the refiner;
- ``rgb/`` and ``depth/``: symbolic links to the source files, or copies with ``copy=True``;
- ``models/`` (+ ``models_original/`` if the source has it) linked or copied, ``models_eval/`` (linked
  from the source when it has one, else computed),
  camera files, the targets file, ``dataset_info.md``.
"""
from __future__ import annotations

import copy as _copy
import os
import shutil
import time
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import YcbvssError, where as fmt_where
from ..gt_info import compute_gt_info
from ..io.atomic import atomic_path, read_json, write_json_atomic, write_text_atomic
from ..io.bop import BopSceneWriter, load_dataset, read_scene_camera, read_scene_gt
from ..io.bop_dataset import write_camera_files, write_models_eval, write_targets
from ..io.results import Estimate, write_bop19_csv
from ..progress import progress
from ..render import Renderer
from ..scene import Instance


def _place(src: Path, dst: Path, copy: bool) -> None:
    """Link (absolute symlink) or copy ``src`` to ``dst``, atomically."""
    src = Path(src).resolve()
    if not src.is_file():
        raise YcbvssError("missing source file", src)
    dst.parent.mkdir(parents=True, exist_ok=True)
    if copy:
        with atomic_path(dst) as tmp:
            shutil.copyfile(src, tmp)
        return
    tmp = dst.parent / f".tmp-link-{dst.name}-{os.getpid()}"
    tmp.unlink(missing_ok=True)
    os.symlink(src, tmp)
    os.replace(tmp, dst)


def _place_models(src_dir: Path, dst_dir: Path, copy: bool) -> None:
    for p in sorted(src_dir.iterdir()):
        if p.is_file() and not p.name.startswith("."):
            _place(p, dst_dir / p.name, copy)


def _refined_scene(refine_dir: Path, split: str, sid: int):
    """(poses {(im, obj): T}, cameras {im: T_w2c or None}, status {(im, obj): dict}) of a refined scene,
    or None when the refine output has no such scene."""
    sdir = refine_dir / split / f"{sid:06d}"
    if not (sdir / "scene_gt.json").is_file():
        return None
    gt = read_scene_gt(sdir / "scene_gt.json", sid)
    poses = {}
    for im, insts in gt.items():
        for i in insts:
            if (im, i.obj_id) in poses:
                raise YcbvssError("refined scene_gt.json has two poses of one object in an image",
                                  sdir / "scene_gt.json", fmt_where(sid, im, i.obj_id))
            poses[(im, i.obj_id)] = i.T_m2c
    cams = {}
    if (sdir / "scene_camera.json").is_file():
        cams = {im: c["T_w2c"] for im, c in read_scene_camera(sdir / "scene_camera.json", sid).items()}
    status = {}
    sp = refine_dir / "refine" / f"{sid:06d}_status.json"
    if sp.is_file():
        for e in read_json(sp, "refine status").get("poses", []):
            status[(int(e["im_id"]), int(e["obj_id"]))] = {k: e.get(k) for k in ("status", "confidence", "reason")}
    return poses, cams, status


def dataset_info_md(source: Path, split: str, refine_dir: Path, counts: dict, copy: bool) -> str:
    src_info = source / "dataset_info.md"
    return (f"# Refined BOP dataset (ycbvss {__version__}, `ycbvss export`)\n\n"
            f"- source dataset: `{source.resolve()}`, split `{split}`\n"
            f"- refined poses: `{refine_dir.resolve()}` (`ycbvss refine`: bundle pose refinement of every object "
            "and camera of a scene, edge + point + temporal terms; see the refine folder's logs)\n"
            f"- poses: {counts['refined']} refined, {counts['kept']} kept from the source (not refined); "
            f"statuses: {', '.join(f'{k} {v}' for k, v in sorted(counts['status'].items())) or '-'}; "
            "per instance in `scene_gt_refine.json`\n"
            f"- cameras: cam_R_w2c/cam_t_w2c solved by the refiner for {counts['cams_refined']} images "
            f"({counts['cams_kept']} kept from the source)\n"
            "- scene_gt_info.json, mask/, mask_visib/: recomputed for the refined poses by bop_toolkit's "
            "calc_gt_info rules\n"
            f"- rgb/, depth/, models/: {'copies' if copy else 'symbolic links to the source files'}\n\n"
            + (f"## Source dataset_info.md\n\n{src_info.read_text()}" if src_info.is_file() else ""))


def export_refined(dataset: str | Path, split: str, refined: str | Path, out: str | Path, copy: bool = False,
                   scenes=None, delta_mm: float = 15.0, show_progress: bool = True) -> dict:
    """Write the refined BOP dataset (see module docstring); returns a summary dict (counts of
    refined/kept poses and cameras, per-status counts, frames, seconds)."""
    t0 = time.perf_counter()
    src, refine_dir, out = Path(dataset), Path(refined), Path(out)
    ds = _open_export(src, split, refine_dir, out, scenes)
    _place_models(src / "models", out / "models", copy)
    if (src / "models_original").is_dir():
        _place_models(src / "models_original", out / "models_original", copy)
    renderer = Renderer()
    counts = {"refined": 0, "kept": 0, "status": {}, "cams_refined": 0, "cams_kept": 0, "frames": 0}
    n_frames = sum(1 for _ in ds.scene_ids)
    bar = progress(total=n_frames, desc="export scenes", unit="scene")
    for scene in ds.iter_scenes():
        ref = _refined_scene(refine_dir, split, scene.scene_id)
        writer = BopSceneWriter(out / split, scene.scene_id)
        side = {}
        for f in scene.frames:
            g, side[str(f.im_id)] = _refined_frame(f, ref, counts)
            depth = f.load_depth_mm() if f.depth_path is not None else None
            masks, masks_visib, infos = compute_gt_info(renderer, g, ds.models, depth, delta_mm)
            writer.write_frame(g, masks=masks, masks_visib=masks_visib, gt_info=infos)
            if f.rgb_path is not None:
                _place(f.rgb_path, writer.dir / Path(f.rgb_path).parent.name / Path(f.rgb_path).name, copy)
            if f.depth_path is not None:
                _place(f.depth_path, writer.dir / "depth" / Path(f.depth_path).name, copy)
            counts["frames"] += 1
        write_json_atomic(writer.dir / "scene_gt_refine.json", side)
        writer.close()
        bar.update(1)
    bar.close()
    write_camera_files(out)
    write_targets(out, split)
    if (src / "models_eval" / "models_info.json").is_file():    # same models: same models_eval
        _place_models(src / "models_eval", out / "models_eval", copy)
    else:
        write_models_eval(out, show_progress=show_progress)
    write_text_atomic(out / "dataset_info.md", dataset_info_md(src, split, refine_dir, counts, copy))
    return {"out": str(out), "split": split, "scenes": list(ds.scene_ids), **counts,
            "seconds": time.perf_counter() - t0}


def _open_export(src: Path, split: str, refine_dir: Path, out: Path, scenes):
    """Check the inputs and create ``out``; returns the source dataset (``scenes`` only)."""
    if not refine_dir.is_dir():
        raise YcbvssError("refine output folder not found", refine_dir)
    if out.resolve() == src.resolve():
        raise YcbvssError("--out must differ from --dataset", out)
    ds = load_dataset(src, split, scene_ids=scenes)
    if not (refine_dir / split).is_dir():
        raise YcbvssError(f"no split {split!r} in the refine output (refine was run with another --split?)",
                          refine_dir / split)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise YcbvssError(f"output folder not writable: {e.strerror}", out) from None
    return ds


def _refined_frame(f, ref: tuple | None, counts: dict) -> tuple:
    """(copy of frame ``f`` with the refined poses and camera where ``ref`` = (poses, cameras, status)
    of its scene has them, the scene_gt_refine.json notes of its instances); updates ``counts``.
    An object seen several times in the image keeps its original poses."""
    poses, cams, status = ref if ref is not None else ({}, {}, {})
    per_obj = {}
    for i in f.instances:
        per_obj[i.obj_id] = per_obj.get(i.obj_id, 0) + 1
    insts, notes = [], []
    for i in f.instances:
        T = poses.get((f.im_id, i.obj_id)) if per_obj[i.obj_id] == 1 else None
        if T is not None:
            insts.append(Instance(i.obj_id, np.asarray(T, np.float64), gt_id=i.gt_id))
            st = status.get((f.im_id, i.obj_id), {})
            notes.append({"refined": True, **st})
            counts["refined"] += 1
            s = st.get("status") or "unknown"
            counts["status"][s] = counts["status"].get(s, 0) + 1
        else:
            insts.append(i)
            why = "scene not refined" if ref is None else (
                "several instances of this object in the image" if per_obj[i.obj_id] > 1 else "no refined pose")
            notes.append({"refined": False, "status": None, "confidence": None, "reason": why})
            counts["kept"] += 1
    g = _copy.copy(f)
    g.instances = insts
    T_w2c = cams.get(f.im_id)
    if T_w2c is not None:
        g.T_w2c = T_w2c
        counts["cams_refined"] += 1
    else:
        counts["cams_kept"] += 1
    return g, notes


def write_gt_csv(dataset: str | Path, split: str, out_csv: str | Path, scenes=None) -> int:
    """A split's GT poses as a BOP19 results CSV (score 1, time -1); returns the number of rows."""
    ds = load_dataset(dataset, split, scene_ids=scenes)
    ests = [Estimate(sc.scene_id, f.im_id, i.obj_id, 1.0, i.T_m2c, -1.0)
            for sc in ds.iter_scenes() for f in sc.frames for i in f.instances]
    if not ests:
        raise YcbvssError(f"no GT instances in split {split!r}", Path(dataset) / split)
    write_bop19_csv(out_csv, ests)
    return len(ests)
