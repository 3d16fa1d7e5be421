"""Edge field of an image and edge-point sampling from rendered templates.

Edge field (paper Sec. 3.2): E = 1 - |grad I| / max |grad I| in [0, 1], small on strong edges.
|grad I| is the colour edge strength (all three channels) or the grey-level one; for
coarse-to-fine it is taken on the image blurred with a Gaussian of standard deviation ``sigma_px``
(derivative-of-Gaussian), so the basin of each edge widens with sigma. E is read through bicubic
(Catmull-Rom) interpolation with its exact gradient -- bilinear reading would put every minimum on
a pixel centre -- plus a bilinearly read Hessian (for the Newton-type step of
:mod:`ycbvss.refine.terms`). Outside the image E = 1 and all derivatives 0.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from . import srgb
from .contour_kernel import contour_bits, crease_bits, near_own_occluded
from .cubic_kernel import cubic_sample
from .interior_edges import flat_at, sharp_at


def to_gray_f32(image: np.ndarray) -> np.ndarray:
    """RGB uint8 (H, W, 3) or gray (H, W) -> gray float32 in [0, 255]."""
    img = np.asarray(image)
    if img.ndim == 3:
        img = cv2.cvtColor(img if img.dtype == np.uint8 else img.astype(np.float32), cv2.COLOR_RGB2GRAY)
    return img.astype(np.float32)


@dataclass
class EdgeField:
    """E and its derivatives stacked (H, W, 6): E, Eu, Ev, Euu, Euv, Evv (u = column, v = row).

    ``interp`` = "cubic" (default): E is read through Catmull-Rom bicubic interpolation, whose
    minima can lie anywhere between pixel centres; "linear": bilinear, whose minima sit on pixel
    centres (a contour that lies half-way between two pixels then snaps to whichever of them has the
    stronger gradient -- a systematic 0.5 px shrink or growth when the object's rim is shaded)."""

    data: np.ndarray
    sigma_px: float
    interp: str = "cubic"

    @property
    def E(self) -> np.ndarray:
        return self.data[..., 0]

    @cached_property
    def E_padded(self) -> np.ndarray:
        """E as float64, edge-replicated by 1 px before and 2 px after each axis (H + 3, W + 3):
        the 4x4 bicubic taps of any in-image point index it directly (same values as clamping)."""
        return np.pad(self.data[..., 0].astype(np.float64), ((1, 2), (1, 2)), mode="edge")

    @cached_property
    def hessian_padded(self) -> np.ndarray:
        """Euu, Euv, Evv (H + 3, W + 3, 3) float64, padded like :attr:`E_padded` (bilinear taps of
        the Hessian at the bicubic sampler's cell)."""
        return np.pad(self.data[..., 3:6].astype(np.float64), ((1, 2), (1, 2), (0, 0)), mode="edge")

    @property
    def shape(self) -> tuple[int, int]:
        return self.data.shape[:2]


def gradient_magnitude(image: np.ndarray, sigma_px: float) -> np.ndarray:
    """Edge strength (H, W) float32 of the Gaussian-blurred image (Sobel). Grey (H, W): |grad I|;
    colour (H, W, 3): the Frobenius norm of the colour Jacobian, sqrt(sum_c |grad I_c|^2 / 3)
    (equal to |grad I| when the channels agree). A yellow bottle on a white table is almost
    invisible in grey levels but not in the blue channel."""
    f = np.asarray(image, dtype=np.float32)
    if f.ndim == 3:
        f = f[..., :3]
    g = cv2.GaussianBlur(f, (0, 0), sigmaX=max(sigma_px, 0.3)) if sigma_px > 0 else f
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3) / 8.0
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3) / 8.0
    s = gx * gx + gy * gy
    if s.ndim == 3:              # channel sum written out: numpy's reduction over a length-3 last axis is ~10x slower
        s = (s[..., 0] + s[..., 1] + s[..., 2]) / 3.0
    return np.sqrt(s)


def srgb_to_linear(image: np.ndarray) -> np.ndarray:
    """8-bit sRGB-encoded image -> linear light float32 in [0, 255] (IEC 61966-2-1 decoding,
    colour-science's values as a table: :mod:`ycbvss.refine.srgb`). Blur and anti-aliasing mix
    light linearly, so an edge's gradient peak is symmetric only in linear light; in the encoded
    image it leans towards the darker side (a bright object looks larger, a dark one smaller)."""
    global _SRGB_LUT
    if _SRGB_LUT is None:
        _SRGB_LUT = (srgb.tables()["decode_u8"] * 255.0).astype(np.float32)
    img = np.asarray(image)
    if img.dtype != np.uint8:
        img = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    return _SRGB_LUT[img]


