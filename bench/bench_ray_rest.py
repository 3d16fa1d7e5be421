"""Where f_edge's parts put one object along its line of sight, and where the refiner rests it,
on a BOP dataset with exact GT (e.g. YCBV-SS written by ``ycbvss synth`` / ``ycbvss validate``).

Two measurements, for one (scene, object):

1. **Ray scan** (no optimisation). In every frame of the scene the object is moved by dz mm along
   its GT line of sight (the other objects stay at their GT), the frame's templates re-rendered
   (fast renderer) and f_edge's finest-level candidates taken as the refiner takes them (contour
   samples matched to the 1 px blur, T-junction samples dropped); the image's edge field (colour,
   sigma 1 px) is read at them. Columns: mean E over the contour samples placed as a flat-coloured
   silhouette predicts ("binary"), placed by the appearance prediction from the template's texture
   and the image's background (``RefineOptions.edge_appearance``), and over the interior texture
   candidates (Canny on the template). Where a column is lowest is where that part alone would
   put the object (E = 1 - normalised edge strength: lower is on an edge).
2. **Rests from the exact GT** (``--rest JSON ...``): the scene refined from its exact GT with each
   set of RefineOptions overrides (table contact off, as ``ycbvss validate`` runs YCBV-SS), the
   object's signed error (mm, camera axes) and rotation error (deg) averaged over the views.

The image is the dataset's own (Blender Cycles for YCBV-SS), never the fast renderer's.

    python bench/bench_ray_rest.py --dataset /tmp/val/ycbvss --scene 1 --obj 5 \\
        --rest '{}' '{"edge_appearance": true}' --out bench/results/shared_clips_ea_s64
"""
from __future__ import annotations

import argparse
import json
import os
import warnings
from pathlib import Path

import numpy as np


def _mean_E(fld, uv: np.ndarray) -> float:
    from ycbvss.refine.edge import sample_field

    if len(uv) == 0:
        return float("nan")
    return float(np.mean(sample_field(fld, uv)[0]))


def ray_scan(sc, models, obj: int, dz_mm: np.ndarray, junction_px: float = 3.0) -> np.ndarray:
    """(len(dz_mm), 3): mean E over the views of (binary contour, appearance contour, interior)
    with ``obj`` moved dz mm along its GT line of sight in every view."""
    from ycbvss.refine.edge import edge_field
    from ycbvss.refine.templates import ensure_meshes, get_renderer, render_view, view_edge_candidates

    r = get_renderer()
    ensure_meshes(r, models)
    views = []
    for fr in sc.frames:
        oids = [i.obj_id for i in fr.instances]
        if obj in oids:
            img = fr.load_rgb()
            views.append((fr, img, edge_field(img, 1.0, colour=True), oids.index(obj) + 1))
    if not views:
        raise SystemExit(f"object {obj} is in no frame of scene {sc.scene_id}")
    out = np.zeros((len(dz_mm), 3))
    for a, dz in enumerate(dz_mm):
        for fr, img, fld, lab in views:
            poses = {}
            for j, inst in enumerate(fr.instances):
                T = np.array(inst.T_m2c, dtype=np.float64)
                if inst.obj_id == obj:
                    T[:3, 3] += dz * T[:3, 3] / np.linalg.norm(T[:3, 3])
                poses[j] = T
            cam = fr.camera
            vr = render_view(r, models, [i.obj_id for i in fr.instances], cam.K, cam.width, cam.height, poses)
            cb = view_edge_candidates(vr, blur_sigma_px=1.0, junction_px=junction_px)
            ca = view_edge_candidates(vr, blur_sigma_px=1.0, junction_px=junction_px, image=img)
            out[a] += (_mean_E(fld, cb.uv_c[cb.l_c == lab]), _mean_E(fld, ca.uv_c[ca.l_c == lab]),
                       _mean_E(fld, cb.uv_i[cb.l_i == lab]))
        out[a] /= len(views)
    return out


