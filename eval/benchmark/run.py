"""Running a tracker on a benchmark configuration: the Python tracker protocol and the runner
(progress bar, one atomic results file per subsequence, resume after an interruption).

Tracker protocol (duck-typed)::

    class MyTracker:
        modality = "rgb"                   # or "rgbd": frames then carry depth_mm
        def __init__(self, models: dict):  # obj_id -> ycbvss.scene.ObjectModel (mm)
            ...
        def init(self, frame: TrackFrame, poses: dict[int, np.ndarray]) -> None:
            ...                            # poses: obj_id -> 4x4 object-to-camera (mm) in frame
        def track(self, frame: TrackFrame) -> dict[int, np.ndarray]:
            ...                            # obj_id -> 4x4; a missing object = lost (a failure)

``init`` is called once per subsequence with its first frame and the init poses; ``track`` for
every following frame in order. There is no re-initialisation inside a subsequence: the runner
never passes GT after ``init``.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Protocol, runtime_checkable

import numpy as np

from ...errors import YcbvssError
from ...io.atomic import read_json, write_json_atomic
from ...progress import progress
from .protocol import frame_K, init_pose
from .results import config_sha256, result_path, write_results
from .sources import load_models, load_scene


@dataclass
class TrackFrame:
    """One image given to a tracker: ``rgb`` HxWx3 uint8, ``depth_mm`` HxW float (RGB-D trackers
    only, else None), ``K`` 3x3."""

    scene_id: int
    im_id: int
    K: np.ndarray
    rgb: np.ndarray
    depth_mm: np.ndarray | None = None


@runtime_checkable
class Tracker(Protocol):
    modality: str

    def init(self, frame: TrackFrame, poses: dict[int, np.ndarray]) -> None: ...

    def track(self, frame: TrackFrame) -> dict[int, np.ndarray]: ...


class StaticTracker:
    """The trivial baseline: every frame keeps the init poses (no motion model)."""

    modality = "rgb"

    def __init__(self, models: dict | None = None):
        self.poses: dict[int, np.ndarray] = {}

    def init(self, frame: TrackFrame, poses: dict[int, np.ndarray]) -> None:
        self.poses = {o: np.asarray(T, dtype=np.float64).copy() for o, T in poses.items()}

    def track(self, frame: TrackFrame) -> dict[int, np.ndarray]:
        return dict(self.poses)


class SceneCache:
    """Loads each scene (frames with image paths) once; see :func:`sources.load_scene`."""

    def __init__(self, root: Path, layout: str, split: str, models: dict):
        self._load = load_scene
        self.root, self.layout, self.split, self.models = root, layout, split, models
        self._sid = None
        self._frames: dict = {}

    def frame(self, scene_id: int, im_id: int):
        if self._sid != scene_id:
            sc = self._load(self.root, self.layout, self.split, scene_id, None)
            self._frames = {f.im_id: f for f in sc.frames}
            self._sid = scene_id
        f = self._frames.get(im_id)
        if f is None:
            raise YcbvssError("frame of the benchmark config not in the dataset", self.root,
                              f"scene {scene_id} frame {im_id}")
        return f


def _track_frame(fr, sub: dict, im_id: int, depth: bool) -> TrackFrame:
    if fr.rgb_path is None:
        raise YcbvssError("frame has no image", fr.rgb_path or "", f"scene {fr.scene_id} frame {im_id}")
    rgb = fr.load_rgb()
    if rgb.ndim == 2:
        rgb = np.repeat(rgb[..., None], 3, axis=2)
    d = None
    if depth:
        if fr.depth_path is None:
            raise YcbvssError("RGB-D tracker but the frame has no depth image", fr.rgb_path,
                              f"scene {fr.scene_id} frame {im_id}")
        d = fr.load_depth_mm()
    return TrackFrame(int(sub["scene_id"]), int(im_id), frame_K(sub, im_id), rgb[..., :3], d)


def run_benchmark(cfg: dict, make_tracker: Callable[[], object], out_dir: str | Path, root: str | Path | None = None,
                  tracker_name: str = "", models: dict | None = None, subsequence_ids=None,
                  frames_of: Callable | None = None) -> dict:
    """Run a tracker on every subsequence of ``cfg`` not yet done in ``out_dir`` (resume).

    ``make_tracker()`` returns a tracker (see module doc); ``root`` overrides the dataset root in the
    config; ``frames_of(scene_id, im_id)`` overrides the frame source (a ``Frame`` with
    ``load_rgb``/``load_depth_mm``). Returns {"done", "skipped", "seconds", "frames"}."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ds = cfg["dataset"]
    root = Path(root or ds.get("root", ""))
    layout, split = ds.get("layout", "bop"), ds.get("split", "")
    sha = config_sha256(cfg)
    runp = out / "run.json"
    _check_previous_run(runp, sha, tracker_name)
    subs = cfg["subsequences"]
    if subsequence_ids is not None:
        keep = set(int(i) for i in subsequence_ids)
        subs = [s for s in subs if int(s["id"]) in keep]
    todo = [s for s in subs if not result_path(out, s["id"]).is_file()]
    skipped = len(subs) - len(todo)
    tracker = make_tracker()
    modality = str(getattr(tracker, "modality", "rgb")).lower()
    if modality not in ("rgb", "rgbd"):
        raise YcbvssError(f"tracker modality must be 'rgb' or 'rgbd', got {modality!r}")
    write_json_atomic(runp, {"tracker": tracker_name or type(tracker).__name__, "modality": modality,
                             "config_sha256": sha, "n_subsequences": len(cfg["subsequences"])})
    if frames_of is None:
        if models is None:
            models = load_models(root, layout)
        cache = SceneCache(root, layout, split, models)
        frames_of = cache.frame
    todo.sort(key=lambda s: (s["scene_id"], s["id"]))
    n_frames = sum(len(s["frames"]) for s in todo)
    bar = progress(desc=f"track ({tracker_name or type(tracker).__name__})", total=n_frames, unit="frame")
    t_all = time.perf_counter()
    try:
        for s in todo:
            write_results(out, s["id"], _track_subsequence(tracker, s, frames_of, modality == "rgbd", bar))
    finally:
        bar.close()
    return {"done": len(todo), "skipped": skipped, "seconds": time.perf_counter() - t_all, "frames": n_frames}


