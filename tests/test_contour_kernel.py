"""The compiled contour-pixel rules (refine.contour_kernel) against their array form: the same
contour pixels, directions, occluded pixels and contour samples, bit for bit."""
from __future__ import annotations

import numpy as np
import pytest

from ycbvss.refine.contour_kernel import contour_bits
from ycbvss.refine.edge import _N4, all_contour_points, occluded_pixels

N_CASES = 40   # random label images per test


def _reference_edges(ic: np.ndarray, dc: np.ndarray, contact_mm: float) -> list[np.ndarray]:
    """Per 4-neighbour direction the contour pixels as whole-array boolean rules (the form the
    kernel replaced): an object pixel whose neighbour in the box has another label and is
    background or farther (by at least ``contact_mm`` when > 0)."""
    h, w = ic.shape
    pad_i = np.pad(ic, 1, constant_values=-1)
    pad_d = np.pad(dc, 1, constant_values=0)
    out = []
    for dv, du in _N4:
        ni = pad_i[1 + dv:1 + dv + h, 1 + du:1 + du + w]
        nd = pad_d[1 + dv:1 + dv + h, 1 + du:1 + du + w]
        far = (nd > dc) if contact_mm <= 0.0 else (nd - dc >= contact_mm)
        out.append((ic > 0) & (ni != ic) & (ni != -1) & ((ni == 0) | far))
    return out


def _reference_occluded(inst: np.ndarray, depth: np.ndarray) -> np.ndarray:
    h, w = inst.shape
    pad_i = np.pad(inst, 1, constant_values=0)
    pad_d = np.pad(depth, 1, constant_values=0)
    out = np.zeros((h, w), bool)
    for dv, du in _N4:
        ni = pad_i[1 + dv:1 + dv + h, 1 + du:1 + du + w]
        nd = pad_d[1 + dv:1 + dv + h, 1 + du:1 + du + w]
        out |= (inst > 0) & (ni > 0) & (ni != inst) & (nd < depth)
    return out


def _scene(rng: np.random.Generator, h: int = 60, w: int = 80) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping discs and boxes of up to 4 objects at random depths (float32 mm, ties included),
    some touching the image border."""
    inst = np.zeros((h, w), np.int32)
    depth = np.zeros((h, w), np.float32)
    yy, xx = np.mgrid[:h, :w]
    for lab in range(1, rng.integers(2, 6)):
        cy, cx = rng.uniform(-5, h + 5), rng.uniform(-5, w + 5)
        if rng.random() < 0.5:
            m = (yy - cy) ** 2 + (xx - cx) ** 2 < rng.uniform(4, 25) ** 2
        else:
            m = (np.abs(yy - cy) < rng.uniform(3, 20)) & (np.abs(xx - cx) < rng.uniform(3, 20))
        z = np.float32(rng.choice([900.0, 950.0, 1000.0])) + np.float32(rng.normal(0, 2)) * (xx / w).astype(np.float32)
        nearer = m & ((depth == 0) | (z < depth))
        inst[nearer], depth[nearer] = lab, z[nearer]
    return inst, depth


@pytest.mark.parametrize("contact_mm", [0.0, 3.0])
def test_bits_match_array_rules(contact_mm: float) -> None:
    rng = np.random.default_rng(7)
    n_contour = 0
    for _ in range(N_CASES):
        inst, depth = _scene(rng)
        bits, occ = contour_bits(inst, depth, np.float32(contact_mm), contact_mm > 0.0, True)
        for k, ref in enumerate(_reference_edges(inst, depth, contact_mm)):
            assert np.array_equal((bits & (1 << k)) != 0, ref)
            n_contour += int(ref.sum())
        assert np.array_equal(occ, _reference_occluded(inst, depth))
        assert np.array_equal(occluded_pixels(inst, depth), _reference_occluded(inst, depth))
    assert n_contour > 1000            # the cases do exercise the rules


def _reference_contour_points(inst, depth, contact_mm: float = 0.0):
    """all_contour_points' samples from the array rules (no junction mask, no rim depth)."""
    box_m = inst > 0
    ys, xs = np.nonzero(box_m.any(axis=1))[0], np.nonzero(box_m.any(axis=0))[0]
    H, W = inst.shape
    y0, x0 = max(ys[0] - 1, 0), max(xs[0] - 1, 0)
    y1, x1 = min(ys[-1] + 2, H), min(xs[-1] + 2, W)
    ic, dc = inst[y0:y1, x0:x1], depth[y0:y1, x0:x1]
    edges = _reference_edges(ic, dc, contact_mm)
    is_c = np.logical_or.reduce(edges)
    if y0 == 0:
        is_c[0, :] = False
    if x0 == 0:
        is_c[:, 0] = False
    if y1 == H:
        is_c[-1, :] = False
    if x1 == W:
        is_c[:, -1] = False
    v, u = np.nonzero(is_c)
    d = np.zeros((len(v), 2), np.float32)
    for (dv, du), e in zip(_N4, edges):
        d[e[v, u]] += (du, dv)
    n = np.linalg.norm(d, axis=1, keepdims=True)
    d = np.where(n > 0, d / np.maximum(n, 1e-9), 0.0)
    return np.stack([u + x0, v + y0], 1).astype(np.float64) + 0.5 * d, dc[v, u].astype(np.float64), ic[v, u].astype(int)


