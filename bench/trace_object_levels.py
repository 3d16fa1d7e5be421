"""Trace one object's error through the refiner's stages and blur levels on one suite clip.

    python bench/trace_object_levels.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \
        --scene 1 --kind long --init add60 --seed 0 --obj 10 [--options '{"edge_contour_slide": false}']

Prints, at the start and end of every level of every stage (keyframe bundle, camera-only chunks,
restart passes in order), the object's ADD (mm), its translation error (mm, in the stage's first
camera) and rotation error (deg) against the exact GT, then the restart/regroup stats and the
object's final status and quality. The rotation error is also given as the rotation vector of
GT^-1 * pose in the model frame (deg about model x, y, z: a turn about a symmetry axis shows on that
axis alone). A diagnostic: the pose is read from the problem the stage solves, so a camera that is
itself off shows as an object error in that stage's first view.
"""
from __future__ import annotations

import argparse
import json
import os
import warnings
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", required=True, help="YCB-Video root (or BOP root) with the 21 models")
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--suite", default="ycbv21")
    ap.add_argument("--scene", type=int, required=True)
    ap.add_argument("--kind", default="long", choices=("short", "medium", "long"))
    ap.add_argument("--init", default="paper")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--obj", type=int, required=True, help="BOP object id to trace")
    ap.add_argument("--options", default="{}", help="RefineOptions overrides as a JSON object")
    a = ap.parse_args(argv)
    os.environ.setdefault("YCBVSS_NO_PROGRESS", "1")
    warnings.simplefilter("ignore")
    import ycbvss.refine.bundle as B
    from ycbvss.eval.metrics import pose_errors_4x4
    from ycbvss.geometry.so3 import log_so3
    from ycbvss.io.bop import load_bop_scene
    from ycbvss.pipeline.suite import build_suite, clips_of
    from ycbvss.pipeline.suite_run import Run, refine_run

    root = Path(a.suite_root)
    models, specs = build_suite(a.dataset, root, a.suite, scene_ids=[a.scene], quiet=True)
    clip = clips_of(specs[0], [a.kind])[0]
    scene = load_bop_scene(root / "test", a.scene, models)
    trace: list[tuple] = []
    iterate = B._Stage._iterate

    def traced(self, fields, n_outer, n_cap, sopt, lam, sigma, n_built):
        def record(tag: str) -> None:
            ids = list(self.pb.obj_ids)
            if a.obj in ids:
                j = ids.index(a.obj)
                trace.append((self.name, sigma, tag, int(self.pb.views[0].im_id), self.pb.T_c[0] @ self.pb.T_m[j]))
        record("start")
        out = iterate(self, fields, n_outer, n_cap, sopt, lam, sigma, n_built)
        record("end")
        return out

    B._Stage._iterate = traced
    try:
        res, _, gt, _, Ks, dt = refine_run(Run(clip, a.init, a.seed), scene, models, json.loads(a.options))
    finally:
        B._Stage._iterate = iterate
    pts = models[a.obj].vertices_mm
    for stage, sigma, tag, im_id, T in trace:
        G = gt[(im_id, a.obj)]
        e = pose_errors_4x4(T, G, Ks[(im_id, a.obj)], pts)
        d = T[:3, 3] - G[:3, 3]
        w = np.degrees(log_so3(G[:3, :3].T @ T[:3, :3]))
        print(f"{stage:10s} level {sigma:4.1f} px {tag:5s} view {im_id:4d}: ADD {e['add_mm']:7.2f} mm, "
              f"t err ({d[0]:6.2f}, {d[1]:6.2f}, {d[2]:6.2f}) mm, R {e['r_deg']:5.2f} deg "
              f"(model axes {w[0]:+6.2f} {w[1]:+6.2f} {w[2]:+6.2f})")
    print("stats:", {k: res.stats.get(k) for k in ("baseline_group", "baseline_deg", "regroup", "slide_restart",
                                                    "turn_restart", "isolate_slid", "sweep_again", "ridge_fallback")})
    k = sorted(x for x in res.poses if x[1] == a.obj)[0]
    print(f"final (view {k[0]}): {res.status.get(k)}: {res.reasons.get(k)}; {dt:.0f} s")
    q = res.quality.get(a.obj, {})
    print("quality:", {n: (round(v, 4) if isinstance(v, float) else v) for n, v in q.items()
                       if isinstance(v, (int, float, str, bool))})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
