"""Compiled (numba) kernels of the pose-error metrics; imported lazily by
:class:`ycbvss.eval.model_points.ModelPoints` and :func:`ycbvss.eval.metrics.prj_px` (numba is a
required dependency; the import is deferred for its start-up cost). Module-level functions so
numba's on-disk cache (``cache=True``) works.

- :func:`add_adds_kernel` ADD and exact ADD-S of a batch of relative transforms against ONE
  object's KD-tree (built once in the model frame, see ``model_points.build_kdtree``): per point
  the certified candidate list first, then (optionally) the exact voxel grid of
  :mod:`ycbvss.eval.nn_grid`, the tree only when both fail; prange over poses.
- :func:`prj_kernel` mean 2D reprojection distance, prange over poses.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from .nn_grid import _dist2, grid_nn2

# the "no grid" arguments of add_adds_kernel (an empty offsets array switches the grid off)
NO_GRID = (np.zeros(5), np.zeros(3, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))


@njit(cache=True, inline="always")
def _gap2(v, lo, hi):
    if v < lo:
        return (lo - v) * (lo - v)
    if v > hi:
        return (v - hi) * (v - hi)
    return 0.0


@njit(cache=True, fastmath=True, nogil=True)
def _nn2(y0, y1, y2, best, tp, lo, hi, child, span, stack_n, stack_d):
    top = 1
    stack_n[0] = 0
    stack_d[0] = 0.0
    while top > 0:
        top -= 1
        if stack_d[top] >= best:
            continue
        node = stack_n[top]
        if child[node, 0] < 0:
            m = best
            for k in range(span[node, 0], span[node, 1]):
                e0 = y0 - tp[0, k]
                e1 = y1 - tp[1, k]
                e2 = y2 - tp[2, k]
                m = min(m, e0 * e0 + e1 * e1 + e2 * e2)
            best = m
        else:
            a = child[node, 0]
            c = child[node, 1]
            da = _gap2(y0, lo[a, 0], hi[a, 0]) + _gap2(y1, lo[a, 1], hi[a, 1]) + _gap2(y2, lo[a, 2], hi[a, 2])
            dc = _gap2(y0, lo[c, 0], hi[c, 0]) + _gap2(y1, lo[c, 1], hi[c, 1]) + _gap2(y2, lo[c, 2], hi[c, 2])
            if da > dc:                       # push the farther child first
                a, c = c, a
                da, dc = dc, da
            if dc < best:
                stack_n[top] = c
                stack_d[top] = dc
                top += 1
            if da < best:
                stack_n[top] = a
                stack_d[top] = da
                top += 1
    return best


@njit(cache=True, inline="always")
def _candidates_best(y0, y1, y2, best, i, pts, cand):
    """Smallest squared distance of ``y`` to point i's candidate points, starting from ``best``."""
    for q in range(cand.shape[1]):
        d = _dist2(y0, y1, y2, pts, cand[i, q])
        if d < best:
            best = d
    return best


@njit(cache=True, parallel=True, fastmath=False)
def add_adds_kernel(pts, A, b, with_adds, cand, rho, tp, lo, hi, child, span, depth, geo, dims, offsets,
                    gidx, gdist):
    """pts (P, 3) in tree order; cand (P, k) indices into pts of each point's k nearest
    other points; rho (P,) distance to the nearest point outside them; the grid arrays of
    :func:`ycbvss.eval.nn_grid.build_grid` or :data:`NO_GRID`. Returns (add, adds, n_grid, n_tree),
    (n,) each: mean distances [mm] and the point queries answered by the grid / the tree."""
    n = A.shape[0]
    P = pts.shape[0]
    use_grid = offsets.shape[0] > 0
    add = np.empty(n)
    adds = np.empty(n)
    n_tree = np.zeros(n, np.int64)
    n_grid = np.zeros(n, np.int64)
    for j in prange(n):
        stack_n = np.empty(2 * depth + 4, np.int64)
        stack_d = np.empty(2 * depth + 4)
        a00, a01, a02 = A[j, 0, 0], A[j, 0, 1], A[j, 0, 2]
        a10, a11, a12 = A[j, 1, 0], A[j, 1, 1], A[j, 1, 2]
        a20, a21, a22 = A[j, 2, 0], A[j, 2, 1], A[j, 2, 2]
        b0, b1, b2 = b[j, 0], b[j, 1], b[j, 2]
        sa = 0.0
        ss = 0.0
        nt = 0
        ng = 0
        for i in range(P):
            x0, x1, x2 = pts[i, 0], pts[i, 1], pts[i, 2]
            y0 = a00 * x0 + a01 * x1 + a02 * x2 + b0
            y1 = a10 * x0 + a11 * x1 + a12 * x2 + b1
            y2 = a20 * x0 + a21 * x1 + a22 * x2 + b2
            e0 = y0 - x0
            e1 = y1 - x1
            e2 = y2 - x2
            d2 = e0 * e0 + e1 * e1 + e2 * e2
            delta = np.sqrt(d2)
            sa += delta
            if with_adds:
                # best of the candidates (exact nearest if certified, else a tight bound)
                best = _candidates_best(y0, y1, y2, d2, i, pts, cand)
                # every point outside cand[i] is at least rho_i - delta_i away from y
                r = rho[i] - delta
                if r <= 0.0 or best > r * r * (1.0 - 1e-12):
                    g = grid_nn2(y0, y1, y2, best, pts, geo, dims, offsets, gidx, gdist) if use_grid else -1.0
                    if g >= 0.0:
                        best = g
                        ng += 1
                    else:
                        best = _nn2(y0, y1, y2, best, tp, lo, hi, child, span, stack_n, stack_d)
                        nt += 1
                ss += np.sqrt(best)
        add[j] = sa / P
        adds[j] = ss / P
        n_tree[j] = nt
        n_grid[j] = ng
    return add, adds, n_grid, n_tree


@njit(cache=True, parallel=True, fastmath=False)
def prj_kernel(pts, KRe, Kte, KRg, Ktg):
    """Mean over ``pts`` of ``|pi(KRe x + Kte) - pi(KRg x + Ktg)|`` per pose (n,)."""
    n = KRe.shape[0]
    P = pts.shape[0]
    out = np.empty(n)
    for j in prange(n):
        s = 0.0
        for i in range(P):
            x0, x1, x2 = pts[i, 0], pts[i, 1], pts[i, 2]
            u = KRe[j, 0, 0] * x0 + KRe[j, 0, 1] * x1 + KRe[j, 0, 2] * x2 + Kte[j, 0]
            v = KRe[j, 1, 0] * x0 + KRe[j, 1, 1] * x1 + KRe[j, 1, 2] * x2 + Kte[j, 1]
            w = KRe[j, 2, 0] * x0 + KRe[j, 2, 1] * x1 + KRe[j, 2, 2] * x2 + Kte[j, 2]
            ug = KRg[j, 0, 0] * x0 + KRg[j, 0, 1] * x1 + KRg[j, 0, 2] * x2 + Ktg[j, 0]
            vg = KRg[j, 1, 0] * x0 + KRg[j, 1, 1] * x1 + KRg[j, 1, 2] * x2 + Ktg[j, 1]
            wg = KRg[j, 2, 0] * x0 + KRg[j, 2, 1] * x1 + KRg[j, 2, 2] * x2 + Ktg[j, 2]
            iw = 1.0 / w
            iwg = 1.0 / wg
            du = u * iw - ug * iwg
            dv = v * iw - vg * iwg
            s += np.sqrt(du * du + dv * dv)
        out[j] = s / P
    return out
