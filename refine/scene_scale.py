"""The scale of a free-camera bundle as f_point's flow matches alone see it.

With free cameras a scene's scale (every object-to-camera translation times 1 + s) is fixed only by
the objects' apparent sizes. Two terms carry that: the contours (f_edge) and the texture flow
matches (f_point). Their biases differ in kind. A contour's image edge lies +-0.05-0.1 px from
its prediction, by object (gamma, rim shading, glossy rims), and over a scene's few objects these
add up to a scale error of about +-0.07 % (``bench/bench_contour_offsets.py --objects``, table
``contour_scale``: rms 0.066 % over the nine ycbv21 scenes at the exact GT with the lit
prediction; up to 1.2 mm of depth). The flow matches' scale at the exact GT varies by about
0.012 % between scenes, about a common -0.024 % (scenes 1-8; scene 9 -0.059 %).

:func:`point_scale` is the scale the point term alone prefers at the current poses: its robust
cost minimised along the scale direction by IRLS, with a standard error.
"""
from __future__ import annotations

import numpy as np

# rms over the nine ycbv21 scenes of the scene scale the contours alone give at the exact GT
# (lit appearance prediction; bench/results/ycbv21/shading_rim_s66/contour_scale.md): the prior
# spread of the contours' scene-scale error, against which the point term's estimate is weighed
CONTOUR_SCALE_RMS = 0.00066


def scale_gradients(K: np.ndarray, T_m2c: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Projections uv (N, 2) px of model points X (N, 3) mm under T_m2c (4x4), their derivative
    g (N, 2) px per unit of scale (the translation times 1 + s: d uv / d Y times t), and valid (N,)
    (:func:`ycbvss.refine.jacobians.project_jac`, the projection f_point's term uses)."""
    from .jacobians import project_jac

    Xc = np.asarray(X, np.float64) @ T_m2c[:3, :3].T + T_m2c[:3, 3]
    uv, J, valid = project_jac(K, Xc)
    return uv, J @ T_m2c[:3, 3], valid


def point_scale(groups: list, K_of, T_of, rho: float, floor_px: float, cap_px: float,
                iters: int = 5) -> tuple[float, float, int]:
    """The scale s (relative; translations times 1 + s) that f_point's matches prefer, its
    standard error and the number of matches used.

    ``groups``: objects with ``i``, ``j``, ``X`` (N, 3) mm, ``x`` (N, 2) px (PointGroup);
    ``K_of(i)``: view i's intrinsics; ``T_of(i, j)``: the current object-to-camera pose (4x4 mm).
    The robust cost of :func:`ycbvss.refine.terms.robust_cost_weights` (``rho``, ``floor_px``,
    ``cap_px``) is minimised along s by ``iters`` IRLS steps from s = 0. Standard error: the
    sandwich estimate sqrt(sum w^2 (r . g)^2) / sum w |g|^2 at the last step. (nan, nan, 0)
    without matches."""
    from .terms import robust_cost_weights

    R, G = [], []
    for gr in groups:
        if len(gr.x) == 0:
            continue
        uv, g, valid = scale_gradients(K_of(gr.i), T_of(gr.i, gr.j), gr.X)
        R.append((np.asarray(gr.x, np.float64) - uv)[valid])
        G.append(g[valid])
    if not R:
        return float("nan"), float("nan"), 0
    r0, g = np.concatenate(R), np.concatenate(G)
    s = 0.0
    for _ in range(max(int(iters), 1)):
        r = r0 - s * g
        _, w, inl = robust_cost_weights(r, rho, floor_px, cap_px)
        den = float(np.sum(w * np.einsum("ij,ij->i", g, g)))
        if not inl.any() or den <= 0.0:
            return float("nan"), float("nan"), 0
        s = float(np.sum(w * np.einsum("ij,ij->i", r0, g)) / den)
    r = r0 - s * g
    _, w, inl = robust_cost_weights(r, rho, floor_px, cap_px)
    den = float(np.sum(w * np.einsum("ij,ij->i", g, g)))
    se = float(np.sqrt(np.sum((w * np.einsum("ij,ij->i", r, g)) ** 2)) / den) if den > 0 else float("nan")
    return s, se, int(inl.sum())


def blended_scale(s_point: float, se_point: float, prior_rms: float = CONTOUR_SCALE_RMS) -> float:
    """The part of the point term's preferred scale to apply: s_point weighted against the
    contours' scene-scale spread, prior_rms^2 / (prior_rms^2 + se_point^2); 0 when not finite."""
    if not (np.isfinite(s_point) and np.isfinite(se_point)):
        return 0.0
    v = prior_rms ** 2
    return float(s_point * v / (v + se_point ** 2))
