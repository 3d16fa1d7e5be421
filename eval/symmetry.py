"""Poses modulo object symmetries (BOP ``models_info`` ``symmetries_discrete`` / ``_continuous``).

:func:`symmetry_transforms` lists the symmetry transforms ``S`` (4x4, mm, model frame) of an
object, identity first: the discrete ones and, for continuous symmetries, rotations about the axis
sampled so that no model point moves more than ``max_step_frac * diameter`` between two samples
(``n = ceil(pi / max_step_frac)`` angles, 315 for the default 0.01, as bop_toolkit).
A GT pose ``T_gt`` is then equivalent to every ``T_gt S``.

:func:`closest_symmetric_gt` picks, for every estimate, the equivalent GT pose that is closest in
mean squared model-point distance; this is computed exactly from the first and second moments of
the model points (no per-point work), so it is cheap even for hundreds of transforms.
"""
from __future__ import annotations

import math

import numpy as np

from ..geometry.so3 import exp_so3


def symmetry_transforms(discrete: list | None = None, continuous: list | None = None,
                        diameter_mm: float | None = None, max_step_frac: float = 0.01) -> np.ndarray:
    """(S, 4, 4) symmetry transforms, identity first.

    ``discrete``: 4x4 matrices or BOP 16-number lists (mm). ``continuous``: dicts ``{"axis": [3],
    "offset": [3] mm}``. Combined as ``T_cont(angle) @ T_disc`` for every pair."""
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
        n = int(math.ceil(math.pi / max_step_frac))
        new = []
        for k in range(1, n):
            R = exp_so3(axis * (2.0 * math.pi * k / n))
            T = np.eye(4)
            T[:3, :3] = R
            T[:3, 3] = offset - R @ offset          # rotation about the axis through `offset`
            new.extend(T @ Tc for Tc in conts)
        conts = conts + new
    return np.stack([Tc @ Td for Tc in conts for Td in disc])


def model_symmetry_transforms(model, max_step_frac: float = 0.01) -> np.ndarray:
    """:func:`symmetry_transforms` of an :class:`ycbvss.scene.ObjectModel`."""
    return symmetry_transforms(model.symmetries_discrete, model.symmetries_continuous,
                               model.diameter_mm, max_step_frac)


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
