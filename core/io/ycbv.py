"""Reader of the original YCB-Video layout.

::

    ROOT/data/NNNN/NNNNNN-{color.png, depth.png, label.png, meta.mat}
    ROOT/models/<name>/{textured.obj, points.xyz}
    ROOT/cameras/asus-{uw,cmu}.json
    ROOT/image_sets/classes.txt

``meta.mat``: ``cls_indexes`` (label values = BOP obj_id), ``poses`` (3x4xN object-to-camera,
metres), ``intrinsic_matrix``, ``factor_depth`` (depth png / factor_depth = metres),
``rotation_translation_matrix`` (world-to-camera of the frame, metres).

Frames are listed from file names without reading images; ``meta.mat`` files are read when a
scene (video) is loaded. Poses come out in mm in the YCB-Video model frame (models are the
``textured.obj`` files in metres, ``unit_scale=1000``).
"""
from __future__ import annotations

import re
import warnings
from functools import lru_cache
from pathlib import Path
from typing import Iterable

import numpy as np
import scipy.io

from ..camera import Camera, check_K
from ..errors import YcbvssError, where as fmt_where
from ..geometry.model_frame import bbox_center
from ..geometry.so3 import orthonormality_error
from ..manifest import bop_symmetries, camera_for_video, object_entries, object_names, protocol_symmetric_ids
from ..scene import Dataset, Frame, Instance, ObjectModel, Scene
from .mesh import diameter_mm, load_vertices_mm

ROT_TOL = 1e-4
_FRAME_RE = re.compile(r"^(\d{6})-meta\.mat$")


def read_classes(root: str | Path) -> dict[int, str]:
    """image_sets/classes.txt -> {class index (1-based) : name}; falls back to the manifest."""
    p = Path(root) / "image_sets" / "classes.txt"
    if p.is_file():
        names = [ln.strip() for ln in p.read_text(encoding="utf-8", errors="replace").splitlines() if ln.strip()]
        if names:
            return {i: n for i, n in enumerate(names, start=1)}
    return object_names()


def list_videos(root: str | Path) -> list[int]:
    d = Path(root) / "data"
    if not d.is_dir():
        raise YcbvssError("not a YCB-Video root (no data/ folder)", Path(root))
    return sorted(int(p.name) for p in d.iterdir() if p.is_dir() and re.fullmatch(r"\d{4}", p.name))


def list_frames(root: str | Path, video: int) -> list[int]:
    """Frame ids of a video from the ``*-meta.mat`` file names (no file is read)."""
    d = Path(root) / "data" / f"{video:04d}"
    if not d.is_dir():
        raise YcbvssError(f"missing video {video:04d}", d)
    return sorted(int(m.group(1)) for p in d.iterdir() if (m := _FRAME_RE.match(p.name)))


def parse_videos(spec: str | Iterable[int] | None, what: str = "video list") -> list[int] | None:
    """'0000,0001' / '0-3,7' / '1 2' / [0, 1] / None -> sorted list of ids (None = all).

    Used for video, scene and frame lists; ``what`` names the list in the error message."""
    if spec is None:
        return None
    if not isinstance(spec, str):
        return sorted({int(v) for v in spec})
    out: set[int] = set()
    for part in spec.replace(" ", ",").split(","):
        if not part:
            continue
        try:
            if "-" in part:
                a, b = part.split("-", 1)
                out.update(range(int(a), int(b) + 1))
            else:
                out.add(int(part))
        except ValueError:
            raise YcbvssError(f"bad {what} {spec!r} (expected e.g. 0000,0001 or 0-59)") from None
    return sorted(out)


def _stamp(path: Path) -> tuple[int, int]:
    st = path.stat()
    return st.st_mtime_ns, st.st_size


@lru_cache(maxsize=256)
def _model_stats(path: str, mtime_ns: int, size: int) -> tuple[float, tuple[float, float, float]]:
    """(diameter mm, bbox centre mm) of a textured.obj in metres; cached per file version."""
    v = load_vertices_mm(path, 1000.0)
    return diameter_mm(v), tuple(float(x) for x in bbox_center(v))


def model_center_mm(obj_path: str | Path) -> np.ndarray:
    """Bounding-box centre c (mm) of a YCB-Video textured.obj: the BOP model origin (cached)."""
    path = Path(obj_path).resolve()
    return np.array(_model_stats(str(path), *_stamp(path))[1])


