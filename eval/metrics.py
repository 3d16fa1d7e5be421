"""Pose-error metrics, one small vectorised function per metric (bop_toolkit ``pose_error`` style).

Conventions: rotations ``R`` (..., 3, 3), translations ``t`` (..., 3) in **mm**, object-to-camera
(BOP/OpenCV). Every function accepts one pose pair or a batch with leading dimension N; model
points ``pts`` are (P, 3) mm in the model frame (``ObjectModel.vertices_mm``).

- :func:`te_axes_mm` ``|t_est - t_gt|`` per camera axis (tx, ty, tz), mm.
- :func:`te_mm` ``||t_est - t_gt||``, mm.
- :func:`re_deg` angle of ``R_est R_gt^T``, degrees in [0, 180].
- :func:`prj_px` mean 2D distance of the model points projected with both poses (pixels);
  one compiled numba kernel (:mod:`ycbvss.eval.nn_kernel`) for the whole batch.
- :func:`add_mm` ADD: mean distance between corresponding transformed model points (mm).
- :func:`adds_mm` ADD-S: for every point in the GT pose, distance to the nearest point in the
  estimated pose, averaged (= bop_toolkit ``adi``). Uses one :class:`ModelPoints` index per object
  (a KD-tree built once in the model frame), never one tree per pose.

Batches are processed in blocks of ``poses_per_block`` poses with the points as rows, so every
rigid transform of a block is ONE matrix product and the temporaries stay in cache.
"""
from __future__ import annotations

import numpy as np

from .model_points import ModelPoints


def _prj_kernel():
    """The compiled PRJ kernel, imported on first use."""
    # lazy: numba kernels compile/load on import
    from .nn_kernel import prj_kernel
    return prj_kernel


def _f64(a) -> np.ndarray:
    return np.asarray(a, dtype=np.float64)


def te_axes_mm(t_est: np.ndarray, t_gt: np.ndarray) -> np.ndarray:
    """Absolute translation error per camera axis: (..., 3) -> (..., 3) [mm]."""
    return np.abs(_f64(t_est) - _f64(t_gt))


def te_mm(t_est: np.ndarray, t_gt: np.ndarray) -> np.ndarray:
    """Euclidean translation error ``||t_est - t_gt||``: (..., 3) -> (...) [mm]."""
    return np.linalg.norm(_f64(t_est) - _f64(t_gt), axis=-1)


def re_deg(R_est: np.ndarray, R_gt: np.ndarray) -> np.ndarray:
    """Rotation error: angle of ``M = R_est R_gt^T`` in degrees, (..., 3, 3) -> (...), in [0, 180].

    Computed as ``atan2(|vee(M - M^T)| / 2, (trace(M) - 1) / 2)``, accurate near 0 and 180 deg
    (equal to bop_toolkit's ``arccos((trace - 1) / 2)`` up to its rounding, ~1e-6 deg near 0)."""
    M = _f64(R_est) @ np.swapaxes(_f64(R_gt), -1, -2)
    c = (np.trace(M, axis1=-2, axis2=-1) - 1.0) / 2.0
    v = np.stack([M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]], -1)
    return np.degrees(np.arctan2(np.linalg.norm(v, axis=-1) / 2.0, c))


def _batched(R_est, t_est, R_gt, t_gt):
    R_est, t_est, R_gt, t_gt = (_f64(x) for x in (R_est, t_est, R_gt, t_gt))
    single = R_est.ndim == 2
    if single:
        R_est, t_est, R_gt, t_gt = R_est[None], t_est.reshape(1, 3), R_gt[None], t_gt.reshape(1, 3)
    return single, R_est, t_est.reshape(-1, 3), R_gt, t_gt.reshape(-1, 3)


def relative_model_transform(R_est, t_est, R_gt, t_gt) -> tuple[np.ndarray, np.ndarray]:
    """(A, b) with ``A = R_est^T R_gt``, ``b = R_est^T (t_gt - t_est)``, batched (N, 3, 3), (N, 3).

    ``y = A x + b`` maps a model point ``x`` in the GT pose into the estimate's model frame;
    ``||y - x||`` is the ADD distance of that point, ``min_j ||y - x_j||`` its ADD-S distance."""
    Rt = np.swapaxes(_f64(R_est), -1, -2)
    A = Rt @ _f64(R_gt)
    b = (Rt @ (_f64(t_gt) - _f64(t_est))[..., None])[..., 0]
    return A, b


