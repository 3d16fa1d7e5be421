"""The status's contour check at the exact GT: per suite clip and object, the median over views and
the worst views (:func:`ycbvss.refine.confidence.worst_views_px`) of the contour offset (px) the
refiner's status reads, with the unlit and the lit template (the lighting fitted to each view,
:func:`ycbvss.refine.shading.lit_template`). At the GT every offset should read well under the
1 px ``uncertain`` threshold; what it reads there is the check's false-alarm margin.

    python bench/bench_contour_check.py --suite-root /tmp/suite/full --dataset ../shared/data/ycbv \
        --scenes 1,2,3,4,5,6,7,8,9 --kinds short,medium,long --out bench/results/ycbv21/contour_check
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def main() -> None:
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.io.bop import load_bop_scene
    from ycbvss.pipeline.suite import build_suite, clip_scene, clips_of
    from ycbvss.refine import bundle as B
    from ycbvss.refine import evidence as Ev
    from ycbvss.refine.confidence import OK_PX
    from ycbvss.refine.templates import ensure_meshes, get_renderer
    from ycbvss.progress import progress

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--scenes", default="1,2,3,4,5,6,7,8,9")
    ap.add_argument("--kinds", default="short,medium,long")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    root = Path(a.suite_root)
    models, specs = build_suite(a.dataset, root, "ycbv21", quiet=True)
    ensure_meshes(get_renderer(), models)
    scenes = {int(s) for s in a.scenes.split(",")}
    kinds = tuple(a.kinds.split(","))
    clips = [(s, c) for s in specs if s.scene_id in scenes for c in clips_of(s, kinds)]
    per: list[tuple[str, int, dict]] = []
    loaded: dict = {}
    for spec, clip in progress(clips, desc="clips", unit="clip"):
        if spec.scene_id not in loaded:
            loaded = {spec.scene_id: load_bop_scene(root / "test", spec.scene_id, models)}
        sc = clip_scene(loaded[spec.scene_id], clip)
        frames, views, imgs, _ = B._scene_views(sc, None)
        gt = {(f.im_id, i.obj_id): i.T_m2c for f in frames for i in f.instances}
        obj_ids = sorted({k[1] for k in gt})
        res = {}
        for lit in (False, True):
            pv, ln = Ev._contour_offsets_all_views(views, models, obj_ids, np.ones(len(obj_ids), bool), gt, imgs, lit=lit)
            worst = Ev._worst_views(pv, ln, obj_ids)
            for o in obj_ids:
                seen = [pv[i][o] for i in pv if o in pv[i]]
                if seen:
                    res.setdefault(o, {})[lit] = (float(np.median(seen)), worst[o])
        for o, d in res.items():
            per.append((clip.kind, o, d))
    t = Table(["clip-objects", "median: max unlit", "median: max lit", "worst views: p95 unlit", "worst views: p95 lit",
               "worst views: max unlit", "worst views: max lit", f"worst > {OK_PX:g} px unlit", f"worst > {OK_PX:g} px lit"],
              label_header="clips", digits=2,
              caption=f"The status's contour offset (px) at the exact GT, per clip-object: median over views and worst views "
                      f"(k-th largest, k = max(2, 5 %), views showing >= half the longest visible contour); scenes {a.scenes}")
    for kind in kinds + ("all",):
        sel = [d for k, _, d in per if kind in (k, "all") and False in d and True in d]
        if not sel:
            continue
        m = {lit: np.array([d[lit][0] for d in sel]) for lit in (False, True)}
        w = {lit: np.array([d[lit][1] for d in sel]) for lit in (False, True)}
        t.rows.append(Row(kind, [float(len(sel)), float(np.nanmax(m[False])), float(np.nanmax(m[True])),
                                 float(np.nanpercentile(w[False], 95)), float(np.nanpercentile(w[True], 95)),
                                 float(np.nanmax(w[False])), float(np.nanmax(w[True])),
                                 float(np.sum(w[False] > OK_PX)), float(np.sum(w[True] > OK_PX))],
                          rule_before=kind == "all"))
    for p in write_table(t, Path(a.out), "contour_check_gt"):
        print(p)


if __name__ == "__main__":
    main()