def _ycbv_symmetries(obj_id: int, c_mm: np.ndarray) -> tuple[list, list]:
    """The manifest's BOP-frame symmetries expressed in the YCB-Video model frame (mm)."""
    disc, cont = bop_symmetries(obj_id)
    out_d = []
    for S in disc:
        T = S.copy()
        T[:3, 3] = S[:3, :3] @ (-c_mm) + S[:3, 3] + c_mm
        out_d.append(T)
    out_c = [{"axis": s["axis"], "offset": (np.asarray(s["offset"], float) + c_mm).tolist()} for s in cont]
    return out_d, out_c


def load_ycbv_models(root: str | Path, symmetric_obj_ids: Iterable[int] | None = None) -> dict[int, ObjectModel]:
    """ObjectModels (textured.obj, metres -> unit_scale 1000) for every model folder present."""
    root = Path(root)
    sym = set(protocol_symmetric_ids() if symmetric_obj_ids is None else symmetric_obj_ids)
    entries = object_entries()
    models = {}
    for oid, name in read_classes(root).items():
        path = root / "models" / name / "textured.obj"
        if not path.is_file():
            continue
        diam, c = _model_stats(str(path.resolve()), *_stamp(path))
        c_mm = np.array(c)
        disc, cont = _ycbv_symmetries(oid, c_mm)
        e = entries.get(oid, {})
        models[oid] = ObjectModel(
            obj_id=oid, path=path, name=name, unit_scale=1000.0, diameter_mm=diam,
            symmetries_discrete=disc, symmetries_continuous=cont, symmetric=oid in sym,
            textureless=bool(e.get("textureless", False)),
            info={"center_m": (c_mm / 1000.0).tolist(), "points_xyz": str(root / "models" / name / "points.xyz")})
    return models


def _mat(meta_path: Path, where: str) -> dict:
    if not meta_path.is_file():
        raise YcbvssError("missing meta.mat of frame", meta_path, where)
    try:
        m = scipy.io.loadmat(str(meta_path), variable_names=(
            "cls_indexes", "poses", "intrinsic_matrix", "factor_depth", "rotation_translation_matrix"))
    except Exception as e:  # scipy raises ValueError/TypeError/MatReadError on corrupt files
        raise YcbvssError(f"corrupt or truncated meta.mat ({type(e).__name__}: {e})", meta_path, where) from None
    for k in ("cls_indexes", "poses", "intrinsic_matrix", "factor_depth"):
        if k not in m:
            raise YcbvssError(f"meta.mat lacks '{k}'", meta_path, where)
    return m


def check_pose(R: np.ndarray, t_mm: np.ndarray, path, where: str, rot_tol: float = ROT_TOL,
               what: str = "pose") -> None:
    """Raise YcbvssError for NaN/inf, a non-orthonormal R, or an object behind the camera."""
    if not (np.all(np.isfinite(R)) and np.all(np.isfinite(t_mm))):
        raise YcbvssError(f"{what} contains NaN/inf", path, where)
    err = float(orthonormality_error(R))
    if err > rot_tol or np.linalg.det(R) < 0:
        raise YcbvssError(f"R is not orthonormal (|R^T R - I| = {err:.3g}, det {np.linalg.det(R):.3g})",
                          path, where)
    if t_mm[2] <= 0:
        raise YcbvssError(f"object behind the camera (t_z = {t_mm[2]:.1f} mm)", path, where)


def read_meta_frame(meta_path: Path, scene_id: int, im_id: int, rot_tol: float = ROT_TOL) -> dict:
    """Parse one meta.mat into obj_ids, T_m2c list (mm), K, depth_scale (mm/unit), T_w2c (mm)."""
    wh = fmt_where(scene_id, im_id)
    m = _mat(meta_path, wh)
    cls = np.asarray(m["cls_indexes"]).astype(np.int64).reshape(-1)
    poses = np.asarray(m["poses"], dtype=np.float64)
    if poses.ndim == 2:
        poses = poses[:, :, None]
    if poses.shape[:2] != (3, 4) or poses.shape[2] != cls.size:
        raise YcbvssError(f"poses shape {poses.shape} does not match {cls.size} cls_indexes", meta_path, wh)
    K = check_K(m["intrinsic_matrix"], str(meta_path), wh)
    fd = np.asarray(m["factor_depth"], dtype=np.float64).reshape(-1)
    if fd.size != 1 or not np.isfinite(fd[0]) or fd[0] <= 0:
        raise YcbvssError(f"bad factor_depth {fd.tolist()}", meta_path, wh)
    Ts = []
    for k, oid in enumerate(cls):
        R = poses[:, :3, k]
        t_mm = poses[:, 3, k] * 1000.0
        check_pose(R, t_mm, meta_path, fmt_where(scene_id, im_id, int(oid)), rot_tol)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, t_mm
        Ts.append(T)
    T_w2c = None
    if "rotation_translation_matrix" in m:
        Rt = np.asarray(m["rotation_translation_matrix"], dtype=np.float64)
        if Rt.shape == (3, 4) and np.all(np.isfinite(Rt)) and orthonormality_error(Rt[:, :3]) <= 1e-3:
            T_w2c = np.eye(4)
            T_w2c[:3, :3], T_w2c[:3, 3] = Rt[:, :3], Rt[:, 3] * 1000.0
    return {"obj_ids": [int(o) for o in cls], "T_m2c": Ts, "K": K,
            "depth_scale": 1000.0 / float(fd[0]), "factor_depth": float(fd[0]), "T_w2c": T_w2c}


