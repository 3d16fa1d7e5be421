"""Contact contours (``refine.edge.all_contour_points(contact_mm=...)``): a silhouette edge against
another object's surface that lies less than ``contact_mm`` behind it is a contact line (an object
resting on another), where the image's edge sits in the contact shadow; it is no f_edge sample."""
from __future__ import annotations

import numpy as np

from ycbvss.refine.edge import all_contour_points


def _two_blocks(gap_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Label 1 (rows 10-19, depth 1000 mm) resting on label 2 (rows 20-39, ``1000 + gap_mm``),
    both columns 10-29 of a 50 x 40 image, background elsewhere."""
    inst = np.zeros((50, 40), np.int32)
    depth = np.zeros((50, 40), np.float32)
    inst[10:20, 10:30], depth[10:20, 10:30] = 1, 1000.0
    inst[20:40, 10:30], depth[20:40, 10:30] = 2, 1000.0 + gap_mm
    return inst, depth


def _bottom_row_samples(uv: np.ndarray, lab: np.ndarray) -> int:
    """Samples of label 1 on its lower boundary (v = 19.5: the contour pixels of row 19 moved half a
    pixel down)."""
    return int(np.count_nonzero((lab == 1) & np.isclose(uv[:, 1], 19.5)))


def test_contact_line_is_dropped_and_free_contour_kept():
    inst, depth = _two_blocks(gap_mm=4.0)
    uv0, _, lab0 = all_contour_points(inst, depth)
    uv1, _, lab1 = all_contour_points(inst, depth, contact_mm=10.0)
    # without the gate the upper block's lower edge (against the block 4 mm behind it) is contour:
    # the 18 pixels between the two corner pixels (whose outward direction is diagonal)
    assert _bottom_row_samples(uv0, lab0) == 18
    # with it, none of them; the corner pixels keep their free (background) side
    assert _bottom_row_samples(uv1, lab1) == 0
    # the upper block's other sides (against the background) keep every sample
    free0 = np.count_nonzero((lab0 == 1) & ~np.isclose(uv0[:, 1], 19.5))
    free1 = np.count_nonzero((lab1 == 1) & ~np.isclose(uv1[:, 1], 19.5))
    assert free1 == free0 > 0
    # the lower block's contour (its neighbour above is nearer: not its contour) is unchanged
    assert np.count_nonzero(lab0 == 2) == np.count_nonzero(lab1 == 2) > 0


def test_occlusion_boundary_with_a_depth_gap_is_kept():
    inst, depth = _two_blocks(gap_mm=80.0)      # in front of a surface 8 cm behind: an occluding edge
    uv0, _, lab0 = all_contour_points(inst, depth)
    uv1, _, lab1 = all_contour_points(inst, depth, contact_mm=10.0)
    assert _bottom_row_samples(uv1, lab1) == _bottom_row_samples(uv0, lab0) == 18
    assert len(uv1) == len(uv0)


def test_contact_samples_marks_the_contact_line_only():
    """``contact_samples`` (f_edge's contact-offset nuisance) marks exactly the samples that
    ``contact_mm`` would drop: label 1's lower boundary against label 2 4 mm behind (its 18 pixels
    between the corners; a corner pixel also borders the background, so it stays a contour pixel),
    not its free sides, and nothing when label 2 lies 40 mm behind."""
    from ycbvss.refine.contour_match import contour_normals
    from ycbvss.refine.edge import contact_samples

    for gap_mm, expected in ((4.0, 18), (40.0, 0)):
        inst, depth = _two_blocks(gap_mm)
        uv, _, lab = all_contour_points(inst, depth)
        n = contour_normals(uv, lab, inst, 1.0)
        c = contact_samples(inst, depth, uv, n, lab, 10.0)
        assert int(np.count_nonzero(c & (lab == 1))) == expected
        assert int(np.count_nonzero(c & (lab == 1) & ~np.isclose(uv[:, 1], 19.5))) == 0
        kept = all_contour_points(inst, depth, contact_mm=10.0)[2]
        assert int(np.count_nonzero(lab == 1)) - int(np.count_nonzero(kept == 1)) == expected
