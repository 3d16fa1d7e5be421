"""An exact nearest-neighbour voxel grid for off-surface ADD-S queries (tracker-level errors).

The model's bounding box, grown by a shell margin, is cut into cubic cells of edge ``s``
(half-diagonal ``h = s sqrt(3) / 2``). For a cell with centre ``c`` whose nearest model point is at
distance ``d_c``, the cell's candidate list holds every model point ``p`` with
``|p - c| <= d_c + 2 h`` (plus a rounding margin), sorted by ``|p - c|``.

Completeness: for a query ``y`` in the cell (``|y - c| <= h``) with nearest model point ``p*``,
``|p* - y| <= |q - y| <= d_c + h`` for ``q`` the nearest point of ``c``, hence
``|p* - c| <= |p* - y| + |y - c| <= d_c + 2 h``: ``p*`` is in the list. Scan order: a list
entry with ``|p - c| - |y - c| > best`` cannot be nearer than the best distance found so far
(triangle inequality), and all later entries are farther from ``c`` -- the scan stops there.
So the answer is exact (equal to a brute-force search up to rounding of the final distance).

Cells farther than the shell from the surface, and cells whose list would exceed ``max_list``
points, get no list: queries there fall back to the KD-tree (:func:`ycbvss.eval.nn_kernel.add_adds_kernel`
queries the grid with :func:`grid_nn2`). Compiled with numba (imported lazily by
:class:`ycbvss.eval.model_points.ModelPoints`, which uses the grid for large ADD-S batches only: its build costs about 1.5 s for an 8k-vertex model).

Measured (8k-vertex YCB meshes, 400 poses 3 deg / 10, 10, 20 mm off, busy 2-core machine): the
query part 1.8-2.5x faster than the KD-tree kernel, 97-100 % of the uncertified queries answered
by the grid, identical ADD-S (max difference 7e-15 mm).
"""
from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit, prange
from scipy.spatial import cKDTree

# numba's parallel kernels: OpenMP before TBB. Blender's bpy (the synthesis runs in-process) loads
# its own libtbb, older than numba accepts; numba then probes it, warns ("The TBB threading layer
# requires TBB version 2021 update 6 or later") and falls back. An explicit THREADING_LAYER set by
# the user (NUMBA_THREADING_LAYER) is left alone.
if numba.config.THREADING_LAYER == "default":
    numba.config.THREADING_LAYER_PRIORITY = ["omp", "workqueue", "tbb"]


