"""BOP dataset layout: read models and scenes, write scenes.

::

    ROOT/models/obj_XXXXXX.ply + models_info.json      (mm; textures obj_XXXXXX.png beside)
    ROOT/SPLIT/SSSSSS/scene_gt.json                    {im_id: [{cam_R_m2c, cam_t_m2c, obj_id}]}
                      scene_camera.json                {im_id: {cam_K, depth_scale[, cam_R_w2c, cam_t_w2c]}}
                      scene_gt_info.json               {im_id: [{bbox_obj, bbox_visib, px_count_*, visib_fract}]}
                      rgb/ | gray/  IIIIII.png|jpg ;  depth/ IIIIII.png (uint16 * depth_scale = mm)
                      mask/ mask_visib/  IIIIII_GGGGGG.png

Every malformed input raises one :class:`~ycbvss.errors.YcbvssError` naming the file and the
scene/frame/object: malformed JSON, K not 3x3 or singular, R not orthonormal (|R^T R - I| >
1e-4), NaN/inf, an object behind the camera, an unknown obj_id, a missing model or frame image,
a model apparently in metres (models_info diameter < 1).
"""
from __future__ import annotations

import os
import shutil
import warnings
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np
from PIL import Image, UnidentifiedImageError

from ..camera import Camera, check_K
from ..errors import YcbvssError, where as fmt_where
from ..geometry.so3 import orthonormality_error
from ..manifest import object_entries, object_names
from ..scene import Dataset, Frame, Instance, ObjectModel, Scene
from .atomic import atomic_path, read_json, write_json_atomic
from .images import write_depth_png, write_jpg, write_png
from .mesh import compute_models_info, load_vertices_mm, mesh_texture_rgb, write_ply_mm
from .ycbv import ROT_TOL, check_pose

IMAGE_DIRS = ("rgb", "gray")
IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".tif")


def model_filename(obj_id: int) -> str:
    return f"obj_{int(obj_id):06d}.ply"


def _int_key(k, path, what="key") -> int:
    try:
        return int(k)
    except (TypeError, ValueError):
        raise YcbvssError(f"{what} {k!r} is not an integer", path) from None


def _floats(x, n: int, path, where: str, name: str) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise YcbvssError(f"{name} is not numeric", path, where) from None
    if a.size != n:
        raise YcbvssError(f"{name} needs {n} numbers, got {a.size}", path, where)
    if not np.all(np.isfinite(a)):
        raise YcbvssError(f"{name} contains NaN/inf", path, where)
    return a


# ------------------------------------------------------------------------------ models
def is_ycbv_models_dir(models_dir: Path) -> bool:
    """A YCB-V model folder: 'ycbv' in its path, or camera_uw/cmu.json beside it (BOP ycbv root)."""
    p = Path(models_dir).resolve()
    if any("ycbv" in part.lower() for part in p.parts[-2:]):
        return True
    return any((p.parent / f"camera_{c}.json").is_file() for c in ("uw", "cmu"))


def _names_for(obj_ids: Iterable[int], names, models_dir: Path) -> dict[int, str]:
    if isinstance(names, dict):
        return {int(k): v for k, v in names.items()}
    if names == "auto" and is_ycbv_models_dir(models_dir):
        man = object_names()
        ids = set(obj_ids)
        return {i: man[i] for i in ids} if ids <= set(man) else {}
    return {}


