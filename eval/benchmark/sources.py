"""The sequences a benchmark is made from and scored on: GT poses and cameras of every frame,
read from the annotation files only (BOP ``scene_gt.json`` + ``scene_camera.json``; original
YCB-Video ``meta.mat``; BCOT ``pose.txt`` + ``K.txt``), never the images.

Layouts: ``bop`` (a split of a BOP root), ``ycbv`` (the original YCB-Video root) and ``bcot``.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import YcbvssError
from ...geometry.so3 import project_to_so3
from ...io.atomic import read_json
from ...io.bcot import (
    BCOT_TEST_SCENES,
    body_obj_ids,
    is_bcot_root,
    list_sequences,
    load_bcot_dataset,
    load_bcot_models,
    load_bcot_sequence,
)
from ...io.bop import load_bop_scene, load_models as load_bop_models, read_scene_camera, read_scene_gt, select_scene_ids
from ...io.ycbv import list_frames, list_videos, load_ycbv_models, load_ycbv_scene, read_meta_frame
from ...progress import progress

BOP_SPLITS = ("test", "val", "train_real", "train_synt", "train_pbr", "train")


@dataclass
class Sequence:
    """One video: ``im_ids`` in temporal order, ``K[im_id]`` (3x3), ``gt[im_id][obj_id]`` 4x4 mm
    object-to-camera (first instance of an object per frame), ``name`` for humans.

    GT rotations are projected onto SO(3) when read (the readers accept |R^T R - I| up to 1e-4;
    YCB-V's meta.mat rotations are float-rounded): ycbvss.eval's ADD maps points through
    ``R_est^T R_gt``, which must be exact for an estimate equal to the GT to score 100."""

    scene_id: int
    name: str
    im_ids: list[int]
    K: dict[int, np.ndarray]
    gt: dict[int, dict[int, np.ndarray]] = field(default_factory=dict)

    def objects_in(self, im_id: int) -> list[int]:
        return sorted(self.gt.get(im_id, {}))


def detect_layout(root: str | Path) -> str:
    """``ycbv`` (data/ + models/<name>/), ``bcot`` (models/*.obj + <scene>/K.txt) or ``bop``."""
    root = Path(root)
    if not root.is_dir():
        raise YcbvssError("dataset not found (a BOP, YCB-Video or BCOT root folder)", root)
    if (root / "data").is_dir() and (root / "models").is_dir() and not (root / "models" / "models_info.json").is_file():
        return "ycbv"
    if is_bcot_root(root):
        return "bcot"
    return "bop"


def detect_split(root: Path) -> str:
    cands = [d.name for d in sorted(root.iterdir()) if d.is_dir()
             and any((s / "scene_camera.json").is_file() for s in d.iterdir() if s.is_dir())]
    if not cands:
        raise YcbvssError("no BOP split folder with scenes (NNNNNN/scene_camera.json) found", root)
    return next((s for s in BOP_SPLITS if s in cands), cands[0])


def load_models(root: str | Path, layout: str, symmetric_obj_ids=(13,)) -> dict:
    """obj_id -> ObjectModel of a dataset root."""
    root = Path(root)
    if layout == "ycbv":
        return load_ycbv_models(root, symmetric_obj_ids)
    if layout == "bcot":
        return load_bcot_models(root)
    names = None if (root / "models" / "ycbvss_objects.json").is_file() else "auto"
    models = load_bop_models(root / "models", symmetric_obj_ids, names=names)
    meta = root / "models" / "ycbvss_objects.json"
    if meta.is_file():
        for k, v in read_json(meta, "object metadata").items():
            if int(k) in models:
                models[int(k)].name = str(v.get("name", models[int(k)].name))
    return models


def _so3(T) -> np.ndarray:
    T = np.array(T, dtype=np.float64)
    T[:3, :3] = project_to_so3(T[:3, :3])
    return T


def _gt_of_frames(frames) -> tuple[dict, dict]:
    K, gt = {}, {}
    for f in frames:
        K[f.im_id] = np.asarray(f.camera.K, dtype=np.float64)
        d = {}
        for inst in f.instances:
            if inst.obj_id in d:
                warnings.warn(f"scene {f.scene_id} frame {f.im_id}: object {inst.obj_id} appears twice; "
                              f"the benchmark tracks its first instance")
                continue
            d[inst.obj_id] = _so3(inst.T_m2c)
        gt[f.im_id] = d
    return K, gt


def load_sequences(root: str | Path, layout: str | None = None, split: str | None = None,
                   scenes: list | None = None, bcot_scenes: list[str] | None = None,
                   quiet: bool = False) -> tuple[list[Sequence], dict]:
    """All sequences of a dataset (GT and cameras only). Returns (sequences, dataset info dict for
    the benchmark JSON: name, root, layout, split, and for BCOT the test scenes)."""
    root = Path(root)
    layout = layout or detect_layout(root)
    info: dict = {"root": str(root.resolve()), "layout": layout}
    seqs: list[Sequence] = []
    if layout == "ycbv":
        vids = list_videos(root) if scenes is None else [int(s) for s in scenes]
        info.update(name="ycbv", split="data")
        for v in progress(vids, desc="read GT", unit="video"):
            d = root / "data" / f"{v:04d}"
            ims = list_frames(root, v)
            K, gt = {}, {}
            for im in ims:
                m = read_meta_frame(d / f"{im:06d}-meta.mat", v, im)
                K[im] = m["K"]
                gt[im] = {}
                for o, T in zip(m["obj_ids"], m["T_m2c"]):
                    gt[im].setdefault(int(o), _so3(T))
            seqs.append(Sequence(v, f"{v:04d}", ims, K, gt))
    elif layout == "bcot":
        have = sorted({s for s, _ in list_sequences(root)})
        if bcot_scenes is None:
            bcot_scenes = [s for s in BCOT_TEST_SCENES if s in have] or have
        ds = load_bcot_dataset(root, bcot_scenes)
        info.update(name="bcot", split="", bcot_test_scenes=list(bcot_scenes))
        ids = ds.scene_ids if scenes is None else [int(s) for s in scenes]
        for sid in progress(ids, desc="read GT", unit="seq"):
            sc = ds.load_scene(sid)
            K, gt = _gt_of_frames(sc.frames)
            seqs.append(Sequence(sid, ds.sequence_names[sid], [f.im_id for f in sc.frames], K, gt))
    elif layout == "bop":
        split = split or detect_split(root)
        sdir = root / split
        if not sdir.is_dir():
            raise YcbvssError(f"split folder '{split}' not found", sdir)
        info.update(name=root.name, split=split)
        for sid in progress(select_scene_ids(sdir, scenes), desc="read GT", unit="scene"):
            d = sdir / f"{sid:06d}"
            cams = read_scene_camera(d / "scene_camera.json", sid)
            if not (d / "scene_gt.json").is_file():
                raise YcbvssError("missing scene_gt.json", d / "scene_gt.json", f"scene {sid}")
            gts = read_scene_gt(d / "scene_gt.json", sid)
            K, gt = {}, {}
            for im in sorted(cams):
                K[im] = np.asarray(cams[im]["K"], dtype=np.float64)
                gt[im] = {}
                for inst in gts.get(im, []):
                    gt[im].setdefault(int(inst.obj_id), _so3(inst.T_m2c))
            seqs.append(Sequence(sid, f"{sid:06d}", sorted(cams), K, gt))
    else:
        raise YcbvssError(f"unknown dataset layout {layout!r} (bop, ycbv or bcot)")
    return seqs, info


def load_scene(root: str | Path, layout: str, split: str, scene_id: int, models: dict | None = None):
    """The :class:`ycbvss.scene.Scene` of one sequence, with image paths (for running trackers)."""
    root = Path(root)
    if layout == "ycbv":
        return load_ycbv_scene(root, scene_id, models)
    if layout == "bcot":
        seqs = list_sequences(root)
        if not 0 <= scene_id < len(seqs):
            raise YcbvssError(f"BCOT sequence {scene_id} not found ({len(seqs)} sequences)", root)
        s, b = seqs[scene_id]
        ids = body_obj_ids({bb for _, bb in seqs} | {p.stem for p in (root / "models").glob("*.obj")})
        return load_bcot_sequence(root, s, b, scene_id, ids[b], need_images=True)
    return load_bop_scene(root / split, scene_id, models)