@pytest.mark.parametrize("contact_mm", [0.0, 3.0])
def test_contour_points_unchanged(contact_mm: float) -> None:
    rng = np.random.default_rng(11)
    for _ in range(N_CASES):
        inst, depth = _scene(rng)
        got = all_contour_points(inst, depth, contact_mm=contact_mm)
        ref = _reference_contour_points(inst, depth, contact_mm)
        for a, b in zip(got, ref):
            assert np.array_equal(a, b)


@pytest.mark.parametrize("sigma_px", [1.0, 2.0, 4.0, 8.0])
def test_blur_search_matches_array_form(sigma_px: float) -> None:
    """The compiled search of the blur-matched contour (cubic_kernel.minimum_along) returns the
    array form's offsets exactly, on silhouettes whose samples reach the image border."""
    from ycbvss.refine.contour_match import (_blur_sobel, _edge_cost, _minimum_along, _minimum_along_array,
                                             _outward_normals, search_px)

    rng = np.random.default_rng(3)
    half_px, step_px = search_px(sigma_px)
    n_moved = 0
    for _ in range(10):
        inst, depth = _scene(rng)
        uv, _, lab = all_contour_points(inst, depth)
        for L in np.unique(lab):
            sel = lab == L
            mask_f = (inst == L).astype(np.float32) * 255.0
            sobel = _blur_sobel(mask_f, sigma_px)
            nrm = _outward_normals(mask_f, sigma_px, uv[sel], sobel)
            field = _edge_cost(mask_f, sigma_px, sobel)
            got = _minimum_along(field, uv[sel], nrm, half_px, step_px)
            assert np.array_equal(got, _minimum_along_array(field, uv[sel], nrm, half_px, step_px))
            n_moved += int(np.count_nonzero(got))
    assert n_moved > 500


def _reference_creases(normal, depth, min_angle_deg=25.0, depth_jump_rel=0.03, inst=None):
    """crease_edges' array form (with the depth-jump mask)."""
    H, W = depth.shape
    out, jumps = np.zeros((H, W), bool), np.zeros((H, W), bool)
    off = np.zeros((H, W, 2), np.float32)
    c = np.cos(np.radians(min_angle_deg))
    for dv, du in ((0, 1), (1, 0)):
        n0, n1 = normal[: H - dv, : W - du], normal[dv:, du:]
        d0, d1 = depth[: H - dv, : W - du], depth[dv:, du:]
        both = (d0 > 0) & (d1 > 0)
        if inst is not None:
            both &= inst[: H - dv, : W - du] == inst[dv:, du:]
        jump = np.abs(d0 - d1) > depth_jump_rel * np.minimum(d0, d1)
        if min_angle_deg < 180.0:
            e = both & (jump | ((n0[..., 0] * n1[..., 0] + n0[..., 1] * n1[..., 1] + n0[..., 2] * n1[..., 2]) < c))
        else:
            e = both & jump
        near0 = d0 <= d1
        a, b = e & near0, e & ~near0
        out[: H - dv, : W - du] |= a
        out[dv:, du:] |= b
        off[: H - dv, : W - du][a] = (0.5 * du, 0.5 * dv)
        off[dv:, du:][b] = (-0.5 * du, -0.5 * dv)
        jumps[: H - dv, : W - du] |= a & jump
        jumps[dv:, du:] |= b & jump
    return out, off, jumps


@pytest.mark.parametrize("min_angle_deg", [10.0, 25.0, 180.0])
def test_creases_match_array_form(min_angle_deg: float) -> None:
    """Folds (random normals, some turning more than the angle) and depth jumps inside objects."""
    from ycbvss.refine.edge import crease_edges

    rng = np.random.default_rng(13)
    n_edges = 0
    for _ in range(10):
        inst, depth = _scene(rng)
        depth = depth * np.where(rng.random(depth.shape) < 0.05, np.float32(1.05), np.float32(1.0)).astype(np.float32)
        nrm = rng.normal(0, 0.3, size=depth.shape + (3,)).astype(np.float32) + np.float32([0, 0, -1])
        nrm /= np.linalg.norm(nrm, axis=2, keepdims=True)
        for lab in (None, inst):
            got = crease_edges(nrm, depth, min_angle_deg, inst=lab, with_jumps=True)
            ref = _reference_creases(nrm, depth, min_angle_deg, inst=lab)
            assert all(np.array_equal(a, b) for a, b in zip(got, ref))
            n_edges += int(ref[0].sum())
    assert n_edges > 500