@njit(cache=True, inline="always")
def _cell_reach(c, origin, s, ny, nz, r):
    """Cell ``c``'s integer coordinates, its centre (mm), ``r^2`` and the reach in cells ``ceil(r / s)``
    of a ball of radius ``r`` about the centre."""
    cz = c % nz
    cy = (c // nz) % ny
    cx = c // (ny * nz)
    x0 = origin[0] + (cx + 0.5) * s
    x1 = origin[1] + (cy + 0.5) * s
    x2 = origin[2] + (cz + 0.5) * s
    return cx, cy, cz, x0, x1, x2, r * r, int(math.ceil(r / s))


@njit(cache=True, inline="always")
def _dist2(y0, y1, y2, pts, p):
    """Squared distance of ``y`` to the model point ``pts[p]`` (mm^2)."""
    e0 = y0 - pts[p, 0]
    e1 = y1 - pts[p, 1]
    e2 = y2 - pts[p, 2]
    return e0 * e0 + e1 * e1 + e2 * e2


@njit(cache=True)
def _ball_points(c, tp, origin, s, nx, ny, nz, r, bstart, border, gidx, gdist, n0):
    """Number of model points within ``r`` (mm) of cell ``c``'s centre, found through the point
    buckets ``bstart``/``border``; with a non-empty ``gidx`` they are also written (index, distance)
    at positions ``n0, n0 + 1, ...`` of ``gidx``/``gdist``."""
    cx, cy, cz, x0, x1, x2, r2, k = _cell_reach(c, origin, s, ny, nz, r)
    write = gidx.shape[0] > 0
    n = n0
    for ix in range(max(0, cx - k), min(nx, cx + k + 1)):
        for iy in range(max(0, cy - k), min(ny, cy + k + 1)):
            for iz in range(max(0, cz - k), min(nz, cz + k + 1)):
                b = (ix * ny + iy) * nz + iz
                for q in range(bstart[b], bstart[b + 1]):
                    p = border[q]
                    d2 = _dist2(x0, x1, x2, tp, p)
                    if d2 <= r2:
                        if write:
                            gidx[n] = p
                            gdist[n] = math.sqrt(d2)
                        n += 1
    return n - n0


@njit(cache=True, parallel=True)
def _count(tp, origin, s, nx, ny, nz, dc, shell, h, eps, bstart, border, max_list, counts):
    none_i, none_f = np.zeros(0, np.int64), np.zeros(0)
    for c in prange(nx * ny * nz):
        counts[c] = 0
        if dc[c] > shell:
            continue
        n = _ball_points(c, tp, origin, s, nx, ny, nz, dc[c] + 2.0 * h + eps, bstart, border, none_i, none_f, 0)
        counts[c] = n if n <= max_list else 0


@njit(cache=True, parallel=True)
def _fill(tp, origin, s, nx, ny, nz, dc, h, eps, bstart, border, offsets, gidx, gdist):
    for c in prange(nx * ny * nz):
        a = offsets[c]
        e = offsets[c + 1]
        if e == a:
            continue
        _ball_points(c, tp, origin, s, nx, ny, nz, dc[c] + 2.0 * h + eps, bstart, border, gidx, gdist, a)
        order = np.argsort(gdist[a:e])
        gi = gidx[a:e][order].copy()
        gd = gdist[a:e][order].copy()
        gidx[a:e] = gi
        gdist[a:e] = gd


def build_grid(tp: np.ndarray, max_cells: int = 1 << 15, shell_frac: float = 0.3, max_list: int = 4096):
    """Grid arrays for :func:`grid_nn2` (see module doc). ``tp`` (P, 3) model points (any order;
    list entries index into it). Shell = ``shell_frac`` x the bounding-box diagonal."""
    tp = np.ascontiguousarray(tp, dtype=np.float64)
    lo, hi = tp.min(axis=0), tp.max(axis=0)
    diag = float(np.linalg.norm(hi - lo))
    shell = max(1.0, shell_frac * diag)
    ext = hi - lo + 2.0 * shell
    s = max(float(np.cbrt(np.prod(ext) / max_cells)), 1e-3 * diag, 1e-6)
    dims = np.maximum(1, np.ceil(ext / s).astype(np.int64))
    origin = lo - shell
    nx, ny, nz = (int(d) for d in dims)
    g = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"), -1).reshape(-1, 3)
    centres = origin + (g + 0.5) * s
    dc = cKDTree(tp).query(centres, k=1)[0]
    h = s * math.sqrt(3.0) / 2.0
    eps = 1e-7 * s + 1e-9 * diag
    ip = np.clip(np.floor((tp - origin) / s).astype(np.int64), 0, dims - 1)
    pc = (ip[:, 0] * ny + ip[:, 1]) * nz + ip[:, 2]
    border = np.argsort(pc, kind="stable").astype(np.int64)
    bstart = np.zeros(nx * ny * nz + 1, np.int64)
    np.add.at(bstart, pc + 1, 1)
    bstart = np.cumsum(bstart)
    counts = np.empty(nx * ny * nz, np.int64)
    _count(tp, origin, s, nx, ny, nz, dc, shell, h, eps, bstart, border, max_list, counts)
    offsets = np.zeros(nx * ny * nz + 1, np.int64)
    np.cumsum(counts, out=offsets[1:])
    gidx = np.empty(int(offsets[-1]), np.int64)
    gdist = np.empty(int(offsets[-1]), np.float64)
    _fill(tp, origin, s, nx, ny, nz, dc, h, eps, bstart, border, offsets, gidx, gdist)
    geo = np.array([origin[0], origin[1], origin[2], s, 1.0 / s], dtype=np.float64)
    return geo, np.array([nx, ny, nz], np.int64), offsets, gidx, gdist


@njit(cache=True, inline="always")
def grid_nn2(y0, y1, y2, best, tp, geo, dims, offsets, gidx, gdist):
    """Exact squared nearest distance of ``y`` if its cell has a list (else -1.0: use the tree);
    ``best`` = an upper bound already known (squared)."""
    fx = (y0 - geo[0]) * geo[4]
    fy = (y1 - geo[1]) * geo[4]
    fz = (y2 - geo[2]) * geo[4]
    if not (fx >= 0.0 and fy >= 0.0 and fz >= 0.0):
        return -1.0
    cx = int(fx)
    cy = int(fy)
    cz = int(fz)
    if cx >= dims[0] or cy >= dims[1] or cz >= dims[2]:
        return -1.0
    c = (cx * dims[1] + cy) * dims[2] + cz
    a = offsets[c]
    e = offsets[c + 1]
    if a == e:
        return -1.0
    s = geo[3]
    d0 = y0 - (geo[0] + (cx + 0.5) * s)
    d1 = y1 - (geo[1] + (cy + 0.5) * s)
    d2 = y2 - (geo[2] + (cz + 0.5) * s)
    dy = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    bd = math.sqrt(best)
    for k in range(a, e):
        if gdist[k] - dy > bd:
            break
        d = _dist2(y0, y1, y2, tp, gidx[k])
        if d < best:
            best = d
            bd = math.sqrt(best)
    return best
