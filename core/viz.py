"""Overlay and layout utilities for previews and validation reports (OpenCV drawing, RGB uint8 images).

All functions take and return RGB ``uint8`` images (H, W, 3); inputs that are grey (H, W), bool or float
(assumed in [0, 1]) are converted with :func:`to_rgb8`.  Nothing here modifies its inputs.
"""
from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from .errors import YcbvssError

# distinct colours (RGB) for instance contours; cycles when there are more masks
PALETTE = np.array([
    [255, 64, 64], [64, 220, 64], [64, 128, 255], [255, 210, 0], [255, 0, 255], [0, 230, 230],
    [255, 140, 0], [160, 90, 255], [150, 255, 120], [255, 120, 180], [0, 160, 120], [200, 200, 200],
], dtype=np.uint8)


def to_rgb8(image: np.ndarray) -> np.ndarray:
    """(H, W), (H, W, 1), (H, W, 3) or (H, W, 4) image of bool / uint8 / uint16 / float (in [0, 1]) -> RGB uint8.

    uint16 is scaled by 1/257; float is clipped to [0, 1]; NaN/inf become 0; alpha is dropped.
    """
    a = np.asarray(image)
    if a.ndim == 3 and a.shape[2] == 1:
        a = a[..., 0]
    if a.ndim not in (2, 3) or (a.ndim == 3 and a.shape[2] not in (3, 4)) or a.size == 0:
        raise YcbvssError(f"viz: expected an (H,W), (H,W,3) or (H,W,4) image, got shape {a.shape}", where="ycbvss.viz")
    if a.dtype == bool:
        a = a.astype(np.uint8) * 255
    elif a.dtype == np.uint16:
        a = (a.astype(np.uint32) // 257).astype(np.uint8)
    elif np.issubdtype(a.dtype, np.floating):
        a = np.nan_to_num(a.astype(np.float64), nan=0.0, posinf=0.0, neginf=0.0)
        a = np.rint(np.clip(a, 0.0, 1.0) * 255.0).astype(np.uint8)
    elif a.dtype != np.uint8:
        a = np.clip(a, 0, 255).astype(np.uint8)
    if a.ndim == 2:
        a = np.repeat(a[..., None], 3, axis=2)
    return np.ascontiguousarray(a[..., :3])


def colorize_depth(depth_mm: np.ndarray, vmin_mm: float | None = None, vmax_mm: float | None = None,
                   colormap: int = cv2.COLORMAP_TURBO) -> np.ndarray:
    """Depth (mm, 0 = invalid) -> RGB uint8 with an OpenCV colormap (near = blue end); invalid pixels black."""
    d = np.asarray(depth_mm, dtype=np.float64)
    valid = np.isfinite(d) & (d > 0)
    if not valid.any():
        return np.zeros(d.shape + (3,), np.uint8)
    lo = float(np.percentile(d[valid], 1)) if vmin_mm is None else float(vmin_mm)
    hi = float(np.percentile(d[valid], 99)) if vmax_mm is None else float(vmax_mm)
    x = np.clip((d - lo) / max(hi - lo, 1e-9), 0.0, 1.0)
    bgr = cv2.applyColorMap(np.rint(x * 255).astype(np.uint8), colormap)
    rgb = bgr[..., ::-1].copy()
    rgb[~valid] = 0
    return rgb


def _colors(n: int, colors) -> np.ndarray:
    if colors is None:
        return PALETTE[np.arange(n) % len(PALETTE)]
    c = np.asarray(colors)
    if c.ndim == 1:
        c = np.tile(c, (n, 1))
    if c.shape != (n, 3):
        raise YcbvssError(f"viz: need {n} RGB colours (or one), got shape {c.shape}", where="ycbvss.viz")
    return np.clip(c, 0, 255).astype(np.uint8)


def contour_overlay(image_rgb: np.ndarray, masks: Sequence[np.ndarray], colors=None, thickness: int = 1) -> np.ndarray:
    """Draw the exterior contour of every mask on a copy of the image (contour pixels lie on the mask's own
    border pixels, drawn inward).  ``colors``: one RGB per mask, a single RGB, or None (palette)."""
    img = to_rgb8(image_rgb).copy()
    masks = list(masks)
    cols = _colors(len(masks), colors)
    H, W = img.shape[:2]
    for k, m in enumerate(masks):
        m = np.asarray(m)
        if m.shape != (H, W):
            raise YcbvssError(f"viz: mask {k} has shape {m.shape}, image is {(H, W)}", where="ycbvss.viz")
        m8 = (m > 0).astype(np.uint8)
        if not m8.any():
            continue
        contours, _ = cv2.findContours(m8, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        if thickness <= 1:
            cv2.drawContours(img, contours, -1, tuple(int(x) for x in cols[k]), 1)
        else:
            # thick: the outermost `thickness` pixels of the (hole-filled) mask, i.e. drawn inward only
            fill = np.zeros((H, W), np.uint8)
            cv2.drawContours(fill, contours, -1, 1, -1)
            inner = cv2.erode(fill, np.ones((3, 3), np.uint8), iterations=int(thickness),
                              borderType=cv2.BORDER_CONSTANT, borderValue=0)
            img[(fill > 0) & (inner == 0)] = cols[k]
    return img


def blend_render(image_rgb: np.ndarray, render_rgb: np.ndarray, mask: np.ndarray, alpha: float = 0.5) -> np.ndarray:
    """``(1 - alpha) * image + alpha * render`` inside ``mask``, the image unchanged outside."""
    img = to_rgb8(image_rgb)
    ren = to_rgb8(render_rgb)
    m = np.asarray(mask) > 0
    if ren.shape != img.shape or m.shape != img.shape[:2]:
        raise YcbvssError(f"viz: blend_render shapes differ: image {img.shape}, render {ren.shape}, mask {m.shape}",
                          where="ycbvss.viz")
    if not 0.0 <= alpha <= 1.0:
        raise YcbvssError(f"viz: alpha must be in [0, 1], got {alpha}", where="ycbvss.viz")
    out = img.copy()
    mix = (1.0 - alpha) * img[m].astype(np.float32) + alpha * ren[m].astype(np.float32)
    out[m] = np.clip(np.rint(mix), 0, 255).astype(np.uint8)
    return out


def put_label(image_rgb: np.ndarray, text: str, org: tuple[int, int] = (4, 4), scale: float = 0.5,
              color=(255, 255, 255), background=(0, 0, 0)) -> np.ndarray:
    """Copy of the image with ``text`` (cv2.putText) on a filled box whose top-left corner is ``org``."""
    img = to_rgb8(image_rgb).copy()
    if not text:
        return img
    font, thick = cv2.FONT_HERSHEY_SIMPLEX, 1
    (tw, th), base = cv2.getTextSize(text, font, scale, thick)
    x, y = int(org[0]), int(org[1])
    cv2.rectangle(img, (x, y), (x + tw + 4, y + th + base + 4), tuple(int(c) for c in background), -1)
    cv2.putText(img, text, (x + 2, y + th + 2), font, scale, tuple(int(c) for c in color), thick, cv2.LINE_AA)
    return img


def _pad_to(img: np.ndarray, h: int, w: int, bg) -> np.ndarray:
    out = np.empty((h, w, 3), np.uint8)
    out[:] = np.asarray(bg, dtype=np.uint8)
    out[:img.shape[0], :img.shape[1]] = img
    return out


def contact_sheet(images: Sequence[np.ndarray], cols: int, labels: Sequence[str] | None = None, gap: int = 2,
                  background=(32, 32, 32)) -> np.ndarray:
    """Grid of images, ``cols`` per row, each cell as large as the largest image (smaller ones padded at the
    bottom/right), ``gap`` pixels between cells.  Size: ``rows*h + (rows-1)*gap`` by ``cols*w + (cols-1)*gap``
    with ``rows = ceil(n / cols)``.  ``labels`` (optional, one per image) are drawn top-left in each cell."""
    imgs = [to_rgb8(im) for im in images]
    if not imgs:
        raise YcbvssError("viz: contact_sheet needs at least one image", where="ycbvss.viz")
    if cols < 1:
        raise YcbvssError(f"viz: cols must be >= 1, got {cols}", where="ycbvss.viz")
    if labels is not None and len(labels) != len(imgs):
        raise YcbvssError(f"viz: {len(labels)} labels for {len(imgs)} images", where="ycbvss.viz")
    cols = min(int(cols), len(imgs))
    rows = -(-len(imgs) // cols)
    h = max(im.shape[0] for im in imgs)
    w = max(im.shape[1] for im in imgs)
    gap = max(int(gap), 0)
    sheet = np.empty((rows * h + (rows - 1) * gap, cols * w + (cols - 1) * gap, 3), np.uint8)
    sheet[:] = np.asarray(background, dtype=np.uint8)
    for k, im in enumerate(imgs):
        if labels is not None and labels[k]:
            im = put_label(im, str(labels[k]))
        r, c = divmod(k, cols)
        y, x = r * (h + gap), c * (w + gap)
        sheet[y:y + h, x:x + w] = _pad_to(im, h, w, background)
    return sheet


def side_by_side(images: Sequence[np.ndarray], labels: Sequence[str] | None = None, gap: int = 2,
                 background=(32, 32, 32)) -> np.ndarray:
    """Images in one row, each keeping its width (shorter ones padded at the bottom), ``gap`` px apart;
    ``labels`` (optional, one per image) drawn top-left of each panel with cv2.putText.
    Size: ``max(h)`` by ``sum(w) + (n-1)*gap``."""
    imgs = [to_rgb8(im) for im in images]
    if not imgs:
        raise YcbvssError("viz: side_by_side needs at least one image", where="ycbvss.viz")
    if labels is not None and len(labels) != len(imgs):
        raise YcbvssError(f"viz: {len(labels)} labels for {len(imgs)} images", where="ycbvss.viz")
    gap = max(int(gap), 0)
    h = max(im.shape[0] for im in imgs)
    panels = []
    for k, im in enumerate(imgs):
        if labels is not None and labels[k]:
            im = put_label(im, str(labels[k]))
        panels.append(_pad_to(im, h, im.shape[1], background))
        if gap and k < len(imgs) - 1:
            panels.append(_pad_to(np.zeros((0, 0, 3), np.uint8), h, gap, background))
    return np.concatenate(panels, axis=1)


def pyplot():
    """``matplotlib.pyplot`` with the non-interactive Agg backend, imported on first use."""
    # lazy: matplotlib takes ~0.9 s to import
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    return plt
