"""Compiled (numba) Catmull-Rom bicubic sampler of the edge field E.

One pass over the points gathers the 4x4 taps of each point from the padded field (see
:attr:`ycbvss.refine.edge.EdgeField.E_padded`), and evaluates the value, its exact gradient
(the derivative of the same interpolant) and, optionally, the bilinear interpolation of the
padded Hessian channels. Replaces the array form (a (N, 16) gather and four einsums per call);
numba is a required dependency and the kernels are module-level so ``cache=True`` works.
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _weights(t: float, w: np.ndarray, dw: np.ndarray) -> None:
    """Catmull-Rom weights of taps -1, 0, 1, 2 at fractional position t in [0, 1), and d/dt."""
    t2 = t * t
    t3 = t2 * t
    w[0] = 0.5 * (-t3 + 2.0 * t2 - t)
    w[1] = 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0)
    w[2] = 0.5 * (-3.0 * t3 + 4.0 * t2 + t)
    w[3] = 0.5 * (t3 - t2)
    dw[0] = 0.5 * (-3.0 * t2 + 4.0 * t - 1.0)
    dw[1] = 0.5 * (9.0 * t2 - 10.0 * t)
    dw[2] = 0.5 * (-9.0 * t2 + 8.0 * t + 1.0)
    dw[3] = 0.5 * (3.0 * t2 - 2.0 * t)


@njit(cache=True, nogil=True)
def cubic_sample(Ep: np.ndarray, u: np.ndarray, v: np.ndarray, with_grad: bool, Hp: np.ndarray,
                 with_hess: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Value (N,), gradient (N, 2) and Hessian channels (N, 3) at in-image pixel positions u, v
    (N,) (pixel centres at integers). Ep: padded E (H + 3, W + 3) float64; Hp: padded Euu, Euv,
    Evv (H + 3, W + 3, 3), read only when ``with_hess``. Unrequested outputs are zero-sized."""
    n = u.shape[0]
    val = np.empty(n)
    grad = np.empty((n if with_grad else 0, 2))
    hess = np.empty((n if with_hess else 0, 3))
    wu, dwu, wv, dwv = np.empty(4), np.empty(4), np.empty(4), np.empty(4)
    for p in range(n):
        fu, fv = np.floor(u[p]), np.floor(v[p])
        iu, iv = int(fu), int(fv)
        tu, tv = u[p] - fu, v[p] - fv
        _weights(tu, wu, dwu)
        _weights(tv, wv, dwv)
        s = 0.0
        su = 0.0
        sv = 0.0
        for r in range(4):
            row = 0.0
            drow = 0.0
            for c in range(4):
                e = Ep[iv + r, iu + c]
                row += e * wu[c]
                drow += e * dwu[c]
            s += row * wv[r]
            su += drow * wv[r]
            sv += row * dwv[r]
        val[p] = s
        if with_grad:
            grad[p, 0] = su
            grad[p, 1] = sv
        if with_hess:
            for ch in range(3):
                hess[p, ch] = ((1.0 - tu) * (1.0 - tv) * Hp[iv + 1, iu + 1, ch] + tu * (1.0 - tv) * Hp[iv + 1, iu + 2, ch]
                               + (1.0 - tu) * tv * Hp[iv + 2, iu + 1, ch] + tu * tv * Hp[iv + 2, iu + 2, ch])
    return val, grad, hess


@njit(cache=True, inline="always")
def _value_at(Ep: np.ndarray, height: int, width: int, u: float, v: float, wu: np.ndarray, dwu: np.ndarray,
              wv: np.ndarray, dwv: np.ndarray) -> float:
    """E at (u, v) as ``edge.sample_E`` reads it: the Catmull-Rom value (the tap sums of
    :func:`cubic_sample`, in the same order) inside [0, W-1] x [0, H-1], 1 outside or not finite."""
    if not (np.isfinite(u) and np.isfinite(v) and u >= 0 and v >= 0 and u <= width - 1 and v <= height - 1):
        return 1.0
    fu, fv = np.floor(u), np.floor(v)
    iu, iv = int(fu), int(fv)
    _weights(u - fu, wu, dwu)
    _weights(v - fv, wv, dwv)
    s = 0.0
    for r in range(4):
        row = 0.0
        for c in range(4):
            row += Ep[iv + r, iu + c] * wu[c]
        s += row * wv[r]
    return s


