"""Slow per-pose reference implementations (the bop_toolkit way), for tests and benchmarks only.

One pose pair at a time: transform the points with both poses, build a KD-tree on the
estimate-posed points for ADD-S (``adi``), project with K for PRJ. Never use these in the pipeline.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def _posed(R, t, pts):
    return pts @ np.asarray(R, np.float64).T + np.asarray(t, np.float64).reshape(1, 3)


def add_ref(R_est, t_est, R_gt, t_gt, pts) -> float:
    return float(np.linalg.norm(_posed(R_est, t_est, pts) - _posed(R_gt, t_gt, pts), axis=1).mean())


def adds_ref(R_est, t_est, R_gt, t_gt, pts) -> float:
    pe, pg = _posed(R_est, t_est, pts), _posed(R_gt, t_gt, pts)
    return float(cKDTree(pe).query(pg, k=1)[0].mean())


def prj_ref(R_est, t_est, R_gt, t_gt, K, pts) -> float:
    def proj(P):
        q = P @ np.asarray(K, np.float64).T
        return q[:, :2] / q[:, 2:3]
    return float(np.linalg.norm(proj(_posed(R_est, t_est, pts)) - proj(_posed(R_gt, t_gt, pts)),
                                axis=1).mean())


def re_ref(R_est, R_gt) -> float:
    c = (np.trace(np.asarray(R_est) @ np.asarray(R_gt).T) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def errors_loop(R_est, t_est, R_gt, t_gt, K, pts) -> dict[str, np.ndarray]:
    """All metrics for N pose pairs with a Python loop and one KD-tree per pose."""
    n = len(R_est)
    out = {k: np.empty(n) for k in ("tx_mm", "ty_mm", "tz_mm", "r_deg", "prj_px", "add_mm", "adds_mm")}
    K = np.broadcast_to(np.asarray(K, np.float64), (n, 3, 3))
    for i in range(n):
        d = np.abs(np.asarray(t_est[i]) - np.asarray(t_gt[i]))
        out["tx_mm"][i], out["ty_mm"][i], out["tz_mm"][i] = d
        out["r_deg"][i] = re_ref(R_est[i], R_gt[i])
        out["prj_px"][i] = prj_ref(R_est[i], t_est[i], R_gt[i], t_gt[i], K[i], pts)
        out["add_mm"][i] = add_ref(R_est[i], t_est[i], R_gt[i], t_gt[i], pts)
        out["adds_mm"][i] = adds_ref(R_est[i], t_est[i], R_gt[i], t_gt[i], pts)
    return out