def load_models_info(models_dir: str | Path) -> dict[int, dict]:
    """models_info.json -> {obj_id: info}; checks diameters (mm) and symmetry matrices."""
    models_dir = Path(models_dir)
    p = models_dir / "models_info.json"
    raw = read_json(p, "models_info.json")
    if not isinstance(raw, dict):
        raise YcbvssError("models_info.json must map obj_id to an info dict", p)
    out = {}
    for k, info in raw.items():
        oid = _int_key(k, p, "obj_id")
        wh = fmt_where(obj_id=oid)
        if not isinstance(info, dict) or "diameter" not in info:
            raise YcbvssError("entry lacks 'diameter'", p, wh)
        d = _floats([info["diameter"]], 1, p, wh, "diameter")[0]
        if d <= 0:
            raise YcbvssError(f"non-positive diameter {d}", p, wh)
        if d < 1.0:
            raise YcbvssError(f"diameter {d:g} < 1: model apparently in metres (BOP models are in mm)", p, wh)
        for S in info.get("symmetries_discrete", []) or []:
            M = _floats(S, 16, p, wh, "symmetries_discrete entry").reshape(4, 4)
            if orthonormality_error(M[:3, :3]) > ROT_TOL:
                raise YcbvssError("symmetries_discrete rotation is not orthonormal", p, wh)
        for c in info.get("symmetries_continuous", []) or []:
            if not isinstance(c, dict) or "axis" not in c:
                raise YcbvssError("symmetries_continuous entry lacks 'axis'", p, wh)
            _floats(c["axis"], 3, p, wh, "symmetry axis")
        out[oid] = info
    return out


def load_models(models_dir: str | Path, symmetric_obj_ids: Iterable[int] = (13,),
                names: dict | str | None = "auto", check_files: bool = True) -> dict[int, ObjectModel]:
    """BOP models: models_info.json + obj_XXXXXX.ply (mm) -> {obj_id: ObjectModel}.

    ``names="auto"``: YCB names/textureless flags from the assets manifest for a YCB-V model folder
    (see :func:`is_ycbv_models_dir`) whose obj_ids are all YCB-V ids (1..21); a dict sets names. Missing models_info.json: info is computed from the PLY files (warning).
    """
    models_dir = Path(models_dir)
    if not models_dir.is_dir():
        raise YcbvssError("models folder not found", models_dir)
    if (models_dir / "models_info.json").is_file():
        infos = load_models_info(models_dir)
    else:
        plys = sorted(models_dir.glob("obj_*.ply"))
        if not plys:
            raise YcbvssError("no models_info.json and no obj_XXXXXX.ply files", models_dir)
        warnings.warn(f"{models_dir}: no models_info.json, computing diameters from the PLY files", stacklevel=2)
        infos = {}
        for p in plys:
            oid = _int_key(p.stem[4:], p, "model file id")
            infos[oid] = compute_models_info(load_vertices_mm(p))
            if infos[oid]["diameter"] < 1.0:
                raise YcbvssError(f"diameter {infos[oid]['diameter']:g} < 1: model apparently in metres",
                                  p, fmt_where(obj_id=oid))
    nm = _names_for(infos, names, models_dir)
    ent = object_entries() if nm else {}
    sym = set(int(i) for i in (symmetric_obj_ids or ()))
    models = {}
    for oid, info in sorted(infos.items()):
        path = models_dir / model_filename(oid)
        if check_files and not path.is_file():
            raise YcbvssError("missing model file", path, fmt_where(obj_id=oid))
        models[oid] = ObjectModel(
            obj_id=oid, path=path, name=nm.get(oid, ""), unit_scale=1.0, diameter_mm=float(info["diameter"]),
            symmetries_discrete=[np.asarray(S, np.float64).reshape(4, 4)
                                 for S in info.get("symmetries_discrete", []) or []],
            symmetries_continuous=[{"axis": list(c["axis"]), "offset": list(c.get("offset", [0, 0, 0]))}
                                   for c in info.get("symmetries_continuous", []) or []],
            symmetric=oid in sym, textureless=bool(ent.get(oid, {}).get("textureless", False)), info=info)
    return models


