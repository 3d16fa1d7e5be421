"""Compiled (numba) kernel of the normal equations of one linearisation.

For points n with pixel Jacobians J_n (2, k), pixel Hessians A_n (2, 2) and pixel gradients
g_n (2,), the kernel sums H = sum_n J_n^T A_n J_n (k, k) and b = sum_n J_n^T g_n (k,) in one pass
over the points, without the (2N, k) temporaries of the array form. The Jacobian of a two-block
linearisation is given as its two (N, 2, 6) halves so it is never concatenated. H is accumulated
on and above the diagonal and mirrored, so it is exactly symmetric. numba is a required
dependency; the kernel is module-level so its on-disk cache (``cache=True``) works.
"""
from __future__ import annotations

import numpy as np
from numba import njit


def as_f64(x: np.ndarray) -> np.ndarray:
    """C-contiguous float64 view/copy of x: the one argument form the refine kernels are compiled for."""
    return np.ascontiguousarray(x, dtype=np.float64)


@njit(cache=True, nogil=True)
def normal_eq(Ja: np.ndarray, Jb: np.ndarray, A: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """H (ka + kb, ka + kb) and b (ka + kb,) for Jacobian halves Ja (N, 2, ka) and Jb (N, 2, kb)
    (kb may be 0: pass an (N, 2, 0) array), pixel Hessians A (N, 2, 2) and gradients g (N, 2)."""
    n, ka, kb = Ja.shape[0], Ja.shape[2], Jb.shape[2]
    k = ka + kb
    H = np.zeros((k, k))
    b = np.zeros(k)
    j0 = np.empty(k)
    j1 = np.empty(k)
    aj0 = np.empty(k)
    aj1 = np.empty(k)
    for p in range(n):
        for c in range(ka):
            j0[c] = Ja[p, 0, c]
            j1[c] = Ja[p, 1, c]
        for c in range(kb):
            j0[ka + c] = Jb[p, 0, c]
            j1[ka + c] = Jb[p, 1, c]
        a00, a01, a10, a11 = A[p, 0, 0], A[p, 0, 1], A[p, 1, 0], A[p, 1, 1]
        g0, g1 = g[p, 0], g[p, 1]
        for c in range(k):
            aj0[c] = a00 * j0[c] + a01 * j1[c]
            aj1[c] = a10 * j0[c] + a11 * j1[c]
            b[c] += j0[c] * g0 + j1[c] * g1
        for r in range(k):
            r0, r1 = j0[r], j1[r]
            for c in range(r, k):
                H[r, c] += r0 * aj0[c] + r1 * aj1[c]
    for r in range(k):
        for c in range(r):
            H[r, c] = H[c, r]
    return H, b
