"""Scale bias of f_point's template-to-image flow matches at the exact GT.

At the exact pose a match should land where it started (the template is drawn at the image's
pose). For every (view, object) of the chosen suite frames (Cycles images; templates from the fast
renderer): the refiner's matches (``refine.bundle._view_matches`` with the default flow options),
and the least-squares scale s of their displacement about the matches' centroid,
s = sum (x_dst - x_src) . (x_src - c) / sum |x_src - c|^2. s > 0: the image looks larger than the
template, i.e. the point term pulls the object s * Z closer. Compared with the contour's shared
offset from ``bench_contour_offsets.py`` it says which term carries which part of the apparent-size
(depth / scene-scale) bias.

    python bench/bench_match_scale.py --suite-root /tmp/suite/full --dataset ../shared/data/ycbv \
        --scenes 1,2,4,5,6,7 --frames 0,10,20,30 --out bench/results/ycbv21/match_scale
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def main() -> None:
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.io.bop import load_bop_scene
    from ycbvss.pipeline.suite import build_suite
    from ycbvss.refine.bundle import RefineOptions, _bbox, _view_matches
    from ycbvss.refine.matching import min_eig_map
    from ycbvss.refine.templates import composite, ensure_meshes, get_renderer, object_mask, render_view

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--scenes", default="1,2,4,5,6,7")
    ap.add_argument("--frames", default="0,10,20,30", help="frame positions within each scene's rendered frames")
    ap.add_argument("--min-matches", type=int, default=30)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    opt = RefineOptions()
    root = Path(a.suite_root)
    scene_ids = [int(s) for s in a.scenes.split(",")]
    models, _ = build_suite(a.dataset, root, "ycbv21", scene_ids=scene_ids)
    r = get_renderer()
    ensure_meshes(r, models)
    rows = []
    for sid in scene_ids:
        sc = load_bop_scene(root / "test", sid, models)
        for pos in [int(p) for p in a.frames.split(",")]:
            if pos >= len(sc.frames):
                continue
            fr = sc.frames[pos]
            cam, img = fr.camera, fr.load_rgb()
            oids = [i.obj_id for i in fr.instances]
            vr = render_view(r, models, oids, cam.K, cam.width, cam.height,
                             {j: i.T_m2c for j, i in enumerate(fr.instances)})
            objs = [j for j in vr.obj_index if int(vr.mask(j).sum()) >= opt.min_visible_px]
            y0, y1, x0, x1 = _bbox(vr.instance > 0, opt.flow_margin_px)
            raw = composite(vr, img, (y0, y1, x0, x1))
            masks = [object_mask(vr, j, opt.match_erode_px)[y0:y1, x0:x1] for j in objs]
            matches = _view_matches(raw, img[y0:y1, x0:x1], masks, opt.flow, min_eig_map(img)[y0:y1, x0:x1])
            for j, (xs, xd) in zip(objs, matches):
                if len(xs) < a.min_matches:
                    continue
                xs, xd = xs[: opt.n_matches], xd[: opt.n_matches]
                c = xs.mean(axis=0)
                rel = xs - c
                s = float(np.sum((xd - xs) * rel) / np.sum(rel * rel))
                z = float(fr.instances[j].T_m2c[2, 3])
                rows.append({"obj_id": oids[j], "n": len(xs), "scale": s, "dz_mm": -s * z,
                             "shift_px": float(np.linalg.norm((xd - xs).mean(axis=0)))})
    s = np.array([x["scale"] for x in rows])
    dz = np.array([x["dz_mm"] for x in rows])
    print(f"groups {len(rows)}: scale mean {s.mean():+.5f} rms {np.sqrt(np.mean(s ** 2)):.5f}; "
          f"implied depth pull mean {dz.mean():+.2f} mm, rms {np.sqrt(np.mean(dz ** 2)):.2f} mm")
    per_obj: dict = {}
    for x in rows:
        per_obj.setdefault(x["obj_id"], []).append(x)
    t = Table(["groups", "matches", "scale mean (%)", "depth pull mean (mm)", "depth pull rms (mm)", "mean shift (px)"],
              label_header="object", digits=3,
              caption=f"f_point's flow matches at the exact GT: least-squares scale of their displacement about "
                      f"their centroid and the depth it pulls (-scale x Z); scenes {a.scenes}, frame positions {a.frames}")
    for o, v in sorted(per_obj.items()):
        d = np.array([x["dz_mm"] for x in v])
        t.rows.append(Row(getattr(models[o], "name", None) or str(o),
                          [float(len(v)), float(np.mean([x["n"] for x in v])), 100 * float(np.mean([x["scale"] for x in v])),
                           float(d.mean()), float(np.sqrt(np.mean(d ** 2))), float(np.mean([x["shift_px"] for x in v]))]))
    t.rows.append(Row("all", [float(len(rows)), float(np.mean([x["n"] for x in rows])), 100 * float(s.mean()),
                              float(dz.mean()), float(np.sqrt(np.mean(dz ** 2))),
                              float(np.mean([x["shift_px"] for x in rows]))], rule_before=True))
    for p in write_table(t, Path(a.out), "match_scale"):
        print(p)


if __name__ == "__main__":
    main()
