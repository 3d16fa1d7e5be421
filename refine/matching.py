"""Point matches from dense optical flow (paper Sec. 3.2): Farneback flow between a source and a
destination image, a reciprocal (forward-backward) check, taken at Shi-Tomasi corners of the source.
"""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import cv2
import numpy as np

from .edge import sample_bilinear


@dataclass
class FlowOptions:
    """Farneback parameters, reciprocal-check threshold and corner detector settings."""

    pyr_scale: float = 0.5
    levels: int = 3
    winsize: int = 15
    iterations: int = 3
    poly_n: int = 5
    poly_sigma: float = 1.1
    check_px: float = 0.75        # forward-backward consistency threshold
    max_corners: int = 1000
    quality: float = 0.01
    min_distance_px: int = 3
    min_eig: float = 5e-4         # absolute Shi-Tomasi threshold (cv2.cornerMinEigenVal, block 3) on the image blurred
                                  # with sigma 1 px: image noise on textureless surfaces stays below it
    # f_point's template and image are contrast-normalised (normalize_for_flow) over this blur (px) before
    # the flow. Session 83 (bench/results/ycbv21/README.md): at the exact GT the lit template's matches of
    # a small textured object read its apparent size off by a per-(scene, object) scale of rms 0.17 %
    # (ycbv21 1-9) and 0.18 % (ycbv21-long2; the gelatin box of long-62 +0.48 %) at 6 px, 0.13 % at 3 px
    template_norm_sigma_px: float = 6.0


def _gray_u8(img: np.ndarray) -> np.ndarray:
    img = np.asarray(img)
    if img.ndim == 3:
        img = cv2.cvtColor(img.astype(np.uint8), cv2.COLOR_RGB2GRAY)
    return np.ascontiguousarray(img.astype(np.uint8))


CORNER_MARGIN_PX = 8   # crop margin around a mask for the corner detector (its response reaches 3 px)

_POOL: tuple[int, ThreadPoolExecutor] | None = None   # (owning pid, executor)


def _pool() -> ThreadPoolExecutor:
    """One worker thread per process for the second flow of a pair (OpenCV releases the GIL).
    A forked child (Ray / multiprocessing worker) does not inherit the thread: it makes its own."""
    global _POOL
    if _POOL is None or _POOL[0] != os.getpid():
        _POOL = (os.getpid(), ThreadPoolExecutor(max_workers=1, thread_name_prefix="ycbvss-flow"))
    return _POOL[1]


def dense_flow(src: np.ndarray, dst: np.ndarray, opt: FlowOptions, init: np.ndarray | None = None) -> np.ndarray:
    """Farneback flow (H, W, 2) float32: src(x) ~ dst(x + flow(x)). ``init`` (H, W, 2): a predicted
    flow to start from (``cv2.OPTFLOW_USE_INITIAL_FLOW``), e.g. :func:`ycbvss.refine.flow_prior.predicted_flow`."""
    if init is None:
        return cv2.calcOpticalFlowFarneback(_gray_u8(src), _gray_u8(dst), None, opt.pyr_scale, opt.levels,
                                            opt.winsize, opt.iterations, opt.poly_n, opt.poly_sigma, 0)
    flow = np.array(init, dtype=np.float32, copy=True, order="C")
    return cv2.calcOpticalFlowFarneback(_gray_u8(src), _gray_u8(dst), flow, opt.pyr_scale, opt.levels,
                                        opt.winsize, opt.iterations, opt.poly_n, opt.poly_sigma,
                                        cv2.OPTFLOW_USE_INITIAL_FLOW)