def write_models(models_dir: str | Path, meshes_mm: dict[int, object],
                 textures: dict[int, np.ndarray | None] | None = None,
                 symmetries: dict[int, tuple[list, list]] | None = None) -> dict[int, dict]:
    """Write obj_XXXXXX.ply (+ obj_XXXXXX.png textures) and models_info.json (atomically).

    ``meshes_mm``: obj_id -> trimesh in mm (BOP frame). ``symmetries``: obj_id -> (discrete
    4x4 list, continuous dict list). Returns the models_info dict written.
    """
    models_dir = Path(models_dir)
    info = {}
    for oid, mesh in sorted(meshes_mm.items()):
        tex = (textures or {}).get(oid)
        if tex is None:
            tex = mesh_texture_rgb(mesh)
        write_ply_mm(models_dir / model_filename(oid), mesh,
                     f"obj_{oid:06d}.png" if tex is not None else None, texture_rgb=tex)
        disc, cont = (symmetries or {}).get(oid, ([], []))
        info[oid] = compute_models_info(mesh, disc, cont)
    write_json_atomic(models_dir / "models_info.json", {str(k): v for k, v in sorted(info.items())})
    return info


# ------------------------------------------------------------------------------ scene JSONs
def read_scene_camera(path: str | Path, scene_id: int | None = None) -> dict[int, dict]:
    """scene_camera.json -> {im_id: {"K": 3x3, "depth_scale": float, "T_w2c": 4x4 | None}}."""
    path = Path(path)
    raw = read_json(path, "scene_camera.json")
    if not isinstance(raw, dict):
        raise YcbvssError("scene_camera.json must map im_id to camera entries", path, fmt_where(scene_id))
    out = {}
    for k, e in raw.items():
        im = _int_key(k, path, "im_id")
        wh = fmt_where(scene_id, im)
        if not isinstance(e, dict) or "cam_K" not in e:
            raise YcbvssError("entry lacks cam_K", path, wh)
        K = check_K(_floats_any(e["cam_K"], path, wh, "cam_K"), str(path), wh)
        ds = float(_floats([e.get("depth_scale", 1.0)], 1, path, wh, "depth_scale")[0])
        if ds <= 0:
            raise YcbvssError(f"non-positive depth_scale {ds}", path, wh)
        T_w2c = None
        if "cam_R_w2c" in e and "cam_t_w2c" in e:
            R = _floats(e["cam_R_w2c"], 9, path, wh, "cam_R_w2c").reshape(3, 3)
            t = _floats(e["cam_t_w2c"], 3, path, wh, "cam_t_w2c")
            err = float(orthonormality_error(R))
            if err > ROT_TOL:
                raise YcbvssError(f"cam_R_w2c is not orthonormal (|R^T R - I| = {err:.3g})", path, wh)
            T_w2c = np.eye(4)
            T_w2c[:3, :3], T_w2c[:3, 3] = R, t
        out[im] = {"K": K, "depth_scale": ds, "T_w2c": T_w2c}
    return out


def _floats_any(x, path, wh, name) -> np.ndarray:
    """Numeric array of any size (check_K reports the shape problem)."""
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise YcbvssError(f"{name} is not numeric", path, wh) from None
    if not np.all(np.isfinite(a)):
        raise YcbvssError(f"{name} contains NaN/inf", path, wh)
    return a