_SRGB_LUT: np.ndarray | None = None


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    """Linear light in [0, 255] -> sRGB-encoded values in [0, 255], float (IEC 61966-2-1 encoding,
    colour-science's values as a table: :mod:`ycbvss.refine.srgb`; the inverse of
    :func:`srgb_to_linear`)."""
    return srgb.encode(np.asarray(x) / 255.0) * 255.0


def edge_field(image: np.ndarray, sigma_px: float = 1.0, norm_percentile: float = 100.0,
               interp: str = "cubic", colour: bool = False, linear: bool = False) -> EdgeField:
    """Edge field of an image (RGB or gray) at blur ``sigma_px``.

    ``colour``: edge strength from all three channels (:func:`gradient_magnitude` of the RGB
    image) instead of the grey value; objects whose colour differs from the background mostly in
    hue (same brightness) keep their silhouettes.

    ``linear``: edge strength of the linear-light image (:func:`srgb_to_linear`), not of the
    sRGB-encoded values.

    ``norm_percentile`` = 100 is the paper's normalisation by the maximum gradient; a lower
    percentile (robust maximum, values above it clip to E = 0) keeps one very strong edge from
    flattening all others. A uniform image (max gradient 0) gives E = 1 everywhere and zero
    derivatives (no pull)."""
    img = srgb_to_linear(image) if linear else np.asarray(image)
    mag = gradient_magnitude(img if (colour and img.ndim == 3) else to_gray_f32(img), sigma_px)
    return _field_from_magnitude(mag, sigma_px, norm_percentile, interp)


def _field_from_magnitude(mag: np.ndarray, sigma_px: float, norm_percentile: float = 100.0,
                          interp: str = "cubic", mx: float | None = None) -> EdgeField:
    """:func:`edge_field` from its edge strength ``mag`` (H, W): normalised, E and its derivatives.
    ``mx``: the normalising strength (None: from ``norm_percentile``)."""
    if mx is None:
        mx = float(mag.max()) if norm_percentile >= 100 else float(np.percentile(mag, norm_percentile))
    if mx <= 1e-6:
        mx = float(mag.max())
    E = np.ones_like(mag) if mx <= 1e-6 else 1.0 - np.minimum(mag / mx, 1.0)
    Ev, Eu = np.gradient(E)
    Euv, Euu = np.gradient(Eu)
    Evv, _ = np.gradient(Ev)
    data = np.stack([E, Eu, Ev, Euu, Euv, Evv], axis=-1).astype(np.float32)
    return EdgeField(data, float(sigma_px), interp)


