"""T-junction contours (``refine.edge.all_contour_points(junction_px=...)``): where a nearer object
cuts an object's silhouette, the occluded object's free contour within ``junction_px`` of the cut is
not sampled; everything else is as without the option."""
from __future__ import annotations

import numpy as np

from ycbvss.refine.edge import all_contour_points, junction_mask


def _scene() -> tuple[np.ndarray, np.ndarray]:
    """Object 1 (30 x 30 px at 1000 mm), its lower right quarter covered by object 2 (at 500 mm):
    object 1's silhouette is cut along column 29 (rows 20-39) and row 19 (columns 30-39)."""
    inst = np.zeros((60, 60), np.int32)
    depth = np.zeros((60, 60), np.float32)
    inst[10:40, 10:40], depth[10:40, 10:40] = 1, 1000.0
    inst[20:50, 30:50], depth[20:50, 30:50] = 2, 500.0
    return inst, depth


def test_junction_drops_only_the_occluded_objects_samples_near_the_cut():
    inst, depth = _scene()
    uv0, _, lab0 = all_contour_points(inst, depth)
    uv1, _, lab1 = all_contour_points(inst, depth, junction_px=3.0)
    # object 2 (the occluder) keeps every contour sample
    assert np.sum(lab1 == 2) == np.sum(lab0 == 2)
    # object 1 loses its free contour pixels within 3 px of the cut: 4 on the bottom row (columns
    # 26-29) and 4 on the right column (rows 16-19)
    gone = {tuple(p) for p in np.round(uv0[lab0 == 1] - 0.5).astype(int)} - \
           {tuple(p) for p in np.round(uv1[lab1 == 1] - 0.5).astype(int)}
    assert np.sum(lab0 == 1) - np.sum(lab1 == 1) == 8
    # uv is (column, row) half a pixel outward; every dropped pixel lies within 3 px of the cut
    for u, v in gone:
        d_col = abs(u - 29) if v >= 20 else np.hypot(u - 29, v - 20)
        d_row = abs(v - 19) if u >= 30 else np.hypot(u - 30, v - 19)
        assert min(d_col, d_row) <= 3.0 + 1.0      # + the half-pixel outward step of the sample


def test_junction_mask_is_per_object_and_radius_bounded():
    inst, depth = _scene()
    occ = np.zeros(inst.shape, bool)
    occ[20:40, 29] = True           # object 1's pixels bordering object 2 (column)
    occ[19, 30:40] = True           # (row)
    m = junction_mask(inst, occ, 2.0)
    assert not m[inst != 1].any()                       # only object 1's own pixels
    ys, xs = np.nonzero(m)
    d = np.min(np.hypot(ys[:, None] - np.nonzero(occ)[0][None], xs[:, None] - np.nonzero(occ)[1][None]), axis=1)
    assert d.max() <= 2.0
    assert m[25, 27] and not m[25, 26]                  # 2 px from the cut is in, 3 px is out


def test_no_junction_without_a_nearer_neighbour():
    inst, depth = _scene()
    depth[inst == 2] = 2000.0       # object 2 now behind object 1's plane: no cut of object 1
    inst2 = inst.copy()
    inst2[10:40, 10:40] = 1         # object 1 drawn in front (the nearer one owns the pixels)
    depth2 = np.where(inst2 == 1, 1000.0, depth).astype(np.float32)
    a = all_contour_points(inst2, depth2)
    b = all_contour_points(inst2, depth2, junction_px=3.0)
    assert np.sum(b[2] == 1) == np.sum(a[2] == 1)
    # object 2 is now the occluded one: it loses samples near where object 1 cuts it
    assert np.sum(b[2] == 2) < np.sum(a[2] == 2)


def test_junction_mask_matches_a_brute_force_distance_on_random_scenes():
    # objects touching the image border and each other, several cut per frame: the mask (computed in
    # each object's bounding box) equals the brute-force Euclidean distance to the object's own cut
    # pixels over the whole frame
    rng = np.random.default_rng(7)
    for _ in range(5):
        inst = np.zeros((48, 64), np.int32)
        depth = np.zeros((48, 64), np.float32)
        for lab in range(1, 5):
            h, w = rng.integers(10, 30, size=2)
            y0, x0 = rng.integers(-8, 30), rng.integers(-8, 40)   # some cross the border
            ys, xs = slice(max(y0, 0), y0 + h), slice(max(x0, 0), x0 + w)
            inst[ys, xs], depth[ys, xs] = lab, 1000.0 - 100.0 * lab   # later labels are nearer
        from ycbvss.refine.edge import occluded_pixels
        occ = occluded_pixels(inst, depth)
        assert occ.any()
        r = 2.5
        m = junction_mask(inst, occ, r)
        yy, xx = np.mgrid[:48, :64]
        want = np.zeros_like(m)
        for lab in np.unique(inst[occ]):
            cy, cx = np.nonzero(occ & (inst == lab))
            d = np.min(np.hypot(yy[..., None] - cy, xx[..., None] - cx), axis=-1)
            want |= (d <= r) & (inst == lab)
        assert np.array_equal(m, want)