def read_scene_gt(path: str | Path, scene_id: int | None = None,
                  known_obj_ids: Iterable[int] | None = None, rot_tol: float = ROT_TOL) -> dict[int, list[Instance]]:
    """scene_gt.json -> {im_id: [Instance(obj_id, T_m2c mm, gt_id)]} with pose checks."""
    path = Path(path)
    raw = read_json(path, "scene_gt.json")
    if not isinstance(raw, dict):
        raise YcbvssError("scene_gt.json must map im_id to lists of poses", path, fmt_where(scene_id))
    known = None if known_obj_ids is None else set(int(i) for i in known_obj_ids)
    out = {}
    for k, lst in raw.items():
        im = _int_key(k, path, "im_id")
        if not isinstance(lst, list):
            raise YcbvssError("entry must be a list", path, fmt_where(scene_id, im))
        insts = []
        for gt_id, e in enumerate(lst):
            if not isinstance(e, dict) or not {"cam_R_m2c", "cam_t_m2c", "obj_id"} <= set(e):
                raise YcbvssError(f"gt {gt_id} lacks cam_R_m2c/cam_t_m2c/obj_id", path, fmt_where(scene_id, im))
            oid = _int_key(e["obj_id"], path, "obj_id")
            wh = fmt_where(scene_id, im, oid)
            if known is not None and oid not in known:
                ply = path.parent.parent.parent / "models" / model_filename(oid)
                why = (f"{ply} exists but models_info.json has no entry \"{oid}\" (add it, e.g. by re-running "
                       "convert)" if ply.is_file() else f"no model file {model_filename(oid)} and no models_info.json "
                       "entry for it")
                raise YcbvssError(f"obj_id {oid} has no usable model: {why}", path, wh)
            R = _floats(e["cam_R_m2c"], 9, path, wh, "cam_R_m2c").reshape(3, 3)
            t = _floats(e["cam_t_m2c"], 3, path, wh, "cam_t_m2c")
            check_pose(R, t, path, wh, rot_tol)
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = R, t
            insts.append(Instance(obj_id=oid, T_m2c=T, gt_id=gt_id))
        out[im] = insts
    return out


def read_scene_gt_info(path: str | Path, scene_id: int | None = None) -> dict[int, list[dict]]:
    """scene_gt_info.json -> {im_id: [info dict per gt]}."""
    path = Path(path)
    raw = read_json(path, "scene_gt_info.json")
    if not isinstance(raw, dict):
        raise YcbvssError("scene_gt_info.json must map im_id to lists", path, fmt_where(scene_id))
    return {_int_key(k, path, "im_id"): v for k, v in raw.items()}


# ------------------------------------------------------------------------------ dataset
def list_scene_ids(split_dir: str | Path) -> list[int]:
    split_dir = Path(split_dir)
    if not split_dir.is_dir():
        raise YcbvssError("split folder not found", split_dir)
    return sorted(int(p.name) for p in split_dir.iterdir()
                  if p.is_dir() and p.name.isdigit() and (p / "scene_camera.json").is_file())


def _image_size(path: Path, where: str) -> tuple[int, int]:
    try:
        with Image.open(path) as im:
            return im.size
    except (OSError, UnidentifiedImageError):
        raise YcbvssError("corrupt or unreadable image", path, where) from None


def _index_images(d: Path) -> dict[int, Path]:
    out = {}
    if d.is_dir():
        for name in os.listdir(d):
            stem, ext = os.path.splitext(name)
            if ext.lower() in IMAGE_EXTS and stem.isdigit() and not name.startswith(".tmp-"):
                out[int(stem)] = d / name
    return out


def _dataset_image_size(root: Path) -> tuple[int, int]:
    """(width, height) from the dataset's camera*.json (BOP), else 640x480 (YCB-V)."""
    for p in sorted(root.glob("camera*.json")):
        try:
            c = read_json(p)
            return int(c["width"]), int(c["height"])
        except (YcbvssError, KeyError, TypeError, ValueError):
            continue
    return 640, 480


