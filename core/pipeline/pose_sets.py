"""Errors of pose sets {(scene, im, obj): 4x4} against exact poses, per object, and the paper's
reference rows (Li et al., Tables 4 and 5) they are reported beside. Used by validate, the
report and the suite."""
from __future__ import annotations

import numpy as np

from ..eval.metrics import pose_errors

# The paper's numbers (Li et al.): mean absolute tx, ty, tz (mm), R (deg), PRJ (px).
PAPER_REFERENCE_ROWS = [
    ("paper (Li et al.) all", (0.28, 0.22, 0.85, 0.23, 0.46)),
    ("binocular-90° [BCOT]", (0.28, 0.23, 0.28, 0.76, None)),
    ("binocular-45° [BCOT]", (0.57, 0.28, 1.35, 0.94, None)),
    ("YCBV original (paper)", (3.03, 2.15, 21.4, 3.27, 4.33)),
]
PAPER_TABLE5 = [
    ("w/o f_edge", (0.29, 0.25, 1.40, 0.29, 0.51)),
    ("w/o f_point", (0.34, 0.32, 1.96, 0.36, 0.60)),
    ("w/o f_t", (0.28, 0.23, 1.16, 0.26, 0.48)),
    ("using all", (0.28, 0.22, 0.85, 0.23, 0.46)),
]
ERR5 = ("tx_mm", "ty_mm", "tz_mm", "r_deg", "prj_px")


def pose_set_errors(est: dict, gt: dict, Ks: dict, models: dict) -> dict:
    """Per-object errors of the pose set ``est`` against ``gt`` (both {(scene, im, obj): 4x4}).

    Returns {obj_id: {"keys": [...], "tx_mm", "ty_mm", "tz_mm", "r_deg", "prj_px", "add_mm": arrays}}
    where ``add_mm`` is ADD-S for symmetric objects; a missing estimate gives NaN errors."""
    out = {}
    for oid in sorted({k[-1] for k in gt}):
        keys = sorted(k for k in gt if k[-1] == oid)
        have = [k for k in keys if k in est and np.all(np.isfinite(est[k]))]
        e = {c: np.full(len(keys), np.nan) for c in (*ERR5, "add_mm")}
        if have:
            idx = np.array([keys.index(k) for k in have])
            m = models[oid]
            pts = m.vertices_mm if m.path is not None else np.asarray(m.mesh.vertices, np.float64)
            E = pose_errors(np.stack([est[k][:3, :3] for k in have]), np.stack([est[k][:3, 3] for k in have]),
                            np.stack([gt[k][:3, :3] for k in have]), np.stack([gt[k][:3, 3] for k in have]),
                            np.stack([Ks[k] for k in have]), pts, with_adds=bool(m.symmetric))
            for c in ERR5:
                e[c][idx] = E[c]
            e["add_mm"][idx] = E["adds_mm"] if m.symmetric else E["add_mm"]
        e["keys"] = keys
        out[oid] = e
    return out


def _cat(per_obj: dict, key: str) -> np.ndarray:
    return np.concatenate([np.asarray(v[key], np.float64) for v in per_obj.values()]) if per_obj else np.zeros(0)


def means(per_obj_or_errs: dict, over_objects: bool = False) -> dict:
    """Mean of each error over all pairs (``over_objects=False``) of a per-object error dict."""
    out = {}
    for c in (*ERR5, "add_mm"):
        x = _cat(per_obj_or_errs, c)
        out[c] = float(np.nanmean(x)) if np.isfinite(x).any() else float("nan")
    return out


def object_means(per_obj: dict) -> dict:
    return {oid: {c: (float(np.nanmean(v[c])) if np.isfinite(v[c]).any() else float("nan"))
                  for c in (*ERR5, "add_mm")} for oid, v in per_obj.items()}