def dense_flow_pair(a: np.ndarray, b: np.ndarray, opt: FlowOptions, init_ab: np.ndarray | None = None,
                    init_ba: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(:func:`dense_flow` (a, b), :func:`dense_flow` (b, a)), the two computed concurrently
    (the backward one in a worker thread); the same flows as two sequential calls. ``init_ab`` /
    ``init_ba``: predicted flows to start each from."""
    ga, gb = _gray_u8(a), _gray_u8(b)
    bwd = _pool().submit(dense_flow, gb, ga, opt, init_ba)
    try:
        fwd = dense_flow(ga, gb, opt, init_ab)
    finally:
        out = bwd.result()
    return fwd, out


def warp_by_flow(img: np.ndarray, flow: np.ndarray) -> np.ndarray:
    """``img`` resampled at x + flow(x) (bilinear, border replicated): the image a flow predicts
    for the source view."""
    h, w = flow.shape[:2]
    gx, gy = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    return cv2.remap(img, gx + flow[..., 0], gy + flow[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def residual_flow_pair(a: np.ndarray, b: np.ndarray, opt: FlowOptions, prior_ab: np.ndarray,
                       prior_ba: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Forward and backward flow between a and b as a prediction plus what Farneback finds between
    one image and the other warped by that prediction: with b_w(x) = b(x + prior(x)) and
    a(x) ~ b_w(x + r(x)), flow(x) = r(x) + prior(x + r(x)). Farneback's smoothing then acts on the residual r only; on
    the full flow of a wide pair it compresses the motion differences between near and far
    points by 1-2 % (``bench/bench_temporal_flow.py``)."""
    ga, gb = _gray_u8(a), _gray_u8(b)
    bwd = _pool().submit(dense_flow, gb, warp_by_flow(ga, prior_ba), opt)
    try:
        fwd = dense_flow(ga, warp_by_flow(gb, prior_ab), opt)
    finally:
        back = bwd.result()
    # a(x) ~ b_w(x + r(x)) = b(x + r(x) + prior(x + r(x))): the prediction is read where r points
    return fwd + warp_by_flow(prior_ab, fwd), back + warp_by_flow(prior_ba, back)


def _mask_box(mask: np.ndarray, margin: int) -> tuple[int, int, int, int]:
    """Bounding box (y0, y1, x0, x1) of a non-empty mask grown by ``margin`` px, clipped to it."""
    H, W = mask.shape
    ys = np.flatnonzero(mask.any(axis=1))
    xs = np.flatnonzero(mask.any(axis=0))
    return (max(int(ys[0]) - margin, 0), min(int(ys[-1]) + 1 + margin, H),
            max(int(xs[0]) - margin, 0), min(int(xs[-1]) + 1 + margin, W))


def min_eig_map(img: np.ndarray) -> np.ndarray:
    """Shi-Tomasi response (cv2.cornerMinEigenVal, block 3) of the image blurred with sigma 1 px (H, W) float32."""
    return cv2.cornerMinEigenVal(cv2.GaussianBlur(_gray_u8(img), (0, 0), 1.0), 3, 3)


def corners(img: np.ndarray, mask: np.ndarray | None, opt: FlowOptions, max_n: int | None = None,
            me: np.ndarray | None = None) -> np.ndarray:
    """Shi-Tomasi corners (N, 2) float64 of an image inside ``mask`` (``me``: precomputed :func:`min_eig_map`).

    The detector runs on the mask's bounding box grown by ``CORNER_MARGIN_PX`` (the same corners
    as on the whole image: its response, local-maximum test and quality level, relative to the
    strongest response inside the mask, only see pixels that close to the mask)."""
    if mask is not None and not np.any(mask):
        return np.zeros((0, 2))
    g = _gray_u8(img)
    y0 = x0 = 0
    gc, mc = g, None
    if mask is not None:
        y0, y1, x0, x1 = _mask_box(mask, CORNER_MARGIN_PX)
        gc = np.ascontiguousarray(g[y0:y1, x0:x1])
        mc = np.ascontiguousarray(mask[y0:y1, x0:x1], dtype=np.uint8)
    pts = cv2.goodFeaturesToTrack(gc, maxCorners=int(max_n or opt.max_corners), qualityLevel=opt.quality,
                                  minDistance=opt.min_distance_px, mask=mc)
    if pts is None:
        return np.zeros((0, 2))
    pts = pts.reshape(-1, 2).astype(np.float64) + (x0, y0)
    if opt.min_eig > 0:   # absolute threshold: a uniform (textureless) region yields no corners at all
        me = min_eig_map(g) if me is None else me
        pts = pts[me[pts[:, 1].astype(int), pts[:, 0].astype(int)] >= opt.min_eig]
    return pts


def reciprocal_matches(pts: np.ndarray, fwd: np.ndarray, bwd: np.ndarray, check_px: float
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Map pts (N, 2) of the source by ``fwd``; keep those whose backward flow returns within check_px.

    Returns (src_pts (M, 2), dst_pts (M, 2))."""
    if len(pts) == 0:
        return np.zeros((0, 2)), np.zeros((0, 2))
    f, ok1 = sample_bilinear(fwd, pts)
    q = pts + f
    b, ok2 = sample_bilinear(bwd, q)
    err = np.linalg.norm(f + b, axis=1)
    keep = ok1 & ok2 & (err < check_px)
    return pts[keep], q[keep]


def flow_matches(src: np.ndarray, dst: np.ndarray, src_masks: list[np.ndarray], opt: FlowOptions,
                 flows: tuple[np.ndarray, np.ndarray] | None = None, corner_image: np.ndarray | None = None,
                 dst_image: np.ndarray | None = None, corner_me: np.ndarray | None = None,
                 dst_me: np.ndarray | None = None) -> list[tuple[np.ndarray, np.ndarray]]:
    """Matches src -> dst at corners of ``corner_image`` (default ``src``) inside each mask of
    ``src_masks`` (one list entry per mask). ``flows`` = (fwd, bwd) may be passed to reuse flows.
    With ``dst_image`` a match must also land on texture there (min eigenvalue >= min_eig / 4):
    flow into a uniform region passes the reciprocal check but carries no information."""
    if flows is None:
        flows = dense_flow_pair(src, dst, opt)
    fwd, bwd = flows
    ci = src if corner_image is None else corner_image
    if opt.min_eig > 0 and corner_me is None and len(src_masks) > 1:
        corner_me = min_eig_map(ci)          # once for all masks
    me_dst = None
    if opt.min_eig > 0 and (dst_image is not None or dst_me is not None):
        me_dst = (min_eig_map(dst_image) if dst_me is None else dst_me)[..., None]
    out = []
    for m in src_masks:
        a, b = reciprocal_matches(corners(ci, m, opt, me=corner_me), fwd, bwd, opt.check_px)
        if me_dst is not None and len(b):
            keep = sample_bilinear(me_dst, b)[0][:, 0] >= 0.25 * opt.min_eig
            a, b = a[keep], b[keep]
        out.append((a, b))
    return out


def normalize_for_flow(img: np.ndarray, sigma_px: float = 6.0) -> np.ndarray:
    """Local contrast normalisation (gray, zero local mean, unit local std -> uint8) so that flow
    between an unlit rendered template and a lit photo is not fooled by shading/gain differences."""
    g = _gray_u8(img).astype(np.float32)
    mu = cv2.GaussianBlur(g, (0, 0), sigma_px)
    hp = g - mu
    sd = np.sqrt(cv2.GaussianBlur(hp * hp, (0, 0), 2 * sigma_px)) + 4.0
    return np.clip(128.0 + 48.0 * hp / sd, 0, 255).astype(np.uint8)