def load_bop_scene(split_dir: str | Path, scene_id: int, models: dict[int, ObjectModel] | None = None,
                   rot_tol: float = ROT_TOL, image_size: tuple[int, int] | None = None) -> Scene:
    """One BOP scene folder. Frames = entries of scene_camera.json; scene_gt.json optional.

    With an rgb/ (or gray/) folder every frame must have its image (and its depth image when
    depth/ exists); a scene without image folders (annotations only) gives frames with
    ``rgb_path=None`` and the image size of the dataset's camera*.json (default 640x480).
    """
    sdir = Path(split_dir) / f"{scene_id:06d}"
    cams = read_scene_camera(sdir / "scene_camera.json", scene_id)
    gt = {}
    if (sdir / "scene_gt.json").is_file():
        gt = read_scene_gt(sdir / "scene_gt.json", scene_id, None if models is None else models.keys(), rot_tol)
    gt_info = read_scene_gt_info(sdir / "scene_gt_info.json", scene_id) if (sdir / "scene_gt_info.json").is_file() else {}
    size = image_size
    img_dir = next((sdir / d for d in IMAGE_DIRS if (sdir / d).is_dir()), None)
    imgs = _index_images(img_dir) if img_dir is not None else {}
    if img_dir is None and size is None:      # annotation-only scene (e.g. refined poses): size from camera JSON
        size = _dataset_image_size(Path(split_dir).parent)
    depth_dir = sdir / "depth"
    depths = _index_images(depth_dir)
    frames = []
    for im_id in sorted(cams):
        wh = fmt_where(scene_id, im_id)
        if img_dir is not None and im_id not in imgs:
            raise YcbvssError("missing frame image", img_dir / f"{im_id:06d}.png", wh)
        if depth_dir.is_dir() and im_id not in depths:
            raise YcbvssError("missing depth image", depth_dir / f"{im_id:06d}.png", wh)
        if size is None:
            size = _image_size(imgs[im_id], wh)
        c = cams[im_id]
        extra = {"gt_info": gt_info.get(im_id)} if im_id in gt_info else {}
        if img_dir is not None and img_dir.name == "gray":
            extra["gray"] = True
        frames.append(Frame(scene_id=scene_id, im_id=im_id, camera=Camera(c["K"], size[0], size[1]),
                            instances=gt.get(im_id, []), depth_scale=c["depth_scale"],
                            rgb_path=imgs.get(im_id), depth_path=depths.get(im_id), T_w2c=c["T_w2c"], extra=extra))
    return Scene(scene_id=scene_id, frames=frames, root=sdir)


def select_scene_ids(split_dir: str | Path, scene_ids: Sequence[int] | None = None) -> list[int]:
    """The scene ids of a split folder, or the requested ones (error naming the first missing one)."""
    split_dir = Path(split_dir)
    all_ids = list_scene_ids(split_dir)
    if scene_ids is None:
        return all_ids
    missing = [s for s in scene_ids if s not in all_ids]
    if missing:
        raise YcbvssError(f"scene {missing[0]} not found", split_dir / f"{missing[0]:06d}")
    return [int(s) for s in scene_ids]


def load_dataset(root: str | Path, split: str, models_subdir: str = "models",
                 scene_ids: Sequence[int] | None = None, symmetric_obj_ids: Iterable[int] = (13,)) -> Dataset:
    """A BOP dataset split as a streaming Dataset (scenes loaded one at a time)."""
    root = Path(root)
    if not root.is_dir():
        raise YcbvssError("BOP dataset root not found", root)
    models = load_models(root / models_subdir, symmetric_obj_ids)
    split_dir = root / split
    all_ids = select_scene_ids(split_dir, scene_ids)
    return Dataset(root, models, all_ids, lambda s: load_bop_scene(split_dir, s, models),
                   name=root.name, split=split)


# ------------------------------------------------------------------------------ writer
def _copy_atomic(src: Path, dst: Path) -> None:
    if not Path(src).is_file():
        raise YcbvssError("missing source file", src)
    with atomic_path(dst) as tmp:
        shutil.copyfile(src, tmp)


