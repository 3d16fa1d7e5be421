"""Does a height-above-the-table term in the template lighting help f_point's flow matches?

``bench_shading_height.py`` found the suite's objects 17-21 % brighter than the lit template
within 5 mm of the table (6-13 % above 20 mm): the table's bounce light and the contact shadow
depend on the height above the table, which the 9 spherical-harmonic terms of the normal cannot
hold. This bench adds one basis image, ``exp(-h / scale)`` of the GT height ``h`` above the table
(:func:`ycbvss.refine.shading.height_basis`, fitted jointly with the 9 terms per view and channel),
and measures what the refiner's f_point cares about: at the exact GT every flow match template ->
image should land where it started. Per (view, object) of the chosen suite frames (Cycles images,
fast-renderer templates): the rms displacement of the matches (px) and the length of their mean,
with the unlit template, the SH-lit one (``RefineOptions.template_shading``) and the SH + height
lit ones; plus each height term's fitted weight (grey, mean over views).

    python bench/bench_height_lighting.py --suite-root /tmp/suite/full --dataset ../shared/data/ycbv \
        --scenes 1,2,4,5,6,7 --frames 0,10,20,30 --out bench/results/ycbv21/s73/height_lighting
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def main() -> None:
    from bench_contour_offsets import add_view_args, gt_view_matches, gt_views   # this folder (run as a script)

    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.geometry.se3 import inv_T
    from ycbvss.refine.shading import N_SH, height_basis, lit_template, view_lighting

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_view_args(ap)
    ap.add_argument("--scales-mm", default="5,10,20", help="fall-off lengths of the height term (mm)")
    ap.add_argument("--min-matches", type=int, default=10)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    if a.supersample != 1:
        raise SystemExit("--supersample 1 only: the lit colours here are the point-sampled template's")
    scales = [float(s) for s in a.scales_mm.split(",")]
    names = ["unlit", "SH lit"] + [f"SH + height {s:g} mm" for s in scales]
    stats: dict[str, list[tuple[float, float]]] = {n: [] for n in names}
    weights: dict[str, list[float]] = {n: [] for n in names[2:]}
    for _, _, fr, img, vr, _ in gt_views(a):
        if fr.T_w2c is None:
            continue
        P = inv_T(fr.T_w2c)                   # the suite's table is world z = 0: height = row 2 of camera -> world
        plane_c = (P[2, :3], float(P[2, 3]))
        colours = {"unlit": None, "SH lit": lit_template(vr.color, vr.normal, vr.instance, img)}
        for s, name in zip(scales, names[2:]):
            E = height_basis(vr.depth_mm, fr.camera.K, plane_c, s)
            C = view_lighting(vr.color, vr.normal, vr.instance, img, extra=E)
            if C is None:
                continue
            weights[name].append(float(C[:, N_SH].mean()))
            colours[name] = lit_template(vr.color, vr.normal, vr.instance, img, coeffs=C, extra=E)
        for name, col in colours.items():
            for xs, xd in gt_view_matches(vr, img, lit=False if col is None else col)[1]:
                if len(xs) < a.min_matches:
                    continue
                d = xd - xs
                stats[name].append((float(np.sqrt(np.mean(np.sum(d * d, axis=1)))), float(np.linalg.norm(d.mean(axis=0)))))
    rows = []
    for name in names:
        v = np.asarray(stats[name]).reshape(-1, 2)
        w = weights.get(name)
        rows.append(Row(name, [len(v), float(v[:, 0].mean()) if len(v) else None,
                               float(v[:, 1].mean()) if len(v) else None,
                               float(np.mean(w)) if w else None, float(np.std(w)) if w else None]))
    t = Table(caption=f"suite scenes {a.scenes}, frames {a.frames}, exact GT: f_point's flow matches template -> image "
                      f"with the template unlit, SH lit, and SH + height lit (mean over (view, object))",
              label_header="template", columns=["(view, object)", "rms (px)", "length of the mean (px)",
                                                "height weight (mean over views)", "its sd over views"],
              rows=rows, digits=4)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for p in write_table(t, out, "height_lighting"):
        print(p)


if __name__ == "__main__":
    main()
