"""Lambertian shading of the refiner's unlit templates, fitted to the image (second-order
spherical harmonics of the surface normal, Ramamoorthi & Hanrahan 2001).

The fast renderer draws each object's albedo texture without light. A lit image (a photo, or a
Cycles render with a sun and glossy surfaces) darkens the faces turned away from the light, so
the template and the image differ by a smooth shading field. Flow between them and the image's
edge locations then lean towards that field's gradient. The irradiance of a distant light on a
convex Lambertian surface is, to within a few per cent, a quadratic polynomial of the normal
(the 9 real SH basis functions up to order 2); it is linear in its 9 coefficients, so one view's
lighting is a linear least-squares fit of image = albedo x shading(normal) over the objects'
pixels. Shadows and highlights are outliers of that model: two trimmed refits drop them.
"""
from __future__ import annotations

import numpy as np

from .edge import srgb_to_linear
from .srgb import encode_u8

N_SH = 9


def sh9_basis(normals: np.ndarray) -> np.ndarray:
    """The 9 real SH basis functions up to order 2 (constants dropped, they fold into the
    coefficients) at unit normals (N, 3): columns 1, x, y, z, xy, xz, yz, x^2 - y^2, 3z^2 - 1."""
    x, y, z = normals[:, 0], normals[:, 1], normals[:, 2]
    return np.stack([np.ones_like(x), x, y, z, x * y, x * z, y * z, x * x - y * y, 3 * z * z - 1], axis=1)


def _u8(x: np.ndarray) -> np.ndarray:
    """8-bit values as :func:`srgb_to_linear` reads them (rounded and clipped when not uint8)."""
    return x if x.dtype == np.uint8 else np.clip(np.rint(x), 0, 255).astype(np.uint8)


def _linear_to_srgb_u8(lin: np.ndarray) -> np.ndarray:
    """Linear light in [0, 255] -> 8-bit sRGB (:func:`ycbvss.refine.srgb.encode_u8`)."""
    return encode_u8(lin)


def fit_shading(image: np.ndarray, albedo: np.ndarray, normals: np.ndarray, mask: np.ndarray,
                ridge: float = 1e-3, trim: float = 2.5, max_px: int = 40000, seed: int = 0,
                additive: np.ndarray | None = None, extra: np.ndarray | None = None) -> np.ndarray | None:
    """Per-channel SH coefficients (3, 9) with ``image ~ albedo * (B(n) @ c)`` in linear light.

    ``image``, ``albedo``: (H, W, 3) uint8 sRGB (the photo and the unlit template); ``normals``
    (H, W, 3) camera-frame unit normals of the template; ``mask`` (H, W) bool, the pixels to fit
    (object interiors, away from the silhouettes). ``ridge``: Tikhonov weight on the order-1/2
    coefficients relative to the data. ``trim``: refit twice without pixels whose residual exceeds
    ``trim`` x the median absolute residual (cast shadows, highlights, occluders the template lacks).
    At most ``max_px`` pixels (a fixed random subset). None when fewer than 50 usable pixels.
    ``additive`` (H, W) or (H, W, m): more basis images, added independently of the albedo (as 255 x
    them, linear light), fitted jointly; their weights are the result's last m columns (a glossy
    surface's reflection, :func:`reflection_basis`; a grazing term in ``bench/bench_fresnel_rim.py``).
    ``extra`` (H, W) or (H, W, k): more basis images multiplying the albedo like the SH terms (a
    height-above-the-table fall-off, :func:`height_basis`); their weights follow the SH's (3, 9 + k)."""
    px = np.flatnonzero(np.asarray(mask, bool))                         # flat indices: faster than a 2D mask
    alb, img = _u8(np.asarray(albedo).reshape(-1, 3)[px]), _u8(np.asarray(image).reshape(-1, 3)[px])
    nrm = np.asarray(normals).reshape(-1, 3)[px].astype(np.float64)
    nn = np.linalg.norm(nrm, axis=1)
    lut = srgb_to_linear(np.arange(256, dtype=np.uint8))               # increasing: min/max commute with it
    a_min = np.minimum(np.minimum(alb[:, 0], alb[:, 1]), alb[:, 2])
    i_max = np.maximum(np.maximum(img[:, 0], img[:, 1]), img[:, 2])
    # no albedo: no shading; saturated: clipped
    ok = np.flatnonzero((nn > 0.5) & (lut[a_min] > 2.0) & (lut[i_max] < 254.0))
    if len(ok) < 50:
        return None
    if len(ok) > max_px:
        ok = ok[np.random.default_rng(seed).choice(len(ok), max_px, replace=False)]
    a = srgb_to_linear(alb[ok]).astype(np.float64)                      # decode only the fitted pixels
    i = srgb_to_linear(img[ok]).astype(np.float64)
    n = nrm[ok] / nn[ok, None]
    B = sh9_basis(n)
    if extra is not None:
        B = np.concatenate([B, _flat_basis(extra, px)[ok]], axis=1)
    nb = B.shape[1]
    f = None if additive is None else 255.0 * _flat_basis(additive, px)[ok]
    k = nb + (0 if f is None else f.shape[1])
    C = np.zeros((3, k))
    reg = np.full(k, ridge)
    reg[0] = 0.0
    reg[N_SH:] = 0.0
    for c in range(3):
        keep = np.ones(len(a), bool)
        aB = a[:, c, None] * B if f is None else np.concatenate([a[:, c, None] * B, f], axis=1)
        for _ in range(3):
            X = np.compress(keep, aB, axis=0)
            A = X.T @ X
            A[np.diag_indices(k)] += reg * np.trace(A) / k
            C[c] = np.linalg.solve(A, X.T @ i[keep, c])
            r = i[:, c] - (a[:, c] * (B @ C[c]) if f is None else aB @ C[c])
            keep = np.abs(r) <= trim * np.median(np.abs(r[keep])) + 1e-6
            if keep.sum() < 50:
                break
    return C


