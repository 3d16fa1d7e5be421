"""Scoring tracker results on a benchmark configuration with ``ycbvss.eval``'s metrics.

Per tracked (subsequence, frame, object) with a GT pose: ADD (ADD-S for the symmetric set, by
default only 024_bowl = obj 13 for YCB-V, none for BCOT), PRJ, translation and rotation error
(:func:`ycbvss.eval.pose_errors`). A missing estimate counts as a failure (infinite error). Per
object: ADD(-S)-AUC (bound 100 mm), PRJ-AUC (10 px), ADD-PRJ-AUC (their mean), SR at 5 cm / 5 deg
(:func:`ycbvss.eval.object_scores`); overall = mean over objects
(:func:`ycbvss.eval.overall_scores`). The same frame may be scored several times when
subsequences overlap (forward and backward, different steps), as in the paper.

ADD-S is computed only for the symmetric set (``adds_all=True`` adds the ADD-S column for every
object; the scores do not change).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...errors import YcbvssError
from ...progress import progress
from ..metrics import pose_errors
from ..model_points import ModelPoints
from ..scores import ADD_BOUND_MM, PRJ_BOUND_PX, object_scores, overall_scores
from .sources import Sequence

ERROR_FIELDS = ("tx_mm", "ty_mm", "tz_mm", "te_mm", "r_deg", "prj_px", "add_mm", "adds_mm", "add_s_mm")


@dataclass
class GtIndex:
    """The scored (subsequence, frame, object) triples of a config, as flat arrays (n,)."""

    sub_id: np.ndarray
    scene_id: np.ndarray
    im_id: np.ndarray
    obj_id: np.ndarray
    length: np.ndarray
    R: np.ndarray
    t: np.ndarray
    K: np.ndarray

    def __len__(self) -> int:
        return len(self.obj_id)


def gt_index(cfg: dict, sequences: list[Sequence]) -> GtIndex:
    """GT of every tracked frame (``frames[1:]``) and object of every subsequence. A tracked object
    without GT in a frame is not scored there. Errors name the subsequence and frame."""
    by_sid = {int(s.scene_id): s for s in sequences}
    rows, Rs, ts, Ks = [], [], [], []
    for s in cfg["subsequences"]:
        seq = by_sid.get(int(s["scene_id"]))
        if seq is None:
            raise YcbvssError("scene of the config not in the dataset", cfg["dataset"].get("root"),
                              f"subsequence {s['id']} scene {s['scene_id']}")
        L = len(s["frames"])
        for im in s["frames"][1:]:
            g = seq.gt.get(int(im))
            if g is None:
                raise YcbvssError("frame of the config not in the dataset", cfg["dataset"].get("root"),
                                  f"subsequence {s['id']} scene {s['scene_id']} frame {im}")
            K = seq.K[int(im)]
            for o in s["objects"]:
                T = g.get(int(o))
                if T is None:
                    continue
                rows.append((int(s["id"]), int(s["scene_id"]), int(im), int(o), L))
                Rs.append(T[:3, :3])
                ts.append(T[:3, 3])
                Ks.append(K)
    a = np.array(rows, dtype=np.int64).reshape(-1, 5)
    return GtIndex(a[:, 0], a[:, 1], a[:, 2], a[:, 3], a[:, 4], np.array(Rs, dtype=np.float64).reshape(-1, 3, 3),
                   np.array(ts, dtype=np.float64).reshape(-1, 3), np.array(Ks, dtype=np.float64).reshape(-1, 3, 3))


@dataclass
class TrackerScores:
    """``errors``: dict of (n,) arrays (:data:`ERROR_FIELDS`, NaN = missing) aligned with the
    GtIndex; ``per_object`` obj_id -> scores; ``overall``; ``per_length`` L -> overall scores of
    the subsequences of that length; ``counts``."""

    name: str
    errors: dict[str, np.ndarray]
    per_object: dict[int, dict]
    overall: dict
    per_length: dict[int, dict] = field(default_factory=dict)
    counts: dict = field(default_factory=dict)


class PointCache:
    """One :class:`ModelPoints` index per object, shared by all trackers of a scoring run."""

    def __init__(self, models: dict):
        self.models = models
        self._mp: dict[int, ModelPoints] = {}

    def __call__(self, o: int) -> ModelPoints:
        if o not in self._mp:
            if o not in self.models:
                raise YcbvssError(f"no model for tracked object {o}")
            self._mp[o] = ModelPoints(self.models[o].vertices_mm)
        return self._mp[o]


def estimate_arrays(gti: GtIndex, results: dict[int, dict]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(have (n,) bool, R (n,3,3), t (n,3)) of a tracker's results aligned with ``gti``."""
    n = len(gti)
    have = np.zeros(n, bool)
    R = np.full((n, 3, 3), np.nan)
    t = np.full((n, 3), np.nan)
    sub, im, obj = gti.sub_id.tolist(), gti.im_id.tolist(), gti.obj_id.tolist()
    for i in range(n):
        rows = results.get(sub[i])
        if rows is None:
            continue
        r = rows.get((im[i], obj[i]))
        if r is None:
            continue
        R[i], t[i] = r[0], r[1]
        have[i] = True
    have &= np.all(np.isfinite(R.reshape(n, 9)), axis=1) & np.all(np.isfinite(t), axis=1)
    return have, R, t


