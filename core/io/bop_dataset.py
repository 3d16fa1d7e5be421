"""Dataset-level files of a BOP root that every ycbvss writer adds (convert, synth, export, demo).

- ``camera_<name>.json``: the dataset's sensors (BOP ``dataset_params.get_camera_params``).
- ``<split>_targets_bop19.json`` (``test_targets_bop19.json`` for split ``test``): the
  estimation targets of BOP19 -- per image and object the number of instances with
  ``visib_fract >= 0.1`` -- built from the split's ``scene_gt.json`` / ``scene_gt_info.json``.
- ``models_eval/``: each model resampled uniformly for evaluation (pymeshlab isotropic explicit
  remeshing, target edge length 1.5 % of the diameter clamped to [1.5, 5] mm) with a
  ``models_info.json`` holding the SAME entries (diameters, extents, symmetries) as ``models/``.
- ``dataset_info.md``: what the dataset is, which models the GT refers to, how it was made.
"""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import trimesh

from ..errors import YcbvssError, where as fmt_where
from ..manifest import cameras
from ..progress import progress
from .atomic import atomic_path, read_json, write_json_atomic, write_text_atomic
from .mesh import load_geometry_mm, write_ply_mm

MIN_VISIB_FRACT = 0.1       # BOP19 targets: instances at least 10 % visible


def targets_filename(split: str) -> str:
    """BOP19 targets file of a split: test_targets_bop19.json, else <split>_targets_bop19.json."""
    return "test_targets_bop19.json" if split == "test" else f"{split}_targets_bop19.json"


def write_camera_files(root: str | Path, depth_scale: float = 0.1, names=None) -> list[Path]:
    """camera_<name>.json for the YCB-Video sensors of the assets manifest (uw, cmu)."""
    root = Path(root)
    written = []
    for name, cam in cameras().items():
        if names is not None and name not in names:
            continue
        K = np.asarray(cam["K"], np.float64)
        p = root / f"camera_{name}.json"
        write_json_atomic(p, {"cx": float(K[0, 2]), "cy": float(K[1, 2]), "depth_scale": float(depth_scale),
                              "fx": float(K[0, 0]), "fy": float(K[1, 1]),
                              "height": int(cam["height"]), "width": int(cam["width"])})
        written.append(p)
    return written


def split_targets(split_dir: str | Path, min_visib_fract: float = MIN_VISIB_FRACT) -> list[dict]:
    """BOP19 targets of every scene of a split folder (sorted by scene, image, object)."""
    split_dir = Path(split_dir)
    out = []
    for sdir in sorted(p for p in split_dir.iterdir() if p.is_dir() and p.name.isdigit()):
        gt_p, info_p = sdir / "scene_gt.json", sdir / "scene_gt_info.json"
        if not gt_p.is_file():
            continue
        sid = int(sdir.name)
        gt = read_json(gt_p, "scene_gt.json")
        info = read_json(info_p, "scene_gt_info.json") if info_p.is_file() else None
        for im in sorted(gt, key=int):
            counts: dict[int, int] = {}
            for g, e in enumerate(gt[im]):
                if info is not None:
                    try:
                        vf = float(info[im][g]["visib_fract"])
                    except (KeyError, IndexError, TypeError, ValueError):
                        raise YcbvssError("no visib_fract for this instance", info_p,
                                          fmt_where(sid, int(im), e.get("obj_id"))) from None
                    if vf < min_visib_fract:
                        continue
                counts[int(e["obj_id"])] = counts.get(int(e["obj_id"]), 0) + 1
            out += [{"im_id": int(im), "inst_count": n, "obj_id": o, "scene_id": sid} for o, n in sorted(counts.items())]
    return out


def write_targets(root: str | Path, split: str) -> Path:
    """Write the split's BOP19 targets file into the dataset root; returns its path."""
    root = Path(root)
    p = root / targets_filename(split)
    write_json_atomic(p, split_targets(root / split))
    return p


def remesh_for_eval(vertices_mm: np.ndarray, faces: np.ndarray, edge_mm: float):
    """Uniformly resampled mesh (pymeshlab isotropic explicit remeshing); returns (V, F)."""
    # lazy: heavy, only needed for models_eval
    import pymeshlab
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(np.asarray(vertices_mm, np.float64), np.asarray(faces, np.int32)))
    ms.meshing_remove_duplicate_vertices()
    ms.meshing_remove_unreferenced_vertices()
    ms.meshing_isotropic_explicit_remeshing(targetlen=pymeshlab.PureValue(float(edge_mm)), iterations=3)
    m = ms.current_mesh()
    return np.asarray(m.vertex_matrix(), np.float64), np.asarray(m.face_matrix(), np.int64)


