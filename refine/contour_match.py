"""Where the blurred edge field shows a template's silhouette: blur-matched contour points.

f_edge pulls template contour samples into minima of the image's edge field E (Gaussian blur of
standard deviation sigma, then Sobel; :mod:`ycbvss.refine.edge`). Blurring a curved silhouette
moves the edge-strength maximum towards the centre of curvature by about
kappa * sigma_eff^2 / 2 px (kappa = 1 / radius of curvature): a disc of 20 px radius shows its
edge 0.04 px inside at sigma 1 px and 0.4 px inside at sigma 4 px. The geometric contour point
(pixel centre + half a pixel outward) also sits 0.02-0.05 px outside the true boundary on average
(the half-pixel step along the summed 4-neighbour direction overshoots on diagonal stretches).
Both make the template look larger than what E shows, so the whole scene drifts away from the
cameras by Z * offset / radius (1-3 mm at 1 m). :func:`match_contour_to_blur` instead places each
contour sample where the same edge field, computed on the template's own binary silhouette, has
its minimum: the image and the template then go through the same filter, and the pixel-centre
sampled silhouette is unbiased in area, so the prediction is unbiased for any curvature.
"""
from __future__ import annotations

import cv2
import numpy as np

from .cubic_kernel import minimum_along
from .edge import EdgeField, gradient_magnitude, linear_to_srgb, sample_bilinear, sample_E, srgb_to_linear
from .srgb import encode_u8


def search_px(sigma_px: float) -> tuple[float, float]:
    """Half-width and coarse step (px) of the search along the normal around the geometric contour
    point: 1 + sigma / 2 px wide (the blur shift reaches about sigma^2 / (2 * radius)), steps of
    max(0.25, sigma / 8) px; the coarse minimum is refined on a five times finer grid and a parabola."""
    return 1.0 + 0.5 * sigma_px, max(0.25, sigma_px / 8.0)


def _crop_box(uv: np.ndarray, shape: tuple[int, int], margin_px: int) -> tuple[int, int, int, int]:
    """(y0, x0, y1, x1) of the samples uv (N, 2) grown by ``margin_px``, clipped to ``shape``."""
    H, W = shape
    lo = np.floor(uv.min(axis=0)).astype(int) - margin_px
    hi = np.ceil(uv.max(axis=0)).astype(int) + margin_px + 1
    return max(lo[1], 0), max(lo[0], 0), min(hi[1], H), min(hi[0], W)


