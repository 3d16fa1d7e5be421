"""Black objects: where the sRGB encoding magnifies an unmodelled rim.

A glossy object's rim brightens where the surface turns away from the camera (Fresnel reflection
of the surroundings), which the refiner's lit template does not model. In linear light that
brightening is a small addition; the sRGB encoding multiplies a change at linear value ``L`` by its
slope, 12.92 below L = 0.0031 and ``1.055 / 2.4 * L**(-1.4 / 2.4)`` above (about 9 at L = 0.005,
3.5 at 0.03, 0.9 at 0.3). On a black object the rim's brightening therefore dominates the sRGB
colour gradient beside its contour and moves the edge the refiner aligns to; on a bright one it
does not. Measured at the exact GT (``bench/bench_contour_spaces.py``, session 93): the extra-large
clamp's contour keeps a shared shift of 0.286 px in the sRGB space and 0.095 px in linear light,
the large clamp's 0.139 and 0.088 px.

An object is *black* when the brightest colour channel's median albedo over its template pixels
is below a threshold (linear light, 0..1). Over the 21 YCB-V textures (20000 surface samples each)
that median is 0.005 for both clamps and 0.068 or more for every other object (the foam brick
0.068, the large marker 0.091, the mug 0.122), so any threshold between them picks the two clamps.
"""
from __future__ import annotations

import numpy as np

from .edge import srgb_to_linear


def albedo_peak(colour_u8: np.ndarray, mask: np.ndarray) -> float:
    """The brightest channel's median albedo (linear light, 0..1) of the template colour
    ``colour_u8`` (H, W, 3 uint8, sRGB) over the pixels ``mask`` (H, W bool); NaN when the mask is
    empty."""
    m = np.asarray(mask, bool)
    if not m.any():
        return float("nan")
    px = srgb_to_linear(np.asarray(colour_u8)[m]) / 255.0
    px = px.reshape(len(px), -1)
    return float(np.median(px, axis=0).max())


def is_black(colour_u8: np.ndarray, mask: np.ndarray, threshold: float) -> bool:
    """True when the object's :func:`albedo_peak` is below ``threshold`` (> 0; 0: never)."""
    if threshold <= 0.0:
        return False
    a = albedo_peak(colour_u8, mask)
    return bool(np.isfinite(a) and a < threshold)
