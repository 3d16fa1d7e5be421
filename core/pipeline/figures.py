"""Figures of the validation report: contour overlays (original / YCBV-SS / initial / refined) and
error (accuracy) curves. Pure image functions plus thin PNG writers."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ..io.atomic import atomic_path
from ..io.images import write_png
from ..viz import contour_overlay, put_label, pyplot, side_by_side

# RGB colours of the pose sets in overlays and curves
# (initial is magenta, not red: a red contour vanishes on the red mug and the red cans)
COLORS = {"gt": (255, 255, 255), "original": (255, 170, 0), "initial": (255, 0, 255), "refined": (40, 200, 60),
          "using all": (40, 200, 60),
          "w/o f_edge": (80, 160, 255), "w/o f_point": (200, 90, 255), "w/o f_t": (255, 150, 40)}


def render_instances(renderer, models: dict, K: np.ndarray, width: int, height: int, poses: dict) -> np.ndarray:
    """obj_id per pixel (0 = none) for ``poses`` {obj_id: T_m2c}, with mutual occlusion."""
    items, ids = [], []
    for oid, T in sorted(poses.items()):
        key = ("pipeline", oid)
        if not renderer.has_mesh(key):
            renderer.add_mesh(key, models[oid].mesh)
        items.append((key, T))
        ids.append(oid)
    if not items:
        return np.zeros((height, width), np.int32)
    out = renderer.render(K, width, height, items, outputs=("instance",))
    lut = np.array([0] + ids, np.int32)
    return lut[out.instance]


def panel(image_rgb: np.ndarray, maps: list[tuple[np.ndarray, tuple, int]], label: str) -> np.ndarray:
    """``image_rgb`` with the object outlines of each (obj_map, RGB colour, thickness) drawn in
    order (ycbvss.viz.contour_overlay) and a label in the top-left corner."""
    im = image_rgb
    for om, color, thick in maps:
        ids = [int(o) for o in np.unique(om) if o != 0]
        if ids:
            im = contour_overlay(im, [om == o for o in ids], colors=color, thickness=thick)
    # the label is the panel's legend: "<set> (colour)" written in the set's own colour, "GT white" beside it
    sets = [tuple(c) for _, c, _ in maps if tuple(c) != COLORS["gt"]]
    has_gt = any(tuple(c) == COLORS["gt"] for _, c, _ in maps)
    legend = f"{label} (this colour)" + (", GT white" if has_gt else "") if sets else label
    color = sets[-1] if sets else (255, 255, 255)
    return put_label(im, legend, scale=max(0.4, image_rgb.shape[0] / 900.0), color=color)


def crop_box(obj_maps: list[np.ndarray], pad_frac: float = 0.08) -> tuple[int, int, int, int] | None:
    """Bounding box (x0, y0, x1, y1) of all objects in the given maps, padded."""
    m = np.zeros_like(obj_maps[0], bool)
    for om in obj_maps:
        m |= om > 0
    ys, xs = np.nonzero(m)
    if len(xs) == 0:
        return None
    H, W = m.shape
    pad = int(pad_frac * max(np.ptp(xs), np.ptp(ys)))
    return (max(0, xs.min() - pad), max(0, ys.min() - pad), min(W, xs.max() + pad + 1), min(H, ys.max() + pad + 1))


def overlay_figure(image_rgb: np.ndarray, gt_map: np.ndarray | None, maps: dict[str, np.ndarray],
                   original_rgb: np.ndarray | None = None, image_label: str = "YCBV-SS",
                   original_label: str = "original", crop: bool = True) -> np.ndarray:
    """One row of panels: [original image], the image (+ GT outlines in white), then one panel per
    pose set in ``maps`` (e.g. initial, refined) with its outlines over the thin white GT ones.
    With ``crop`` all panels are cropped to the objects' bounding box."""
    box = crop_box([m for m in [gt_map, *maps.values()] if m is not None]) if crop else None
    def c(a):
        return a if (box is None or a is None) else a[box[1]:box[3], box[0]:box[2]]
    image_rgb, gt_map, original_rgb = c(image_rgb), c(gt_map), c(original_rgb)
    maps = {k: c(v) for k, v in maps.items()}
    gt_layer = [] if gt_map is None else [(gt_map, COLORS["gt"], 1)]
    panels = []
    if original_rgb is not None:
        panels.append(panel(original_rgb, [], original_label))
    panels.append(panel(image_rgb, gt_layer, image_label + (" + GT" if gt_map is not None else "")))
    for name, om in maps.items():
        panels.append(panel(image_rgb, gt_layer + [(om, COLORS.get(name, (255, 255, 0)), 2)], name))
    return side_by_side(panels, gap=4, background=(255, 255, 255))


def write_overlay(path: str | Path, fig_rgb: np.ndarray, max_width: int = 2400) -> Path:
    if fig_rgb.shape[1] > max_width:
        s = max_width / fig_rgb.shape[1]
        fig_rgb = cv2.resize(fig_rgb, (max_width, int(round(fig_rgb.shape[0] * s))), interpolation=cv2.INTER_AREA)
    write_png(path, fig_rgb)
    return Path(path)


def error_curves_png(path: str | Path, series: dict[str, dict], add_max_mm: float = 30.0,
                     prj_max_px: float = 10.0, title: str = "") -> Path:
    """Accuracy curves (fraction of (view, object) pairs with error <= threshold) of ADD and PRJ
    for each pose set in ``series`` {name: {"add_mm": array, "prj_px": array}}; one PNG, 2 panels."""
    plt = pyplot()


    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), dpi=110)
    for ax, key, xmax, xlabel in ((axes[0], "add_mm", add_max_mm, "ADD threshold (mm)"),
                                  (axes[1], "prj_px", prj_max_px, "PRJ threshold (px)")):
        th = np.linspace(0, xmax, 301)
        for name, err in series.items():
            e = np.asarray(err.get(key, []), np.float64)
            e = e[np.isfinite(e)]
            if len(e) == 0:
                continue
            acc = (e[None, :] <= th[:, None]).mean(axis=1)
            col = np.asarray(COLORS.get(name, (100, 100, 100))) / 255.0
            ax.plot(th, acc, label=f"{name} (mean {e.mean():.2f})", color=col, lw=1.8)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("fraction of poses")
        ax.set_xlim(0, xmax)
        ax.set_ylim(0, 1.02)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="lower right")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    with atomic_path(path, ".png") as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)
    return Path(path)