def sample_bilinear(data: np.ndarray, uv: np.ndarray, outside: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Bilinear sample of ``data`` (H, W, C) at pixel positions uv (N, 2) (pixel centres at integers).

    Returns values (N, C) and inside (N,) bool; outside samples get ``outside`` (C,) (default 0)."""
    H, W = data.shape[:2]
    C = data.shape[2]
    uv = np.asarray(uv, dtype=np.float64)
    u, v = uv[:, 0], uv[:, 1]
    inside = np.isfinite(u) & np.isfinite(v) & (u >= 0) & (v >= 0) & (u <= W - 1) & (v <= H - 1)
    out = np.zeros((len(uv), C)) if outside is None else np.tile(np.asarray(outside, float), (len(uv), 1))
    if not np.any(inside):
        return out, inside
    ui, vi = u[inside], v[inside]
    u0 = np.minimum(np.floor(ui).astype(int), W - 2) if W > 1 else np.zeros(len(ui), int)
    v0 = np.minimum(np.floor(vi).astype(int), H - 2) if H > 1 else np.zeros(len(vi), int)
    a, b = (ui - u0)[:, None], (vi - v0)[:, None]
    u1, v1 = np.minimum(u0 + 1, W - 1), np.minimum(v0 + 1, H - 1)
    out[inside] = ((1 - a) * (1 - b) * data[v0, u0] + a * (1 - b) * data[v0, u1]
                   + (1 - a) * b * data[v1, u0] + a * b * data[v1, u1])
    return out, inside


_NO_HESS = np.zeros((0, 0, 3))


def _sample_cubic(Ep: np.ndarray, u: np.ndarray, v: np.ndarray, with_grad: bool,
                  Hp: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """Catmull-Rom bicubic value (N,) and exact gradient (N, 2) of E at in-image points (taps
    clamped), and with ``Hp`` (:attr:`EdgeField.hessian_padded`) the bilinear Hessian channels (N, 3).

    ``Ep`` is E padded as :attr:`EdgeField.E_padded` (so the 16 taps of a point are read
    directly); compiled kernel :func:`ycbvss.refine.cubic_kernel.cubic_sample`."""
    u = np.ascontiguousarray(u, dtype=np.float64)
    v = np.ascontiguousarray(v, dtype=np.float64)
    val, grad, hess = cubic_sample(Ep, u, v, with_grad, _NO_HESS if Hp is None else Hp, Hp is not None)
    return val, (grad if with_grad else None), (hess if Hp is not None else None)


def _inside(shape: tuple[int, int], uv: np.ndarray) -> np.ndarray:
    H, W = shape
    u, v = uv[:, 0], uv[:, 1]
    return np.isfinite(u) & np.isfinite(v) & (u >= 0) & (v >= 0) & (u <= W - 1) & (v <= H - 1)


def sample_E(field: EdgeField, uv: np.ndarray) -> np.ndarray:
    """E at uv (N, 2) with the field's interpolation (1 outside the image)."""
    uv = np.asarray(uv, dtype=np.float64)
    if field.interp != "cubic":
        return sample_bilinear(field.data[..., :1], uv, outside=np.ones(1))[0][:, 0]
    out = np.ones(len(uv))
    ins = _inside(field.shape, uv)
    if ins.any():
        out[ins] = _sample_cubic(field.E_padded, uv[ins, 0], uv[ins, 1], False)[0]
    return out


def sample_field(field: EdgeField, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """E (N,), gradient (N, 2), Hessian (N, 2, 2) and inside (N,) of the field at uv (N, 2).

    E is interpolated (bicubic or bilinear, see :class:`EdgeField`) and the gradient is the exact
    derivative of that interpolant (so it is consistent with the cost the solver evaluates); the
    Hessian is the bilinear interpolation of the central-difference second derivatives (it only
    scales the step)."""
    uv = np.asarray(uv, dtype=np.float64)
    if field.interp != "cubic":
        vals, inside = sample_bilinear(field.data, uv, outside=np.array([1, 0, 0, 0, 0, 0], float))
        E_out, hess = vals[:, 0].copy(), vals[:, 3:]
    else:                    # value, gradient and bilinear Hessian from one bicubic gather
        inside = _inside(field.shape, uv)
        E_out, hess = np.ones(len(uv)), np.zeros((len(uv), 3))
    grad = np.zeros((len(uv), 2))
    if np.any(inside):
        u, v = uv[inside, 0], uv[inside, 1]
        if field.interp == "cubic":
            E_out[inside], grad[inside], hess[inside] = _sample_cubic(field.E_padded, u, v, True, field.hessian_padded)
        else:
            E = field.data[..., 0]
            H_, W_ = E.shape
            u0 = np.clip(np.floor(u).astype(int), 0, max(W_ - 2, 0))
            v0 = np.clip(np.floor(v).astype(int), 0, max(H_ - 2, 0))
            u1, v1 = np.minimum(u0 + 1, W_ - 1), np.minimum(v0 + 1, H_ - 1)
            a, b = u - u0, v - v0
            e00, e01, e10, e11 = E[v0, u0], E[v0, u1], E[v1, u0], E[v1, u1]
            grad[inside, 0] = (1 - b) * (e01 - e00) + b * (e11 - e10)
            grad[inside, 1] = (1 - a) * (e10 - e00) + a * (e11 - e01)
    H = np.empty((len(uv), 2, 2))
    H[:, 0, 0], H[:, 0, 1], H[:, 1, 0], H[:, 1, 1] = hess[:, 0], hess[:, 1], hess[:, 1], hess[:, 2]
    return E_out, grad, H, inside


# ---------------------------------------------------------------- template edge points
_N4 = ((0, 1), (0, -1), (1, 0), (-1, 0))
MAX_RIM_CHORD_MM = 40.0   # longer chords at a contour pixel crossed a concavity: no rim depth from them


def contour_points(inst: np.ndarray, depth: np.ndarray, label: int) -> tuple[np.ndarray, np.ndarray]:
    """Exterior-contour samples of the silhouette ``inst == label``.

    A contour pixel is an object pixel with a 4-neighbour outside the object that is background or
    a surface farther away (an occluder's edge is not this object's contour); pixels on the image
    border are skipped (truncated silhouettes are no edges). Each sample is moved half a pixel
    outward (to the silhouette boundary between pixel centres). Returns uv (N, 2), depth (N,)."""
    full = inst == label
    if not full.any():
        return np.zeros((0, 2)), np.zeros(0)
    ys, xs = np.nonzero(full)
    y0, x0 = max(ys.min() - 1, 0), max(xs.min() - 1, 0)     # 1 px margin: the outside neighbours are real
    y1, x1 = min(ys.max() + 2, inst.shape[0]), min(xs.max() + 2, inst.shape[1])
    uv, d = _contour_points(inst[y0:y1, x0:x1], depth[y0:y1, x0:x1], label, inst.shape, (y0, x0))
    return uv + (x0, y0), d


def _contour_points(inst, depth, label, full_shape, origin):
    H, W = inst.shape
    m = inst == label
    pad_i = np.pad(inst, 1, constant_values=-1)
    pad_d = np.pad(depth, 1, constant_values=0)
    dirs = np.zeros((H, W, 2), np.float32)
    is_c = np.zeros((H, W), bool)
    for dv, du in _N4:
        ni = pad_i[1 + dv:1 + dv + H, 1 + du:1 + du + W]
        nd = pad_d[1 + dv:1 + dv + H, 1 + du:1 + du + W]
        edge = m & (ni != label) & (ni != -1) & ((ni == 0) | (nd > depth))
        is_c |= edge
        dirs[edge] += (du, dv)
    # pixels on the image border: a truncated silhouette is no edge
    y0, x0 = origin
    if y0 == 0:
        is_c[0, :] = False
    if x0 == 0:
        is_c[:, 0] = False
    if y0 + H == full_shape[0]:
        is_c[-1, :] = False
    if x0 + W == full_shape[1]:
        is_c[:, -1] = False
    v, u = np.nonzero(is_c)
    d = dirs[v, u]
    n = np.linalg.norm(d, axis=1, keepdims=True)
    d = np.where(n > 0, d / np.maximum(n, 1e-9), 0.0)
    uv = np.stack([u, v], 1).astype(np.float64) + 0.5 * d
    return uv, depth[v, u].astype(np.float64)


def crease_edges(normal: np.ndarray, depth: np.ndarray, min_angle_deg: float = 25.0,
                 depth_jump_rel: float = 0.03, inst: np.ndarray | None = None,
                 with_jumps: bool = False) -> tuple[np.ndarray, ...]:
    """Geometric edges of a rendered template (H, W) bool: the normal turns by more than
    ``min_angle_deg`` (>= 180: folds off, self-occlusions only) or the depth jumps (self-occlusion)
    towards the right/lower neighbour; the
    edge is marked on the nearer pixel with an offset (H, W, 2) of half a pixel towards the other
    one (the edge lies between the pixel centres). These are the shading/crease edges a photo
    shows even on textureless objects (box edges, a mug's rim). ``with_jumps``: also return the
    (H, W) bool mask of the edges that are depth jumps (self-occlusion rims), not folds."""
    # the pixel rules in one compiled pass (refine.contour_kernel): the same edges, offsets and
    # jumps as the array form (per direction, the two neighbours' masks; float32 where depth is)
    d = np.ascontiguousarray(depth)
    ft = d.dtype.type
    nrm = np.ascontiguousarray(normal) if min_angle_deg < 180.0 else np.zeros((1, 1, 3), d.dtype)
    lab = np.ascontiguousarray(inst) if inst is not None else np.zeros((1, 1), np.int32)
    out, off, jumps = crease_bits(nrm, d, nrm.dtype.type(np.cos(np.radians(min_angle_deg))), min_angle_deg < 180.0,
                                  ft(depth_jump_rel), lab, inst is not None)
    return (out, off, jumps) if with_jumps else (out, off)


def subpixel_offsets(gray: np.ndarray, v: np.ndarray, u: np.ndarray, sigma_px: float = 1.0) -> np.ndarray:
    """Sub-pixel position of edge pixels (v, u) along the gradient: parabola through the gradient
    magnitude at -1, 0, +1 px along the gradient direction. Returns offsets (N, 2) (du, dv), |.| <= 0.5."""
    g = cv2.GaussianBlur(gray.astype(np.float32), (0, 0), sigma_px)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3) / 8.0
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3) / 8.0
    mag = np.sqrt(gx * gx + gy * gy)
    d = np.stack([gx[v, u], gy[v, u]], 1).astype(np.float64)
    d /= np.linalg.norm(d, axis=1, keepdims=True) + 1e-9
    p = np.stack([u, v], 1).astype(np.float64)
    m0 = mag[v, u].astype(np.float64)
    mp = sample_bilinear(mag[..., None], p + d)[0][:, 0]
    mm = sample_bilinear(mag[..., None], p - d)[0][:, 0]
    den = mm - 2 * m0 + mp
    t = np.where(den < -1e-9, 0.5 * (mm - mp) / np.where(den < -1e-9, den, -1.0), 0.0)
    t = np.clip(t, -0.5, 0.5)
    return t[:, None] * d