def score_tracker(name: str, gti: GtIndex, results: dict[int, dict], points: PointCache,
                  symmetric_obj_ids=(13,), adds_all: bool = False, add_bound_mm: float = ADD_BOUND_MM,
                  prj_bound_px: float = PRJ_BOUND_PX) -> TrackerScores:
    """Errors and scores of one tracker (see module doc)."""
    have, Re, te = estimate_arrays(gti, results)
    n = len(gti)
    err = {k: np.full(n, np.nan) for k in ERROR_FIELDS}
    sym = set(int(o) for o in (symmetric_obj_ids or ()))
    obj_ids = sorted(set(gti.obj_id.tolist()))
    for o in obj_ids:
        idx = np.flatnonzero((gti.obj_id == o) & have)
        if len(idx) == 0:
            continue
        e = pose_errors(Re[idx], te[idx], gti.R[idx], gti.t[idx], gti.K[idx], points(o),
                        with_adds=adds_all or o in sym)
        for k in ("tx_mm", "ty_mm", "tz_mm", "r_deg", "prj_px", "add_mm", "adds_mm"):
            err[k][idx] = e[k]
        err["te_mm"][idx] = np.linalg.norm(te[idx] - gti.t[idx], axis=1)
        err["add_s_mm"][idx] = e["adds_mm"] if o in sym else e["add_mm"]
    per_object = {}
    for o in obj_ids:
        sel = gti.obj_id == o
        per_object[o] = object_scores({k: err[k][sel] for k in err}, add_bound_mm, prj_bound_px)
        per_object[o]["symmetric"] = o in sym
    per_length = {}
    for L in sorted(set(gti.length.tolist())):
        pl = {}
        for o in obj_ids:
            sel = (gti.obj_id == o) & (gti.length == L)
            if sel.any():
                pl[o] = object_scores({k: err[k][sel] for k in err}, add_bound_mm, prj_bound_px)
        per_length[int(L)] = {**overall_scores(pl), "n": int((gti.length == L).sum())}
    times = [r[2] for rows in results.values() for r in rows.values() if len(r) > 2 and r[2] >= 0]
    counts = {"n_scored": int(n), "n_estimates": int(have.sum()), "n_missing": int((~have).sum()),
              "mean_time_s": float(np.mean(times)) if times else float("nan")}
    return TrackerScores(name, err, per_object, overall_scores(per_object), per_length, counts)


def score_benchmark(cfg: dict, sequences: list[Sequence], models: dict, results: dict[str, dict[int, dict]],
                    symmetric_obj_ids=(13,), adds_all: bool = False) -> tuple[GtIndex, list[TrackerScores]]:
    """Score several trackers (name -> {sub_id: rows}) on one config; GT and model indices are
    built once and shared."""
    gti = gt_index(cfg, sequences)
    if len(gti) == 0:
        raise YcbvssError("the benchmark config has no scored frame (no tracked object with GT)")
    pts = PointCache(models)
    out = []
    for name, res in progress(list(results.items()), desc="score", unit="tracker"):
        out.append(score_tracker(name, gti, res, pts, symmetric_obj_ids, adds_all))
    return gti, out