def hold_rim(irradiance: np.ndarray, instance: np.ndarray, rim_px: int) -> np.ndarray:
    """``irradiance`` (H, W, C) with every object pixel within ``rim_px`` px of its silhouette
    (``instance`` (H, W) > 0 labels the objects; the rim is what a (2 rim_px + 1)-square erosion
    removes) given the value of the nearest pixel of the same object further in. A new array.

    Why: the lighting is fitted ``erode_px`` (3) px inside the silhouettes (:func:`view_lighting`),
    so at the rim, where the normals turn to face sideways, its quadratic in the normal
    extrapolates the Lambertian fall-off, and a glossy surface's grazing Fresnel reflection (which
    the model lacks) brightens that band in a Cycles image or a photo. Measured at the exact GT of
    the ``ycbv21`` suite (scenes 3, 5, 9): the wood block's bevelled lower edge came out 10 % darker
    than the image in its outer 2 px, which put the predicted contour 0.35 px inside the image's.
    Objects smaller than the rim (no pixel left after the erosion) keep their values."""
    import cv2
    from scipy.ndimage import distance_transform_edt

    out = np.array(irradiance, copy=True)
    inst = np.asarray(instance)
    if rim_px <= 0:
        return out
    ker = np.ones((2 * rim_px + 1,) * 2, np.uint8)
    for lab in np.unique(inst[inst > 0]):
        ys, xs = np.nonzero(inst == lab)
        y0, y1, x0, x1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
        m = inst[y0:y1, x0:x1] == lab
        core = cv2.erode(m.astype(np.uint8), ker, borderType=cv2.BORDER_CONSTANT, borderValue=0).astype(bool)
        if not core.any():
            continue
        _, (iy, ix) = distance_transform_edt(~core, return_indices=True)
        rim = m & ~core
        crop = out[y0:y1, x0:x1]                                         # a view: written in place
        crop[rim] = crop[iy[rim], ix[rim]]
    return out


def _flat_basis(images: np.ndarray | None, px: np.ndarray) -> np.ndarray:
    """Basis images (H, W) or (H, W, m) at the flat pixel indices ``px``: (N, m); (N, 0) for None."""
    if images is None:
        return np.zeros((len(px), 0))
    E = np.asarray(images, np.float64)
    return E.reshape(E.shape[0] * E.shape[1], -1)[px]