@njit(cache=True, nogil=True)
def edge_cost_sum(Ep: np.ndarray, height: int, width: int, K: np.ndarray, T: np.ndarray, X: np.ndarray,
                  min_z_mm: float) -> float:
    """sum_X E(pi(T X)) over model points X (N, 3) mm for the camera-from-model transform T (4, 4)
    and intrinsics K (3, 3): E read like :func:`cubic_sample` (no gradient), 1 for a point behind
    the camera (Z <= ``min_z_mm``), not finite, or outside the image [0, W-1] x [0, H-1]. The
    projection, validity and inside rules are those of ``jacobians.project_points`` and
    ``edge.sample_E`` (the cost path of the edge term in one pass, no (N, 2) temporaries)."""
    total = 0.0
    wu, dwu, wv, dwv = np.empty(4), np.empty(4), np.empty(4), np.empty(4)
    for p in range(X.shape[0]):
        x0, x1, x2 = X[p, 0], X[p, 1], X[p, 2]
        Yx = T[0, 0] * x0 + T[0, 1] * x1 + T[0, 2] * x2 + T[0, 3]
        Yy = T[1, 0] * x0 + T[1, 1] * x1 + T[1, 2] * x2 + T[1, 3]
        Z = T[2, 0] * x0 + T[2, 1] * x1 + T[2, 2] * x2 + T[2, 3]
        if not (Z > min_z_mm and Z < np.inf and np.isfinite(Yx) and np.isfinite(Yy)):
            total += 1.0
            continue
        x, y = Yx / Z, Yy / Z
        u = K[0, 0] * x + K[0, 1] * y + K[0, 2]
        v = K[1, 1] * y + K[1, 2]
        total += _value_at(Ep, height, width, u, v, wu, dwu, wv, dwv)
    return total


@njit(cache=True, nogil=True)
def minimum_along(Ep: np.ndarray, height: int, width: int, uv: np.ndarray, n: np.ndarray, coarse: np.ndarray,
                  fine: np.ndarray, fine_step: float, half_px: float) -> np.ndarray:
    """Signed offsets t (N,) of the smallest E along uv + t n (uv, n (N, 2) px), E read like
    :func:`_value_at`: the first minimum over the ``coarse`` offsets, then over ``fine`` offsets
    about it, a parabola through the fine minimum (moved off the grid's ends) and its two
    neighbours (fraction clipped to +-1 step), the result clipped to +-``half_px``. The arithmetic
    of ``contour_match._minimum_along``'s array form, point by point."""
    N = uv.shape[0]
    out = np.empty(N)
    nf = fine.shape[0]
    Ef = np.empty(nf)
    wu, dwu, wv, dwv = np.empty(4), np.empty(4), np.empty(4), np.empty(4)
    for p in range(N):
        u0, v0, nu, nv = uv[p, 0], uv[p, 1], n[p, 0], n[p, 1]
        best, kc = np.inf, 0
        for k in range(coarse.shape[0]):
            t = 0.0 + coarse[k]
            e = _value_at(Ep, height, width, u0 + t * nu, v0 + t * nv, wu, dwu, wv, dwv)
            if e < best:
                best, kc = e, k
        best, kf = np.inf, 0
        for k in range(nf):
            t = coarse[kc] + fine[k]
            e = _value_at(Ep, height, width, u0 + t * nu, v0 + t * nv, wu, dwu, wv, dwv)
            Ef[k] = e
            if e < best:
                best, kf = e, k
        kf = min(max(kf, 1), nf - 2)
        e0, e1, e2 = Ef[kf - 1], Ef[kf], Ef[kf + 1]
        den = e0 - 2.0 * e1 + e2
        frac = 0.5 * (e0 - e2) / den if den > 1e-12 else 0.0
        frac = min(max(frac, -1.0), 1.0)
        out[p] = min(max(coarse[kc] + fine[kf] + frac * fine_step, -half_px), half_px)
    return out


@njit(cache=True, nogil=True)
def anchored_edge_values(Ep: np.ndarray, height: int, width: int, K: np.ndarray, Y: np.ndarray, uv0: np.ndarray,
                         nrm: np.ndarray, ok0: np.ndarray, min_z_mm: float) -> np.ndarray:
    """f_edge's per-sample values (N,) of one group whose samples move across their edges only
    (``EdgeTerm``'s anchors): for camera points Y (N, 3) mm, E at uv0 + ((pi(Y) - uv0) . n) n, 1 where
    the projection is invalid (``jacobians._project``'s rule), the anchor not usable (``ok0`` False)
    or the point outside the image. The arithmetic of the array form (projection, the two-term dot
    product, :func:`_value_at`), so the values are the same bit for bit; the caller sums them with
    NumPy (its pairwise order)."""
    N = Y.shape[0]
    e = np.empty(N)
    wu, dwu, wv, dwv = np.empty(4), np.empty(4), np.empty(4), np.empty(4)
    for p in range(N):
        Z = Y[p, 2]
        if not (Z > min_z_mm and Z < np.inf and np.isfinite(Y[p, 0]) and np.isfinite(Y[p, 1]) and ok0[p]):
            e[p] = 1.0
            continue
        x, y = Y[p, 0] / Z, Y[p, 1] / Z
        u = K[0, 0] * x + K[0, 1] * y + K[0, 2]
        v = K[1, 1] * y + K[1, 2]
        d = (u - uv0[p, 0]) * nrm[p, 0] + (v - uv0[p, 1]) * nrm[p, 1]
        e[p] = _value_at(Ep, height, width, uv0[p, 0] + d * nrm[p, 0], uv0[p, 1] + d * nrm[p, 1], wu, dwu, wv, dwv)
    return e