def _blur_sobel(mask_f: np.ndarray, sigma_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Sobel derivatives (u, v; float32, unscaled) of ``mask_f`` Gaussian-blurred by ``sigma_px``
    (at least 1 px): the blur :func:`_outward_normals` takes, and for sigma >= 1 px the one
    :func:`ycbvss.refine.edge.gradient_magnitude` takes."""
    g = cv2.GaussianBlur(mask_f, (0, 0), max(sigma_px, 1.0))
    return cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3), cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3)


def _edge_cost(mask_f: np.ndarray, sigma_px: float, sobel: tuple[np.ndarray, np.ndarray] | None = None) -> EdgeField:
    """E only (no derivatives) of a silhouette image, as :func:`ycbvss.refine.edge.edge_field` computes it.
    ``sobel``: :func:`_blur_sobel` of the same image and blur (sigma >= 1 px), reused instead of
    blurring again (the same numbers)."""
    if sobel is not None and sigma_px >= 1.0:
        gx, gy = sobel[0] / 8.0, sobel[1] / 8.0            # gradient_magnitude's scaling, float32
        mag = np.sqrt(gx * gx + gy * gy)
    else:
        mag = gradient_magnitude(mask_f, sigma_px)
    mx = float(mag.max())
    E = np.ones_like(mag) if mx <= 1e-6 else 1.0 - mag / mx
    return EdgeField(E[..., None], float(sigma_px))


def _outward_normals(mask_f: np.ndarray, sigma_px: float, uv: np.ndarray,
                     sobel: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Unit outward normals (N, 2) at uv of the Gaussian-blurred silhouette (the mask falls outward).
    ``sobel``: :func:`_blur_sobel` (mask_f, sigma_px) when already computed."""
    gu, gv = _blur_sobel(mask_f, sigma_px) if sobel is None else sobel
    grad = sample_bilinear(np.stack([gu, gv], -1), uv)[0]
    n = -grad
    nn = np.linalg.norm(n, axis=1, keepdims=True)
    return np.where(nn > 1e-9, n / np.maximum(nn, 1e-9), 0.0)


def _grid_minimum(field, uv: np.ndarray, n: np.ndarray, t0: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index (N,) of the smallest E along uv + (t0 + s) n over the offsets s (S,), and E (N, S)."""
    t = t0[:, None] + s[None, :]
    P = (uv[:, None, :] + t[..., None] * n[:, None, :]).reshape(-1, 2)
    E = sample_E(field, P).reshape(len(uv), len(s))
    return np.argmin(E, axis=1), E


def _search_grids(half_px: float, step_px: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The coarse offsets (step ``step_px`` over [-half_px, half_px]), the fine ones (a fifth of
    the step, -5..5) and the fine step of :func:`_minimum_along`."""
    fine_step = step_px / 5.0
    return np.arange(-half_px, half_px + 1e-9, step_px), np.arange(-5, 6) * fine_step, fine_step


def _minimum_along_array(field, uv: np.ndarray, n: np.ndarray, half_px: float, step_px: float) -> np.ndarray:
    """:func:`_minimum_along` as array operations, for any interpolation of ``field``."""
    coarse, fine, fine_step = _search_grids(half_px, step_px)
    k, _ = _grid_minimum(field, uv, n, np.zeros(len(uv)), coarse)
    k2, E = _grid_minimum(field, uv, n, coarse[k], fine)
    k2 = np.clip(k2, 1, len(fine) - 2)
    r = np.arange(len(uv))
    e0, e1, e2 = E[r, k2 - 1], E[r, k2], E[r, k2 + 1]
    den = e0 - 2.0 * e1 + e2
    frac = np.where(den > 1e-12, 0.5 * (e0 - e2) / np.where(den > 1e-12, den, 1.0), 0.0)
    return np.clip(coarse[k] + fine[k2] + np.clip(frac, -1.0, 1.0) * fine_step, -half_px, half_px)


def _minimum_along(field, uv: np.ndarray, n: np.ndarray, half_px: float, step_px: float) -> np.ndarray:
    """Signed offsets t (N,) in [-half_px, half_px] of the minimum of E along uv + t n: coarse grid
    of ``step_px``, a five times finer grid around its minimum, a parabola through the fine minimum
    and its two neighbours. A bicubic field is searched point by point by the compiled
    :func:`ycbvss.refine.cubic_kernel.minimum_along` (the same numbers as the array form)."""
    if field.interp != "cubic":
        return _minimum_along_array(field, uv, n, half_px, step_px)
    coarse, fine, fine_step = _search_grids(half_px, step_px)
    H, W = field.shape
    return minimum_along(field.E_padded, H, W, np.ascontiguousarray(uv, dtype=np.float64),
                         np.ascontiguousarray(n, dtype=np.float64), coarse, fine, fine_step, half_px)


def match_contour_to_blur(uv: np.ndarray, labels: np.ndarray, inst: np.ndarray, sigma_px: float) -> np.ndarray:
    """Contour samples uv (N, 2) (px, pixel centres at integers) of the silhouettes ``inst == label``
    moved along their outward normals to the minimum of the edge field (blur ``sigma_px``) of each
    object's own binary silhouette; (N, 2). A sample whose minimum is not found inside the search
    window (:func:`search_px`; flat field, e.g. a one-pixel sliver) keeps its position."""
    out = np.array(uv, dtype=np.float64, copy=True)
    if len(out) == 0:
        return out
    half_px, step_px = search_px(sigma_px)
    margin = int(np.ceil(3.0 * max(sigma_px, 1.0) + half_px)) + 2
    for lab in np.unique(labels):
        sel = np.flatnonzero(labels == lab)
        y0, x0, y1, x1 = _crop_box(out[sel], inst.shape, margin)
        mask_f = (inst[y0:y1, x0:x1] == lab).astype(np.float32) * 255.0
        p = out[sel] - (x0, y0)
        sobel = _blur_sobel(mask_f, sigma_px)                  # one blur for the normals and E
        n = _outward_normals(mask_f, sigma_px, p, sobel)
        t = _minimum_along(_edge_cost(mask_f, sigma_px, sobel), p, n, half_px, step_px)
        ok = (np.abs(t) < half_px - step_px) & np.any(n != 0.0, axis=1)
        out[sel[ok]] = out[sel[ok]] + t[ok, None] * n[ok]
    return out


def contour_normals(uv: np.ndarray, labels: np.ndarray, inst: np.ndarray, sigma_px: float = 1.0) -> np.ndarray:
    """Unit outward normals (N, 2) of the silhouettes ``inst == label`` at the contour samples uv
    (N, 2) (px), from the Gaussian-blurred (``sigma_px``, at least 1 px) binary silhouette; zero
    where the blurred silhouette is flat. Used by f_edge's contour-dilation nuisance
    (:class:`ycbvss.refine.terms.EdgeTerm`)."""
    out = np.zeros((len(uv), 2))
    if len(uv) == 0:
        return out
    margin = int(np.ceil(3.0 * max(sigma_px, 1.0))) + 3
    for lab in np.unique(labels):
        sel = np.flatnonzero(labels == lab)
        y0, x0, y1, x1 = _crop_box(uv[sel], inst.shape, margin)
        mask_f = (inst[y0:y1, x0:x1] == lab).astype(np.float32) * 255.0
        out[sel] = _outward_normals(mask_f, sigma_px, uv[sel] - (x0, y0))
    return out


# --- appearance of the contour -------------------------------------------------------------------
#
# The binary match above predicts where the edge field shows a silhouette whose inside is one flat
# colour. Real images are not: scanned textures darken towards the rim (the gelatin box's red
# falls by a third in its outermost pixel), and anti-aliasing mixes light linearly while the edge
# field is computed on sRGB-encoded values, which moves the gradient peak of a high-contrast edge
# about 0.1 px towards its darker side. Measured on suite scene 1 from the exact GT (sigma 1 px,
# 5 frames), the image edges lie -0.26 px (gelatin) to +0.11 px (banana) from the binary
# prediction, 0.126 px per object on average; an object whose edges all lie 0.1 px inside looks
# 0.1 / radius smaller, i.e. 2.5 mm farther at 1 m for a 40 px radius. :func:`appearance_offsets`
# predicts that part from the template's own texture and the image's background beside each
# sample, in one dimension along the normal: the same frames then leave -0.13 to +0.08 px,
# 0.049 px per object on average. Not modelled: the brightening of dark glossy rims under
# Blender's specular/Fresnel shading (the mug's texture darkens at its rim, its image brightens),
# which at sigma 2 px makes the prediction worse than the binary one for the mug and the large
# clamp; so the refiner applies it at the finest blur level only (``RefineOptions.edge_appearance``).

def _peak_offset(profile: np.ndarray, t: np.ndarray, sigma_px: float, half_px: float) -> np.ndarray:
    """Position (px) of the largest colour-gradient magnitude of sRGB profiles (N, K, C) sampled at
    t (K,), after a Gaussian blur of ``sigma_px`` along t, searched within |t| <= half_px (parabola
    through the largest sample and its neighbours)."""
    from scipy.ndimage import gaussian_filter1d

    h = float(t[1] - t[0])
    g = gaussian_filter1d(profile, sigma_px / h, axis=1, mode="nearest")
    nb = max(int(round(1.0 / h)), 1)        # central difference over +-1 px, as the Sobel derivative takes it
    d = np.zeros_like(g)
    d[:, nb:-nb] = 0.5 * (g[:, 2 * nb:] - g[:, :-2 * nb])
    mag = np.sqrt((d * d).sum(axis=2))
    win = np.abs(t) <= half_px
    idx = np.flatnonzero(win)
    k = idx[np.argmax(mag[:, win], axis=1)]
    k = np.clip(k, 1, len(t) - 2)
    r = np.arange(len(profile))
    e0, e1, e2 = mag[r, k - 1], mag[r, k], mag[r, k + 1]
    den = e0 - 2.0 * e1 + e2
    frac = np.where(den < -1e-12, 0.5 * (e0 - e2) / np.where(den < -1e-12, den, -1.0), 0.0)
    return t[k] + np.clip(frac, -1.0, 1.0) * h


def pixel_filter_kernel(spec: str, step_px: float) -> np.ndarray:
    """Weights (K,) summing to 1 of a pixel's footprint across an edge, on a grid of ``step_px``:
    how much of the light at each offset a pixel gathers. ``spec`` "box": an ideal area sensor, 1 px
    wide (standard deviation 0.29 px); "blackman-harris:W": the Blackman-Harris window W px wide
    (Blender Cycles' default pixel filter; W = 1 has a standard deviation of 0.14 px, W = 1.5 of
    0.21 px). The sRGB encoding shifts an anti-aliased edge towards its darker side by an amount
    that grows with this footprint: a dark object (linear 0.05) on a brighter ground (0.3) shows its
    edge 0.09 px inside through a box and 0.045 px through Cycles' 1 px filter."""
    if spec == "box":
        nb = max(int(round(1.0 / step_px)), 1)
        w = np.ones(nb + 1)
        w[0] = w[-1] = 0.5
        return w / w.sum()
    kind, _, width = spec.partition(":")
    if kind != "blackman-harris" or not width:
        raise ValueError(f"pixel filter must be 'box' or 'blackman-harris:W', got {spec!r}")
    w_px = float(width)
    if not w_px > 0.0:
        raise ValueError(f"pixel filter width must be > 0, got {spec!r}")
    half = int(np.floor(0.5 * w_px / step_px))
    x = 2.0 * np.pi * (np.arange(-half, half + 1) * step_px / w_px + 0.5)
    w = 0.35875 - 0.48829 * np.cos(x) + 0.14128 * np.cos(2.0 * x) - 0.01168 * np.cos(3.0 * x)
    w = np.clip(w, 0.0, None)
    return w / w.sum()


def appearance_offsets(uv: np.ndarray, labels: np.ndarray, inst: np.ndarray, colour_tmpl: np.ndarray,
                       image: np.ndarray, sigma_px: float, colour_edges: bool = True,
                       step_px: float = 0.25, outside_from_image_px: float | None = None,
                       inside_from_image_px: float | None = None,
                       pixel_filter: str = "box",
                       linear_labels: frozenset = frozenset()) -> tuple[np.ndarray, np.ndarray]:
    """Offsets t (N,) px along the outward normals n (N, 2) of the image edge predicted from appearance,
    relative to where a flat-coloured silhouette shows it, at the contour samples uv (N, 2)
    (geometric boundary points, px) of the silhouettes ``inst == labels``.

    One profile per sample along its normal, in linear light: inside, the template's colour
    ``colour_tmpl`` (H, W, 3 uint8 sRGB; albedo) times a per-object gain that maps it to the
    image's interior (ratio of medians over the silhouette eroded by 3 px); outside, the image's
    colour 2.5-3.5 px beyond the contour (its median). The profile is integrated over one pixel
    (anti-aliasing; ``pixel_filter``, :func:`pixel_filter_kernel`), encoded to sRGB, blurred by
    ``sigma_px`` and differentiated as the edge field is; the offset is its gradient peak minus that
    of a flat step through the same pipeline without encoding. Samples of silhouettes smaller than
    20 px get 0. Returns (t, n).

    Two probes of where the image departs from that model (``bench/bench_contour_rim_source.py``;
    the refiner uses neither): ``outside_from_image_px`` d: the outside is the image's own profile
    along the normal from d px out (held at its value at d nearer), not one flat colour;
    ``inside_from_image_px`` d: the inside is the image's own profile from d px in, the template
    (scaled to meet it at d) nearer. The second reads the image where the object's own edge lies
    once d is about a pixel, so the prediction then follows the image rather than the pose.

    ``linear_labels``: silhouettes whose profiles stay in linear light (not sRGB-encoded), for an
    object whose edge field is the linear-light image's (``RefineOptions.edge_linear_dark``)."""
    from scipy.ndimage import distance_transform_edt

    uv = np.asarray(uv, dtype=np.float64)
    out = np.zeros(len(uv))
    normals = np.zeros((len(uv), 2))
    if len(uv) == 0:
        return out, normals
    sig = max(float(sigma_px), 0.5)
    reach = 3.0 * sig + 3.0
    t = np.arange(-np.ceil(reach / step_px), np.ceil(reach / step_px) + 1) * step_px
    half = 1.0 + 0.5 * sig
    box = pixel_filter_kernel(pixel_filter, step_px)  # the pixel's footprint on the step_px grid
    from scipy.ndimage import convolve1d
    step = (t >= 0).astype(np.float64)[None, :, None]
    ref = float(_peak_offset(convolve1d(step, box, axis=1, mode="nearest"), t, sig, half)[0])
    margin = int(np.ceil(reach)) + 6
    # decoded only inside the box that holds every object's crop below (per-pixel work: the same values)
    by0, bx0, by1, bx1 = _crop_box(uv, inst.shape, margin)
    lin_img = srgb_to_linear(np.asarray(image)[by0:by1, bx0:bx1])
    lin_img = lin_img if (colour_edges and lin_img.ndim == 3) else lin_img.mean(axis=2, keepdims=True) \
        if lin_img.ndim == 3 else lin_img[..., None]
    lin_tmpl = srgb_to_linear(np.asarray(colour_tmpl)[by0:by1, bx0:bx1])
    lin_tmpl = lin_tmpl if (colour_edges and lin_tmpl.ndim == 3) else lin_tmpl.mean(axis=2, keepdims=True)
    inside_t, outside_t = t < 0, np.array([2.5, 3.0, 3.5])
    for lab in np.unique(labels):
        sel = np.flatnonzero(labels == lab)
        y0, x0, y1, x1 = _crop_box(uv[sel], inst.shape, margin)
        m = inst[y0:y1, x0:x1] == lab
        if m.sum() < 20:
            continue
        tm = lin_tmpl[y0 - by0:y1 - by0, x0 - bx0:x1 - bx0]
        im = lin_img[y0 - by0:y1 - by0, x0 - bx0:x1 - bx0]
        inner = cv2.erode(m.astype(np.uint8), np.ones((7, 7), np.uint8)) > 0
        if inner.sum() < 10:
            inner = m
        gain = np.median(im[inner], axis=0) / np.maximum(np.median(tm[inner], axis=0), 1e-3)
        gain = np.clip(gain, 0.05, 20.0)
        _, (iy, ix) = distance_transform_edt(~m, return_indices=True)
        filled = (tm[iy, ix] * gain[None, None]).astype(np.float32)    # the inside colour carried outward
        p = uv[sel] - (x0, y0)
        n = _outward_normals(m.astype(np.float32) * 255.0, sig, p)
        P_in = p[:, None, :] + t[None, inside_t, None] * n[:, None, :]
        a = sample_bilinear(filled, P_in.reshape(-1, 2))[0].reshape(len(p), int(inside_t.sum()), -1)
        if inside_from_image_px is not None:
            a = _image_inside(a, im, p, n, t[inside_t], float(inside_from_image_px))
        if outside_from_image_px is None:
            b = np.median(_along(im, p, n, outside_t), axis=1)
            bo = np.repeat(b[:, None, :], int((~inside_t).sum()), axis=1)
        else:
            bo = _along(im, p, n, np.maximum(t[~inside_t], float(outside_from_image_px)))
        prof = np.concatenate([a, bo], axis=1)
        prof = convolve1d(prof, box, axis=1, mode="nearest")
        prof = prof if int(lab) in linear_labels else linear_to_srgb(prof)
        off = _peak_offset(prof, t, sig, half) - ref
        ok = np.any(n != 0.0, axis=1) & np.all(np.isfinite(prof.reshape(len(p), -1)), axis=1)
        out[sel[ok]] = off[ok]
        normals[sel] = n
    return out, normals


def _along(im: np.ndarray, p: np.ndarray, n: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The image ``im`` (h, w, C) sampled bilinearly at p + t n: (N, len(t), C)."""
    P = p[:, None, :] + t[None, :, None] * n[:, None, :]
    return sample_bilinear(im.astype(np.float32), P.reshape(-1, 2))[0].reshape(len(p), len(t), -1)


def _image_inside(a: np.ndarray, im: np.ndarray, p: np.ndarray, n: np.ndarray, t_in: np.ndarray,
                  d_px: float) -> np.ndarray:
    """``inside_from_image_px`` of :func:`appearance_offsets`: the inside profiles ``a`` (N, K, C) at
    t_in (K,) (< 0) replaced by the image's from ``d_px`` in, the template's nearer scaled per
    channel to meet the image at -d_px."""
    ai = _along(im, p, n, np.minimum(t_in, -d_px))
    k = int(np.argmin(np.abs(t_in + d_px)))
    scale = np.clip(ai[:, k:k + 1] / np.maximum(a[:, k:k + 1], 1e-4), 0.2, 5.0)
    return np.where((t_in <= -d_px)[None, :, None], ai, a * scale)


# --- the contour predicted by the image's own edge operator on a synthetic image -----------------
#
# appearance_offsets models one profile per sample along its normal. Session 89 measured what that
# misses (bench/bench_contour_synthetic.py): a texture band narrower than a pixel at the rim (the
# master chef can's dark bottom rim puts its edge 0.79 px inside the binary silhouette; the 1-D
# model predicts 0.56-0.59 even from the exact pixel-area colour), texture edges beside the contour
# and its curvature, all in 2-D. :func:`synthetic_contour_offsets` instead forms the image the
# template predicts -- the template's colour mixed with the background by each pixel's coverage in
# linear light, as a camera forms it -- and searches the minimum of the same edge field the image
# gets (colour, blur sigma) along each sample's normal. The refiner uses it with
# ``RefineOptions.edge_appearance_model = "synthetic"`` (off by default).

def synthetic_image(instance: np.ndarray, coverage: np.ndarray | None, colour: np.ndarray, image: np.ndarray,
                    ring_px: float = 2.5, psf_sigma_px: float = 0.0) -> np.ndarray:
    """The image (H, W, 3) uint8 sRGB a template predicts: each pixel's ``colour`` (H, W, 3 uint8 sRGB,
    the objects' colour wherever ``coverage`` > 0) mixed in linear light by its ``coverage`` (H, W)
    in [0, 1] (None: the binary ``instance`` > 0) with the background. The background is ``image``
    (H, W, 3 uint8) farther than ``ring_px`` px from every silhouette of ``instance`` and, nearer,
    the nearest such pixel's colour: the image's own pixels beside the silhouette hold the object's
    blurred edge whenever the pose is off, so the prediction would follow the image, not the pose.
    ``psf_sigma_px`` > 0: the mix is blurred in linear light by a Gaussian of that sigma (px), a
    camera's blur beyond the pixel's area, before it is encoded."""
    from scipy.ndimage import distance_transform_edt

    inside = np.asarray(instance) > 0
    cov = inside.astype(np.float32) if coverage is None else np.clip(np.asarray(coverage, np.float32), 0.0, 1.0)
    far = distance_transform_edt(~inside) > ring_px
    lin_img = srgb_to_linear(image)
    if far.any():
        _, (iy, ix) = distance_transform_edt(~far, return_indices=True)
        bg = lin_img[iy, ix]
    else:
        bg = np.broadcast_to(np.median(lin_img.reshape(-1, lin_img.shape[-1]), axis=0), lin_img.shape)
    lin = cov[..., None] * srgb_to_linear(colour) + (1.0 - cov[..., None]) * bg
    if psf_sigma_px > 0.0:
        lin = cv2.GaussianBlur(np.ascontiguousarray(lin, np.float32), (0, 0), float(psf_sigma_px))
    return encode_u8(lin)


def synthetic_contour_offsets(uv: np.ndarray, n: np.ndarray, synthetic: np.ndarray, sigma_px: float,
                              half_px: float = 1.5, step_px: float = 0.25) -> np.ndarray:
    """Offsets t (N,) px along the unit normals n (N, 2) from the contour samples uv (N, 2) (px) to
    the minimum of the edge field of ``synthetic`` (:func:`synthetic_image`; the image's operator:
    colour gradient after a Gaussian blur of ``sigma_px``), within +-``half_px``; NaN where the
    minimum lies at the window's end (no edge found)."""
    from .edge import edge_field

    uv = np.asarray(uv, np.float64).reshape(-1, 2)
    out = np.full(len(uv), np.nan)
    if len(uv) == 0:
        return out
    margin = int(np.ceil(3.0 * max(sigma_px, 1.0) + half_px)) + 3
    y0, x0, y1, x1 = _crop_box(uv, synthetic.shape[:2], margin)
    fld = edge_field(np.ascontiguousarray(synthetic[y0:y1, x0:x1]), sigma_px, colour=True)
    t = _minimum_along(fld, uv - (x0, y0), np.asarray(n, np.float64), half_px, step_px)
    ok = np.abs(t) < half_px - step_px
    out[ok] = t[ok]
    return out


def rim_colour(instance: np.ndarray, coverage: np.ndarray, area_colour: np.ndarray, lit: np.ndarray) -> np.ndarray:
    """The lit template's colour (H, W, 3 uint8 sRGB) wherever an object covers part of a pixel, for
    :func:`synthetic_image`: inside the binary silhouette (``instance`` > 0) ``lit`` (``area_colour``,
    the pixel-area colour, lit), on the partly covered pixels beside it (``coverage`` > 0) their
    ``area_colour`` shaded as the nearest inside pixel is (the ratio ``lit`` / ``area_colour`` there,
    in linear light)."""
    from scipy.ndimage import distance_transform_edt

    inside = np.asarray(instance) > 0
    out = np.array(lit, copy=True)
    part = (~inside) & (np.asarray(coverage) > 0)
    if not part.any() or not inside.any():
        return out
    ratio = srgb_to_linear(lit) / np.maximum(srgb_to_linear(area_colour), 1.0)
    _, (iy, ix) = distance_transform_edt(~inside, return_indices=True)    # the nearest inside pixel
    out[part] = encode_u8(srgb_to_linear(area_colour)[part] * ratio[iy, ix][part])
    return out