def add_adds_mm(R_est, t_est, R_gt, t_gt, points: ModelPoints | np.ndarray, with_adds: bool = True,
                poses_per_block: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """ADD and ADD-S together (they share the transformed points). Returns (add, adds) [mm],
    scalars for one pose, (N,) for a batch; adds is NaN when ``with_adds`` is False."""
    mp = points if isinstance(points, ModelPoints) else ModelPoints(points)
    single, R_est, t_est, R_gt, t_gt = _batched(R_est, t_est, R_gt, t_gt)
    A, b = relative_model_transform(R_est, t_est, R_gt, t_gt)
    add, adds = mp.add_adds(A, b, with_adds=with_adds, poses_per_block=poses_per_block)
    if adds is None:
        adds = np.full(len(add), np.nan)
    if single:
        return add[0], adds[0]
    return add, adds


def add_mm(R_est, t_est, R_gt, t_gt, pts, poses_per_block: int = 16):
    """ADD [mm]: mean over model points of ``||(R_est x + t_est) - (R_gt x + t_gt)||``."""
    return add_adds_mm(R_est, t_est, R_gt, t_gt, pts, with_adds=False, poses_per_block=poses_per_block)[0]


def adds_mm(R_est, t_est, R_gt, t_gt, pts, poses_per_block: int = 16):
    """ADD-S [mm]: mean over GT-posed points of the distance to the nearest estimate-posed point.

    ``pts`` may be a :class:`ModelPoints` (build it once per object and reuse it)."""
    return add_adds_mm(R_est, t_est, R_gt, t_gt, pts, with_adds=True, poses_per_block=poses_per_block)[1]


def prj_px(R_est, t_est, R_gt, t_gt, K, pts):
    """PRJ [px]: mean 2D distance between the model points projected with the estimated and the
    GT pose through the intrinsics ``K`` (3, 3) or (N, 3, 3). Points behind the camera are not
    special-cased (as bop_toolkit ``proj``)."""
    pts = pts.points if isinstance(pts, ModelPoints) else _f64(pts)
    single, R_est, t_est, R_gt, t_gt = _batched(R_est, t_est, R_gt, t_gt)
    n = len(R_est)
    K = np.broadcast_to(_f64(K), (n, 3, 3))
    # fold K into the pose: K (R x + t) = (K R) x + K t
    KRe, KRg = K @ R_est, K @ R_gt
    Kte, Ktg = (K @ t_est[..., None])[..., 0], (K @ t_gt[..., None])[..., 0]
    c = np.ascontiguousarray
    out = _prj_kernel()(c(pts), c(KRe), c(Kte), c(KRg), c(Ktg))
    return out[0] if single else out


ERROR_KEYS = ("tx_mm", "ty_mm", "tz_mm", "r_deg", "prj_px", "add_mm", "adds_mm")


def pose_errors(R_est, t_est, R_gt, t_gt, K, points: ModelPoints | np.ndarray, with_adds: bool = True,
                poses_per_block: int = 16) -> dict[str, np.ndarray]:
    """All per-pose errors of N pose pairs of ONE object: dict of (N,) arrays keyed by
    :data:`ERROR_KEYS` (``adds_mm`` is NaN when ``with_adds`` is False)."""
    mp = points if isinstance(points, ModelPoints) else ModelPoints(points)
    _, R_est, t_est, R_gt, t_gt = _batched(R_est, t_est, R_gt, t_gt)
    te = te_axes_mm(t_est, t_gt)
    add, adds = add_adds_mm(R_est, t_est, R_gt, t_gt, mp, with_adds=with_adds, poses_per_block=poses_per_block)
    return {"tx_mm": te[:, 0], "ty_mm": te[:, 1], "tz_mm": te[:, 2], "r_deg": re_deg(R_est, R_gt),
            "prj_px": prj_px(R_est, t_est, R_gt, t_gt, K, mp.points),
            "add_mm": np.atleast_1d(add), "adds_mm": np.atleast_1d(adds)}


def pose_errors_4x4(T_est: np.ndarray, T_gt: np.ndarray, K: np.ndarray, points: ModelPoints | np.ndarray,
                    with_adds: bool = False) -> dict[str, float]:
    """:func:`pose_errors` of ONE pose pair given as 4x4 object-to-camera matrices (mm): floats
    keyed by :data:`ERROR_KEYS` (``adds_mm`` NaN unless ``with_adds``)."""
    T_est, T_gt = _f64(T_est), _f64(T_gt)
    e = pose_errors(T_est[:3, :3], T_est[:3, 3], T_gt[:3, :3], T_gt[:3, 3], K, points, with_adds=with_adds)
    return {k: float(v[0]) for k, v in e.items()}