def _check_previous_run(runp: Path, sha: str, tracker_name: str) -> None:
    """A results folder belongs to one config (by sha256) and one tracker: refuse to mix."""
    if not runp.is_file():
        return
    prev = read_json(runp, "benchmark run info")
    if prev.get("config_sha256") not in (None, sha):
        raise YcbvssError("this folder holds results of another benchmark config; use a new --out", runp)
    if tracker_name and prev.get("tracker") not in (None, tracker_name):
        raise YcbvssError(f"this folder holds results of tracker {prev.get('tracker')!r}, not {tracker_name!r}",
                          runp)


def _track_subsequence(tracker, s: dict, frames_of: Callable, with_depth: bool, bar) -> list[tuple]:
    """Run ``tracker`` on subsequence ``s``: init on its first frame with the config's poses, then
    track frame by frame. Returns rows (im_id, obj_id, T_m2c 4x4 mm, seconds of that track call)
    for every finite 4x4 pose returned for a tracked object."""
    frames = [int(f) for f in s["frames"]]
    objs = [int(o) for o in s["objects"]]
    f0 = _track_frame(frames_of(int(s["scene_id"]), frames[0]), s, frames[0], with_depth)
    tracker.init(f0, {o: init_pose(s, o) for o in objs})
    bar.update(1)
    rows = []
    for im in frames[1:]:
        fr = _track_frame(frames_of(int(s["scene_id"]), im), s, im, with_depth)
        t0 = time.perf_counter()
        poses = tracker.track(fr) or {}
        dt = time.perf_counter() - t0
        for o in objs:
            T = poses.get(o)
            if T is None:
                continue
            T = np.asarray(T, dtype=np.float64)
            if T.shape != (4, 4) or not np.all(np.isfinite(T)):
                continue
            rows.append((im, o, T, dt))
        bar.update(1)
    return rows
