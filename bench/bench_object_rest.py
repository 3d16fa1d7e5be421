"""Where one suite clip's objects come to rest from the exact GT, under option variants, with a
zoomed contour overlay (GT green, refined red) of one object.

Refinement started at the exact GT should not move anything (issue: no bias). This bench runs one
clip of the ``ycbv21`` suite (Blender Cycles images) from the exact GT for each variant given
(``RefineOptions`` overrides as JSON, ``{}`` = the defaults) and writes, per variant and object,
the mean signed camera-frame offset (dx, dy, dz mm), the rotation (deg) and the status, as
Markdown / CSV / LaTeX, plus ``overlay_<variant>.png``: the object's silhouette at the GT and at
the refined pose over the image, magnified ``--zoom`` times (bicubic), for the chosen frames.

    python bench/bench_object_rest.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \
        --clip medium-4 --obj 21 --frames 0,30 \
        --variants '{}' '{"use_edge": false}' '{"edge_contact_mm": 10}' \
        --out bench/results/ycbv21/contact_shadow
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def _label(kw: dict) -> str:
    return "defaults" if not kw else ",".join(f"{k}={v}" for k, v in kw.items())


def _overlay(img: np.ndarray, K: np.ndarray, mesh_key, poses: list, box: tuple, zoom: int) -> np.ndarray:
    """The crop ``box`` (x, y, w, h) of ``img`` magnified ``zoom`` times with the silhouette
    contour of each pose drawn (green, then red)."""
    import cv2

    from ycbvss.refine.templates import get_renderer
    from ycbvss.viz import contour_overlay

    x, y, w, h = box
    big = cv2.resize(np.ascontiguousarray(img[y:y + h, x:x + w]), None, fx=zoom, fy=zoom,
                     interpolation=cv2.INTER_CUBIC)
    Kz = K.astype(np.float64).copy()
    Kz[0, 2] = (K[0, 2] - x + 0.5) * zoom - 0.5
    Kz[1, 2] = (K[1, 2] - y + 0.5) * zoom - 0.5
    Kz[:2, :2] *= zoom
    r = get_renderer()
    masks = [r.render(Kz, w * zoom, h * zoom, [(mesh_key, T)], outputs=("depth",)).depth_mm > 0 for T in poses]
    return contour_overlay(big, masks, colors=[(0, 255, 0), (255, 0, 0)][:len(masks)])


def main() -> None:
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.geometry.so3 import log_so3
    from ycbvss.io.images import write_png
    from ycbvss.pipeline import suite_run as S
    from ycbvss.pipeline.suite import load_clip
    from ycbvss.refine.bundle import RefineOptions, refine_scene
    from ycbvss.refine.templates import ensure_meshes, get_renderer, mesh_key

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--clip", required=True, help="e.g. medium-4")
    ap.add_argument("--obj", type=int, required=True, help="object id of the overlay")
    ap.add_argument("--frames", default="0", help="frame ids of the overlay")
    ap.add_argument("--variants", nargs="+", default=["{}"], help="RefineOptions overrides, one JSON each")
    ap.add_argument("--zoom", type=int, default=6)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    models, sc = load_clip(a.dataset, a.suite_root, a.clip)
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in sc.frames for i in f.instances}
    frames = {f.im_id: f for f in sc.frames}
    rows = []
    for v in a.variants:
        kw = json.loads(v)
        opt = RefineOptions(keyframe_step=S.keyframe_step_for(len(sc.frames)), **kw)
        res = refine_scene(sc, models, dict(gt), opt)
        for o in sorted({k[1] for k in res.poses}):
            ks = [k for k in res.poses if k[1] == o]
            d = np.mean([res.poses[k][:3, 3] - gt[k][:3, 3] for k in ks], axis=0)
            r_deg = np.mean([np.degrees(np.linalg.norm(log_so3(gt[k][:3, :3].T @ res.poses[k][:3, :3]))) for k in ks])
            rows.append(Row(f"{_label(kw)}: {models[o].name} ({res.status[ks[0]]})",
                            [float(d[0]), float(d[1]), float(d[2]), float(r_deg)]))
        r = get_renderer()
        ensure_meshes(r, models)
        tiles = []
        for im in (int(x) for x in a.frames.split(",")):
            f = frames[im]
            T_gt, T_est = gt[(im, a.obj)], res.poses[(im, a.obj)]
            ys, xs = np.nonzero(r.render(f.camera.K, f.camera.width, f.camera.height, [(mesh_key(a.obj, models[a.obj]), T_gt)],
                                         outputs=("depth",)).depth_mm > 0)
            m = 12
            box = (max(xs.min() - m, 0), max(ys.min() - m, 0))
            box = box + (min(xs.max() + m, f.camera.width) - box[0], min(ys.max() + m, f.camera.height) - box[1])
            tiles.append(_overlay(f.load_rgb(), f.camera.K, mesh_key(a.obj, models[a.obj]), [T_gt, T_est], box, a.zoom))
        hmax = max(t.shape[0] for t in tiles)
        tiles = [np.pad(t, ((0, hmax - t.shape[0]), (0, 2), (0, 0))) for t in tiles]
        write_png(out / f"overlay_{_label(kw).replace('=', '-').replace(',', '_')}.png", np.concatenate(tiles, 1))
    t = Table(caption=f"{a.clip} from the exact GT: mean signed offset of each object (camera frame, mm; "
                      f"refined - GT) and rotation (deg), status", label_header="variant: object (status)",
              columns=["dx (mm)", "dy (mm)", "dz (mm)", "R (deg)"], rows=rows)
    for p in write_table(t, out, "object_rest"):
        print(p)


if __name__ == "__main__":
    main()
