"""The baseline tracker shipped with ycbvss: the refiner's edge and flow terms run frame to frame.

For every new frame, the last frame and the new one form a two-view bundle (:func:`refine_scene`):
the objects start at their last poses in both views, the new view's camera at the last one; the
edge term (template contours against the new image's edge field, coarse to fine), the point
term (dense flow matches between the two images lifted on the rendered templates) and the
temporal term are minimised, and the objects' poses in the new view are the output. Nothing is
learned and nothing is tuned for tracking: this is a baseline, not a method.

Modes:

- ``joint`` (default): all tracked objects in ONE two-view bundle, i.e. the objects are assumed
  rigid with respect to each other between two frames (static scenes with a moving camera, as
  YCB-V; any single-object sequence, as BCOT). One refinement per frame.
- ``per_object``: one two-view bundle per object (independent motions), one refinement per
  frame and object.

A pose the refiner flags ``failed`` (non-finite / singular system), or that is not a valid pose
(not a rotation, behind the camera), keeps the last pose; an object whose last pose is invalid is
not refined any more (it is lost). The tracker never re-initialises from GT. ``n_kept`` counts
the (frame, object) pairs that kept their last pose.
"""
from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np

from ..camera import Camera
from ..geometry.so3 import is_rotation
from ..scene import Frame, Scene
from .bundle import RefineOptions, refine_scene

TRACKER_OPTIONS = RefineOptions(
    use_edge=True, use_point=True, use_temporal=True,
    max_iters=3, coarse_iters=1, inner_iters=3, extra_iters=0,
    n_edge_points=600, n_matches=600, compute_uncertainty=False, seed=0,
    # two-view bundles are narrow: no table homographies per frame (the benchmark's figures predate
    # table contact on narrow bundles, session 50)
    table_contact=False,
)


def valid_pose(T) -> bool:
    """Finite, a rotation (1e-3) and in front of the camera."""
    T = np.asarray(T, dtype=np.float64)
    return (T.shape == (4, 4) and bool(np.all(np.isfinite(T))) and bool(is_rotation(T[:3, :3], 1e-3))
            and T[2, 3] > 0)


class EdgeFlowTracker:
    """Frame-to-frame baseline (see module doc). ``models``: obj_id -> ObjectModel (mm)."""

    modality = "rgb"

    def __init__(self, models: dict, options: RefineOptions | None = None, mode: str = "joint"):
        if mode not in ("joint", "per_object"):
            raise ValueError(f"mode must be 'joint' or 'per_object', got {mode!r}")
        self.models = models
        self.options = options or TRACKER_OPTIONS
        self.mode = mode
        self._img: np.ndarray | None = None
        self._K: np.ndarray | None = None
        self._scene_id = 0
        self.poses: dict[int, np.ndarray] = {}
        self.stats: list[dict] = []
        self.n_kept = 0

    def init(self, frame, poses: dict[int, np.ndarray]) -> None:
        self._img = np.asarray(frame.rgb)
        self._K = np.asarray(frame.K, dtype=np.float64)
        self._scene_id = int(frame.scene_id)
        self.poses = {int(o): np.asarray(T, dtype=np.float64).copy() for o, T in poses.items()}
        self.stats = []

    def _refine(self, frame, obj_ids: list[int]) -> dict[int, np.ndarray]:
        h, w = frame.rgb.shape[:2]
        f0 = Frame(scene_id=self._scene_id, im_id=0, camera=Camera(self._K.copy(), w, h))
        f1 = Frame(scene_id=self._scene_id, im_id=1, camera=Camera(np.asarray(frame.K, dtype=np.float64), w, h))
        init = {}
        for o in obj_ids:
            init[(0, o)] = self.poses[o]
            init[(1, o)] = self.poses[o]
        models = {o: self.models[o] for o in obj_ids}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = refine_scene(Scene(self._scene_id, [f0, f1]), models, init,
                               replace(self.options), images={0: self._img, 1: np.asarray(frame.rgb)})
        self.stats.append({"total_s": res.stats.get("total_s"), "n_objects": len(obj_ids)})
        out = {}
        for o in obj_ids:
            P = res.poses.get((1, o))
            if P is None or res.status.get((1, o)) == "failed" or not valid_pose(P):
                continue
            out[o] = np.asarray(P, dtype=np.float64)
        return out

    def track(self, frame) -> dict[int, np.ndarray]:
        objs = sorted(self.poses)
        live = [o for o in objs if valid_pose(self.poses[o])]
        new: dict[int, np.ndarray] = {}
        if live:
            if self.mode == "joint":
                new = self._refine(frame, live)
            else:
                for o in live:
                    new.update(self._refine(frame, [o]))
        self.n_kept += len(objs) - len(new)
        for o, P in new.items():
            self.poses[o] = P
        self._img = np.asarray(frame.rgb)
        self._K = np.asarray(frame.K, dtype=np.float64)
        return {o: self.poses[o].copy() for o in objs}


class EdgeFlowTrackerPerObject(EdgeFlowTracker):
    """:class:`EdgeFlowTracker` in ``per_object`` mode (one two-view bundle per object and frame:
    independent object motions, about n_objects times the cost)."""

    def __init__(self, models: dict, options: RefineOptions | None = None):
        super().__init__(models, options, mode="per_object")
