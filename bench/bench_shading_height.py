"""How well the lit template predicts the image's brightness near the table, at the exact GT.

The refiner lights its templates with 9 spherical-harmonic terms of the surface normal fitted per
view (:mod:`ycbvss.refine.shading`): a distant light with no shadows and no inter-reflection. Near
the table an object also gets the table's bounce light and loses some of it to its own contact
shadow, which depends on the height above the table, not on the normal alone. This bench renders
the suite clips' objects at the GT (fast renderer), lights the template as the refiner does, and
tabulates the ratio image / lit template in linear light (grey, object pixels, median and
quartiles) by the pixel's height above the GT table (world z = 0 of the suite's scenes) and by
whether the pixel lies within 3 px of the silhouette (the rim, where gloss adds grazing light).

    python bench/bench_shading_height.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \
        --clips short-1,short-2,short-4,short-5,short-6,short-7 --out bench/results/ycbv21/s72/shading_height
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

HEIGHT_BINS_MM = (0.0, 2.0, 5.0, 10.0, 20.0, 40.0, np.inf)
RIM_PX = 3.0


def main() -> None:
    import cv2

    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.geometry.se3 import inv_T
    from ycbvss.pipeline.suite import load_clip
    from ycbvss.refine.edge import srgb_to_linear
    from ycbvss.refine.jacobians import backproject_px
    from ycbvss.refine.shading import lit_template, view_lighting
    from ycbvss.refine.templates import ensure_meshes, get_renderer, render_view

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--clips", default="short-1,short-2,short-4,short-5,short-6,short-7")
    ap.add_argument("--frames-per-clip", type=int, default=3)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    r = get_renderer()
    logs: dict[tuple[int, bool], list[np.ndarray]] = {}
    for clip in a.clips.split(","):
        models, sc = load_clip(a.dataset, a.suite_root, clip)
        ensure_meshes(r, models)
        for f in sc.frames[: a.frames_per_clip]:
            img = f.load_rgb()
            H, W = img.shape[:2]
            ids = [i.obj_id for i in f.instances]
            poses = {j: i.T_m2c for j, i in enumerate(f.instances)}
            vr = render_view(r, models, ids, f.camera.K, W, H, poses)
            lit = lit_template(vr.color, vr.normal, vr.instance, img,
                               coeffs=view_lighting(vr.color, vr.normal, vr.instance, img))
            inside = vr.instance > 0
            dist_px = cv2.distanceTransform(inside.astype(np.uint8), cv2.DIST_L2, 3)
            ys, xs = np.nonzero(inside)
            X_cam = backproject_px(f.camera.K, np.c_[xs, ys].astype(np.float64), vr.depth_mm[ys, xs])
            P = inv_T(f.T_w2c)
            height_mm = X_cam @ P[2, :3] + P[2, 3]
            i_lin = srgb_to_linear(img[ys, xs]).mean(axis=1)
            t_lin = srgb_to_linear(lit[ys, xs]).mean(axis=1)
            ok = (t_lin > 5.0) & (i_lin < 250.0)        # a dark template or a clipped image says nothing
            rim = dist_px[ys, xs] <= RIM_PX
            for k in range(len(HEIGHT_BINS_MM) - 1):
                in_bin = ok & (height_mm >= HEIGHT_BINS_MM[k]) & (height_mm < HEIGHT_BINS_MM[k + 1])
                for at_rim in (False, True):
                    sel = in_bin & (rim == at_rim)
                    if sel.any():
                        logs.setdefault((k, at_rim), []).append(np.log(i_lin[sel] / t_lin[sel]))
    rows = []
    for (k, at_rim), parts in sorted(logs.items()):
        lr = np.concatenate(parts)
        lo, hi = HEIGHT_BINS_MM[k], HEIGHT_BINS_MM[k + 1]
        name = f"{lo:g}-{hi:g} mm" if np.isfinite(hi) else f">= {lo:g} mm"
        rows.append(Row(f"{name}, {'rim (<= 3 px)' if at_rim else 'inside'}",
                        [len(lr), float(np.exp(np.median(lr))), float(np.exp(np.percentile(lr, 25))),
                         float(np.exp(np.percentile(lr, 75)))]))
    t = Table(caption=f"{a.clips}: image / lit template (linear light, grey) on object pixels at the exact GT, by height "
                      f"above the table and distance from the silhouette ({a.frames_per_clip} frames per clip)",
              label_header="height above the table, where", columns=["pixels", "median", "p25", "p75"],
              rows=rows, digits=3)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for p in write_table(t, out, "shading_height"):
        print(p)


if __name__ == "__main__":
    main()