class BopSceneWriter:
    """Write one BOP scene: images as frames come, the scene JSONs atomically at :meth:`close`.

    ``write_frame(frame, rgb=None, depth_mm=None, masks=None, masks_visib=None, gt_info=None,
    rgb_src=None, depth_src=None)``: ``frame`` supplies im_id, K, depth_scale, T_w2c and the
    instances (poses in mm in the BOP model frames). ``rgb``: (H,W,3) uint8 RGB written as
    ``rgb/IIIIII.<rgb_ext>``; or ``rgb_src``: a file byte-copied. ``depth_mm``: float mm written
    as uint16 with ``frame.depth_scale``; or ``depth_src``: a uint16 PNG byte-copied (its units
    must already be ``frame.depth_scale`` mm). ``masks``/``masks_visib``: one bool image per
    instance (mask/ and mask_visib/ IIIIII_GGGGGG.png). ``gt_info``: list of dicts per instance.
    Usable as a context manager (close on success only).
    """

    def __init__(self, split_dir: str | Path, scene_id: int, rgb_ext: str = "png"):
        self.scene_id = int(scene_id)
        self.dir = Path(split_dir) / f"{self.scene_id:06d}"
        self.rgb_ext = rgb_ext.lstrip(".")
        self.scene_gt: dict[str, list] = {}
        self.scene_camera: dict[str, dict] = {}
        self.scene_gt_info: dict[str, list] = {}
        self.closed = False

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            self.close()
        return False

    def write_frame(self, frame: Frame, rgb: np.ndarray | None = None, depth_mm: np.ndarray | None = None,
                    masks: Sequence[np.ndarray] | None = None, masks_visib: Sequence[np.ndarray] | None = None,
                    gt_info: Sequence[dict] | None = None, rgb_src: str | Path | None = None,
                    depth_src: str | Path | None = None) -> None:
        im = int(frame.im_id)
        d = self.dir
        if rgb_src is not None:
            _copy_atomic(Path(rgb_src), d / "rgb" / f"{im:06d}{Path(rgb_src).suffix.lower()}")
        elif rgb is not None:
            p = d / "rgb" / f"{im:06d}.{self.rgb_ext}"
            (write_jpg if self.rgb_ext in ("jpg", "jpeg") else write_png)(p, rgb)
        if depth_src is not None:
            _copy_atomic(Path(depth_src), d / "depth" / f"{im:06d}.png")
        elif depth_mm is not None:
            write_depth_png(d / "depth" / f"{im:06d}.png", depth_mm, frame.depth_scale)
        for sub, ms in (("mask", masks), ("mask_visib", masks_visib)):
            if ms is None:
                continue
            if len(ms) != len(frame.instances):
                raise YcbvssError(f"{len(ms)} {sub} images for {len(frame.instances)} instances",
                                  d / sub, fmt_where(self.scene_id, im))
            for gt_id, m in enumerate(ms):
                write_png(d / sub / f"{im:06d}_{gt_id:06d}.png", (np.asarray(m) > 0).astype(np.uint8) * 255, rgb=False)
        cam = {"cam_K": np.asarray(frame.camera.K, np.float64).reshape(-1).tolist(),
               "depth_scale": float(frame.depth_scale)}
        if frame.T_w2c is not None:
            cam["cam_R_w2c"] = np.asarray(frame.T_w2c[:3, :3]).reshape(-1).tolist()
            cam["cam_t_w2c"] = np.asarray(frame.T_w2c[:3, 3]).reshape(-1).tolist()
        self.scene_camera[str(im)] = cam
        self.scene_gt[str(im)] = [{"cam_R_m2c": np.asarray(i.T_m2c[:3, :3]).reshape(-1).tolist(),
                                   "cam_t_m2c": np.asarray(i.T_m2c[:3, 3]).reshape(-1).tolist(),
                                   "obj_id": int(i.obj_id)} for i in frame.instances]
        if gt_info is not None:
            self.scene_gt_info[str(im)] = [dict(g) for g in gt_info]

    def close(self) -> None:
        """Write scene_camera.json, scene_gt.json (and scene_gt_info.json) atomically."""
        if self.closed:
            return
        order = lambda dct: {k: dct[k] for k in sorted(dct, key=int)}  # noqa: E731
        write_json_atomic(self.dir / "scene_gt.json", order(self.scene_gt))
        if self.scene_gt_info:
            write_json_atomic(self.dir / "scene_gt_info.json", order(self.scene_gt_info))
        # scene_camera.json last: its presence marks a complete scene (see list_scene_ids)
        write_json_atomic(self.dir / "scene_camera.json", order(self.scene_camera))
        self.closed = True
