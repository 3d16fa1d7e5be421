"""How far an object's template edges are from where the image's edges fit them best, searched in 2-D.

The contour offset of :func:`ycbvss.refine.confidence.contour_offset_px` measures sub-pixel
misalignment along the contour normals within +-3 px; it is made to tell 0.2 px from 1 px. A
pose several pixels off is beyond its reach, and the offset it then reads is whatever edge lies
within those 3 px: on the suite's long clip 1 refined from ADD 60 mm with four outer iterations per
coarse level, frame 21 (a non-keyframe whose camera was solved 4.5 deg off) had its seven objects
1.6-38 px off in the image (PRJ), yet their contour offsets read 0.14-3 px, median 0.87 px, under
the 1 px bound, and six of its poses (15-49 mm off) were reported ``converged``.

:func:`object_shift_px` searches the translation of the object's template edge magnitude (the
lit template composited over the image, inside its visible silhouette grown by a few pixels)
against the image's edge magnitude over +-``reach_px`` in both axes by normalised
cross-correlation (OpenCV ``matchTemplate``, masked). A pose that fits reads 0 (or 1) px; on that
frame the objects read 1-18 px, median 8.9 px, and the correctly solved frames beside it 0 px.
The view's median over its objects (:func:`view_shift_px`) is a check of the view's camera: a
camera solved wrongly moves every object of its view in the image.
"""
from __future__ import annotations

import cv2
import numpy as np

REACH_PX = 16.0          # search half-width at 640 px width (refine.confidence.REF_WIDTH_PX; callers scale it)
DILATE_PX = 2            # the silhouette grown by this much, so its own edge is inside the mask
MIN_PX = 200             # objects with fewer visible pixels are not measured
MIN_GAIN_NCC = 0.05      # a shifted peak counts only when it correlates this much better than no shift
MIN_FIT_NCC = 0.2        # below this best correlation the template fits nowhere in the window: read as the reach


def object_shift_px(image_mag: np.ndarray, template_mag: np.ndarray, mask: np.ndarray,
                    reach_px: float = REACH_PX, dilate_px: int = DILATE_PX, min_px: int = MIN_PX,
                    min_gain: float = MIN_GAIN_NCC, min_fit: float = MIN_FIT_NCC) -> tuple[float, float, float]:
    """(shift px, NCC at the best shift, NCC at no shift) of ``template_mag`` (H, W) inside
    ``mask`` (H, W bool, the object's visible silhouette) against ``image_mag`` (H, W): the
    length of the integer translation (px) within +-``reach_px`` that maximises the masked
    normalised cross-correlation (``cv2.TM_CCOEFF_NORMED``). The shift is 0 when the best peak
    correlates less than ``min_gain`` better than no shift (a flat or repetitive neighbourhood
    decides nothing), and ``reach_px`` when even the best correlates less than ``min_fit`` (the
    template fits nowhere in the window: the object is at least that far off; at the exact GT of
    the suite's Cycles images every object correlates >= 0.71 at no shift). NaN for all three when fewer than ``min_px`` pixels are visible or the
    template has no contrast. The image is zero-padded where the search leaves it."""
    m = np.asarray(mask, bool)
    if int(m.sum()) < min_px:
        return float("nan"), float("nan"), float("nan")
    r = int(np.ceil(reach_px))
    k = 2 * int(dilate_px) + 1
    m8 = cv2.dilate(m.astype(np.uint8), np.ones((k, k), np.uint8))
    ys = np.flatnonzero(m8.any(axis=1))
    xs = np.flatnonzero(m8.any(axis=0))
    y0, y1, x0, x1 = int(ys[0]), int(ys[-1]) + 1, int(xs[0]), int(xs[-1]) + 1
    T = np.ascontiguousarray(template_mag[y0:y1, x0:x1], np.float32)
    M = np.ascontiguousarray(m8[y0:y1, x0:x1], np.float32)
    if float(T[M > 0].std()) <= 1e-6:
        return float("nan"), float("nan"), float("nan")
    img = cv2.copyMakeBorder(np.asarray(image_mag, np.float32), r, r, r, r, cv2.BORDER_CONSTANT, value=0.0)
    I = np.ascontiguousarray(img[y0:y1 + 2 * r, x0:x1 + 2 * r])
    R = np.nan_to_num(cv2.matchTemplate(I, T, cv2.TM_CCOEFF_NORMED, mask=M), nan=-1.0, posinf=-1.0, neginf=-1.0)
    best = np.unravel_index(int(np.argmax(R)), R.shape)
    ncc_best, ncc_zero = float(R[best]), float(R[r, r])
    if ncc_best < min_fit:
        return float(reach_px), ncc_best, ncc_zero
    if ncc_best - ncc_zero < min_gain:
        return 0.0, ncc_best, ncc_zero
    return float(np.hypot(best[0] - r, best[1] - r)), ncc_best, ncc_zero


def view_shift_px(shifts_px) -> float:
    """Median of a view's object shifts (px; NaN ones left out), NaN when none was measured."""
    s = np.asarray([x for x in shifts_px if np.isfinite(x)], float)
    return float(np.median(s)) if len(s) else float("nan")