def shade(albedo: np.ndarray, normals: np.ndarray, mask: np.ndarray, coeffs: np.ndarray,
          instance: np.ndarray | None = None, rim_px: int = 0, extra: np.ndarray | None = None,
          additive: np.ndarray | None = None) -> np.ndarray:
    """The template lit by ``coeffs`` (3, 9 + k + m) where ``mask``, else ``albedo`` unchanged: (H, W, 3) uint8 sRGB.
    ``extra``: the k basis images of :func:`fit_shading` that multiply the albedo; ``additive``: its m
    basis images added to it (both needed when the coefficients have more than 9 columns).
    ``rim_px`` > 0 (with ``instance``, the labels): the irradiance within ``rim_px`` px of each
    silhouette held at its value further in (:func:`hold_rim`; the additive part is not held)."""
    out = np.array(albedo, copy=True)
    px = np.flatnonzero(np.asarray(mask, bool))
    n = np.asarray(normals).reshape(-1, 3)[px].astype(np.float64)
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-9)
    E, F = _flat_basis(extra, px), _flat_basis(additive, px)
    k, m = E.shape[1], F.shape[1]
    if coeffs.shape[1] != N_SH + k + m:
        raise ValueError(f"lighting with {coeffs.shape[1]} terms needs 9 SH terms and its extra basis images "
                         f"(given {k} extra, {m} additive)")
    B = np.concatenate([sh9_basis(n), E], axis=1)
    s = np.clip(B @ coeffs[:, : N_SH + k].T, 0.0, None)                 # (N, 3) irradiance per channel
    if rim_px > 0 and instance is not None:
        full = np.zeros((out.shape[0] * out.shape[1], 3))
        full[px] = s
        s = hold_rim(full.reshape(out.shape[0], out.shape[1], 3), instance, rim_px).reshape(-1, 3)[px]
    flat = out.reshape(-1, 3)                                            # a view of out (a fresh copy)
    lin = srgb_to_linear(flat[px]) * s
    if m:
        lin = lin + 255.0 * np.clip(F @ coeffs[:, N_SH + k:].T, 0.0, None)
    flat[px] = _linear_to_srgb_u8(lin)
    return out


def reflection_basis(normals: np.ndarray, K: np.ndarray) -> np.ndarray:
    """(H, W, 4) additive basis images of a glossy surface's reflection: 1 and the three components
    of the mirror direction ``r = 2 (n . v) n - v`` (camera frame; ``v`` the unit vector from each
    pixel's surface point to the camera, from ``K``; ``normals`` (H, W, 3) the camera-frame normals).

    Why: Blender's principled surfaces (and real plastic, paper and paint) reflect part of the light
    at their surface, whatever the albedo, as a blurred mirror image of the surroundings: bright
    from above, the table's colour from the side. Dark objects are lifted and greyed by it, which an
    albedo x shading model cannot hold; a linear function of the mirror direction can, to first
    order. Measured at the exact GT (8 frames of ``ycbv21`` long-1, long-2 and ``ycbv21-long3``
    long-66, linear light 0-255, pixels 3 px inside the silhouettes): the mean absolute residual of
    the lit template drops on all 21 objects but the mug of long-66 (5.9 -> 6.9), e.g. the foam brick
    7.4 -> 1.9 and 7.3 -> 2.5, the extra-large clamp 8.5 -> 2.4, the mug of long-1 7.6 -> 3.5."""
    H, W = normals.shape[:2]
    K = np.asarray(K, np.float64)
    u = (np.arange(W, dtype=np.float64) - K[0, 2]) / K[0, 0]
    v = (np.arange(H, dtype=np.float64) - K[1, 2]) / K[1, 1]
    d = np.empty((H, W, 3))
    d[..., 0], d[..., 1], d[..., 2] = u[None, :], v[:, None], 1.0
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    n = np.asarray(normals, np.float64)
    n = n / np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-9)
    ndv = np.clip(-(n * d).sum(axis=2, keepdims=True), 0.0, 1.0)        # v = -d
    out = np.empty((H, W, 4))
    out[..., 0] = 1.0
    out[..., 1:] = 2.0 * ndv * n + d
    return out


