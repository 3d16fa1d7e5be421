"""f_point's flow matches at the exact GT with the unlit template and with the template lit by
the lighting fitted to the image (``RefineOptions.template_shading``, :mod:`ycbvss.refine.shading`).

At the exact pose every match should land where it started. Per (view, object) of the chosen
suite frames (Cycles images; templates from the fast renderer): the rms displacement of the
refiner's matches (px) and their mean displacement, with either template.

    python bench/bench_template_shading.py --suite-root /tmp/suite/full --dataset ../shared/data/ycbv \
        --scenes 1,2,4,5,6,7 --frames 0,10,20,30 --out bench/results/ycbv21/template_shading
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def main() -> None:
    from bench_contour_offsets import add_view_args, gt_view_matches, gt_views   # this folder (run as a script)

    from ycbvss.eval.tables import Row, Table, write_table

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_view_args(ap)
    ap.add_argument("--min-matches", type=int, default=10)
    ap.add_argument("--reflection", action="store_true",
                    help="the lit template's lighting also has the glossy reflection's basis (RefineOptions.shading_reflection)")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    per: dict = {}           # obj_id -> {"unlit": [(rms, |mean|, n)], "lit": [...]}
    models: dict = {}
    for models, _, frame, img, vr, oids in gt_views(a):
        for name in ("unlit", "lit"):
            objs, matches = gt_view_matches(vr, img, lit=name == "lit",
                                            reflection_K=frame.camera.K if a.reflection and name == "lit" else None)
            for j, (xs, xd) in zip(objs, matches):
                if len(xs) < a.min_matches:
                    continue
                d = xd - xs
                per.setdefault(oids[j], {}).setdefault(name, []).append(
                    (float(np.sqrt(np.mean(np.sum(d * d, axis=1)))), float(np.linalg.norm(d.mean(axis=0))), len(xs)))
    cols = ["groups", "unlit: rms (px)", "unlit: |mean| (px)", "unlit: matches",
            "lit: rms (px)", "lit: |mean| (px)", "lit: matches"]
    t = Table(cols, label_header="object", digits=3,
              caption=f"f_point's flow matches at the exact GT, unlit against lit template"
                      f"{' (lighting with the glossy reflection basis)' if a.reflection else ''}: rms and mean displacement "
                      f"per (view, object) (0 = exact); scenes {a.scenes}, frame positions {a.frames}")

    def stats(L: list) -> list[float]:
        return [float(np.mean([x[0] for x in L])), float(np.mean([x[1] for x in L])), float(np.mean([x[2] for x in L]))]

    for o, d in sorted(per.items()):
        if "unlit" in d and "lit" in d:
            t.rows.append(Row(getattr(models[o], "name", None) or str(o), [float(len(d["unlit"]))] + stats(d["unlit"]) + stats(d["lit"])))
    allu = [x for d in per.values() for x in d.get("unlit", [])]
    alll = [x for d in per.values() for x in d.get("lit", [])]
    t.rows.append(Row("all", [float(len(allu))] + stats(allu) + stats(alll), rule_before=True))
    print(f"unlit: rms {stats(allu)[0]:.3f} px, |mean| {stats(allu)[1]:.3f} px; lit: rms {stats(alll)[0]:.3f}, |mean| {stats(alll)[1]:.3f}")
    for p in write_table(t, Path(a.out), "template_shading"):
        print(p)


if __name__ == "__main__":
    main()
