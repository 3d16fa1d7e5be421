"""Object symmetries (BOP ``models_info`` ``symmetries_discrete`` / ``_continuous``) as rigid transforms.

A symmetry transform ``S`` (4x4, mm, model frame) leaves the object's appearance unchanged, so a
pose ``T`` is equivalent to every ``T S``. Continuous symmetries (rotation about an axis through
``offset``) are sampled at ``n_continuous`` angles ``2 pi k / n``.

- :func:`symmetry_group`: the transforms of lists of discrete / continuous symmetries, identity first.
- :func:`symmetry_transforms`: the same for an :class:`ycbvss.scene.ObjectModel`. The refiner's
  initialisation uses 36 steps per axis; evaluation uses :func:`continuous_steps` so that no model point
  moves more than ``max_step_frac * diameter`` between two samples (315 for 0.01, as bop_toolkit).
- :func:`closest_symmetric_gt`: for every estimate, the equivalent GT pose that is closest in mean
  squared model-point distance, exactly from the points' first and second moments (no per-point work).
"""
from __future__ import annotations

import math

import numpy as np

from .so3 import exp_so3

REFINE_CONTINUOUS_STEPS = 36    # samples per continuous axis for the refiner's symmetric initialisation


def continuous_steps(max_step_frac: float) -> int:
    """Samples per continuous axis so that a point at the diameter moves at most ``max_step_frac *
    diameter`` between neighbours: ``ceil(pi / max_step_frac)``."""
    return int(math.ceil(math.pi / max_step_frac))


def symmetry_group(discrete: list | None, continuous: list | None, n_continuous: int) -> np.ndarray:
    """(S, 4, 4) symmetry transforms, identity first.

    ``discrete``: 4x4 matrices or BOP 16-number lists (mm); identity entries are skipped.
    ``continuous``: dicts ``{"axis": [3], "offset": [3] mm}``. Combined as ``T_cont(angle) @ T_disc``
    for every pair, continuous axes one after the other."""
    disc = [np.eye(4)]
    for S in discrete or []:
        S = np.asarray(S, dtype=np.float64).reshape(4, 4)
        if not np.allclose(S, np.eye(4)):
            disc.append(S)
    conts = [np.eye(4)]
    for c in continuous or []:
        axis = np.asarray(c["axis"], dtype=np.float64)
        axis = axis / np.linalg.norm(axis)
        offset = np.asarray(c.get("offset", [0.0, 0.0, 0.0]), dtype=np.float64)
        new = []
        for k in range(1, n_continuous):
            R = exp_so3(axis * (2.0 * math.pi * k / n_continuous))
            T = np.eye(4)
            T[:3, :3] = R
            T[:3, 3] = offset - R @ offset          # rotation about the axis through `offset`
            new.extend(T @ Tc for Tc in conts)
        conts = conts + new
    return np.stack([Tc @ Td for Tc in conts for Td in disc])


def symmetry_transforms(model, n_continuous: int = REFINE_CONTINUOUS_STEPS) -> np.ndarray:
    """:func:`symmetry_group` of an ObjectModel's ``symmetries_discrete`` / ``symmetries_continuous``
    (missing attributes count as none)."""
    return symmetry_group(getattr(model, "symmetries_discrete", None), getattr(model, "symmetries_continuous", None),
                          n_continuous)


def point_moments(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean (3,) and second moment ``mean(x x^T)`` (3, 3) of model points."""
    pts = np.asarray(pts, dtype=np.float64)
    return pts.mean(axis=0), pts.T @ pts / len(pts)


def closest_symmetric_gt(R_est, t_est, R_gt, t_gt, syms: np.ndarray, pts: np.ndarray,
                         chunk: int = 2048) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For N pose pairs, the equivalent GT pose ``T_gt S`` (S in ``syms``) closest to the estimate.

    Criterion: mean over model points of ``||(R_e - R_g R_s) x + (t_e - t_g - R_g t_s)||^2``
    = ``tr(M Sigma M^T) + 2 v^T M mu + |v|^2`` with ``M = R_e - R_g R_s``, ``v = t_e - t_g - R_g t_s``.
    Returns (R_gt', t_gt', index of the chosen symmetry) with shapes (N,3,3), (N,3), (N,)."""
    R_est, t_est = np.asarray(R_est, np.float64), np.asarray(t_est, np.float64)
    R_gt, t_gt = np.asarray(R_gt, np.float64), np.asarray(t_gt, np.float64)
    syms = np.asarray(syms, np.float64)
    n = len(R_est)
    if len(syms) == 1:
        return R_gt.copy(), t_gt.copy(), np.zeros(n, dtype=np.int64)
    mu, Sig = point_moments(pts)
    Rs, ts = syms[:, :3, :3], syms[:, :3, 3]
    best = np.empty(n, dtype=np.int64)
    for s in range(0, n, chunk):
        sl = slice(s, min(n, s + chunk))
        RgRs = np.einsum("nij,sjk->nsik", R_gt[sl], Rs)                 # (m, S, 3, 3)
        M = R_est[sl, None] - RgRs
        v = (t_est[sl] - t_gt[sl])[:, None, :] - np.einsum("nij,sj->nsi", R_gt[sl], ts)
        cost = (np.einsum("nsij,jk,nsik->ns", M, Sig, M) + 2.0 * np.einsum("nsi,nsij,j->ns", v, M, mu)
                + np.einsum("nsi,nsi->ns", v, v))
        best[sl] = cost.argmin(axis=1)
    R_new = R_gt @ Rs[best]
    t_new = t_gt + (R_gt @ ts[best][..., None])[..., 0]
    return R_new, t_new, best
