"""Input adapters for synthesis: scenes with per-frame tolerance (a frame whose meta data is missing,
corrupt or holds an invalid pose is skipped and reported instead of failing the whole video)."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ..camera import Camera
from ..errors import YcbvssError
from ..geometry.so3 import orthonormality_error
from ..io.atomic import read_json
from ..io.bop import load_dataset, read_scene_camera
from ..io.ycbv import list_frames, load_ycbv_dataset, read_meta_frame
from ..scene import Frame, Instance, Scene


def load_ycbv_scene_tolerant(root, video: int, models: dict, width: int = 640, height: int = 480):
    """Like ``ycbvss.io.ycbv.load_ycbv_scene`` but returns ``(Scene, [(im_id, reason), ...])``."""
    root = Path(root)
    d = root / "data" / f"{video:04d}"
    frames, skipped = [], []
    for im_id in list_frames(root, video):
        stem = d / f"{im_id:06d}"
        try:
            meta = read_meta_frame(Path(f"{stem}-meta.mat"), video, im_id)
            for oid in meta["obj_ids"]:
                if oid not in models:
                    raise YcbvssError(f"object {oid} has no model", Path(f"{stem}-meta.mat"))
        except YcbvssError as e:
            skipped.append((im_id, f"bad frame meta data: {e}"))
            continue
        insts = [Instance(obj_id=int(oid), T_m2c=T, gt_id=k)
                 for k, (oid, T) in enumerate(zip(meta["obj_ids"], meta["T_m2c"]))]
        label = Path(f"{stem}-label.png")
        frames.append(Frame(scene_id=video, im_id=im_id, camera=Camera(meta["K"], width, height),
                            instances=insts, depth_scale=meta["depth_scale"],
                            rgb_path=Path(f"{stem}-color.png"), depth_path=Path(f"{stem}-depth.png"),
                            label_path=label, T_w2c=meta.get("T_w2c")))
    return Scene(scene_id=video, frames=frames, root=d), skipped


def _bop_pose(e: dict) -> np.ndarray:
    """4x4 pose (mm) of one scene_gt entry; raises ValueError with the reason if unusable."""
    R = np.asarray(e["cam_R_m2c"], np.float64).reshape(3, 3)
    t = np.asarray(e["cam_t_m2c"], np.float64).reshape(3)
    if not (np.all(np.isfinite(R)) and np.all(np.isfinite(t))):
        raise ValueError("pose has NaN/inf")
    if orthonormality_error(R) > 1e-4 or np.linalg.det(R) < 0:
        raise ValueError("R is not a rotation")
    if t[2] <= 0:
        raise ValueError(f"object behind the camera (t_z = {t[2]:.1f} mm)")
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


def load_bop_scene_tolerant(split_dir, scene_id: int, models: dict):
    """A BOP scene as ``(Scene, [(im_id, reason), ...])``: frames with an invalid scene_gt entry are skipped
    and reported; missing images are left to the frame worker (skipped and reported there)."""
    sdir = Path(split_dir) / f"{scene_id:06d}"
    cams = read_scene_camera(sdir / "scene_camera.json", scene_id)
    raw = read_json(sdir / "scene_gt.json", "scene_gt.json") if (sdir / "scene_gt.json").is_file() else {}
    img_dir = sdir / ("gray" if (sdir / "gray").is_dir() and not (sdir / "rgb").is_dir() else "rgb")
    size = None
    frames, skipped = [], []
    for im_id in sorted(cams):
        rgb = next((img_dir / f"{im_id:06d}{ext}" for ext in (".png", ".jpg", ".jpeg", ".tif")
                    if (img_dir / f"{im_id:06d}{ext}").is_file()), img_dir / f"{im_id:06d}.png")
        if size is None and rgb.is_file():
            im = cv2.imread(str(rgb), cv2.IMREAD_UNCHANGED)
            size = (im.shape[1], im.shape[0]) if im is not None else None
        insts = []
        try:
            for gt_id, e in enumerate(raw.get(str(im_id), [])):
                oid = int(e["obj_id"])
                if oid not in models:
                    raise ValueError(f"object {oid} has no model")
                try:
                    insts.append(Instance(obj_id=oid, T_m2c=_bop_pose(e), gt_id=gt_id))
                except ValueError as err:
                    raise ValueError(f"object {oid} (gt {gt_id}): {err}") from None
        except (ValueError, KeyError, TypeError) as err:
            skipped.append((im_id, f"bad scene_gt entry: {err}"))
            continue
        c = cams[im_id]
        w, h = size or (640, 480)
        depth = sdir / "depth" / f"{im_id:06d}.png"
        frames.append(Frame(scene_id=scene_id, im_id=im_id, camera=Camera(c["K"], w, h), instances=insts,
                            depth_scale=c["depth_scale"], rgb_path=rgb, depth_path=depth, T_w2c=c["T_w2c"]))
    return Scene(scene_id=scene_id, frames=frames, root=sdir), skipped


def open_input(dataset, split: str, scenes: list[int] | None = None):
    """``(Dataset, layout, scene_loader)``: layout "ycbv" (YCB-Video root) or "bop" (BOP root + split);
    ``scene_loader(scene_id) -> (Scene, skipped [(im_id, reason)])``."""
    root = Path(dataset)
    if not root.is_dir():
        raise YcbvssError("input dataset not found", root)
    if (root / "data").is_dir() and (root / "models").is_dir() and not (root / "models" / "models_info.json").is_file():
        ds = load_ycbv_dataset(root, scenes)
        return ds, "ycbv", lambda sid: load_ycbv_scene_tolerant(root, sid, ds.models)
    ds = load_dataset(root, split, scene_ids=scenes)
    return ds, "bop", lambda sid: load_bop_scene_tolerant(root / split, sid, ds.models)
