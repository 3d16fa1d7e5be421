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

``--norm-sigmas 6,3,2``: instead, the scale per (scene, object) (mean over its views) with f_point's
contrast normalisation over each of these blurs (``FlowOptions.template_norm_sigma_px``), and its
mean and rms over the (scene, object)s; table ``match_scale_norm``.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def match_scale(xs: np.ndarray, xd: np.ndarray) -> float:
    """Least-squares scale (relative) of the displacements xd - xs (N, 2 px) about the centroid of xs."""
    rel = xs - xs.mean(axis=0)
    return float(np.sum((xd - xs) * rel) / np.sum(rel * rel))


def main() -> None:
    from bench_contour_offsets import add_view_args, gt_view_matches, gt_views   # this folder (run as a script)

    from ycbvss.eval.tables import Row, Table, write_table

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_view_args(ap)
    ap.add_argument("--min-matches", type=int, default=30)
    ap.add_argument("--lit", action="store_true",
                    help="the template lit by the lighting fitted to the image (RefineOptions.template_shading)")
    ap.add_argument("--norm-sigmas", default=None,
                    help="comma-separated blurs (px) of f_point's contrast normalisation to compare (FlowOptions.template_norm_sigma_px)")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    if a.norm_sigmas:
        return norm_table(a)
    rows = []
    models: dict = {}
    for models, _, fr, img, vr, oids in gt_views(a):
        objs, matches = gt_view_matches(vr, img, lit=a.lit)
        for j, (xs, xd) in zip(objs, matches):
            if len(xs) < a.min_matches:
                continue
            s = match_scale(xs, xd)
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
              caption=f"f_point's flow matches at the exact GT ({'lit' if a.lit else 'unlit'} template): least-squares scale of their displacement about "
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


def norm_table(a: argparse.Namespace) -> None:
    """Table ``match_scale_norm``: per (scene, object), the mean over its views of the matches' scale
    at the exact GT for each contrast-normalisation blur of ``--norm-sigmas``; mean and rms over them."""
    from bench_contour_offsets import gt_view_matches, gt_views

    from ycbvss.eval.tables import Row, Table, write_table

    sigmas = [float(x) for x in a.norm_sigmas.split(",")]
    per: dict = {}
    names: dict = {}
    for models, sid, fr, img, vr, oids in gt_views(a):
        for sg in sigmas:
            objs, matches = gt_view_matches(vr, img, lit=a.lit, norm_sigma_px=sg)
            for j, (xs, xd) in zip(objs, matches):
                if len(xs) < a.min_matches:
                    continue
                per.setdefault((sid, oids[j]), {}).setdefault(sg, []).append(match_scale(xs, xd))
                names[oids[j]] = getattr(models[oids[j]], "name", None) or str(oids[j])
    keys = sorted(k for k, v in per.items() if all(sg in v for sg in sigmas))
    t = Table([f"scale (%), {sg:g} px" for sg in sigmas], label_header="scene / object", digits=3,
              caption=f"f_point's matches at the exact GT ({'lit' if a.lit else 'unlit'} template): scale of their displacement about their "
                      f"centroid per (scene, object), mean over its views, by the blur of the contrast normalisation "
                      f"(FlowOptions.template_norm_sigma_px); scenes {a.scenes}, frame positions {a.frames}")
    M = np.array([[100 * float(np.mean(per[k][sg])) for sg in sigmas] for k in keys])
    for k, m in zip(keys, M):
        t.rows.append(Row(f"{k[0]} / {names[k[1]]}", [float(x) for x in m]))
    t.rows.append(Row("mean", [float(x) for x in M.mean(axis=0)], rule_before=True))
    t.rows.append(Row("rms", [float(x) for x in np.sqrt(np.mean(M ** 2, axis=0))]))
    for p in write_table(t, Path(a.out), "match_scale_norm"):
        print(p)


if __name__ == "__main__":
    main()
