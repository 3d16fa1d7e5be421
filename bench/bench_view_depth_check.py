"""How far along the line of sight a frame's poses can be off before the status's per-view checks
see it: the contour offset and (since session 74) the 2-D template shift.

The status reads, per view, the median over its objects of each object's contour offset from the
image's edges (:mod:`ycbvss.refine.evidence`, lit templates, as the status does); above 1 px (at
640 px width) every pose of the view is `uncertain`. This bench takes frames of one suite clip at
the exact GT, moves every object of the frame nearer to the camera by d mm (what a non-keyframe
camera off along its optical axis does) and prints each object's offset and the view's median,
and the view's median 2-D template shift (:mod:`ycbvss.refine.view_shift`; above 3 px at 640 px
every pose of the view is `uncertain`).

    python bench/bench_view_depth_check.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \
        --clip long-1 --frames 21,100 --out bench/results/ycbv21/s72/view_depth_check
"""
from __future__ import annotations

import argparse
import types
from pathlib import Path

import numpy as np


def main() -> None:
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.pipeline.suite import load_clip
    from ycbvss.refine.confidence import OK_PX, VIEW_SHIFT_PX
    from ycbvss.refine.view_shift import view_shift_px
    from ycbvss.refine.evidence import _view_contour_offsets
    from ycbvss.refine.templates import ensure_meshes, get_renderer

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--clip", default="long-1")
    ap.add_argument("--frames", default="21,100")
    ap.add_argument("--shifts-mm", default="0,10,20,30")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    models, sc = load_clip(a.dataset, a.suite_root, a.clip)
    r = get_renderer()
    ensure_meshes(r, models)
    frames = {f.im_id: f for f in sc.frames}
    rows, obj_cols = [], None
    for im in (int(x) for x in a.frames.split(",")):
        f = frames[im]
        img = f.load_rgb()
        H, W = img.shape[:2]
        view = types.SimpleNamespace(image=img, K=f.camera.K, width=W, height=H, im_id=im)
        ids = [i.obj_id for i in f.instances]
        obj_cols = obj_cols or ids
        for d in (float(x) for x in a.shifts_mm.split(",")):
            poses = {}
            for i in f.instances:
                T = i.T_m2c.copy()
                T[2, 3] -= d
                poses[(im, i.obj_id)] = T
            shifts: dict = {}
            off = _view_contour_offsets([view], models, ids, np.ones(len(ids), bool), poses, r, lit=True,
                                        shifts=shifts)[0]
            vals = [off.get(o, float("nan")) for o in obj_cols]
            rows.append(Row(f"frame {im}, {d:g} mm nearer",
                            vals + [float(np.nanmedian(vals)), view_shift_px(shifts.get(0, {}).values())],
                            rule_before=d == 0.0 and bool(rows)))
    t = Table(caption=f"{a.clip}: per-object contour offset (px) and the view's median when every object of the frame "
                      f"is moved nearer along the camera's optical axis (the status's per-view check: > {OK_PX:g} px is "
                      f"uncertain at 640 px width), and the view's median 2-D template shift (px; > {VIEW_SHIFT_PX:g} px "
                      f"is uncertain)",
              label_header="frame, shift", columns=[f"obj {o}" for o in obj_cols] + ["view median", "view shift"],
              rows=rows, digits=2)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for p in write_table(t, out, "view_depth_check"):
        print(p)


if __name__ == "__main__":
    main()
