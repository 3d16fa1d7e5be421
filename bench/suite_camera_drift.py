"""How the free-camera bundle bends a clip's camera path: one suite clip refined from the exact GT
under chosen conditions, its cameras and objects compared with the GT.

Each ``--condition LABEL=JSON`` is a set of ``RefineOptions`` overrides, e.g.

- ``defaults={}``: cameras and objects refined, as on real data;
- ``objects held={"fix_objects": true}``: every object kept at its exact pose, the cameras alone
  refined -- each view's image evidence then turns its own camera (no structure to trade with);
- ``edges, objects held={"fix_objects": true, "use_point": false, "use_temporal": false,
  "edge_sigmas_px": [1.0]}``: the same with f_edge alone at the finest level.

Per condition, with the refined world aligned to the first camera (the gauge), for the frames
whose GT camera has turned at least 2 deg from the first: ``path ratio`` = median of |C_i| / |C_i,GT|
(the camera centres' distance from the first camera; < 1: the path is shortened), ``turn ratio`` =
least-squares slope of the refined turn from the first camera against the GT turn (< 1: the
cameras turn too little), and per object the signed depth change dz (refined minus GT, mm) over its
views. A path both shortened and turned too little while far objects recede and near ones come
closer is the narrow-baseline (bas-relief) trade of turn against depth.

    python bench/suite_camera_drift.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \
        --clip medium-1 --condition "defaults={}" --condition 'objects held={"fix_objects": true}' \
        --out bench/results/ycbv21/camera_drift
"""
from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path

import numpy as np

MIN_TURN_DEG = 2.0


def path_figures(T_gt: list[np.ndarray], T_ref: list[np.ndarray]) -> tuple[float, float]:
    """(path ratio, turn ratio) of refined world-to-camera poses ``T_ref`` against ``T_gt`` (same
    frames, any world each): both expressed relative to their first camera; only frames whose GT
    turn from the first is at least MIN_TURN_DEG count."""
    from ycbvss.geometry.so3 import rotation_angle_deg
    from ycbvss.procedural.layout import camera_centre

    g0, r0 = np.linalg.inv(T_gt[0]), np.linalg.inv(T_ref[0])
    ratios, a_gt, a_ref = [], [], []
    for Tg, Tr in zip(T_gt[1:], T_ref[1:]):
        g, r = Tg @ g0, Tr @ r0
        ag = float(rotation_angle_deg(g[:3, :3]))
        if ag < MIN_TURN_DEG:
            continue
        ratios.append(np.linalg.norm(camera_centre(r)) / np.linalg.norm(camera_centre(g)))
        a_gt.append(ag)
        a_ref.append(float(rotation_angle_deg(r[:3, :3])))
    if not ratios:
        return float("nan"), float("nan")
    a_gt, a_ref = np.asarray(a_gt), np.asarray(a_ref)
    return float(np.median(ratios)), float(a_gt @ a_ref / (a_gt @ a_gt))


def main(argv: list[str] | None = None) -> int:
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.pipeline.suite import build_suite, clip_scene, clips_of
    from ycbvss.pipeline.suite_run import Run, initial_poses, keyframe_step_for
    from ycbvss.io.bop import load_bop_scene
    from ycbvss.progress import progress
    from ycbvss.refine.bundle import RefineOptions, refine_scene

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", required=True, help="YCB-Video root (or BOP root) with the 21 models")
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--clip", required=True, help="e.g. medium-1")
    ap.add_argument("--condition", action="append", required=True, help="LABEL=JSON RefineOptions overrides (repeat)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--name", default=None, help="table stem (default camera_drift_<clip>)")
    a = ap.parse_args(argv)
    kind, _, sid = a.clip.partition("-")
    if not sid.isdigit():
        raise SystemExit(f"error: --clip {a.clip!r}: expected KIND-SCENE, e.g. medium-1")
    conds = []
    for spec in a.condition:
        label, _, js = spec.partition("=")
        try:
            conds.append((label, json.loads(js or "{}")))
        except json.JSONDecodeError as e:
            raise SystemExit(f"error: --condition {spec!r}: {e}")
    root = Path(a.suite_root)
    models, specs = build_suite(a.dataset, root, "ycbv21", scene_ids=[int(sid)], quiet=True)
    clip = next((c for s in specs for c in clips_of(s, (kind,)) if c.name == a.clip), None)
    if clip is None:
        raise SystemExit(f"error: suite ycbv21 has no clip {a.clip!r}")
    sc = clip_scene(load_bop_scene(root / "test", clip.scene_id, models), clip)
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in sc.frames for i in f.instances}
    Ks = {k: next(f.camera.K for f in sc.frames if f.im_id == k[0]) for k in gt}
    pts = {o: models[o].vertices_mm for o in {k[1] for k in gt}}
    init = initial_poses(Run(clip, "gt", 0), gt, Ks, pts)
    ims = [f.im_id for f in sc.frames]
    objs = sorted({k[1] for k in gt})
    ref = objs[0]                    # GT cameras from one object's GT poses (world = its frame)
    T_gt = [gt[(im, ref)] for im in ims]
    results = []
    for label, kw in progress(conds, desc=f"{a.clip} from the exact GT", unit="run"):
        ro = RefineOptions(keyframe_step=keyframe_step_for(len(sc.frames)), seed=0, **kw)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = refine_scene(sc, models, init, ro)
        path, turn = path_figures(T_gt, [np.asarray(res.T_w2c[im]) for im in ims])
        dz = {o: float(np.mean([res.poses[(im, o)][2, 3] - gt[(im, o)][2, 3] for im in ims if (im, o) in res.poses]))
              for o in objs}
        results.append((label, path, turn, dz))
    depth = {o: float(np.mean([gt[(im, o)][2, 3] for im in ims])) for o in objs}
    t = Table(columns=[lab for lab, *_ in results], label_header="", digits=4,
              caption=(f"{a.clip} refined from the exact GT: the camera path against the GT (relative to the "
                       f"first camera, frames turned >= {MIN_TURN_DEG:g} deg) and per object the signed mean "
                       "depth change dz (mm), objects by GT depth"))
    t.rows.append(Row("path ratio |C| / |C_GT|", [r[1] for r in results], bold=[False] * len(results)))
    t.rows.append(Row("turn ratio", [r[2] for r in results], bold=[False] * len(results)))
    for o in sorted(objs, key=depth.get):
        name = models[o].name if o in models else str(o)
        t.rows.append(Row(f"{name} (z {depth[o]:.0f} mm): dz", [r[3][o] for r in results],
                          bold=[False] * len(results), rule_before=o == min(objs, key=depth.get)))
    for p in write_table(t, Path(a.out), a.name or f"camera_drift_{a.clip}"):
        print(p)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
