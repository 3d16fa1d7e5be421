"""Association of GT instances and estimates, per (scene_id, im_id, obj_id).

BOP approach: within one image and object, estimates are taken in decreasing score (ties: file
order) and each is matched to the still unmatched GT instance with the lowest error (the caller's
``cost``, e.g. ADD(-S)). With one GT instance (YCB-V: one instance per object per image) this is
simply "the highest-scored estimate"; further estimates of that object are surplus.
Estimates for images absent from the GT and estimates of objects absent from their image are
left unmatched and counted.
"""
from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass
from typing import Callable

import numpy as np


@dataclass
class MatchResult:
    est_for_gt: np.ndarray          # (n_gt,) index into the estimates, -1 = no estimate
    n_est_no_image: int             # estimates for (scene, im) not in the GT
    n_est_no_object: int            # estimates for an object absent from its (known) image
    n_est_surplus: int              # further estimates of an object once all its instances matched
    n_groups_surplus: int           # (image, object) groups with more estimates than GT instances


def match(gt_scene, gt_im, gt_obj, est_scene, est_im, est_obj, est_score,
          cost: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> MatchResult:
    """Greedy score-ordered matching (see module doc).

    ``cost(gt_idx, est_idx) -> (len(est_idx), len(gt_idx))`` errors; only called for groups
    with more than one GT instance (when None, GT instances are taken in order)."""
    gt_keys = list(zip(np.asarray(gt_scene).tolist(), np.asarray(gt_im).tolist(), np.asarray(gt_obj).tolist()))
    groups: dict[tuple, list[int]] = defaultdict(list)
    images = set()
    for i, k in enumerate(gt_keys):
        groups[k].append(i)
        images.add(k[:2])
    est_groups: dict[tuple, list[int]] = defaultdict(list)
    n_no_image = n_no_object = 0
    for j, k in enumerate(zip(np.asarray(est_scene).tolist(), np.asarray(est_im).tolist(),
                              np.asarray(est_obj).tolist())):
        if k[:2] not in images:
            n_no_image += 1
        elif k not in groups:
            n_no_object += 1
        else:
            est_groups[k].append(j)
    score = np.asarray(est_score, dtype=np.float64)
    est_for_gt = np.full(len(gt_keys), -1, dtype=np.int64)
    n_surplus = n_multi = 0
    for k, ests in est_groups.items():
        gts = groups[k]
        order = sorted(ests, key=lambda j: -score[j])            # stable: ties keep file order
        if len(ests) > len(gts):
            n_surplus += len(ests) - len(gts)
            n_multi += 1
        if len(gts) == 1:
            est_for_gt[gts[0]] = order[0]
            continue
        C = (np.zeros((len(order), len(gts))) if cost is None
             else np.asarray(cost(np.asarray(gts), np.asarray(order)), dtype=np.float64))
        free = np.ones(len(gts), dtype=bool)
        for r, j in enumerate(order):
            if not free.any():
                break
            c = np.where(free, np.nan_to_num(C[r], nan=np.inf, posinf=np.inf), np.inf)
            g = int(np.argmin(c)) if np.isfinite(c).any() else int(np.flatnonzero(free)[0])
            est_for_gt[gts[g]] = j
            free[g] = False
    return MatchResult(est_for_gt, n_no_image, n_no_object, n_surplus, n_multi)