def view_lighting(color: np.ndarray, normals: np.ndarray, instance: np.ndarray, image: np.ndarray,
                  erode_px: int = 3, max_px: int = 40000, extra: np.ndarray | None = None,
                  additive: np.ndarray | None = None) -> np.ndarray | None:
    """One view's lighting (3, 9 [+ k] [+ m]) fitted to ``image`` over the template's (``color`` H, W, 3 uint8,
    unlit; ``normals``; ``instance`` > 0 where an object is drawn) pixels at least ``erode_px`` px
    inside the silhouettes, at most ``max_px`` of them (:func:`fit_shading`, with its ``extra`` and
    ``additive`` basis images); None when too few."""
    import cv2

    obj = np.asarray(instance) > 0
    inner = cv2.erode(obj.astype(np.uint8), np.ones((2 * erode_px + 1,) * 2, np.uint8)).astype(bool) if erode_px > 0 else obj
    return fit_shading(image, color, normals, inner, max_px=max_px, extra=extra, additive=additive)


def height_basis(depth_mm: np.ndarray, K: np.ndarray, plane_c: tuple[np.ndarray, float],
                 scale_mm: float) -> np.ndarray:
    """(H, W) ``exp(-h / scale_mm)`` of each template pixel's height ``h`` (mm, >= 0) above the
    support plane, 0 where ``depth_mm`` is 0 (no surface): a lighting basis image for
    :func:`fit_shading`'s ``extra``.

    ``plane_c``: (unit normal n, offset d) in the camera frame, ``n . X + d`` the height of the
    camera-frame point X (mm), positive on the objects' side. Why: near a table an object gets the
    table's bounce light and loses some to its own contact shadow, which depend on the height above
    the table, not on the normal alone, so the 9 SH terms cannot hold them (measured at the exact GT
    of the ``ycbv21`` suite's short clips, ``bench/bench_shading_height.py``: the image over the lit
    template 1.17-1.21 within 5 mm of the table, 1.06-1.13 above 20 mm). An exponential fall-off
    with height is the simplest such field; its weight is fitted per view and channel, of either sign."""
    z = np.asarray(depth_mm, np.float64)
    H, W = z.shape
    K = np.asarray(K, np.float64)
    u = (np.arange(W, dtype=np.float64) - K[0, 2]) / K[0, 0]
    v = (np.arange(H, dtype=np.float64) - K[1, 2]) / K[1, 1]
    n, d = np.asarray(plane_c[0], np.float64), float(plane_c[1])
    h = z * (n[0] * u[None, :] + n[1] * v[:, None] + n[2]) + d
    out = np.exp(-np.clip(h, 0.0, None) / float(scale_mm))
    out[z <= 0] = 0.0
    return out


def lit_template(color: np.ndarray, normals: np.ndarray, instance: np.ndarray, image: np.ndarray,
                 erode_px: int = 3, max_px: int = 40000, coeffs: np.ndarray | None = None,
                 rim_px: int = 0, extra: np.ndarray | None = None,
                 additive: np.ndarray | None = None) -> np.ndarray:
    """One view's template ``color`` (H, W, 3 uint8, unlit) shaded by the lighting fitted to
    ``image`` (:func:`view_lighting`), or by ``coeffs`` (3, 9) when given (a lighting fitted
    before: it is the view's, not the poses'). The unlit template when the fit has too few pixels.
    ``rim_px`` > 0: the shading of each silhouette's outer ``rim_px`` px held at its value further
    in (:func:`hold_rim`; ``erode_px``, where the fit stops, is the natural choice). ``extra``: the
    lighting's extra and additive basis images (:func:`fit_shading`; the additive ones of this
    render, e.g. :func:`reflection_basis`, also with ``coeffs``)."""
    C = (view_lighting(color, normals, instance, image, erode_px, max_px, extra=extra, additive=additive)
         if coeffs is None else coeffs)
    return np.asarray(color) if C is None else shade(color, normals, np.asarray(instance) > 0, C,
                                                     instance=instance, rim_px=rim_px, extra=extra,
                                                     additive=additive)
