"""The interior-texture check's pictures at the exact ground truth: for every object of the ycbv21
suite's scenes (first and middle frame), the interior NCC of the image's edge strength against the
refiner's unlit template (``refine.evidence._template_magnitude``, the others in place as occluders,
as the status's check builds it) and the
template's texture share above several edge strengths (``refine.turn_check.texture_share``).

    python bench/texture_at_gt.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \
        --scenes 1,2,3,4,5,6,7,8,9 --out bench/results/ycbv21/texture_gt_s53.csv

Session 53 used it to choose ``turn_check.TEXTURE_MAG`` / ``TEXTURED_MIN`` (which objects are judged).
"""
from __future__ import annotations

import argparse
import csv
import io
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np

MAGS = (1.0, 2.0, 4.0, 8.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", required=True, help="YCB-Video root with the 21 models")
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--scenes", default="1,2,3,4,5,6,7,8,9")
    ap.add_argument("--out", required=True, help="CSV written (atomically)")
    a = ap.parse_args()
    from ycbvss.geometry.model_frame import bbox_center
    from ycbvss.io.atomic import write_text_atomic
    from ycbvss.io.bop import load_bop_scene
    from ycbvss.pipeline.suite import suite_models
    from ycbvss.refine.evidence import _sphere_window, _template_magnitude
    from ycbvss.refine.edge import gradient_magnitude
    from ycbvss.refine.templates import _subpixel_K, ensure_meshes, get_renderer, mesh_key
    from ycbvss.refine.turn_check import interior_ncc, texture_share

    root = Path(a.suite_root)
    models = suite_models(a.dataset, root)
    r = get_renderer()
    ensure_meshes(r, models)
    rows = []
    for sid in (int(s) for s in a.scenes.split(",")):
        sc = load_bop_scene(root / "test", sid, models)
        for f in (sc.frames[0], sc.frames[len(sc.frames) // 2]):
            img, K = f.load_rgb(), f.camera.K
            view = SimpleNamespace(K=K, width=img.shape[1], height=img.shape[0], image=img)
            mag = gradient_magnitude(img, 1.0)
            P = {i.obj_id: i.T_m2c for i in f.instances}
            for o, T in P.items():
                V = np.asarray(models[o].mesh.vertices, np.float64)
                c = bbox_center(V)
                box = _sphere_window(view, T, c, float(np.linalg.norm(V - c, axis=1).max()))
                if box is None:
                    continue
                y0, y1, x0, x1 = box
                Kc = _subpixel_K(K, box, 1)        # the window's intrinsics, as the status's check
                others = [(mesh_key(k, models[k]), Tk) for k, Tk in P.items() if k != o]
                occ = r.render(Kc, x1 - x0, y1 - y0, others, outputs=("depth", "color")) if others else None
                out = r.render(Kc, x1 - x0, y1 - y0, [(mesh_key(o, models[o]), T)], outputs=("depth", "color"))
                tm, inner = _template_magnitude(img[y0:y1, x0:x1], out.depth_mm, out.color,
                                                None if occ is None else occ.depth_mm,
                                                None if occ is None else occ.color)
                ncc = interior_ncc(mag[y0:y1, x0:x1], tm, inner, erode_px=0)
                row = {"scene_id": sid, "im_id": f.im_id, "obj_id": o, "ncc_at_gt": round(ncc, 4)}
                row.update({f"share_above_{m:g}": round(texture_share(tm, inner, erode_px=0, mag_min=m), 4) for m in MAGS})
                rows.append(row)
                print(row, flush=True)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
    write_text_atomic(a.out, buf.getvalue())
    judged = [r for r in rows if math.isfinite(r["share_above_2"])]
    print(f"{len(judged)} object views with an interior; min share above 2: "
          f"{min(r['share_above_2'] for r in judged):.3f}; NCC < 0.25 at the GT: "
          f"{[(r['scene_id'], r['im_id'], r['obj_id'], r['ncc_at_gt']) for r in judged if r['ncc_at_gt'] < 0.25]}")


if __name__ == "__main__":
    main()