def interior_points(inst: np.ndarray, depth: np.ndarray, color: np.ndarray, label: int,
                    canny_lo: float = 20.0, canny_hi: float = 60.0, erode_px: int = 2,
                    normal: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Interior edges inside the (eroded) silhouette: Canny on the rendered colour plus (if
    ``normal`` is given) crease / self-occlusion edges of the geometry. uv (N, 2), depth (N,)."""
    m = (inst == label).astype(np.uint8)
    if erode_px > 0:
        m = cv2.erode(m, np.ones((2 * erode_px + 1, 2 * erode_px + 1), np.uint8))
    if not m.any():
        return np.zeros((0, 2)), np.zeros(0)
    ys, xs = np.nonzero(m)
    y0, y1, x0, x1 = max(ys.min() - 2, 0), ys.max() + 3, max(xs.min() - 2, 0), xs.max() + 3
    gray = cv2.cvtColor(np.ascontiguousarray(color[y0:y1, x0:x1]), cv2.COLOR_RGB2GRAY)
    inside = m[y0:y1, x0:x1] > 0
    edges = (cv2.Canny(gray, canny_lo, canny_hi) > 0) & inside
    v, u = np.nonzero(edges)
    uv = np.stack([u, v], 1).astype(np.float64) + subpixel_offsets(gray, v, u)
    dep = depth[v + y0, u + x0]
    if normal is not None:
        ce, off = crease_edges(normal[y0:y1, x0:x1], depth[y0:y1, x0:x1])
        ce &= inside & ~edges
        v2, u2 = np.nonzero(ce)
        uv = np.concatenate([uv, np.stack([u2, v2], 1) + off[v2, u2]])
        dep = np.concatenate([dep, depth[v2 + y0, u2 + x0]])
    return uv + (x0, y0), dep.astype(np.float64)


def subsample(n_max: int, n: int, rng: np.random.Generator) -> np.ndarray:
    """Indices of at most n_max of n items (random, without replacement, sorted)."""
    if n <= n_max:
        return np.arange(n)
    return np.sort(np.argpartition(rng.random(n), n_max)[:n_max])


def _labels_box(inst: np.ndarray, margin_px: int) -> tuple[int, int, int, int] | None:
    """(y0, x0, y1, x1) of all labelled pixels grown by ``margin_px`` and clipped to the image
    (end exclusive); None when nothing is labelled."""
    H, W = inst.shape
    m = inst > 0
    if not m.any():
        return None
    ys, xs = np.nonzero(m.any(axis=1))[0], np.nonzero(m.any(axis=0))[0]
    return (max(ys[0] - margin_px, 0), max(xs[0] - margin_px, 0),
            min(ys[-1] + margin_px + 1, H), min(xs[-1] + margin_px + 1, W))


def _outward_directions() -> np.ndarray:
    """(16, 2) float32: the outward unit direction of a contour pixel for each 4-bit mask of the
    _N4 directions it borders in (the sum of those (du, dv), normalised; 0 for none)."""
    bits = np.arange(16)
    d = np.zeros((16, 2), np.float32)
    for k, (dv, du) in enumerate(_N4):
        d[(bits & (1 << k)) != 0] += (du, dv)
    n = np.linalg.norm(d, axis=1, keepdims=True)
    return np.where(n > 0, d / np.maximum(n, 1e-9), 0.0)


_OUTWARD = _outward_directions()


def all_contour_points(inst: np.ndarray, depth: np.ndarray, back_depth: np.ndarray | None = None,
                       back_inst: np.ndarray | None = None, max_chord_mm: float = MAX_RIM_CHORD_MM,
                       contact_mm: float = 0.0, junction_px: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`contour_points` for every label at once: uv (N, 2), depth (N,), label (N,).

    With ``back_depth`` / ``back_inst`` (the nearest back faces, see
    :attr:`ycbvss.render.RenderOutput.back_depth_mm`) the depth of a contour sample is the rim's
    (:func:`rim_depth`), not the depth of the surface at the contour pixel's centre.

    ``contact_mm`` > 0: a neighbour of another object makes a contour only when its surface lies at
    least that far behind (mm); nearer, the two surfaces touch (an object resting on another), and
    the image's edge there is the contact shadow's, not the silhouette's. 0: any farther surface.

    ``junction_px`` > 0: no contour samples within that distance (px, Euclidean) of a pixel where
    the same object borders a nearer one (:func:`junction_mask`)."""
    box = _labels_box(inst, 1)
    if box is None:
        return np.zeros((0, 2)), np.zeros(0), np.zeros(0, int)
    y0, x0, y1, x1 = box
    ic, dc = inst[y0:y1, x0:x1], depth[y0:y1, x0:x1]
    # the pixel rules in one compiled pass (refine.contour_kernel): bit k of ``bits`` = a contour
    # pixel bordering in direction _N4[k]
    dcc = np.ascontiguousarray(dc)
    bits, occ = contour_bits(np.ascontiguousarray(ic), dcc, dcc.dtype.type(contact_mm), contact_mm > 0.0,
                             junction_px > 0.0)
    is_c = bits != 0
    if junction_px > 0.0:
        is_c &= ~junction_mask(ic, occ, junction_px)
    if y0 == 0:
        is_c[0, :] = False
    if x0 == 0:
        is_c[:, 0] = False
    if y1 == inst.shape[0]:
        is_c[-1, :] = False
    if x1 == inst.shape[1]:
        is_c[:, -1] = False
    v, u = np.nonzero(is_c)
    d = _OUTWARD[bits[v, u]]                   # each contour pixel's outward unit direction
    uv = np.stack([u + x0, v + y0], 1).astype(np.float64) + 0.5 * d
    z = dc[v, u].astype(np.float64)
    if back_depth is not None and back_inst is not None:
        z = rim_depth(z, back_depth[y0:y1, x0:x1][v, u], back_inst[y0:y1, x0:x1][v, u] == ic[v, u], max_chord_mm)
    return uv, z, ic[v, u].astype(int)


def occluded_pixels(inst: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """(H, W) bool: object pixels with a 4-neighbour of another object that is nearer (smaller
    depth) -- where a nearer object cuts the object's silhouette."""
    d = np.ascontiguousarray(depth)
    return contour_bits(np.ascontiguousarray(inst), d, d.dtype.type(0), False, True)[1]


def junction_mask(inst: np.ndarray, occluded: np.ndarray, radius_px: float) -> np.ndarray:
    """(H, W) bool: the pixels of each object within ``radius_px`` (Euclidean) of one of its own
    ``occluded`` pixels (where it borders a nearer object).

    Where an occluder's silhouette cuts an object's (a T-junction), the image's edge field within
    the blur's reach of the junction mixes the two edges, and the occluded object's free contour
    there sees the occluder's edge as well as its own. Measured at the exact GT of suite short-1
    (frames 0, 9, 21; ``bench/bench_edge_pull.py``): the large clamp, 24 % visible behind the master
    chef can, gets 2.88 of its 3.95 /deg pull about its long axis from the 15-18 free contour samples
    per frame within 3 px of such pixels (of ~150), and ends 4.3 deg off."""
    # one compiled pass over the occluded pixels (refine.contour_kernel), the same pixels as each
    # object's exact distance transform to its own occluded pixels compared with the radius
    return near_own_occluded(np.ascontiguousarray(inst), np.ascontiguousarray(occluded, dtype=bool),
                             np.float32(radius_px))


def contact_samples(inst: np.ndarray, depth: np.ndarray, uv: np.ndarray, normals: np.ndarray, labels: np.ndarray,
                    contact_mm: float) -> np.ndarray:
    """(N,) bool: contour samples uv (N, 2; half a pixel outside their contour pixel, as
    :func:`all_contour_points` puts them) with outward unit normals (N, 2) whose outside pixel
    belongs to another object whose surface lies less than ``contact_mm`` behind the contour
    pixel's: a contact line, where the image's edge is the contact shadow's (see
    ``contact_mm`` of :func:`all_contour_points`). Samples without a normal are never contact."""
    H, W = inst.shape
    uv = np.asarray(uv, np.float64).reshape(-1, 2)
    inside = np.clip(np.floor(uv - 0.5 * normals + 0.5).astype(int), 0, [W - 1, H - 1])
    out = np.clip(np.floor(uv + 0.5 * normals + 0.5).astype(int), 0, [W - 1, H - 1])
    lab_o = inst[out[:, 1], out[:, 0]]
    d_in = depth[inside[:, 1], inside[:, 0]].astype(np.float64)
    d_out = depth[out[:, 1], out[:, 0]].astype(np.float64)
    has_n = np.any(normals != 0.0, axis=1)
    return has_n & (lab_o > 0) & (lab_o != labels) & (d_out - d_in < contact_mm)


def rim_depth(front_mm: np.ndarray, back_mm: np.ndarray, same_object: np.ndarray,
              max_chord_mm: float = MAX_RIM_CHORD_MM) -> np.ndarray:
    """Depth (mm) of the rim -- where the viewing ray grazes the surface -- seen at contour pixels
    whose ray enters the object at ``front_mm`` and leaves it at ``back_mm``: the chord's midpoint.

    The surface at a contour pixel's centre lies up to a pixel inside the silhouette, where a
    rounded side has already turned towards the camera: its depth is 1-10 mm nearer than the rim
    the silhouette belongs to (YCB-V objects at 1 m, 640 px), and a model point lifted there turns
    with the object about a lever arm the rim does not have. For a locally circular cross-section
    the midpoint of any chord parallel to the tangent ray lies at the tangent point's depth; for a
    convex smooth one it tends to it as the chord shrinks. Where the ray leaves through another
    object (``same_object`` False), not at all, or after a chord longer than ``max_chord_mm`` (it
    crossed a concavity), the front depth is kept."""
    ok = same_object & (back_mm > front_mm) & (back_mm - front_mm <= max_chord_mm)
    return np.where(ok, 0.5 * (front_mm + back_mm), front_mm)


def across_edge_directions(H: np.ndarray) -> np.ndarray:
    """(N, 2) unit eigenvectors of the largest eigenvalue of symmetric 2x2 matrices H (N, 2, 2): for
    E's Hessian at an edge sample, the direction across the edge (the angle of
    :func:`ycbvss.refine.terms.psd2`'s first eigenvector)."""
    a, b, c = H[:, 0, 0], 0.5 * (H[:, 0, 1] + H[:, 1, 0]), H[:, 1, 1]
    th = 0.5 * np.arctan2(2 * b, a - c)
    return np.stack([np.cos(th), np.sin(th)], 1)


def ridge_edges(color: np.ndarray, inside: np.ndarray, sigma_px: float = 1.0, min_strength: float = 8.0,
                iters: int = 4, max_move_px: float = 0.75) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Texture edges of a template crop ``color`` (h, w, 3 uint8) located with the operator the
    image's edge field uses (:func:`edge_field`, colour, blur ``sigma_px``, bicubic reading): the
    minima of the template's own E across the edge, inside ``inside`` (h, w) bool. A pixel is a
    candidate where the blurred colour edge strength is at least ``min_strength`` (sRGB levels per
    px) and E is lowest along its direction of largest curvature; Newton steps along that direction
    (at most 0.25 px each) move it to the minimum; candidates that move more than ``max_move_px`` or
    end where E curves down are dropped. Returns v, u (N,) the candidate pixels and uv (N, 2) the
    minima (crop coordinates, pixel centres at integers).

    Why: Canny on the raw grey template with a parabola on its blurred grey gradient puts a sample
    where the image's colour edge field, blurred and bicubically read, is not at its minimum; on
    fine print the difference is systematic (suite long-2's pudding box, at the exact GT with the
    template itself as the image: the interior samples pull its turn about model y by -2.66 / deg,
    -0.51 located this way; ``bench/bench_edge_pull.py``)."""
    mag = gradient_magnitude(color, sigma_px)       # colour edge strength, as edge_field(colour=True)
    tf = _field_from_magnitude(mag, sigma_px)
    v, u = np.nonzero(inside & (mag >= min_strength))
    H = np.empty((len(v), 2, 2))
    H[:, 0, 0], H[:, 0, 1], H[:, 1, 1] = tf.data[v, u, 3], tf.data[v, u, 4], tf.data[v, u, 5]
    H[:, 1, 0] = H[:, 0, 1]
    n = across_edge_directions(H)
    curved = np.einsum("ni,nij,nj->n", n, H, n) > 0     # E curves up across the edge
    v, u, n = v[curved], u[curved], n[curved]
    if len(v) == 0:
        return v, u, np.zeros((0, 2))
    p = np.stack([u, v], 1).astype(np.float64)
    e0 = tf.data[v, u, 0]
    ep = sample_field(tf, p + n)[0]
    em = sample_field(tf, p - n)[0]
    keep = (e0 <= ep) & (e0 < em)
    v, u, p, n = v[keep], u[keep], p[keep], n[keep]
    moved = np.zeros(len(p))
    h = 0.1                                   # px: the curvature along n from the bicubic interpolant itself
    for _ in range(iters):
        e0, g, _, _ = sample_field(tf, p)
        cn = (sample_field(tf, p + h * n)[0] - 2.0 * e0 + sample_field(tf, p - h * n)[0]) / (h * h)
        gn = np.einsum("ni,ni->n", g, n)
        step = np.clip(np.where(cn > 1e-9, -gn / np.maximum(cn, 1e-9), 0.0), -0.25, 0.25)
        p += step[:, None] * n
        moved += step
    e0 = sample_field(tf, p)[0]
    cn = sample_field(tf, p + h * n)[0] - 2.0 * e0 + sample_field(tf, p - h * n)[0]
    ok = (np.abs(moved) <= max_move_px) & (cn > 0)
    return v[ok], u[ok], p[ok]


def all_interior_points(inst: np.ndarray, depth: np.ndarray, color: np.ndarray, normal: np.ndarray | None,
                        canny_lo: float = 20.0, canny_hi: float = 60.0, erode_px: int = 2,
                        fold_min_angle_deg: float = 25.0, back_depth: np.ndarray | None = None,
                        back_inst: np.ndarray | None = None, texture_max_turn_deg: float = 0.0,
                        surface_normal: np.ndarray | None = None,
                        texture_min_sharpness: float = 0.0, texture_ridge_sigma_px: float = 0.0,
                        texture_ridge_min_strength: float = 8.0,
                        texture_turn_labels: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`interior_points` for every label at once: uv (N, 2), depth (N,), label (N,).
    ``normal`` None: no crease edges; ``fold_min_angle_deg``: see :func:`crease_edges`. With
    ``back_depth`` / ``back_inst`` a self-occlusion edge (a depth jump within the object, the near
    part's rim) is lifted at the rim's depth (:func:`rim_depth`), as the exterior contour.
    ``texture_max_turn_deg`` > 0 with ``surface_normal`` (the rendered normals, H x W x 3): texture
    (Canny) edges only where the surface is flat at the pixel scale
    (:func:`ycbvss.refine.interior_edges.flat_at`); where one is dropped a crease edge may take its
    place; ``texture_turn_labels``: only the texture edges of these labels are gated (None: all).
    ``texture_min_sharpness`` > 0: texture edges only where they are sharp
    (:func:`ycbvss.refine.interior_edges.sharp_at`), not on soft colour ramps.
    ``texture_ridge_sigma_px`` > 0: texture edges located by :func:`ridge_edges` at that blur (the
    image edge field's operator; strength at least ``texture_ridge_min_strength``), not by Canny."""
    box = _labels_box(inst, 2)
    if box is None:
        return np.zeros((0, 2)), np.zeros(0), np.zeros(0, int)
    y0, x0, y1, x1 = box
    ic = inst[y0:y1, x0:x1]
    lab = ic.astype(np.float32)
    k = np.ones((2 * erode_px + 1, 2 * erode_px + 1), np.uint8)
    inside = (ic > 0) & (cv2.erode(lab, k) == lab) & (cv2.dilate(lab, k) == lab) if erode_px > 0 else ic > 0
    gray = cv2.cvtColor(np.ascontiguousarray(color[y0:y1, x0:x1]), cv2.COLOR_RGB2GRAY)
    if texture_ridge_sigma_px > 0:
        rv, ru, ruv = ridge_edges(np.ascontiguousarray(color[y0:y1, x0:x1]), inside, texture_ridge_sigma_px,
                                  texture_ridge_min_strength)
        edges = np.zeros(inside.shape, bool)
        edges[rv, ru] = True
        sub = np.zeros(inside.shape + (2,))
        sub[rv, ru] = ruv - np.stack([ru, rv], 1)
    else:
        edges = (cv2.Canny(gray, canny_lo, canny_hi) > 0) & inside
    if texture_min_sharpness > 0:
        v, u = np.nonzero(edges)
        edges[v, u] = sharp_at(gray, v, u, texture_min_sharpness)
    if texture_max_turn_deg > 0 and surface_normal is not None:
        v, u = np.nonzero(edges)
        keep = flat_at(surface_normal[y0:y1, x0:x1], ic, np.stack([u, v], 1).astype(np.float64),
                       texture_max_turn_deg)
        if texture_turn_labels is not None:
            keep |= ~np.isin(ic[v, u], np.asarray(texture_turn_labels, int))
        edges[v, u] = keep
    v, u = np.nonzero(edges)
    uv = np.stack([u, v], 1).astype(np.float64) + (sub[v, u] if texture_ridge_sigma_px > 0 else subpixel_offsets(gray, v, u))
    dep, labs = depth[v + y0, u + x0], ic[v, u]
    if normal is not None:
        ce, off, jumps = crease_edges(normal[y0:y1, x0:x1], depth[y0:y1, x0:x1], min_angle_deg=fold_min_angle_deg,
                                      inst=ic, with_jumps=True)
        ce &= inside & ~edges
        v2, u2 = np.nonzero(ce)
        d2 = depth[v2 + y0, u2 + x0].astype(np.float64)
        if back_depth is not None and back_inst is not None:
            jv = jumps[v2, u2]
            d2[jv] = rim_depth(d2[jv], back_depth[v2[jv] + y0, u2[jv] + x0],
                               back_inst[v2[jv] + y0, u2[jv] + x0] == ic[v2[jv], u2[jv]])
        uv = np.concatenate([uv, np.stack([u2, v2], 1) + off[v2, u2]])
        dep = np.concatenate([dep, d2])
        labs = np.concatenate([labs, ic[v2, u2]])
    return uv + (x0, y0), dep.astype(np.float64), labs.astype(int)