def load_ycbv_scene(root: str | Path, video: int, models: dict[int, ObjectModel] | None = None,
                    width: int = 640, height: int = 480, rot_tol: float = ROT_TOL,
                    check_camera: bool = True) -> Scene:
    """All frames of one video (reads every meta.mat of the video; images stay on disk).

    A frame whose meta.mat, color.png or depth.png is missing raises YcbvssError; an object
    without a model (when ``models`` is given) raises YcbvssError naming the model file.
    If meta.mat's intrinsic_matrix disagrees with the manifest camera for the video, one
    warning is emitted per video (meta.mat's K is used).
    """
    root = Path(root)
    d = root / "data" / f"{video:04d}"
    frames = []
    warned = False
    try:
        cam_name, K_man = camera_for_video(video)
    except YcbvssError:
        cam_name, K_man = None, None
    for im_id in list_frames(root, video):
        stem = d / f"{im_id:06d}"
        meta = read_meta_frame(Path(f"{stem}-meta.mat"), video, im_id, rot_tol)
        wh = fmt_where(video, im_id)
        for suffix in ("color.png", "depth.png"):
            if not Path(f"{stem}-{suffix}").is_file():
                raise YcbvssError(f"missing {suffix} of frame", Path(f"{stem}-{suffix}"), wh)
        if check_camera and K_man is not None and not warned and not np.allclose(meta["K"], K_man, rtol=0, atol=1e-3):
            warnings.warn(f"{stem}-meta.mat: {wh}: intrinsic_matrix {meta['K'][[0, 1, 0, 1], [0, 1, 2, 2]].round(4).tolist()} "
                          f"differs from the manifest camera {cam_name!r}; using meta.mat", stacklevel=2)
            warned = True
        insts = []
        for gt_id, (oid, T) in enumerate(zip(meta["obj_ids"], meta["T_m2c"])):
            if models is not None and oid not in models:
                names = read_classes(root)
                mp = root / "models" / names.get(oid, f"class_{oid}") / "textured.obj"
                raise YcbvssError("missing model file", mp, fmt_where(video, im_id, oid))
            insts.append(Instance(obj_id=oid, T_m2c=T, gt_id=gt_id))
        label = Path(f"{stem}-label.png")
        frames.append(Frame(scene_id=video, im_id=im_id, camera=Camera(meta["K"], width, height),
                            instances=insts, depth_scale=meta["depth_scale"],
                            rgb_path=Path(f"{stem}-color.png"), depth_path=Path(f"{stem}-depth.png"),
                            label_path=label if label.is_file() else None, T_w2c=meta["T_w2c"],
                            extra={"meta_path": Path(f"{stem}-meta.mat"), "factor_depth": meta["factor_depth"],
                                   "camera_name": cam_name}))
    return Scene(scene_id=video, frames=frames, root=d)


def load_ycbv_dataset(root: str | Path, videos: str | Iterable[int] | None = None,
                      symmetric_obj_ids: Iterable[int] | None = None) -> Dataset:
    """The original YCB-Video layout as a streaming :class:`Dataset` (scene id = video number).

    Models: ``models/<name>/textured.obj`` in metres (``unit_scale=1000``); poses in mm in that
    model frame; ``depth_scale = 1000 / factor_depth``; frames carry ``label_path``; camera K
    from each frame's meta.mat. ``videos``: None (all), a list, or '0000,0001' / '0-59'.
    """
    root = Path(root)
    if not root.is_dir():
        raise YcbvssError("YCB-Video root not found", root)
    all_v = list_videos(root)
    sel = parse_videos(videos)
    if sel is None:
        sel = all_v
    else:
        missing = [v for v in sel if v not in all_v]
        if missing:
            raise YcbvssError(f"video {missing[0]:04d} not found", root / "data" / f"{missing[0]:04d}")
    models = load_ycbv_models(root, symmetric_obj_ids)
    return Dataset(root, models, sel, lambda v: load_ycbv_scene(root, v, models), name="ycbv", split="data")
