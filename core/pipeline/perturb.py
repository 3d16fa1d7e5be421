"""Calibrated random deviations of exact poses: the "initial poses" of a refinement experiment.

The paper (Sec. 5.1) starts the refinement on YCBV-SS from the exact poses plus a random
deviation with mean ADD 22.1 mm and mean PRJ 5.2 px -- an error that, like the one of the
original YCB-Video annotations, is mostly along the line of sight (a lateral error of 20 mm
would be ~25 px at 0.8 m).

Model. For every (view, object) pair *independently* (as single-view tracking output would be):

    t' = t + a * s_z * n_z * d  +  b * (s_x * n_x * e_x + s_y * n_y * e_y)
    R' = exp(b * s_r * w) R,      n_* ~ N(0, 1),  w ~ N(0, I_3)

``d`` is the unit viewing ray through the object centre, ``e_x``/``e_y`` complete it to an
orthonormal frame close to the camera x/y axes; ``(s_x, s_y, s_z, s_r)`` is a fixed *shape*
(default: proportional to the YCB-V original annotation error tx 3.03, ty 2.15, tz 21.4 mm,
R 3.27 deg of the paper's Table 4). Two scales are then calibrated: ``a`` (depth) mostly
controls ADD, ``b`` (lateral + rotation) mostly controls PRJ. With the random draws fixed
(common random numbers) the achieved means are smooth in (a, b) and a multiplicative
fixed-point iteration hits both targets to < 0.5 %.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..eval.metrics import add_adds_mm, prj_px
from ..eval.model_points import ModelPoints
from ..geometry.so3 import exp_so3

# Per-axis error shape (tx, ty, tz in mm, R in deg) of the paper's "YCBV original" row.
YCBV_ORIGINAL_SHAPE = (3.03, 2.15, 21.4, 3.27)

Key = tuple  # (im_id, obj_id) or (scene_id, im_id, obj_id)


@dataclass
class PerturbResult:
    """Perturbed poses and what they achieve (means over all (view, object) pairs)."""

    poses: dict                     # key -> 4x4 T_m2c (mm)
    add_mm: float                   # achieved mean ADD
    prj_px: float                   # achieved mean PRJ
    target_add_mm: float
    target_prj_px: float
    depth_scale: float              # a
    lateral_scale: float            # b
    per_key: dict = field(default_factory=dict)   # key -> (ADD mm, PRJ px)
    converged: bool = True
    message: str = ""

    def summary(self) -> str:
        return (f"initial poses: mean ADD {self.add_mm:.2f} mm (target {self.target_add_mm:.2f}), "
                f"mean PRJ {self.prj_px:.2f} px (target {self.target_prj_px:.2f}), "
                f"{len(self.poses)} (view, object) pairs" + (f" -- {self.message}" if self.message else ""))


def _ray_frame(t: np.ndarray) -> np.ndarray:
    """Rows (e_x, e_y, d): d the unit viewing ray to t, e_x/e_y orthonormal, close to camera x/y."""
    d = t / np.linalg.norm(t)
    ex = np.array([1.0, 0.0, 0.0]) - d[0] * d
    ex /= np.linalg.norm(ex)
    ey = np.cross(d, ex)
    return np.stack([ex, ey, d])


def _subsample(points: np.ndarray, max_points: int) -> np.ndarray:
    points = np.asarray(points, np.float64)
    if len(points) <= max_points:
        return points
    return points[:: int(np.ceil(len(points) / max_points))]


def _apply(gt: np.ndarray, frames: np.ndarray, z: np.ndarray, shape: np.ndarray, a: float, b: float) -> np.ndarray:
    """Vectorised deviations: gt (P,4,4), frames (P,3,3) rows e_x,e_y,d, z (P,6) standard normals."""
    coef = np.stack([b * shape[0] * z[:, 0], b * shape[1] * z[:, 1], a * shape[2] * z[:, 2]], 1)   # (P,3)
    dt = np.einsum("pk,pkj->pj", coef, frames)
    w = np.radians(b * shape[3]) * z[:, 3:6]
    out = gt.copy()
    out[:, :3, :3] = exp_so3(w) @ gt[:, :3, :3]
    out[:, :3, 3] = gt[:, :3, 3] + dt
    return out


def _errors(est: np.ndarray, gt: np.ndarray, Ks: np.ndarray, groups: dict) -> tuple[np.ndarray, np.ndarray]:
    """ADD (mm) and PRJ (px) of every pair, (P,) each: est/gt (P, 4, 4), Ks (P, 3, 3); ``groups``
    obj_id -> (indices of its pairs, its ModelPoints)."""
    add = np.empty(len(gt))
    prj = np.empty(len(gt))
    for idx, mp in groups.values():
        Re, te, Rg, tg = est[idx, :3, :3], est[idx, :3, 3], gt[idx, :3, :3], gt[idx, :3, 3]
        add[idx] = add_adds_mm(Re, te, Rg, tg, mp, with_adds=False)[0]
        prj[idx] = prj_px(Re, te, Rg, tg, Ks[idx], mp.points)
    return add, prj


def perturb_poses(gt_poses: dict, Ks: dict, points_mm: dict, target_add_mm: float = 22.1,
                  target_prj_px: float = 5.2, seed: int = 0, shape=YCBV_ORIGINAL_SHAPE,
                  max_points: int = 1000, tol: float = 0.003, max_iter: int = 60,
                  depth_scale: float | None = None) -> PerturbResult:
    """Perturb exact poses so that the mean ADD / PRJ over all pairs match the targets.

    ``gt_poses``: key -> 4x4 T_m2c (mm), key = (..., obj_id) with the object id last;
    ``Ks``: key -> 3x3 intrinsics of that key's view; ``points_mm``: obj_id -> (N,3) model points
    (subsampled to ``max_points`` for the calibration). Pure: same inputs and seed -> same output.
    With ``depth_scale`` the depth scale ``a`` is held at that value and only ``b`` is calibrated,
    to the PRJ target (``target_add_mm`` is then not a target; the achieved ADD is reported).
    """
    keys = sorted(gt_poses)
    if not keys:
        raise ValueError("no poses to perturb")
    if target_add_mm <= 0 or target_prj_px <= 0:
        raise ValueError("target ADD and PRJ must be > 0")
    gt = np.stack([np.asarray(gt_poses[k], np.float64) for k in keys])
    K = np.stack([np.asarray(Ks[k], np.float64) for k in keys])
    obj = np.array([k[-1] for k in keys])
    groups = {o: (np.flatnonzero(obj == o), ModelPoints(_subsample(points_mm[o], max_points), k=0))
              for o in sorted(set(obj.tolist()))}
    frames = np.stack([_ray_frame(T[:3, 3]) for T in gt])
    rng = np.random.default_rng(seed)
    z = rng.standard_normal((len(keys), 6))
    shape = np.asarray(shape, np.float64)
    a, b = (1.0 if depth_scale is None else float(depth_scale)), 1.0
    converged = False
    for _ in range(max_iter):
        est = _apply(gt, frames, z, shape, a, b)
        add, prj = _errors(est, gt, K, groups)
        m_add, m_prj = add.mean(), prj.mean()
        if (depth_scale is not None or abs(m_add / target_add_mm - 1) < tol) and abs(m_prj / target_prj_px - 1) < tol:
            converged = True
            break
        if depth_scale is None:
            a *= (target_add_mm / max(m_add, 1e-9)) ** 0.9
        b *= (target_prj_px / max(m_prj, 1e-9)) ** 0.9
        a, b = float(np.clip(a, 0.0, 1e4)), float(np.clip(b, 0.0, 1e4))
    msg = "" if converged else ("targets not reachable together with this error shape; achieved values "
                                "reported")
    return PerturbResult(poses={k: est[i] for i, k in enumerate(keys)}, add_mm=float(m_add), prj_px=float(m_prj),
                         target_add_mm=float(target_add_mm), target_prj_px=float(target_prj_px),
                         depth_scale=a, lateral_scale=b,
                         per_key={k: (float(add[i]), float(prj[i])) for i, k in enumerate(keys)},
                         converged=converged, message=msg)
