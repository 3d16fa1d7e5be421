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

from .edge import EdgeField, _field_from_magnitude, sample_E, srgb_to_linear


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


def contrast_matched(linear: EdgeField, srgb: EdgeField, uv: np.ndarray, min_strength: float = 0.02) -> EdgeField:
    """The linear-light edge field ``linear`` rescaled so that at the image points ``uv`` (N, 2) px (an
    object's edge samples) its strength 1 - E has the median it has in the sRGB field ``srgb``: the
    edges' positions are the linear field's, their weight in f_edge the sRGB field's. Both fields
    are normalised by their own image's strongest gradient, and in linear light a black object's
    contour is 2-3 times weaker against the scene's highlights than in sRGB. Only samples with
    strength >= ``min_strength`` in both fields count; with fewer than 10 of them, or at an
    unchanged scale, ``linear`` is returned."""
    a = 1.0 - sample_E(srgb, uv)
    b = 1.0 - sample_E(linear, uv)
    ok = np.isfinite(a) & np.isfinite(b) & (a >= min_strength) & (b >= min_strength)
    if int(ok.sum()) < 10:
        return linear
    scale = float(np.median(a[ok]) / np.median(b[ok]))
    if not np.isfinite(scale) or abs(scale - 1.0) < 1e-6:
        return linear
    return _field_from_magnitude(scale * (1.0 - linear.E.astype(np.float64)), linear.sigma_px, interp=linear.interp,
                                 mx=1.0)
