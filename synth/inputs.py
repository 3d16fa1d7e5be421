"""Input adapters for synthesis: scenes with per-frame tolerance (a frame whose meta data is missing,
corrupt or holds an invalid pose is skipped and reported instead of failing the whole video)."""
from __future__ import annotations

from pathlib import Path

from ..errors import YcbvssError


def load_ycbv_scene_tolerant(root, video: int, models: dict, width: int = 640, height: int = 480):
    """Like ``ycbvss.io.ycbv.load_ycbv_scene`` but returns ``(Scene, [(im_id, reason), ...])``."""
    from ..camera import Camera
    from ..io.ycbv import list_frames, read_meta_frame
    from ..scene import Frame, Instance, Scene
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


def open_input(dataset, split: str, scenes: list[int] | None = None):
    """``(Dataset, layout, scene_loader)``: layout "ycbv" (YCB-Video root) or "bop" (BOP root + split);
    ``scene_loader(scene_id) -> (Scene, skipped [(im_id, reason)])``."""
    root = Path(dataset)
    if not root.is_dir():
        raise YcbvssError("input dataset not found", root)
    if (root / "data").is_dir() and (root / "models").is_dir() and not (root / "models" / "models_info.json").is_file():
        from ..io.ycbv import load_ycbv_dataset
        ds = load_ycbv_dataset(root, scenes)
        return ds, "ycbv", lambda sid: load_ycbv_scene_tolerant(root, sid, ds.models)
    from ..io.bop import load_dataset
    ds = load_dataset(root, split, scene_ids=scenes)
    return ds, "bop", lambda sid: (ds.load_scene(sid), [])
