"""Where an object's flow matches may lie: its visible silhouette eroded, but never to nothing.

f_point (template -> image) and f_t (image -> image) take their matches only inside each object's
visible silhouette eroded by ``RefineOptions.match_erode_px`` (6 px): the Farneback window (15 px)
of a pixel nearer the outline than that holds background too, which moves differently. A fixed
erosion also removes every pixel of a silhouette narrower than 2 * 6 + 1 = 13 px: the large marker
(18 mm across) from 1.3 m on, a clamp's jaw, a sliver of an occluded object. Such an object then
has no flow match at all and its texture acts only through f_edge's interior samples.

Found on the sealed ycbv21-long3 long-66 (session 85): the marker, 1.24-1.44 m from the cameras,
about 13 px wide, had no f_point or f_t match in any view. The coarse blur levels let it slide
15 mm along its own axis (f_edge's axial stiffness there is 1/10 of its finest level's), and the
finest level pulled it back by turning it about its axis: 16 deg at seed 0 (60 deg in a second
render of the scene), 8 deg at seed 5, `converged`. With a 3 px erosion the marker had matches
from the first level on and never slid (axial offset under 1 mm, turn under 1 deg).

Here the erosion is capped by the silhouette's own thickness: at most ``erode_px``, and at most its
inscribed radius (the largest distance transform value, px) minus ``core_px``, so a core of
half-width ``core_px`` is left; at least 1 px. A silhouette whose inscribed radius is
``erode_px + core_px`` or more is eroded by ``erode_px`` as before.
"""
from __future__ import annotations

import cv2
import numpy as np

MIN_ERODE_PX = 1   # the outline's own pixels mix object and background in every case


def match_erosion_px(mask: np.ndarray, erode_px: int, core_px: int) -> int:
    """The erosion (px) of a bool/uint8 silhouette ``mask`` (H, W): ``erode_px``, capped at its
    inscribed radius minus ``core_px`` (``core_px`` <= 0: no cap), at least ``MIN_ERODE_PX``
    (0 when ``erode_px`` is 0)."""
    if erode_px <= 0:
        return 0
    if core_px <= 0:
        return int(erode_px)
    m = np.asarray(mask).astype(np.uint8, copy=False)
    x, y, w, h = cv2.boundingRect(m)
    if w == 0 or h == 0:
        return int(erode_px)
    crop = cv2.copyMakeBorder(m[y:y + h, x:x + w], 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)   # a 1 px frame of background
    r_px = float(cv2.distanceTransform(crop, cv2.DIST_L2, 5).max())
    return int(np.clip(int(np.floor(r_px)) - int(core_px), MIN_ERODE_PX, erode_px))


def match_mask(mask: np.ndarray, erode_px: int, core_px: int) -> np.ndarray:
    """``mask`` (H, W) eroded by :func:`match_erosion_px` with a square (2e + 1) kernel, as bool."""
    m = np.asarray(mask).astype(np.uint8, copy=False)
    e = match_erosion_px(m, erode_px, core_px)
    if e > 0 and m.any():
        m = cv2.erode(m, np.ones((2 * e + 1, 2 * e + 1), np.uint8))
    return m > 0
