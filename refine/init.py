"""Scene-consistent initialisation from per-view pose estimates (CosyPose-style, paper Eq. 1).

Given initial object-to-camera poses P^_ij for some (view, object) pairs, find cameras T_c[i]
(world = camera of view 0) and world object poses T_m[j] minimising
sum_ij sum_X rho(||pi(P^_ij X) - pi(T_c[i] T_m[j] X)||) over sampled model points X with a
truncated quadratic loss rho, then once more with the model points' observed depths added
(:class:`ycbvss.refine.terms.DepthTerm`; see :func:`initialise`). Symmetric objects: each
observation is first replaced by its symmetric equivalent P^_ij S closest to the current
scene-consistent pose.
"""
from __future__ import annotations

import numpy as np

from ..geometry.se3 import inv_T
from ..geometry.so3 import rotation_angle_deg
from .jacobians import object_point_jacobians
from .problem import BundleProblem, View
from .solver import SolverOptions, run_lm
from .terms import DepthGroup, DepthTerm, PointGroup, PointTerm


def sample_model_points(vertices_mm: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    v = np.asarray(vertices_mm, dtype=np.float64)
    if len(v) <= n:
        return v.copy()
    return v[rng.choice(len(v), n, replace=False)]


def _reproj_cost(K, P_hat, P, X, trunc_px: float = 50.0) -> float:
    """Mean truncated reprojection distance; points behind either camera count as truncated."""
    a, _, _, ok_a = object_point_jacobians(K, np.eye(4), P_hat, X)
    b, _, _, ok_b = object_point_jacobians(K, np.eye(4), P, X)
    d = np.where(ok_a & ok_b, np.linalg.norm(a - b, axis=1), trunc_px)
    return float(np.mean(np.minimum(d, trunc_px)))


def propagate(n_views: int, n_objs: int, obs: dict[tuple[int, int], np.ndarray], Ks: list[np.ndarray],
              X: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Initial guess by propagation over the view-object graph starting at view 0.

    The unknown camera seeing the most placed objects is placed next, taking the candidate (one per
    such object) with the lowest truncated reprojection cost over all its placed observations. Returns T_c, T_m,
    cam_known (n,), obj_known (m,). Views not connected to view 0 take the nearest connected view's
    camera (by index); objects never observed stay unknown."""
    T_c = np.tile(np.eye(4), (n_views, 1, 1))
    T_m = np.tile(np.eye(4), (n_objs, 1, 1))
    ck = np.zeros(n_views, bool)
    ok_ = np.zeros(n_objs, bool)
    # view 0 defines the world; if it has no observation, start from the first view that has one
    # (view 0 then takes that camera, the nearest by index, as its initial guess)
    with_obs = sorted({i for (i, _) in obs})
    start = 0 if (not with_obs or with_obs[0] == 0) else with_obs[0]
    ck[start] = True
    changed = True
    while changed:
        changed = False
        for (i, j), P in obs.items():
            if ck[i] and not ok_[j]:
                T_m[j] = inv_T(T_c[i]) @ P
                ok_[j] = True
                changed = True
        # place the unknown camera that sees the most placed objects first (consensus among candidates)
        counts = [(sum(1 for j in range(n_objs) if ok_[j] and (i, j) in obs), i) for i in range(n_views) if not ck[i]]
        counts = [c for c in counts if c[0] > 0]
        if counts:
            _, i = max(counts)
            seen = [j for j in range(n_objs) if ok_[j] and (i, j) in obs]
            cands = [obs[(i, j)] @ inv_T(T_m[j]) for j in seen]
            T_c[i] = min(cands, key=lambda C: sum(_reproj_cost(Ks[i], obs[(i, j)], C @ T_m[j], X[j]) for j in seen))
            ck[i] = True
            changed = True
    if ck.any():
        known = np.flatnonzero(ck)
        for i in np.flatnonzero(~ck):
            T_c[i] = T_c[known[np.argmin(np.abs(known - i))]]
    return T_c, T_m, ck, ok_


# An observation is replaced by a symmetric equivalent only when that is closer to the consensus by
# more than SYM_MARGIN_DEG: a flip, not noise. The continuous symmetries (cans, the large marker) are
# sampled every 5 deg (72 steps), and with the margin at 1 deg every observation more than ~3.5 deg
# off the consensus about the axis was snapped to within 2.5 deg of it: the consensus kept its own
# roll, whatever the observations said. Suite, the paper's initial error (per-view estimates ~5.5 deg
# off), seed 5: long-2's large marker -1.08 deg about its long axis (its observations' mean +0.05;
# refinement hardly turns a marker about its axis and ended 1.21 deg off), long-1's master chef can
# -1.95 deg (observations +0.30); with 15 deg -0.09 and +0.28, the other objects within 0.09 deg.
SYM_MARGIN_DEG = 15.0


def align_symmetric(obs: dict, T_c: np.ndarray, T_m: np.ndarray, syms: list[list[np.ndarray]],
                    X: list[np.ndarray], margin_deg: float = SYM_MARGIN_DEG) -> dict:
    """Replace each observation P^_ij by the symmetric equivalent P^_ij S whose rotation is closest
    (geodesic angle) to the current consistent pose T_c[i] T_m[j]; the observation itself is kept
    unless an equivalent is closer by more than ``margin_deg`` (see ``SYM_MARGIN_DEG``).

    The rotation angle, not a mean 3D point distance, decides: with a translation error (typically
    2 cm in depth) an unevenly sampled mesh makes the point distance prefer a turn of 10-20 deg
    about a continuous symmetry axis (a can), which the edge term cannot undo and the texture then
    contradicts. ``X`` is unused (kept for the signature)."""
    out = {}
    for (i, j), P in obs.items():
        if len(syms[j]) <= 1:
            out[(i, j)] = P
            continue
        Rc = (T_c[i] @ T_m[j])[:3, :3]
        S = np.asarray(syms[j])
        R = np.einsum("ab,nbc->nac", P[:3, :3], S[:, :3, :3])
        ang = rotation_angle_deg(np.einsum("ba,nbc->nac", Rc, R))
        k = int(np.argmin(ang))
        out[(i, j)] = P if ang[0] <= ang[k] + margin_deg else P @ S[k]
    return out


def initialise(views: list[View], n_objs: int, obs: dict[tuple[int, int], np.ndarray], X: list[np.ndarray],
               syms: list[list[np.ndarray]] | None = None, trunc_px: tuple[float, ...] = (40.0, 15.0),
               max_iters: int = 15, log: list | None = None, depth_weight: float = 0.05,
               depth_cap_mm: float = 60.0, px_scale: float = 1.0) -> tuple[BundleProblem, np.ndarray]:
    """Scene-consistent cameras and objects from the observations ``obs[(view index, object index)]``.

    The reprojection cost (one stage per truncation in ``trunc_px``) hardly sees depth: a common
    scale of all camera and object positions about the first camera, and the depth of each object
    along its rays, change the reprojection only through apparent size (0.1 % of depth moves a
    100 px object's outline by 0.05 px). Its minimum along those directions is set by the
    observations' size noise and by where propagation started, not by their depths, and it lay
    too deep: on the suite's long clip 3 (200 views, the paper's initial error; per-object mean
    depth error of the observations -4.0 to +1.8 mm) +2.7 to +15.5 mm; on the short and medium
    clips of scenes 4-9 (seeds 0, 5) the mean depth error was +1 to +12 mm in 21 of 24 runs. A
    last stage therefore adds :class:`DepthTerm` on the observed depths of the model points, with
    ``depth_weight`` per mm^2 against 1 per px^2 of reprojection (0.05: depth errors of pose
    estimates are several times their lateral ones, about 1 mm per px at 1 m) and truncated at
    ``depth_cap_mm``; ``depth_weight=0`` leaves it out. With it the consensus's mean |depth error|
    fell in all 24 of those runs (medium-4, seed 0: 15.8 -> 7.5 mm) and its lateral error in 21.

    ``trunc_px`` and ``depth_weight`` are set for 640-px-wide images (YCB-V's); ``px_scale`` (the
    image width / 640) scales them so that the truncation covers the same angle and a mm of depth
    weighs the same against the pixels, which shrink with the image: at 320 px the unscaled depth
    weight counted 4 times as much against the reprojection. On the 16 keyframes of
    ``bench/bench_refine_long.py``'s scene (the paper's initial error, PRJ scaled with the width)
    the consensus poses' mean translation error at 320 px was 10.0 / 10.7 mm unscaled (seeds 1, 2),
    8.4 / 9.4 mm scaled, and 8.1 mm at 640 px (seed 1).

    Returns (problem with T_c, T_m set; obj_known (m,) bool). ``X[j]``: sampled model points (mm)."""
    n = len(views)
    Ks = [v.K for v in views]
    syms = syms or [[np.eye(4)] for _ in range(n_objs)]
    T_c, T_m, ck, okn = propagate(n, n_objs, obs, Ks, X)
    pb = BundleProblem(views, list(range(n_objs)), T_c, T_m,
                       cam_free=np.r_[False, ck[1:]], obj_free=okn)
    trunc_px = tuple(float(t) * px_scale for t in trunc_px)
    depth_weight = depth_weight * px_scale ** 2          # weight per mm^2 against 1 per px^2
    stages = [(tau, False) for tau in trunc_px] + ([(trunc_px[-1], True)] if depth_weight > 0 and trunc_px else [])
    for tau, with_depth in stages:
        cur = align_symmetric(obs, pb.T_c, pb.T_m, syms, X)
        groups, depth = [], []
        for (i, j), P in cur.items():
            if not okn[j]:
                continue
            x, _, _, valid = object_point_jacobians(Ks[i], np.eye(4), P, X[j])
            if valid.any():
                groups.append(PointGroup(i, j, X[j][valid], x[valid]))
                if with_depth:
                    depth.append(DepthGroup(i, j, X[j][valid], X[j][valid] @ P[2, :3] + P[2, 3]))
        terms = [PointTerm(groups, weight=1.0, rho=2.0, floor_px=0.0, cap_px=tau, name="init")]
        if with_depth:
            terms.append(DepthTerm(depth, weight=depth_weight, cap_mm=depth_cap_mm))
        run_lm(pb, terms, SolverOptions(max_iters=max_iters), log=log,
               stage=f"init tau={tau:g}px" + (" +depth" if with_depth else ""))
    return pb, okn
