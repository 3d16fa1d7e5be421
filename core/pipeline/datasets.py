"""Open the dataset a validation runs on (BOP root + split, or an original YCB-Video root) with
clear errors, and select frames."""
from __future__ import annotations

from pathlib import Path

from ..errors import YcbvssError
from ..io.atomic import read_json
from ..io.bop import list_scene_ids, load_bop_scene, load_models
from ..io.ycbv import load_ycbv_dataset
from ..procedural.io import OBJECTS_META
from ..scene import Dataset, Scene

SPLIT_PREFERENCE = ("test", "val", "train_real", "train_synt", "train_pbr", "train")


def is_ycbv_root(root: Path) -> bool:
    """Original YCB-Video layout: data/NNNN/*-meta.mat and models/<name>/ (no models_info.json)."""
    return (root / "data").is_dir() and (root / "models").is_dir() and not (root / "models" / "models_info.json").is_file()


def detect_split(root: Path) -> str:
    """The BOP split folder holding scenes (NNNNNN/scene_camera.json), preferring test/val/train_real."""
    cands = []
    for d in sorted(p for p in root.iterdir() if p.is_dir()):
        if any(s.is_dir() and s.name.isdigit() and (s / "scene_camera.json").is_file() for s in d.iterdir()):
            cands.append(d.name)
    if not cands:
        raise YcbvssError("no BOP split folder with scenes (NNNNNN/scene_camera.json) and no YCB-Video "
                          "data/ folder found -- is this a BOP root or a YCB-Video root?", root)
    for s in SPLIT_PREFERENCE:
        if s in cands:
            return s
    return cands[0]


SYNTH_REPORT = "synth_report.json"


def enlarged_model_scales(root: str | Path) -> dict[int, float]:
    """Object id -> scale of the models a YCBV-SS dataset (written by ``ycbvss synth``, its
    ``synth_report.json`` at the root) renders enlarged (scale > 1); {} for any other dataset.

    Such a dataset's models are larger than the objects in the real frames, and its GT poses are
    the source's annotations, so its objects do not stand on the real table with the models'
    surfaces: on the shared clip 0001 the enlarged models' lowest points lie 7.4-12.3 mm below the
    table plane of the real depth (scratch measurement, session 50). The pipeline therefore turns
    the table contact off on such datasets (``RefineOptions.table_contact``)."""
    p = Path(root) / SYNTH_REPORT
    if not p.is_file():
        return {}
    objs = read_json(p, "synthesis report").get("objects", {})
    out = {}
    for k, v in (objs.items() if isinstance(objs, dict) else ()):
        try:
            sc = float(v.get("scale", 1.0))
        except (TypeError, ValueError, AttributeError):
            continue
        if sc > 1.0:
            out[int(k)] = sc
    return out


def apply_object_meta(models: dict, models_dir: Path) -> None:
    """Names / textureless flags from ``ycbvss_objects.json`` (written for procedural models)."""
    p = Path(models_dir) / OBJECTS_META
    if not p.is_file():
        return
    meta = read_json(p, "object metadata")
    for k, v in meta.items():
        m = models.get(int(k))
        if m is not None:
            m.name = str(v.get("name", m.name))
            m.textureless = bool(v.get("textureless", m.textureless))


def open_dataset(path: str | Path, split: str | None = None, scenes: list[int] | None = None) -> tuple[Dataset, str, str]:
    """(Dataset, layout "bop"|"ycbv", split). Raises YcbvssError for a missing / unrecognised root."""
    root = Path(path)
    if not root.exists():
        raise YcbvssError("dataset not found", root)
    if not root.is_dir():
        raise YcbvssError("dataset must be a folder (a BOP root or a YCB-Video root)", root)
    if is_ycbv_root(root):
        return load_ycbv_dataset(root, scenes), "ycbv", split or "test"
    split = split or detect_split(root)
    if not (root / split).is_dir():
        raise YcbvssError(f"split folder '{split}' not found", root / split)
    names = None if (root / "models" / OBJECTS_META).is_file() else "auto"
    ds = _load_bop(root, split, scenes, names)
    apply_object_meta(ds.models, root / "models")
    return ds, "bop", split


def _load_bop(root: Path, split: str, scenes, names) -> Dataset:
    models = load_models(root / "models", names=names)
    split_dir = root / split
    all_ids = list_scene_ids(split_dir)
    if not all_ids:
        raise YcbvssError("split has no complete scene (NNNNNN/scene_camera.json)", split_dir)
    if scenes is not None:
        missing = [s for s in scenes if s not in all_ids]
        if missing:
            raise YcbvssError(f"scene {missing[0]} not found (available: {all_ids[:20]})", split_dir)
        all_ids = [int(s) for s in scenes]
    return Dataset(root, models, all_ids, lambda s: load_bop_scene(split_dir, s, models), name=root.name, split=split)


def select_frames(scene: Scene, max_frames: int | None = None, frame_step: int = 1) -> Scene:
    """Every ``frame_step``-th frame (sorted by im_id), at most ``max_frames`` of them; only frames
    with at least one annotated instance."""
    frames = [f for f in sorted(scene.frames, key=lambda f: f.im_id) if f.instances][:: max(1, int(frame_step))]
    if max_frames:
        frames = frames[: int(max_frames)]
    return Scene(scene.scene_id, frames, scene.root)