def eval_edge_mm(diameter_mm: float) -> float:
    """Target edge length of models_eval: 1.5 % of the diameter, clamped to [1.5, 5] mm."""
    return float(min(5.0, max(1.5, 0.015 * float(diameter_mm))))


def write_models_eval(root: str | Path, obj_ids=None, overwrite: bool = False, show_progress: bool = True) -> dict:
    """models_eval/obj_XXXXXX.ply (uniformly remeshed, no texture) + models_info.json (copied from
    models/). Skips models whose models_eval PLY is newer than the model unless ``overwrite``.
    Returns {obj_id: number of vertices written}."""
    root = Path(root)
    src, dst = root / "models", root / "models_eval"
    info_p = src / "models_info.json"
    if not info_p.is_file():
        raise YcbvssError("models_info.json missing: cannot write models_eval", info_p)
    info = read_json(info_p, "models_info.json")
    ids = sorted(int(k) for k in info) if obj_ids is None else sorted(int(i) for i in obj_ids)
    dst.mkdir(parents=True, exist_ok=True)
    counts = {}
    it = progress(ids, desc="models_eval", unit="model") if show_progress else ids
    for oid in it:
        ply_in, ply_out = src / f"obj_{oid:06d}.ply", dst / f"obj_{oid:06d}.ply"
        if str(oid) not in info:
            raise YcbvssError("model has no entry in models_info.json", info_p, fmt_where(obj_id=oid))
        if not ply_in.is_file():
            raise YcbvssError("model file missing", ply_in, fmt_where(obj_id=oid))
        if not overwrite and ply_out.is_file() and ply_out.stat().st_mtime >= ply_in.stat().st_mtime:
            continue
        g = load_geometry_mm(ply_in)
        V, F = remesh_for_eval(g.vertices, g.faces, eval_edge_mm(info[str(oid)]["diameter"]))
        write_ply_mm(ply_out, trimesh.Trimesh(V, F, process=False))
        counts[oid] = len(V)
    with atomic_path(dst / "models_info.json") as tmp:
        shutil.copyfile(info_p, tmp)
    return counts


def write_all_dataset_files(root: str | Path, splits, info_md: str | None = None, models_eval: bool = True,
                            show_progress: bool = True) -> None:
    """Camera files, the targets file of each split, models_eval/ and dataset_info.md."""
    root = Path(root)
    write_camera_files(root)
    for sp in ([splits] if isinstance(splits, str) else splits):
        if (root / sp).is_dir():
            write_targets(root, sp)
    if models_eval:
        write_models_eval(root, show_progress=show_progress)
    if info_md is not None:
        write_text_atomic(root / "dataset_info.md", info_md)


def split_names(root: str | Path) -> list[str]:
    """Split folders of a BOP root: sub-folders holding at least one scene folder with scene_camera.json."""
    root = Path(root)
    if not root.is_dir():
        return []
    out = []
    for d in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")):
        if any(s.is_dir() and s.name.isdigit() and (s / "scene_camera.json").is_file() for s in d.iterdir()):
            out.append(d.name)
    return out


def resolve_split(root: str | Path, split: str | None) -> str:
    """``split`` if given; else the only split of the BOP root (error naming the choices otherwise)."""
    if split:
        return split
    names = split_names(root)
    if len(names) == 1:
        return names[0]
    if not names:
        raise YcbvssError("no split folder (with scene folders) in this BOP root; give --split", root)
    raise YcbvssError(f"several splits ({', '.join(names)}): choose one with --split", root)


def write_camera_json(root: str | Path, K: np.ndarray, width: int, height: int, depth_scale: float,
                      name: str = "camera.json") -> Path:
    """A single-sensor dataset's camera file (BOP ``camera.json``)."""
    K = np.asarray(K, np.float64)
    p = Path(root) / name
    write_json_atomic(p, {"cx": float(K[0, 2]), "cy": float(K[1, 2]), "depth_scale": float(depth_scale),
                          "fx": float(K[0, 0]), "fy": float(K[1, 1]), "height": int(height), "width": int(width)})
    return p
