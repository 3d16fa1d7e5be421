"""Compiled (numba) pixel rules of the template's contour: which object pixels border the background
or a farther object (silhouette contour pixels, with the 4-neighbour directions they border in), and
which border a nearer object (where that object cuts the silhouette).

One pass over the labelled box replaces eight whole-box boolean arrays per call of
:func:`ycbvss.refine.edge.all_contour_points` and :func:`ycbvss.refine.edge.occluded_pixels`; the
rules are theirs, pixel for pixel (tests/test_contour_kernel.py compares them with the array form).
Kernels are module-level so ``cache=True`` works; ``nogil`` lets the view threads run them at once.
"""
from __future__ import annotations

import numpy as np
from numba import njit

# the 4-neighbour offsets (dv, du) in the order of ycbvss.refine.edge._N4; bit k of a contour
# pixel's direction mask is set when it borders in direction k
N4_DV = np.array([0, 0, 1, -1], np.int64)
N4_DU = np.array([1, -1, 0, 0], np.int64)


@njit(cache=True, nogil=True)
def contour_bits(inst: np.ndarray, depth: np.ndarray, contact_mm, use_contact: bool,
                 with_occluded: bool) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel of a labelled box (``inst`` (h, w) int labels, 0 = background; ``depth`` (h, w)
    float32 mm): the 4-bit mask (uint8) of the directions in which the pixel is a contour pixel,
    and (``with_occluded``) whether it is occluded (bool; else a (0, 0) array).

    Direction k (offset ``N4_DV[k], N4_DU[k]``) counts for an object pixel when the neighbour lies
    inside the box, has another label, and is background or farther: its depth greater than the
    pixel's (``use_contact`` False), or at least ``contact_mm`` greater (True; ``contact_mm`` of
    the depths' dtype, the difference taken in it, as NumPy compares an array with a scalar). Occluded: an object pixel with a 4-neighbour of another object whose depth is
    smaller (outside the box counts as background)."""
    h, w = inst.shape
    bits = np.zeros((h, w), np.uint8)
    occ = np.zeros((h if with_occluded else 0, w if with_occluded else 0), np.bool_)
    for y in range(h):
        for x in range(w):
            lab = inst[y, x]
            if lab <= 0:
                continue
            d = depth[y, x]
            b = 0
            o = False
            for k in range(4):
                yy = y + N4_DV[k]
                xx = x + N4_DU[k]
                if yy < 0 or yy >= h or xx < 0 or xx >= w:
                    continue                 # outside the box: label -1 for the contour, 0 for occlusion
                ni = inst[yy, xx]
                if ni == lab:
                    continue
                nd = depth[yy, xx]
                if ni == 0:
                    b |= 1 << k
                    continue
                if use_contact:
                    far = (nd - d) >= contact_mm
                else:
                    far = nd > d
                if far:
                    b |= 1 << k
                if ni > 0 and nd < d:
                    o = True
            bits[y, x] = b
            if with_occluded:
                occ[y, x] = o
    return bits, occ


@njit(cache=True, nogil=True)
def near_own_occluded(inst: np.ndarray, occluded: np.ndarray, radius_px: np.float32) -> np.ndarray:
    """(h, w) bool: the object pixels within ``radius_px`` (Euclidean, between pixel centres) of an
    ``occluded`` pixel of their own object. The distance of an offset (dy, dx) is taken as
    float32(sqrt(dy^2 + dx^2)), the value OpenCV's exact distance transform gives at these short
    ranges, and compared with ``radius_px`` in float32 (as ``ycbvss.refine.edge.junction_mask``
    compared that transform with it)."""
    h, w = inst.shape
    out = np.zeros((h, w), np.bool_)
    reach = int(np.ceil(radius_px))
    for y in range(h):
        for x in range(w):
            if not occluded[y, x]:
                continue
            lab = inst[y, x]
            if lab <= 0:
                continue
            for dy in range(-reach, reach + 1):
                yy = y + dy
                if yy < 0 or yy >= h:
                    continue
                for dx in range(-reach, reach + 1):
                    xx = x + dx
                    if xx < 0 or xx >= w or inst[yy, xx] != lab:
                        continue
                    if np.float32(np.sqrt(np.float32(dy * dy + dx * dx))) <= radius_px:
                        out[yy, xx] = True
    return out


@njit(cache=True, nogil=True)
def crease_bits(normal: np.ndarray, depth: np.ndarray, cos_min, use_angle: bool, jump_rel, inst: np.ndarray,
                use_inst: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The crease / self-occlusion edges of ``ycbvss.refine.edge.crease_edges`` in one pass: (edge
    (H, W) bool, offset (H, W, 2) float32, depth-jump edge (H, W) bool). Between each pixel and its
    right, then its lower neighbour (both rendered, same object when ``use_inst``): an edge where
    the depth jumps by more than ``jump_rel`` times the nearer depth, or (``use_angle``) the
    normals' dot product (float32, x + y + z in that order) is below ``cos_min``; it is marked on the
    nearer pixel (the first one on a tie), offset half a pixel towards the other. Offsets are written
    in the array form's order (per direction the first pixels', then the second pixels', the lower
    neighbours' last), so where two edges meet at a pixel the same one wins. ``cos_min`` and
    ``jump_rel`` come in the depths' dtype, as NumPy compares and scales with them."""
    H, W = depth.shape
    out = np.zeros((H, W), np.bool_)
    jumps = np.zeros((H, W), np.bool_)
    off = np.zeros((H, W, 2), np.float32)
    second = np.zeros((H, W), np.uint8)     # per direction: 1 = edge marked on the second pixel, 2 = and a jump
    for k in range(2):
        dv, du = (0, 1) if k == 0 else (1, 0)
        hh, ww = H - dv, W - du
        for y in range(hh):                 # the rule once per pair; the first pixels' marks written now
            for x in range(ww):
                second[y, x] = 0
                d0, d1 = depth[y, x], depth[y + dv, x + du]
                if not (d0 > 0 and d1 > 0):
                    continue
                if use_inst and inst[y, x] != inst[y + dv, x + du]:
                    continue
                jump = abs(d0 - d1) > jump_rel * min(d0, d1)
                e = jump
                if use_angle and not e:
                    dot = (normal[y, x, 0] * normal[y + dv, x + du, 0] + normal[y, x, 1] * normal[y + dv, x + du, 1]
                           + normal[y, x, 2] * normal[y + dv, x + du, 2])
                    e = dot < cos_min
                if not e:
                    continue
                if d0 <= d1:
                    out[y, x] = True
                    off[y, x, 0], off[y, x, 1] = 0.5 * du, 0.5 * dv
                    if jump:
                        jumps[y, x] = True
                else:
                    second[y, x] = 2 if jump else 1
        for y in range(hh):                 # then the second pixels' (their offsets win where both mark)
            for x in range(ww):
                if second[y, x] == 0:
                    continue
                out[y + dv, x + du] = True
                off[y + dv, x + du, 0], off[y + dv, x + du, 1] = -0.5 * du, -0.5 * dv
                if second[y, x] == 2:
                    jumps[y + dv, x + du] = True
    return out, off, jumps
