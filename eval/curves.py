"""Accuracy-vs-threshold curves (PNG): ADD(-S) on 0..100 mm and PRJ on 0..10 px.

One thin curve per object and a thick mean curve (mean over objects of the per-object curves, so
its normalised area equals the overall AUC). Missing estimates never pass a threshold.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.atomic import atomic_path
from ..viz import pyplot
from .scores import ADD_BOUND_MM, PRJ_BOUND_PX, accuracy_curve


def plot_curves(add_errors: dict, prj_errors: dict, out_png: str | Path, names: dict | None = None,
                add_bound_mm: float = ADD_BOUND_MM, prj_bound_px: float = PRJ_BOUND_PX,
                title: str = "", n_thresholds: int = 201) -> Path:
    """``add_errors`` / ``prj_errors``: obj_id -> (n,) errors (ADD(-S) mm / PRJ px, NaN = missing)."""
    plt = pyplot()

    names = names or {}
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), constrained_layout=True)
    panels = ((axes[0], add_errors, add_bound_mm, "ADD(-S) threshold (mm)"),
              (axes[1], prj_errors, prj_bound_px, "PRJ threshold (px)"))
    cmap = plt.get_cmap("tab20")
    for ax, errs, bound, xlabel in panels:
        ax.set_title(xlabel.split(" threshold")[0])
        thr = np.linspace(0.0, bound, n_thresholds)
        curves = []
        for i, o in enumerate(sorted(errs)):
            c = accuracy_curve(errs[o], thr)
            if np.all(np.isnan(c)):
                continue
            curves.append(c)
            ax.plot(thr, c, lw=0.9, alpha=0.8, color=cmap(i % 20), label=str(names.get(o, o)))
        if curves:
            mean = np.mean(curves, axis=0)
            auc = float(np.trapz(mean, thr) / bound)
            ax.plot(thr, mean, lw=2.6, color="black", label=f"mean (AUC {auc:.1f})")
            ax.set_title(f"{xlabel.split(' threshold')[0]}: mean over {len(curves)} objects, AUC {auc:.1f}")
        style_accuracy_axes(ax, bound, xlabel)
    axes[1].legend(fontsize=6, ncol=2, loc="lower right")
    return save_png(fig, out_png, 120, title)


def style_accuracy_axes(ax, bound: float, xlabel: str) -> None:
    """Axes of an accuracy curve: x from 0 to the threshold bound, y accuracy 0..100 %, a light grid."""
    ax.set_xlim(0, bound)
    ax.set_ylim(0, 100)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("accuracy (%)")
    ax.grid(alpha=0.3)


def save_png(fig, out_png: str | Path, dpi: int, title: str = "") -> Path:
    """Write a matplotlib figure as PNG (atomically), with an optional overall title; closes it."""
    if title:
        fig.suptitle(title)
    out_png = Path(out_png)
    with atomic_path(out_png) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    pyplot().close(fig)
    return out_png
