"""Where a Blender image's interior (texture) edges lie relative to the template's at the exact GT,
by how sharp the template edge is.

f_edge's interior samples are the template's Canny edges; the image edge they are pulled to is the
edge-field minimum near them. A soft edge (a colour ramp over several pixels: the scans' baked
shading, a banana's darker flank) has its gradient maximum wherever the scene's shading tilts the
ramp, so its image position depends on the lighting the template does not have. This bench
measures that: for every Canny edge pixel of the template (unlit texture, the refiner's default;
eroded 2 px from the object's border, as the refiner takes them) the edge-field minimum (colour
gradient, sigma 1 px) of the Cycles image and of the template composited onto that image, searched
along the template's grey-level gradient (+-1.5 px); offset = image minus template (px, towards the
brighter side +). Sharpness = |grad| at sigma 1 / |grad| at sigma 2.5 of the template's grey
levels: 2.0-2.3 for a step edge, towards 1 for a ramp much wider than 2.5 px.

The image is the suite's Cycles render, never the fast renderer's.

    python bench/bench_interior_offsets.py --suite-root /tmp/suite/full --dataset ../shared/data/ycbv \
        --scenes 1,2,4,5 --frames 0,20 --out bench/results/ycbv21
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

SHARPNESS_BINS = (0.0, 1.4, 1.8, 2.2, np.inf)


def gradient_direction(gray: np.ndarray, v: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Unit grey-level gradient direction (N, 2) at pixels (v, u) after a sigma-1 blur."""
    import cv2

    g = cv2.GaussianBlur(gray, (0, 0), 1.0)
    d = np.stack([cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3)[v, u], cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3)[v, u]], 1)
    return d.astype(np.float64) / (np.linalg.norm(d, axis=1, keepdims=True) + 1e-9)


def main() -> None:
    import cv2

    from bench_contour_offsets import add_view_args, gt_views
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.refine.contour_match import _minimum_along
    from ycbvss.refine.edge import edge_field
    from ycbvss.refine.interior_edges import sharpness_ratio
    from ycbvss.refine.templates import composite

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_view_args(ap)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    recs = []          # (obj_id, sharpness, offset px)
    models: dict = {}
    for models, sid, fr, img, vr, oids in gt_views(a):
        gray = cv2.cvtColor(np.ascontiguousarray(vr.color), cv2.COLOR_RGB2GRAY)
        lab = vr.instance.astype(np.float32)
        k = np.ones((5, 5), np.uint8)
        inside = (vr.instance > 0) & (cv2.erode(lab, k) == lab) & (cv2.dilate(lab, k) == lab)
        v, u = np.nonzero((cv2.Canny(gray, 20, 60) > 0) & inside)
        if not len(v):
            continue
        ratio, n = sharpness_ratio(gray, v, u), gradient_direction(gray.astype(np.float32), v, u)
        uv = np.stack([u, v], 1).astype(np.float64)
        t_img = _minimum_along(edge_field(img, 1.0, colour=True), uv, n, 1.5, 0.25)
        t_tpl = _minimum_along(edge_field(composite(vr, img), 1.0, colour=True), uv, n, 1.5, 0.25)
        ok = (np.abs(t_img) < 1.25) & (np.abs(t_tpl) < 1.25)      # a minimum at the window's end: no edge
        oid = np.asarray(oids)[vr.instance[v, u] - 1]
        recs.append(np.stack([oid[ok], ratio[ok], (t_img - t_tpl)[ok]], 1))
    R = np.concatenate(recs)
    cols = ["samples", "share", "median |offset| (px)", "mean offset (px)", "MAD (px)"]

    def stats(s: np.ndarray) -> list[float]:
        x = R[s, 2]
        return [float(s.sum()), float(s.mean()), float(np.median(np.abs(x))), float(x.mean()),
                float(1.4826 * np.median(np.abs(x - np.median(x))))]

    t = Table(cols, label_header="template edge sharpness", digits=3,
              caption=f"Interior (Canny) edges of the template at the exact GT: image edge minus template edge along "
                      f"the template's gradient (px, + towards the brighter side), by sharpness |grad| at sigma 1 / "
                      f"sigma 2.5 (step edge 2.0-2.3); scenes {a.scenes}, frame positions {a.frames}")
    for lo, hi in zip(SHARPNESS_BINS[:-1], SHARPNESS_BINS[1:]):
        s = (R[:, 1] >= lo) & (R[:, 1] < hi)
        if s.sum():
            t.rows.append(Row(f"[{lo:g}, {hi:g})", stats(s)))
    t.rows.append(Row("all", stats(np.ones(len(R), bool)), rule_before=True))
    for oid in sorted({int(o) for o in R[:, 0]}):
        for name, s in (("soft (< 1.8)", R[:, 1] < 1.8), ("sharp (>= 2.2)", R[:, 1] >= 2.2)):
            s = s & (R[:, 0] == oid)
            if s.sum() >= 20:
                t.rows.append(Row(f"{getattr(models[oid], 'name', None) or oid}: {name}", stats(s),
                                  rule_before=name.startswith("soft")))
    for p in write_table(t, Path(a.out), "interior_offsets"):
        print(p)
    for r in t.rows[:len(SHARPNESS_BINS)]:
        print(r.label, [round(x, 3) for x in r.values])


if __name__ == "__main__":
    main()
