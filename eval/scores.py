"""Scores from per-instance errors: AUC with an error bound, success rate, accuracy curves.

- ``auc(e, b) = mean_i max(0, 1 - e_i / b) * 100``: the normalised area under the accuracy-vs-
  threshold curve on [0, b] (``(1/b) * integral_0^b P(e <= tau) dtau``). A missing estimate has
  ``e = inf`` (or NaN) and contributes 0. Bounds of the paper: 100 mm for ADD(-S), 10 px for PRJ.
- ``success_rate``: percentage with ``||t_est - t_gt|| < t_mm`` and ``R < r_deg`` (5 cm / 5 deg).
- Per object, then the overall score is the mean over objects (the paper's "Avg." columns);
  ``ADD-PRJ-AUC = (ADD-AUC + PRJ-AUC) / 2``.
"""
from __future__ import annotations

import numpy as np

ADD_BOUND_MM = 100.0
PRJ_BOUND_PX = 10.0


def _clean(errors) -> np.ndarray:
    e = np.asarray(errors, dtype=np.float64).reshape(-1)
    return np.where(np.isnan(e), np.inf, e)


def auc(errors, bound: float) -> float:
    """AUC in percent of errors with upper bound ``bound`` (NaN/inf count as failed). NaN if empty."""
    e = _clean(errors)
    if e.size == 0:
        return float("nan")
    if bound <= 0:
        raise ValueError("AUC bound must be > 0")
    return float(np.mean(np.maximum(0.0, 1.0 - e / bound)) * 100.0)


def success_rate(te_mm, r_deg, t_thr_mm: float = 50.0, r_thr_deg: float = 5.0) -> float:
    """Percentage of instances with translation error < t_thr_mm and rotation error < r_thr_deg."""
    te, r = _clean(te_mm), _clean(r_deg)
    if te.size == 0:
        return float("nan")
    return float(np.mean((te < t_thr_mm) & (r < r_thr_deg)) * 100.0)


def accuracy_curve(errors, thresholds) -> np.ndarray:
    """Fraction (percent) of instances with error <= each threshold (NaN/inf never pass)."""
    e = np.sort(_clean(errors))
    thr = np.asarray(thresholds, dtype=np.float64)
    if e.size == 0:
        return np.full(thr.shape, np.nan)
    return np.searchsorted(e, thr, side="right") / e.size * 100.0


def mean_finite(x) -> float:
    """Mean of the finite entries (NaN = no estimate and inf = missed are left out); NaN if none."""
    x = np.asarray(x, dtype=np.float64)
    x = x[np.isfinite(x)]
    return float(x.mean()) if x.size else float("nan")


MEAN_KEYS = ("tx_mm", "ty_mm", "tz_mm", "r_deg", "prj_px", "add_mm", "adds_mm", "add_s_mm", "te_mm")


def object_scores(err: dict[str, np.ndarray], add_bound_mm: float = ADD_BOUND_MM,
                  prj_bound_px: float = PRJ_BOUND_PX, sr_t_mm: float = 50.0,
                  sr_r_deg: float = 5.0) -> dict:
    """Scores and mean errors of the GT instances of one object.

    ``err``: (n,) arrays ``add_s_mm`` (ADD or ADD-S as the protocol says), ``prj_px``, ``te_mm``,
    ``r_deg`` and optionally the other :data:`MEAN_KEYS`; NaN = no estimate. Mean errors are over
    the instances that have an estimate; the AUCs count missing ones as failed."""
    n = len(err["add_s_mm"])
    missing = ~np.isfinite(np.asarray(err["add_s_mm"], dtype=np.float64))
    out = {"n_gt": int(n), "n_missing": int(missing.sum())}
    a = auc(err["add_s_mm"], add_bound_mm)
    p = auc(err["prj_px"], prj_bound_px)
    out.update(add_auc=a, prj_auc=p, add_prj_auc=(a + p) / 2.0,
               sr=success_rate(err["te_mm"], err["r_deg"], sr_t_mm, sr_r_deg),
               sr_5cm5deg=success_rate(err["te_mm"], err["r_deg"], 50.0, 5.0))
    for k in MEAN_KEYS:
        if k in err:
            out[f"mean_{k}"] = mean_finite(err[k])
    return out


SCORE_KEYS = ("add_auc", "prj_auc", "add_prj_auc", "sr", "sr_5cm5deg")


def overall_scores(per_object: dict) -> dict:
    """Mean over objects of each score (objects with no GT instance are skipped)."""
    out = {}
    for k in SCORE_KEYS:
        vals = [v[k] for v in per_object.values() if v.get("n_gt", 0) > 0 and np.isfinite(v[k])]
        out[k] = float(np.mean(vals)) if vals else float("nan")
    return out