def rest_from_gt(sc, models, obj: int, over: dict) -> tuple[np.ndarray, float]:
    """Signed mean (dx, dy, dz) mm in camera axes and mean rotation error (deg) of ``obj`` after
    refining the scene from its exact GT with the RefineOptions overrides ``over``."""
    from ycbvss.geometry.so3 import rotation_angle_deg
    from ycbvss.refine import RefineOptions, refine_scene

    gt = {(f.im_id, i.obj_id): np.array(i.T_m2c, dtype=np.float64) for f in sc.frames for i in f.instances}
    opt = RefineOptions(**{"keyframe_step": 0, "seed": 0, "compute_uncertainty": False, "table_contact": False, **over})
    res = refine_scene(sc, models, dict(gt), opt)
    keys = [k for k in gt if k[1] == obj]
    d = np.array([res.poses[k][:3, 3] - gt[k][:3, 3] for k in keys])
    r = [float(rotation_angle_deg(res.poses[k][:3, :3] @ gt[k][:3, :3].T)) for k in keys]
    return d.mean(axis=0), float(np.mean(r))


def main() -> None:
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.pipeline.datasets import open_dataset

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", required=True, help="BOP root with exact GT")
    ap.add_argument("--split", default=None)
    ap.add_argument("--scene", type=int, required=True)
    ap.add_argument("--obj", type=int, required=True)
    ap.add_argument("--dz", default="-6:3:1", help="start:stop:step in mm (stop included)")
    ap.add_argument("--rest", nargs="*", default=[], help="RefineOptions overrides (JSON), one refinement each")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    os.environ.setdefault("YCBVSS_NO_PROGRESS", "1")
    warnings.simplefilter("ignore")
    ds, _, _ = open_dataset(a.dataset, a.split, None)
    sc = next((s for s in ds.iter_scenes() if s.scene_id == a.scene), None)
    if sc is None:
        raise SystemExit(f"{a.dataset}: no scene {a.scene}")
    lo, hi, st = (float(x) for x in a.dz.split(":"))
    dz = np.arange(lo, hi + 0.5 * st, st)
    name = getattr(ds.models[a.obj], "name", None) or str(a.obj)
    E = ray_scan(sc, ds.models, a.obj, dz)
    t = Table(["contour, binary", "contour, appearance", "interior (Canny)"], label_header="dz (mm)", digits=5,
              caption=f"{name} (object {a.obj}), scene {a.scene} of {a.dataset}: mean edge-field value E at f_edge's "
                      f"finest-level samples with the object moved dz mm along its GT line of sight (other objects at "
                      f"the GT), mean over the views; lowest = where that part alone puts the object")
    for z, row in zip(dz, E):
        t.rows.append(Row(f"{z:+.1f}", [float(v) for v in row]))
    paths = write_table(t, Path(a.out), f"ray_scan_scene{a.scene}_obj{a.obj}")
    for c, lab in enumerate(("binary", "appearance", "interior")):
        print(f"{lab}: lowest at dz {dz[int(np.argmin(E[:, c]))]:+.1f} mm")
    if a.rest:
        t2 = Table(["dx (mm)", "dy (mm)", "dz (mm)", "R (deg)"], label_header="RefineOptions overrides", digits=3,
                   caption=f"{name} (object {a.obj}), scene {a.scene}: signed error after refining from the exact GT "
                           f"(camera axes, mean over the views; table contact off)")
        for js in a.rest:
            d, r = rest_from_gt(sc, ds.models, a.obj, json.loads(js))
            print(f"{js}: dx {d[0]:+.3f} dy {d[1]:+.3f} dz {d[2]:+.3f} mm, R {r:.3f} deg")
            t2.rows.append(Row(js.replace("|", "/"), [float(d[0]), float(d[1]), float(d[2]), r]))
        paths += write_table(t2, Path(a.out), f"rest_from_gt_scene{a.scene}_obj{a.obj}")
    for p in paths:
        print(p)


if __name__ == "__main__":
    main()
