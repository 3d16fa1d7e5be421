"""Outputs of ``ycbvss refine``: BOP19 CSV, BOP scene_gt.json + scene_camera.json (with the solved
cam_R_w2c / cam_t_w2c), world object poses, per-pose uncertainty and the convergence log."""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np

from ..io.atomic import write_json_atomic
from ..io.bop import BopSceneWriter
from ..io.results import Estimate
from ..scene import Instance
from .bundle import RefineResult


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k) if not isinstance(k, tuple) else "_".join(str(int(v)) for v in k): _jsonable(v)
                for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return x


def view_checks(scene, res: RefineResult) -> list[dict]:
    """Per frame (sorted by im_id, the refiner's view order) the status's two per-view checks:
    ``contour_px``, the median contour offset of its objects (> ``OK_PX``: its poses are at best
    uncertain), ``shift_px``, the median 2-D shift at which its objects' templates fit the image's
    edges (:mod:`ycbvss.refine.view_shift`), and ``camera_off``: the shift above ``VIEW_SHIFT_PX``
    (both px bounds at 640 px width, scaled with the frame's). NaN values are written as null."""
    from .confidence import OK_PX, REF_WIDTH_PX, VIEW_SHIFT_PX

    frames = sorted(scene.frames, key=lambda f: f.im_id)
    vc = res.stats.get("view_contour_px", [])
    vs = res.stats.get("view_shift_px", [])
    out = []
    for n, f in enumerate(frames):
        c = float(vc[n]) if n < len(vc) else float("nan")
        sh = float(vs[n]) if n < len(vs) else float("nan")
        k = f.camera.width / REF_WIDTH_PX
        out.append({"im_id": int(f.im_id), "contour_px": round(c, 3) if np.isfinite(c) else None,
                    "shift_px": round(sh, 2) if np.isfinite(sh) else None,
                    "contour_loose": bool(np.isfinite(c) and c > OK_PX * k),
                    "camera_off": bool(np.isfinite(sh) and sh > VIEW_SHIFT_PX * k)})
    return out


def estimates_of(scene_id: int, res: RefineResult, time_s: float = -1.0) -> list[Estimate]:
    """BOP19 estimates; the score is the pose's confidence in [0, 1] (a failed pose scores <= 0.1),
    the same time for every estimate of the scene."""
    return [Estimate(int(scene_id), int(im), int(o), float(res.confidence.get((im, o), 0.0)), T, time_s)
            for (im, o), T in sorted(res.poses.items())]


def write_scene_outputs(out_dir: str | Path, split: str, scene, res: RefineResult) -> Path:
    """Write <out>/<split>/<scene:06d>/{scene_gt.json, scene_camera.json} and
    <out>/refine/<scene:06d>_{world.json, sigma.json, status.json, log.json}; status.json holds each
    object's quality, each frame's per-view checks (:func:`view_checks`) and each pose's status,
    confidence and reason. Returns the scene directory."""
    out_dir = Path(out_dir)
    w = BopSceneWriter(out_dir / split, scene.scene_id)
    for f in sorted(scene.frames, key=lambda f: f.im_id):
        g = copy.copy(f)
        g.T_w2c = res.T_w2c.get(f.im_id)
        g.instances = [Instance(o, res.poses[(im, o)], gt_id=k) for k, ((im, o)) in
                       enumerate(sorted(key for key in res.poses if key[0] == f.im_id))]
        w.write_frame(g)
    w.close()
    base = out_dir / "refine"
    sid = f"{scene.scene_id:06d}"
    write_json_atomic(base / f"{sid}_world.json", {
        "world": "camera frame of the first image",
        "T_m2w": {str(o): np.asarray(T).tolist() for o, T in res.T_m2w.items()},
        "T_w2c": {str(i): np.asarray(T).tolist() for i, T in res.T_w2c.items()},
        "missing_objects": res.missing_objects, "converged": res.converged})
    write_json_atomic(base / f"{sid}_sigma.json", _jsonable(res.sigma))
    write_json_atomic(base / f"{sid}_status.json", {
        "rules": "see ycbvss.refine.confidence",
        "objects": _jsonable(res.quality),
        "views": view_checks(scene, res),
        "poses": [{"im_id": int(im), "obj_id": int(o), "status": res.status.get((im, o), "failed"),
                   "confidence": round(float(res.confidence.get((im, o), 0.0)), 4),
                   "reason": res.reasons.get((im, o), "")} for (im, o) in sorted(res.poses)]})
    write_json_atomic(base / f"{sid}_log.json", _jsonable({"stats": res.stats, "log": res.log}))
    return w.dir
